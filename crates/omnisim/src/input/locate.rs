//! Finding objects in a RON file's text (scene objects, data-set sets), so that errors can say
//! where: serde and RON give positions but not which element of a list they fall in. Written by hand because it needs
//! only a bracket-depth scan (strings and comments skipped), not a second parser.

/// The 1-based (line, column) of the `occurrence`-th (from 0) `name` field naming `name`.
pub fn name_field(text: &str, name: &str, occurrence: usize) -> Option<(usize, usize)> {
    let quoted = format!("\"{name}\"");
    text.lines()
        .enumerate()
        .filter_map(|(number, line)| {
            let at = line.find(&quoted)?;
            let before = line[..at].trim_end().strip_suffix(':')?.trim_end();
            let field = before.strip_suffix("name")?;
            Some((number + 1, field.chars().count() + 1))
        })
        .nth(occurrence)
}

/// The characters of RON text outside strings and comments, with their byte offsets.
fn code(text: &str, from: usize) -> impl Iterator<Item = (usize, char)> + '_ {
    let mut chars = text[from..].char_indices().map(move |(i, c)| (i + from, c)).peekable();
    std::iter::from_fn(move || {
        loop {
            let (i, c) = chars.next()?;
            match c {
                '"' => {
                    // Skip the string, escapes included.
                    while let Some((_, s)) = chars.next() {
                        match s {
                            '\\' => {
                                chars.next();
                            }
                            '"' => break,
                            _ => {}
                        }
                    }
                }
                '/' if chars.peek().is_some_and(|&(_, n)| n == '/') => {
                    while chars.next_if(|&(_, n)| n != '\n').is_some() {}
                }
                '/' if chars.peek().is_some_and(|&(_, n)| n == '*') => {
                    chars.next();
                    let mut last = ' ';
                    for (_, n) in chars.by_ref() {
                        if last == '*' && n == '/' {
                            break;
                        }
                        last = n;
                    }
                }
                _ => return Some((i, c)),
            }
        }
    })
}

/// The 1-based (line, column) of the scene's own `field` (outside `objects`), e.g. `name`.
pub fn scene_field(text: &str, field: &str) -> Option<(usize, usize)> {
    let mut depth = 0usize;
    let mut previous_is_word = false;
    for (i, c) in code(text, 0) {
        match c {
            '(' | '[' | '{' => depth += 1,
            ')' | ']' | '}' => depth = depth.saturating_sub(1),
            _ if depth == 1 && !previous_is_word && text[i..].starts_with(field) => {
                let after = text[i + field.len()..].trim_start();
                let word_ends = !text[i + field.len()..].starts_with(|n: char| n.is_alphanumeric() || n == '_');
                if word_ends && after.starts_with(':') {
                    return Some(line_column(text, i));
                }
            }
            _ => {}
        }
        previous_is_word = c.is_alphanumeric() || c == '_';
    }
    None
}

/// The name of the element of the `list: [...]` list (`objects`, `sets`) whose text contains
/// the 1-based (line, column), if it has a `name: "…"` field.
pub fn element_at(text: &str, list: &str, line: usize, column: usize) -> Option<String> {
    let target = offset_of(text, line, column)?;
    let list = list_key(text, list)?;
    let mut depth = 0usize;
    let mut start = None;
    for (i, c) in code(text, list) {
        match c {
            '(' | '[' | '{' => {
                depth += 1;
                // Depth 1 is inside `list: [`; an element opens at depth 2.
                if depth == 2 {
                    start = Some(i);
                }
            }
            ')' | ']' | '}' => {
                if depth == 2
                    && let Some(s) = start.take()
                    && (s..=i).contains(&target)
                {
                    return object_name(&text[s..=i]);
                }
                depth = depth.checked_sub(1)?;
                if depth == 0 {
                    return None;
                }
            }
            _ => {}
        }
    }
    // The list never closed (a syntax error): the last object opened before the position.
    start.filter(|&s| s <= target).and_then(|s| object_name(&text[s..]))
}

/// The byte offset of the `list:` key itself, not the word in a comment or a string.
fn list_key(text: &str, list: &str) -> Option<usize> {
    let mut previous_is_word = false;
    code(text, 0).find_map(|(i, c)| {
        let found = !previous_is_word && is_key_at(text, i, list);
        previous_is_word = c.is_alphanumeric() || c == '_';
        found.then_some(i)
    })
}

