//! Integration tests live in tests/tests/; this crate's own test checks that the workspace's
//! tests say what they need.

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    /// A function of a source file: its attributes and doc lines (without white space), and its
    /// text.
    struct Function {
        attributes: String,
        body: String,
    }

    /// The functions of `text` (at any indentation), each up to the next one.
    fn functions(text: &str) -> BTreeMap<String, Function> {
        let lines: Vec<&str> = text.lines().collect();
        let name_at = |line: &str| {
            let line = line.trim_start();
            let line = ["pub(crate) ", "pub "]
                .iter()
                .find_map(|p| line.strip_prefix(p))
                .unwrap_or(line);
            let rest = line.strip_prefix("fn ")?;
            Some(rest[..rest.find(['(', '<'])?].to_string())
        };
        let starts: Vec<(usize, String)> = (0..lines.len())
            .filter_map(|i| name_at(lines[i]).map(|name| (i, name)))
            .collect();
        let mut found = BTreeMap::new();
        for (k, (start, name)) in starts.iter().enumerate() {
            let end = starts.get(k + 1).map_or(lines.len(), |(next, _)| *next);
            // Up to a blank line or the end of the item before (attributes may span lines).
            let first_attribute = (0..*start)
                .rev()
                .take_while(|&i| {
                    let line = lines[i].trim();
                    !line.is_empty() && (line.starts_with("//") || !line.ends_with(['}', ';']))
                })
                .last()
                .unwrap_or(*start);
            found.insert(
                name.clone(),
                Function {
                    attributes: lines[first_attribute..*start].concat().replace(char::is_whitespace, ""),
                    body: lines[start + 1..end].join("\n"),
                },
            );
        }
        found
    }

    /// Whether `body` calls the function `name` (not a method of that name).
    fn calls(body: &str, name: &str) -> bool {
        body.match_indices(&format!("{name}(")).any(|(at, _)| {
            !body[..at]
                .chars()
                .next_back()
                .is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '.')
        })
    }

    fn sources(dir: &Path, found: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                sources(&path, found);
            } else if path.extension().is_some_and(|e| e == "rs") {
                found.push(path);
            }
        }
    }

    /// Every test that needs a GPU adapter (through `gpu_tracer`) or the Python readers
    /// (`OMNISIM_PYTHON`), directly or through a helper of its file, carries the attribute that
    /// counts it as ignored where that is missing (`test_cfg.rs`): no test passes unrun.
    #[test]
    fn tests_that_need_a_gpu_or_python_are_ignored_where_they_cannot_run() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let mut files = Vec::new();
        sources(&root.join("tests/tests"), &mut files);
        for crate_dir in std::fs::read_dir(root.join("crates")).unwrap() {
            sources(&crate_dir.unwrap().path(), &mut files);
        }
        let needs = [
            ("gpu_tracer(", "#[cfg_attr(omnisim_no_gpu,ignore"),
            ("\"OMNISIM_PYTHON\"", "#[cfg_attr(omnisim_no_python,ignore"),
        ];
        let mut marked = [0; 2];
        for file in &files {
            let functions = functions(&std::fs::read_to_string(file).unwrap());
            for (k, (seed, attribute)) in needs.iter().enumerate() {
                // The functions that need it, and those that call them, to a fixed point.
                let mut needing: Vec<&str> = functions
                    .iter()
                    .filter(|(_, f)| f.body.contains(seed))
                    .map(|(name, _)| name.as_str())
                    .collect();
                loop {
                    let more: Vec<&str> = functions
                        .iter()
                        .filter(|(name, f)| {
                            !needing.contains(&name.as_str()) && needing.iter().any(|n| calls(&f.body, n))
                        })
                        .map(|(name, _)| name.as_str())
                        .collect();
                    if more.is_empty() {
                        break;
                    }
                    needing.extend(more);
                }
                for name in needing {
                    let function = &functions[name];
                    if function.attributes.contains("#[test]") {
                        assert!(
                            function.attributes.contains(attribute),
                            "{}: test {name} needs `{attribute} = \"needs ...\")]`",
                            file.display()
                        );
                        marked[k] += 1;
                    }
                }
            }
        }
        // The check sees the tests it is about.
        assert!(marked[0] >= 21 && marked[1] >= 4, "{marked:?}");
    }
}
