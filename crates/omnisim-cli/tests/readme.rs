//! README's examples work: its shell commands run (renders at 32×32, the data set shrunk), its
//! inline commands run with their placeholders filled, omnisim checks its RON snippets, its Rust
//! example is the one `manifest.rs` compiles as a doctest, and its Python example reads the data
//! set. A README example that breaks fails here; a new one must run here or be listed in
//! `NOT_RUN` with why.

use std::path::{Path, PathBuf};
use std::process::Command;

/// README commands (by prefix) that are not run, and why.
const NOT_RUN: &[(&str, &str)] = &[
    ("cargo test --workspace", "the test run itself"),
    (
        "cargo install --locked --path crates/omnisim-cli",
        "installs into ~/.cargo/bin; the `omnisim` commands run the binary built for the tests",
    ),
    (
        "jobid=$(sbatch",
        "Slurm; its omnisim command is a shard run: shards are tested in omnisim-dataset",
    ),
    (
        "sbatch --dependency",
        "Slurm; its omnisim command is the merge, run below",
    ),
    (
        "bench ",
        "measures for seconds, and --chart writes docs/; bench's tests are in tests/cli.rs",
    ),
    ("render --edge-samples 16", "names a flag in prose; no scene"),
    (
        "dataset merge DIR SHARD_DIR...",
        "needs shards rendered apart: merges are tested in omnisim-dataset",
    ),
];

/// Placeholders of README's inline commands, and what fills them here.
const PLACEHOLDERS: &[(&str, &str)] = &[
    ("<scene>", "scenes/env1.ron"),
    ("out.ply|out.obj", "out.ply"),
    ("SPEC.ron", "scenes/env1-dataset.ron"),
    ("PREFIX", "plan"),
    ("DIR", "data/env1"),
];

/// The shipped data-set spec, shrunk: 32×32 images, 24 map frames, 3 per test set.
const SHRINK: &[(&str, &str)] = &[
    ("size: (250, 250)", "size: (32, 32)"),
    ("spacing: 0.1", "spacing: 0.4"),
    ("count: 50", "count: 3"),
];

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A fenced block of README: its language, first line (1-based) and text.
struct Block {
    language: String,
    line: usize,
    text: String,
}

/// README's fenced blocks, and its prose (everything else, lines joined by spaces).
fn readme() -> (Vec<Block>, String) {
    let text = std::fs::read_to_string(workspace().join("README.md")).unwrap();
    let mut blocks = Vec::new();
    let mut prose = String::new();
    let mut open: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        match (line.strip_prefix("```"), open.as_mut()) {
            (Some(_), Some(_)) => blocks.extend(open.take()),
            (Some(language), None) => {
                open = Some(Block {
                    language: language.trim().to_string(),
                    line: i + 2,
                    text: String::new(),
                });
            }
            (None, Some(block)) => {
                block.text.push_str(line);
                block.text.push('\n');
            }
            (None, None) => {
                prose.push_str(line);
                prose.push(' ');
            }
        }
    }
    (blocks, prose)
}

/// The commands of a shell block with the README line each starts on (`first`: the block's
/// first line): continuation lines joined, comments left out.
fn commands(block: &str, first: usize) -> Vec<(usize, String)> {
    let mut found: Vec<(usize, String)> = Vec::new();
    let mut continued = false;
    for (i, line) in block.lines().enumerate() {
        let line = line.split(" # ").next().unwrap().trim();
        let (text, continues) = line.strip_suffix('\\').map_or((line, false), |t| (t, true));
        match found.last_mut() {
            Some((_, command)) if continued => command.push_str(text),
            _ if text.is_empty() || text.starts_with('#') => {}
            _ => found.push((first + i, text.to_string())),
        }
        continued = continues;
    }
    found
}

/// The arguments of an omnisim command, as README writes it (`cargo run ... --` or `omnisim`).
fn omnisim_arguments(command: &str) -> Option<&str> {
    ["cargo run --release -p omnisim-cli -- ", "omnisim "]
        .iter()
        .find_map(|prefix| command.strip_prefix(prefix))
}

/// Runs omnisim with `arguments` in `dir`, renders at 32×32 and panoramas at 64×16 so that the
/// whole README takes seconds; panics with its output if it fails.
fn run(dir: &Path, arguments: &str, origin: &str) {
    let mut arguments: Vec<&str> = arguments.split_whitespace().collect();
    if arguments[0] == "render" && !arguments.contains(&"--size") && !arguments.contains(&"--help") {
        arguments.extend(["--size", "32x32"]);
    }
    if arguments[0] == "describe" {
        arguments.extend(["--panorama", "64x16"]);
    }
    let output = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args(&arguments)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "README {origin}: omnisim {} failed:\n{}",
        arguments.join(" "),
        String::from_utf8_lossy(&output.stderr)
    );
}

fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let target = to.join(path.file_name().unwrap());
        if path.is_dir() {
            copy_folder(&path, &target);
        } else {
            std::fs::copy(&path, &target).unwrap();
        }
    }
}

/// A folder with a copy of `scenes/` (the shipped data-set spec shrunk), where README's
/// commands run as from the repository.
fn project() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    copy_folder(&workspace().join("scenes"), &dir.path().join("scenes"));
    let spec = dir.path().join("scenes/env1-dataset.ron");
    let mut text = std::fs::read_to_string(&spec).unwrap();
    for (from, to) in SHRINK {
        assert!(text.contains(from), "scenes/env1-dataset.ron has no '{from}' to shrink");
        text = text.replace(from, to);
    }
    std::fs::write(&spec, text).unwrap();
    dir
}