/// The elements of the `list: [...]` list, as byte ranges of `text`: the whole list inside its
/// brackets, and each element from just after the `[` or `,` before it (its leading comments
/// and name, e.g. `Set`, included) to its closing bracket. `None` if the list is missing or
/// does not close. Lets a caller cut a spec into one-element specs that keep the rest verbatim.
pub fn list_elements(text: &str, list: &str) -> Option<(std::ops::Range<usize>, Vec<std::ops::Range<usize>>)> {
    let key = list_key(text, list)?;
    let mut depth = 0usize;
    let (mut inside, mut element_start) = (None, 0);
    let mut elements = Vec::new();
    for (i, c) in code(text, key) {
        match c {
            '(' | '[' | '{' => {
                depth += 1;
                if depth == 1 {
                    inside = Some(i + 1);
                    element_start = i + 1;
                }
            }
            ')' | ']' | '}' => {
                depth = depth.checked_sub(1)?;
                match depth {
                    0 => return Some((inside?..i, elements)),
                    1 => elements.push(element_start..i + 1),
                    _ => {}
                }
            }
            ',' if depth == 1 => element_start = i + 1,
            _ => {}
        }
    }
    None
}

/// The 1-based (line, column) of the field `path` (`poses.tilt`, `layouts[0].rate`) of the
/// element whose `name` field is at (line, column): each key of the path is sought after the
/// one before, inside that element. `None` if the first key is not after the name.
pub fn field_of_element(text: &str, (line, column): (usize, usize), path: &str) -> Option<(usize, usize)> {
    let from = offset_of(text, line, column)?;
    let mut keys = path
        .split('.')
        .map(|key| key.split('[').next().unwrap_or(key))
        .peekable();
    let mut found = None;
    let mut depth = 0usize;
    let mut previous_is_word = false;
    for (i, c) in code(text, from) {
        match c {
            '(' | '[' | '{' => depth += 1,
            // The element closes: the rest of the path is not in it.
            ')' | ']' | '}' if depth == 0 => break,
            ')' | ']' | '}' => depth -= 1,
            _ if !previous_is_word && keys.peek().is_some_and(|key| is_key_at(text, i, key)) => {
                found = Some(line_column(text, i));
                keys.next();
                if keys.peek().is_none() {
                    break;
                }
            }
            _ => {}
        }
        previous_is_word = c.is_alphanumeric() || c == '_';
    }
    found
}

/// The field a RON parse error falls in: the last key at or before it, except where that key
/// is not the cause (a missing field is reported where its struct ends and names itself;
/// trailing characters follow everything).
pub fn field_of_error(text: &str, error: &ron::error::SpannedError) -> Option<String> {
    match error.code {
        ron::Error::MissingStructField { .. } | ron::Error::TrailingCharacters => None,
        _ => key_before(text, error.span.start.line, error.span.start.col),
    }
}

/// The last `key:` of RON text starting at or before the 1-based (line, column): the field a
/// parse error at that place is in (or names, for an unknown field).
fn key_before(text: &str, line: usize, column: usize) -> Option<String> {
    let end = offset_of(text, line, column)?;
    let mut key = None;
    let mut word_start = None;
    for (i, c) in code(text, 0) {
        if c.is_alphanumeric() || c == '_' {
            if word_start.is_none() && i > end {
                break;
            }
            word_start.get_or_insert(i);
        } else if let Some(start) = word_start.take()
            && text[i..].trim_start().starts_with(':')
        {
            key = Some(text[start..i].to_string());
        }
    }
    key
}

/// Whether `key` starts at byte `i` of `text` as a whole word followed by `:`.
fn is_key_at(text: &str, i: usize, key: &str) -> bool {
    let Some(rest) = text[i..].strip_prefix(key) else {
        return false;
    };
    !rest.starts_with(|n: char| n.is_alphanumeric() || n == '_') && rest.trim_start().starts_with(':')
}

/// 1-based (line, column in characters) of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset];
    let line_start = before.rfind('\n').map_or(0, |n| n + 1);
    (
        before.matches('\n').count() + 1,
        before[line_start..].chars().count() + 1,
    )
}

