//! Seeded mutations of the shipped scenes (bytes and tokens) through loading, validation, the
//! BVH build and a tiny CPU render: no input may panic, and every parse error names its
//! <file:line:column>. Time per input is bounded by construction (the scenes are a few KB, the
//! render 16×8 rays), so a hang shows as a slow test, never an endless one.

mod common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use glam::DVec3;
use omnisim::camera::Equirectangular;
use omnisim::{BackendChoice, Camera, Planes, Pose, Renderer, Scene, SceneError};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Mutations per shipped scene.
const MUTATIONS: usize = 2500;

/// Numbers that broke or could break geometry code.
const NUMBERS: [&str; 14] = [
    "0.0",
    "-0.0",
    "-1.0",
    "1e308",
    "1.7976931348623157e308",
    "1e39",
    "-1e30",
    "1e-320",
    "NaN",
    "inf",
    "1e6",
    "1000000.1",
    "4294967296",
    "255",
];

/// Token-level edits keep the file mostly well-formed, so they reach validation and the BVH.
fn mutate_tokens(text: &str, rng: &mut StdRng) -> String {
    let numbers: Vec<(usize, usize)> = {
        let bytes = text.as_bytes();
        let mut spans = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i].is_ascii_digit() && (i == 0 || !bytes[i - 1].is_ascii_alphanumeric()) {
                let start = if i > 0 && bytes[i - 1] == b'-' { i - 1 } else { i };
                while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
                    i += 1;
                }
                spans.push((start, i));
            } else {
                i += 1;
            }
        }
        spans
    };
    let mut out = text.to_string();
    for _ in 0..rng.random_range(1..4) {
        match rng.random_range(0..4) {
            // A number replaced by one of the dangerous ones.
            0 | 1 => {
                let (start, end) = numbers[rng.random_range(0..numbers.len())];
                if end <= out.len() && out.is_char_boundary(start) && out.is_char_boundary(end) {
                    out.replace_range(start..end, NUMBERS[rng.random_range(0..NUMBERS.len())]);
                }
            }
            // A line duplicated (duplicate names, repeated objects) or removed.
            2 => {
                let mut lines: Vec<&str> = out.lines().collect();
                let k = rng.random_range(0..lines.len());
                if rng.random_bool(0.5) {
                    lines.insert(k, lines[k]);
                } else {
                    lines.remove(k);
                }
                out = lines.join("\n");
            }
            // A name made hostile.
            _ => {
                out = out.replacen(
                    "name: \"",
                    ["name: \"../", "name: \"/", "name: \"\\u{0}", "name: \"\""][rng.random_range(0..4)],
                    1,
                );
            }
        }
    }
    out
}

/// Byte-level edits: flips, insertions, deletions, truncation.
fn mutate_bytes(text: &str, rng: &mut StdRng) -> String {
    let mut bytes = text.as_bytes().to_vec();
    for _ in 0..rng.random_range(1..4) {
        let at = rng.random_range(0..bytes.len());
        match rng.random_range(0..4) {
            0 => bytes[at] = rng.random(),
            1 => bytes.insert(at, b"()[]{},:\"-.e0\\"[rng.random_range(0..14)]),
            2 => {
                let end = (at + rng.random_range(1..40)).min(bytes.len());
                bytes.drain(at..end);
            }
            _ => bytes.truncate(at),
        }
        if bytes.is_empty() {
            break;
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Loads, builds and renders one mutated scene: whether it rendered, or `Err` describing a
/// broken promise.
fn exercise(text: &str) -> Result<bool, String> {
    let path = Path::new("fuzz.ron");
    match Scene::from_ron(text, path) {
        Ok(scene) => {
            let renderer = Renderer::new(BackendChoice::Cpu).map_err(|e| e.to_string())?;
            let prepared = renderer.prepare(&scene).map_err(|e| e.to_string())?;
            let (lo, hi) = scene.bounds().ok_or("a loaded scene has bounds")?;
            let camera = Camera::Equirectangular(Equirectangular { width: 16, height: 8 });
            renderer
                .render(
                    &prepared,
                    &camera,
                    &Pose::new((lo + hi) / 2.0, DVec3::ZERO),
                    Planes::COLOUR,
                )
                .map_err(|e| format!("render failed: {e}"))?;
            Ok(true)
        }
        Err(error @ SceneError::Parse { line, column, .. }) if line >= 1 && column >= 1 => {
            let message = error.to_string();
            message
                .starts_with(&format!("fuzz.ron:{line}:{column}: "))
                .then_some(false)
                .ok_or(format!("parse error without its position: {message}"))
        }
        Err(error @ SceneError::Invalid { location: None, .. }) => {
            // Only a name the text does not hold literally (escapes) cannot be located.
            let SceneError::Invalid { ref object, .. } = error else {
                unreachable!()
            };
            match text.contains(&format!("\"{object}\"")) {
                true => Err(format!("invalid object not located: {error}")),
                false => Ok(false),
            }
        }
        Err(SceneError::Parse { .. }) => Err("parse error at line or column 0".into()),
        Err(_) => Ok(false),
    }
}

#[test]
fn mutated_scene_files_never_panic_and_errors_say_where() {
    let mut failures = Vec::new();
    let mut rendered = 0;
    for (room_index, room) in common::ROOMS.iter().enumerate() {
        let text = std::fs::read_to_string(common::scene_path(room)).unwrap();
        let mut rng = StdRng::seed_from_u64(0x5eed + room_index as u64);
        for case in 0..MUTATIONS {
            let mutated = if case % 2 == 0 {
                mutate_tokens(&text, &mut rng)
            } else {
                mutate_bytes(&text, &mut rng)
            };
            let outcome =
                catch_unwind(AssertUnwindSafe(|| exercise(&mutated))).unwrap_or_else(|_| Err("panicked".to_string()));
            rendered += usize::from(outcome == Ok(true));
            if let Err(problem) = outcome {
                let kept = std::env::temp_dir().join(format!("omnisim-fuzz-{room}-{case}.ron"));
                let _ = std::fs::write(&kept, &mutated);
                failures.push(format!("{room} case {case} ({}): {problem}", kept.display()));
            }
        }
    }
    // The token edits must reach the BVH and the renderer often, or they test only the parser.
    assert!(rendered > MUTATIONS / 10, "only {rendered} mutated scenes rendered");
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
