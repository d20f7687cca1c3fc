//! A scene's name becomes part of every output file name (`<name>-0000.png`), so it must be a
//! plain file name on every system: no path separators, no `..`, no hidden or control
//! characters, not empty, at most `MAX_NAME_BYTES`.

/// Longest scene name, in bytes (file systems allow 255; the suffixes need the rest).
pub const MAX_NAME_BYTES: usize = 100;

fn allowed(c: char) -> bool {
    c.is_alphanumeric() || matches!(c, '-' | '_' | '.' | ' ')
}

/// Why `name` cannot name output files, if it cannot.
pub(super) fn check_scene_name(name: &str) -> Result<(), String> {
    let shown: String = crate::input::shown(name, 40);
    let problem = if name.is_empty() {
        "is empty".to_string()
    } else if name.len() > MAX_NAME_BYTES {
        format!("is {} bytes long, more than {MAX_NAME_BYTES}", name.len())
    } else if let Some(c) = name.chars().find(|&c| !allowed(c)) {
        format!("contains '{}'", c.escape_debug())
    } else if name.starts_with(['.', '-', ' ']) || name.ends_with(['.', ' ']) {
        "starts with '.', '-' or a space, or ends with '.' or a space".to_string()
    } else {
        return Ok(());
    };
    Err(format!(
        "the scene name '{shown}' {problem}; it names the output files, so use 1 to {MAX_NAME_BYTES} bytes of \
         letters, digits, '-', '_', '.' and spaces, not starting with '.', '-' or a space"
    ))
}

/// A safe file-name stem from any name, for scenes built in code rather than loaded (whose
/// names were never checked): disallowed characters become '_', leading dots and dashes go,
/// long names are cut at `MAX_NAME_BYTES`; never empty.
pub(super) fn file_stem(name: &str) -> String {
    let mut stem: String = name
        .chars()
        .map(|c| if allowed(c) { c } else { '_' })
        .collect::<String>()
        .trim_start_matches(['.', '-', ' '])
        .trim_end_matches(['.', ' '])
        .to_string();
    while stem.len() > MAX_NAME_BYTES {
        stem.pop();
    }
    if stem.is_empty() { "scene".to_string() } else { stem }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hostile_names_are_refused_and_made_safe() {
        for good in ["env1", "Küche 2", "room_3.v2", "部屋"] {
            assert!(check_scene_name(good).is_ok(), "{good}");
            assert_eq!(file_stem(good), good);
        }
        let long = "a".repeat(101);
        for bad in [
            "",
            "../escaped",
            "/etc/x",
            "a\\b",
            "a\0b",
            "..",
            ".hidden",
            "a\nb",
            &long,
            "-rf",
            "x.",
        ] {
            assert!(check_scene_name(bad).is_err(), "{bad:?}");
            let stem = file_stem(bad);
            assert!(check_scene_name(&stem).is_ok(), "{bad:?} -> {stem:?}");
        }
        assert_eq!(file_stem("../../etc/passwd"), "_.._etc_passwd");
        assert_eq!(file_stem("..."), "scene");
        assert!(check_scene_name("a\0b").unwrap_err().contains("contains '\\0'"));
    }
}
