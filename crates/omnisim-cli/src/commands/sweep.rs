//! A data-set spec cut into one spec per set and expanded over sweeps, for `omnisim localize
//! SPEC`: a set whose text holds `${NAME}` becomes one set per value of `--sweep
//! NAME=V1,V2,...` (its name must hold the placeholder too, so the copies differ), and each set
//! is rendered by the data-set pipeline into a folder of its own. A set's folder is stamped by
//! its own one-set spec, so a re-run renders nothing, and a sweep that gains a value renders
//! that value's set alone. The one-set spec keeps the rest of the text verbatim (seed, rig,
//! outputs), and every random draw of a set derives from the seed and the set's name, so a set
//! is the same frames as in the whole spec.

use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use omnisim::Renderer;
use omnisim::input::locate::list_elements;
use omnisim_dataset::{Dataset, RunOptions};

use crate::progress::Progress;

/// One sweep: a placeholder's name and its values, as given to `--sweep NAME=V1,V2,...`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Sweep {
    pub name: String,
    pub values: Vec<String>,
}

/// Characters of a sweep's name and values: values land in set (folder) names and spec text.
fn plain(text: &str) -> bool {
    !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_'))
}

impl Sweep {
    /// Parses `NAME=V1,V2,...`.
    pub(crate) fn parse(text: &str) -> Result<Self, String> {
        let (name, values) = text
            .split_once('=')
            .ok_or_else(|| format!("--sweep {text:?}: give NAME=V1,V2,..., e.g. sigma=0,0.01,0.02"))?;
        let values: Vec<String> = values.split(',').map(|v| v.trim().to_string()).collect();
        if !plain(name) || !name.starts_with(|c: char| c.is_ascii_alphabetic()) {
            return Err(format!(
                "--sweep {text:?}: the name must start with a letter and hold only letters, digits, '.', '-', '_'"
            ));
        }
        if let Some(bad) = values.iter().find(|v| !plain(v)) {
            return Err(format!(
                "--sweep {text:?}: value {bad:?} must be a number or word of letters, digits, '.', '-', '_'"
            ));
        }
        Ok(Self {
            name: name.to_string(),
            values,
        })
    }

    fn placeholder(&self) -> String {
        format!("${{{}}}", self.name)
    }
}

/// `text` with every sweep's placeholder replaced by each of its values that it holds: the
/// product over the sweeps it names, in `--sweep` order.
pub(crate) fn expand(text: &str, sweeps: &[Sweep]) -> Vec<String> {
    sweeps.iter().fold(vec![text.to_string()], |texts, sweep| {
        let placeholder = sweep.placeholder();
        texts
            .into_iter()
            .flat_map(|t| {
                if t.contains(&placeholder) {
                    sweep.values.iter().map(|v| t.replace(&placeholder, v)).collect()
                } else {
                    vec![t]
                }
            })
            .collect()
    })
}

/// One set of the expanded spec: its name and its one-set spec text.
pub(crate) struct SetSpecText {
    pub name: String,
    pub text: String,
}

/// The sets of the spec at `path` (text `text`) expanded over `sweeps`, each as a one-set spec.
pub(crate) fn sets(text: &str, path: &Path, sweeps: &[Sweep]) -> anyhow::Result<Vec<SetSpecText>> {
    let (inside, elements) = list_elements(text, "sets").with_context(|| {
        format!(
            "{}: no closed `sets: [...]` list (is it a data-set spec?)",
            path.display()
        )
    })?;
    let (head, tail) = (&text[..inside.start], &text[inside.end..]);
    for sweep in sweeps {
        let placeholder = sweep.placeholder();
        if head.contains(&placeholder) || tail.contains(&placeholder) {
            bail!(
                "{}: {placeholder} is outside the sets; only a set's fields can be swept",
                path.display()
            );
        }
        if !elements.iter().any(|e| text[e.clone()].contains(&placeholder)) {
            bail!(
                "{}: --sweep {} is not used: no set holds {placeholder}",
                path.display(),
                sweep.name
            );
        }
    }
    let mut out: Vec<SetSpecText> = Vec::new();
    for element in elements {
        // Blank lines in place of the sets before it: the set keeps its lines, so that an
        // error's line:column is the spec file's.
        let before = "\n".repeat(text[inside.start..element.start].matches('\n').count());
        let original = &text[element];
        for set in expand(original, sweeps) {
            let one = format!("{head}{before}{set}\n{tail}");
            let spec = omnisim_dataset::spec::parse(&one, path).map_err(|error| {
                let error = anyhow::Error::new(error);
                if set.contains("${") {
                    error.context(
                        "a set holds a placeholder ${…} that no --sweep gives a value (--sweep NAME=V1,V2,...)",
                    )
                } else {
                    error
                }
            })?;
            let name = spec.sets.first().context("a set")?.name.clone();
            // A placeholder that still parses (in a name or a path) is refused all the same.
            if set.contains("${") {
                bail!(
                    "{}: set '{name}' holds a placeholder ${{…}} that no --sweep gives a value (--sweep NAME=V1,V2,...)",
                    path.display()
                );
            }
            if out.iter().any(|s| s.name == name) {
                bail!(
                    "{}: two sets are named '{name}'; put the swept placeholder in the set's name too, e.g. \
                     name: \"test-noise-${{sigma}}\"",
                    path.display()
                );
            }
            out.push(SetSpecText { name, text: one });
        }
    }
    Ok(out)
}

/// Set names as given to `--map` / `--test`, each expanded over the sweeps it names.
pub(crate) fn expand_names(names: &[String], sweeps: &[Sweep]) -> Vec<String> {
    names.iter().flat_map(|n| expand(n, sweeps)).collect()
}