#[test]
fn readme_commands_and_snippets_work() {
    let (blocks, prose) = readme();
    let dir = project();
    let mut listed = vec![false; NOT_RUN.len()];
    let mut skipped = |command: &str| {
        let index = NOT_RUN.iter().position(|(prefix, _)| command.starts_with(prefix));
        index.inspect(|&k| listed[k] = true).is_some()
    };
    let mut ran = 0;
    for block in blocks.iter().filter(|b| b.language == "sh") {
        for (line, command) in commands(&block.text, block.line) {
            let origin = format!("line {line}");
            match omnisim_arguments(&command) {
                _ if skipped(&command) => {}
                Some(arguments) if skipped(arguments) => {}
                Some(arguments) => {
                    run(dir.path(), arguments, &origin);
                    ran += 1;
                }
                None => panic!("README {origin}: `{command}` is neither run here nor listed in NOT_RUN"),
            }
        }
    }
    // Inline commands with arguments (`omnisim poses random` names a subcommand).
    for span in prose.split('`').skip(1).step_by(2) {
        let Some(arguments) = span.strip_prefix("omnisim ") else {
            continue;
        };
        let words: Vec<&str> = arguments.split_whitespace().collect();
        let word = |w: &&str| w.chars().all(|c| c.is_ascii_lowercase());
        if !words.first().is_some_and(word) || words.iter().all(word) || skipped(arguments) {
            continue;
        }
        let filled = PLACEHOLDERS.iter().fold(words.join(" "), |text, (placeholder, value)| {
            text.replace(placeholder, value)
        });
        run(dir.path(), &filled, &format!("`{span}`"));
        ran += 1;
    }
    let stale: Vec<_> = NOT_RUN.iter().zip(&listed).filter(|(_, seen)| !**seen).collect();
    assert!(
        stale.is_empty(),
        "NOT_RUN lists commands README no longer has: {stale:?}"
    );
    assert!(ran >= 15, "only {ran} README commands ran");

    let mut snippets = 0;
    for block in blocks.iter().filter(|b| b.language == "ron") {
        let name = format!("scenes/readme-{}.ron", block.line);
        let text = block.text.trim_start();
        let (text, check) = if text.starts_with("Scene(") {
            (text.to_string(), format!("scene check {name}"))
        } else if text.starts_with("Dataset(") {
            (text.to_string(), format!("preview {name} --out readme-{}", block.line))
        } else if text.starts_with("lighting:") {
            // A scene's last field: in a copy of env1.
            let room = std::fs::read_to_string(workspace().join("scenes/env1.ron")).unwrap();
            let end = room.rfind(')').unwrap();
            (
                format!("{}{}{}", &room[..end], block.text, &room[end..]),
                format!("scene check {name}"),
            )
        } else {
            panic!("README line {}: a RON example of an unknown kind", block.line);
        };
        std::fs::write(dir.path().join(&name), text).unwrap();
        run(dir.path(), &check, &format!("RON example at line {}", block.line));
        snippets += 1;
    }
    assert_eq!(
        snippets, 4,
        "README's RON examples: a scene, a textured scene, its lighting, a data-set spec"
    );

    // The Rust example is the doctest of `Manifest::read`, which `cargo test --doc` compiles.
    let code = |text: &str| -> Vec<String> {
        text.lines()
            .map(|line| line.split("//").next().unwrap().trim().to_string())
            .filter(|line| !line.is_empty() && !line.starts_with('#'))
            .collect()
    };
    let rust: Vec<_> = blocks.iter().filter(|b| b.language == "rust").collect();
    assert_eq!(rust.len(), 1);
    let source = std::fs::read_to_string(workspace().join("crates/omnisim-dataset/src/manifest.rs")).unwrap();
    let doctest = source
        .split("/// ```no_run\n")
        .nth(1)
        .unwrap()
        .split("/// ```\n")
        .next()
        .unwrap();
    let doctest: String = doctest
        .lines()
        .map(|l| l.trim_start().trim_start_matches("///"))
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(
        code(&rust[0].text),
        code(&doctest),
        "README's Rust example differs from manifest.rs's doctest"
    );
}

/// README's Python example reads the data set README's command renders.
#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn readme_python_example_reads_the_data_set() {
    let python = std::env::var_os("OMNISIM_PYTHON").expect(
        "OMNISIM_PYTHON names no Python: set it to one with tests/readers/requirements.txt (.ci/run makes one) \
         (README, Tests)",
    );
    let (blocks, _) = readme();
    let dir = project();
    run(
        dir.path(),
        "dataset scenes/env1-dataset.ron --out data/env1",
        "data set",
    );
    let example = blocks.iter().find(|b| b.language == "python").unwrap();
    // The last frame's images were read.
    let script = format!("{}assert rgb.shape[2] == 3 and rng.ndim == 2\n", example.text);
    let output = Command::new(python)
        .args(["-c", &script])
        .env("OPENCV_IO_ENABLE_OPENEXR", "1")
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "README's Python example (line {}):\n{}",
        example.line,
        String::from_utf8_lossy(&output.stderr)
    );
}