/// The text of the object's `name: "…"` field (escapes kept as written).
fn object_name(object: &str) -> Option<String> {
    let at = object.find("name")?;
    let rest = object[at + 4..]
        .trim_start()
        .strip_prefix(':')?
        .trim_start()
        .strip_prefix('"')?;
    let mut escaped = false;
    let end = rest.char_indices().find_map(|(i, c)| {
        let closes = !escaped && c == '"';
        escaped = !escaped && c == '\\';
        closes.then_some(i)
    })?;
    Some(rest[..end].to_string())
}

fn offset_of(text: &str, line: usize, column: usize) -> Option<usize> {
    let start: usize = text
        .split_inclusive('\n')
        .take(line.checked_sub(1)?)
        .map(str::len)
        .sum();
    let line_text = text[start..].split('\n').next()?;
    let byte = line_text
        .char_indices()
        .nth(column.saturating_sub(1))
        .map_or(line_text.len(), |(b, _)| b);
    Some(start + byte)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locates_object_by_name_field() {
        let text = "Scene(\n  objects: [\n    Box(\n      name: \"table\",\n";
        assert_eq!(name_field(text, "table", 0), Some((4, 7)));
        assert_eq!(name_field(text, "chair", 0), None);
        let twice = "  Wall(name: \"w\"),\n  Wall(name: \"w\"),\n";
        assert_eq!(name_field(twice, "w", 1), Some((2, 8)));
    }

    #[test]
    fn finds_the_object_around_a_position() {
        let text = "Scene(name: \"s\", objects: [\n  // a comment (with a bracket\n  Wall(name: \"a (\\\"x\", height: 1.0),\n  Box(name: \"b\",\n      colour: (300, 1, 1)),\n])";
        assert_eq!(element_at(text, "objects", 3, 10).as_deref(), Some("a (\\\"x"));
        assert_eq!(element_at(text, "objects", 5, 16).as_deref(), Some("b"));
        assert_eq!(element_at(text, "objects", 1, 3), None);
    }

    /// Each element's text, from after the separator to its closing bracket, comments kept and
    /// brackets in strings and comments ignored.
    #[test]
    fn lists_elements_with_their_names() {
        let text = "D(a: 1, // sets: [no]\n sets: [\n  // first\n  Set(name: \"a)\", p: [1, 2]),\n  Set(name: \"b\"), /* ] */\n], z: 2)";
        let (inside, elements) = list_elements(text, "sets").unwrap();
        assert!(text[inside].trim_end().ends_with("/* ] */"));
        let texts: Vec<&str> = elements.iter().map(|r| text[r.clone()].trim()).collect();
        assert_eq!(texts, ["// first\n  Set(name: \"a)\", p: [1, 2])", "Set(name: \"b\")"]);
        assert!(list_elements("D(sets: [S(", "sets").is_none());
        assert!(list_elements("D(objects: [])", "sets").is_none());
    }

    #[test]
    fn a_list_named_in_a_comment_before_it_is_not_the_list() {
        let text = "// three test sets\nDataset(rig: Omni(size: (1, 1)), sets: [\n  Set(name: \"a\"),\n  Set(name: \"b\", x: (300)),\n])";
        assert_eq!(element_at(text, "sets", 4, 22).as_deref(), Some("b"));
    }

    #[test]
    fn fields_are_found_inside_their_element_after_its_name() {
        let text = "sets: [\n  Set(name: \"a\",\n    poses: Random(count: 3, tilt: 100.0),\n    layouts: [Tum(rate: -1.0)]),\n  Set(name: \"b\", tilt: 1.0),\n]";
        let a = name_field(text, "a", 0).unwrap();
        assert_eq!(field_of_element(text, a, "poses.tilt"), Some((3, 29)));
        assert_eq!(field_of_element(text, a, "layouts[0].rate"), Some((4, 19)));
        assert_eq!(
            field_of_element(text, a, "lights[0]"),
            None,
            "not in set a, nor taken from set b"
        );
        assert_eq!(key_before(text, 3, 35).as_deref(), Some("tilt"));
        assert_eq!(
            key_before(text, 3, 29).as_deref(),
            Some("tilt"),
            "an error at the key names it"
        );
    }

    #[test]
    fn finds_the_scene_name_field() {
        let text = "/* name: 1 */ Scene(\n  // name: 2\n  objects: [Wall(name: \"w\")],\n  rename: 0, name: \"x\")";
        assert_eq!(scene_field(text, "name"), Some((4, 14)));
        assert_eq!(scene_field("Scene(objects: [])", "name"), None);
    }
}