/// Renders (or finds rendered) each named set of `specs` into `root/<set>/`, one data set per
/// set, by the renderer on `backend`; returns each set's folder. Only the sets named are
/// rendered.
pub(crate) fn render(
    spec_path: &Path,
    specs: &[SetSpecText],
    names: &[String],
    root: &Path,
    renderer: &Renderer,
) -> anyhow::Result<BTreeMap<String, PathBuf>> {
    let mut folders = BTreeMap::new();
    for name in names {
        if folders.contains_key(name) {
            continue;
        }
        let Some(set) = specs.iter().find(|s| &s.name == name) else {
            let have: Vec<&str> = specs.iter().map(|s| s.name.as_str()).collect();
            bail!("{} has no set '{name}'; it has {have:?}", spec_path.display());
        };
        let dataset = Dataset::from_text(set.text.clone(), spec_path)?;
        for warning in &dataset.warnings {
            crate::streams::stderr(format_args!("warning: {warning}"))?;
        }
        omnisim::output::folder::create_real_folder(root, root)?;
        let folder = root.join(name);
        let mut progress = Progress::new("frames");
        let mut unwritten = None;
        // The folder is localize's own: a set whose spec changed is rendered again.
        let options = RunOptions {
            overwrite: true,
            ..RunOptions::default()
        };
        let summary = dataset
            .run(renderer, &folder, &options, &mut |frame| match progress.step(
                frame.done,
                frame.total,
                !frame.rendered,
                &format!("set '{name}'"),
            ) {
                Ok(()) => ControlFlow::Continue(()),
                Err(error) => {
                    unwritten = Some(error);
                    ControlFlow::Break(())
                }
            })
            .with_context(|| format!("rendering set '{name}' into {}", folder.display()))?;
        progress.finish();
        if let Some(error) = unwritten {
            return Err(error);
        }
        crate::streams::stderr(format_args!(
            "set '{name}': {} frame(s) rendered, {} already done ({})",
            summary.rendered,
            summary.resumed,
            folder.display()
        ))?;
        folders.insert(name.clone(), folder);
    }
    Ok(folders)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweeps_parse_and_expand() {
        let sigma = Sweep::parse("sigma=0, 0.01,0.05").unwrap();
        assert_eq!(sigma.values, ["0", "0.01", "0.05"]);
        let step = Sweep::parse("step=0.2,0.4").unwrap();
        for bad in ["sigma", "=1", "1x=2", "s=a/b", "s=", "s=1,,2"] {
            assert!(Sweep::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(
            expand("n-${sigma}-${step}", &[sigma.clone(), step.clone()]),
            [
                "n-0-0.2",
                "n-0-0.4",
                "n-0.01-0.2",
                "n-0.01-0.4",
                "n-0.05-0.2",
                "n-0.05-0.4"
            ]
        );
        assert_eq!(expand("day", std::slice::from_ref(&sigma)), ["day"]);
        assert_eq!(
            expand_names(&["map".into(), "t-${sigma}".into()], &[sigma]),
            ["map", "t-0", "t-0.01", "t-0.05"]
        );
    }

    /// A spec cut into one-set specs: swept sets expanded, each set at its own lines (errors
    /// point into the file), and the refusals.
    #[test]
    fn a_spec_is_cut_into_sets() {
        let text = "Dataset(\n    scene: \"env1.ron\",\n    rig: Omni(size: (32, 32), mirror: Hyperbolic(a: 0.04, b: 0.16)),\n    sets: [\n        Set(name: \"map\", poses: List([(0.0, 0.0, 0.4, 0.0, 0.0, 0.0)])),\n        Set(name: \"t-${s}\", poses: List([(0.0, 0.0, 0.4, 0.0, 0.0, 0.0)]),\n            noise: (colour: [Gaussian(sigma: ${s})])),\n    ],\n)\n";
        let path = Path::new("s.ron");
        let s = Sweep::parse("s=0.1,0.2").unwrap();
        let cut = sets(text, path, std::slice::from_ref(&s)).unwrap();
        let names: Vec<&str> = cut.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["map", "t-0.1", "t-0.2"]);
        assert!(cut[2].text.contains("sigma: 0.2") && !cut[2].text.contains("name: \"map\""));
        // The second set keeps its line (7, `sigma`) in its one-set spec.
        let named_only = text.replace("sigma: ${s}", "sigma: 0.1");
        let refused = format!("{:#}", sets(&named_only, path, &[]).err().unwrap());
        assert!(
            refused.contains("set 't-${s}'") && refused.contains("no --sweep gives"),
            "{refused}"
        );
        let unswept = format!("{:#}", sets(text, path, &[]).err().unwrap());
        assert!(
            unswept.contains("no --sweep gives") && unswept.contains("s.ron:7:"),
            "{unswept}"
        );
        let unused = sets(text, path, &[s.clone(), Sweep::parse("q=1").unwrap()])
            .err()
            .unwrap();
        assert!(unused.to_string().contains("--sweep q is not used"), "{unused}");
        let outside = text.replace("size: (32, 32)", "size: (${s}, 32)");
        let outside = sets(&outside, path, std::slice::from_ref(&s)).err().unwrap();
        assert!(outside.to_string().contains("outside the sets"), "{outside}");
        let twice = text.replace("name: \"t-${s}\"", "name: \"t\"");
        let twice = sets(&twice, path, &[s]).err().unwrap();
        assert!(twice.to_string().contains("two sets are named 't'"), "{twice}");
    }
}
