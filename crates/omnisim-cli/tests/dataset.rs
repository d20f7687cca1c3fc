//! `omnisim dataset` killed at random moments resumes to the bytes of an uninterrupted run; a run
//! holds its folder while it writes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const SPEC: &str = r#"Dataset(
    scene: "env1.ron",
    seed: 5,
    rig: Pinhole(size: (160, 120)),
    outputs: (segmentation: true),
    sets: [
        Set(name: "map", poses: Trajectory(through: [(-2.0, -0.9, 0.4), (2.0, -0.9, 0.4)], count: 12),
            layouts: [Tum(rate: 30.0)], noise: (colour: [Gaussian(sigma: 0.01)], depth: (c2: 0.002))),
        Set(name: "test", poses: Random(count: 8, low: (-2.5, -1.5, 0.0), high: (2.5, 1.5, 1.0), tilt: 10.0),
            occluders: [Occluders(shape: Person, count: 1)]),
    ],
)"#;

fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                files.insert(
                    path.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&path).unwrap(),
                );
            }
        }
    }
    files
}

fn dataset(spec: &Path, out: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_omnisim"));
    command
        .args(["dataset", "--backend", "cpu", "--out"])
        .arg(out)
        .arg(spec)
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    command
}

/// A folder with env1.ron and `SPEC`; returns it and the spec's path.
fn project() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.path().join("env1.ron")).unwrap();
    let spec = dir.path().join("spec.ron");
    std::fs::write(&spec, SPEC).unwrap();
    (dir, spec)
}

#[test]
fn a_run_killed_at_random_moments_resumes_to_the_same_bytes() {
    let (dir, spec) = project();
    let whole = dir.path().join("whole");
    let started = std::time::Instant::now();
    let output = dataset(&spec, &whole).output().unwrap();
    let uninterrupted = started.elapsed();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let reference = snapshot(&whole);
    for set in ["map", "test"] {
        assert!(
            reference.contains_key(&Path::new(set).join("contact-sheet.png")),
            "{set} has no contact sheet"
        );
    }

    let killed = dir.path().join("killed");
    // Kills at random moments within the uninterrupted run's time (fractions from a fixed
    // linear congruential sequence): the same moments, relative to this machine's speed.
    let mut state = 12345u64;
    let mut kills = 0;
    for _ in 0..30 {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let delay = uninterrupted.mul_f64(0.1 + 0.6 * ((state >> 11) as f64 / (1u64 << 53) as f64));
        let mut child = dataset(&spec, &killed).spawn().unwrap();
        std::thread::sleep(delay);
        if let Some(status) = child.try_wait().unwrap() {
            assert!(status.success());
            break;
        } else {
            child.kill().unwrap();
            child.wait().unwrap();
            kills += 1;
        }
    }
    let output = dataset(&spec, &killed).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(kills >= 2, "the run was killed only {kills} times: make it longer");
    let resumed = snapshot(&killed);
    assert_eq!(resumed.keys().collect::<Vec<_>>(), reference.keys().collect::<Vec<_>>());
    for (name, bytes) in &reference {
        assert!(
            &resumed[name] == bytes,
            "{} differs after {kills} kills",
            name.display()
        );
    }
}

/// A run holds its folder against an `--overwrite` of another spec while it writes (shown
/// with the folder and what to do); killed, it holds nothing.
#[test]
fn a_running_data_set_is_not_overwritten_and_a_killed_one_blocks_nothing() {
    let (dir, spec) = project();
    // Long enough to be running still when the second command starts.
    std::fs::write(&spec, SPEC.replace("count: 12", "count: 400")).unwrap();
    let other = dir.path().join("other.ron");
    std::fs::write(&other, SPEC.replace("seed: 5", "seed: 6")).unwrap();
    let out = dir.path().join("out");
    let mut running = dataset(&spec, &out).spawn().unwrap();
    while !out.join("map/.frames/000000.json").exists() {
        assert!(running.try_wait().unwrap().is_none(), "the first run ended early");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let refused = dataset(&other, &out).arg("--overwrite").output().unwrap();
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert!(
        stderr.contains(&format!("{} is in use by another omnisim run", out.display()))
            && stderr.contains("wait for it to end"),
        "{stderr}"
    );
    assert!(running.try_wait().unwrap().is_none(), "the first run ended early");
    running.kill().unwrap();
    running.wait().unwrap();
    let output = dataset(&other, &out).arg("--overwrite").output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("--overwrite: removed"), "{stderr}");
}

#[test]
fn preview_writes_the_svg_and_png_it_names_and_locates_spec_errors() {
    let (dir, spec) = project();
    let prefix = dir.path().join("pictures/plan");
    let preview = || {
        Command::new(env!("CARGO_BIN_EXE_omnisim"))
            .args(["preview", "--out"])
            .arg(&prefix)
            .arg(&spec)
            .output()
            .unwrap()
    };
    let output = preview();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let printed = String::from_utf8(output.stdout).unwrap();
    let svg = dir.path().join("pictures/plan.svg");
    let png = dir.path().join("pictures/plan.png");
    assert_eq!(printed, format!("{}\n{}\n", svg.display(), png.display()));
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg "));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    assert!(String::from_utf8_lossy(&output.stderr).contains("20 pose(s) of 2 set(s)"));

    std::fs::write(&spec, SPEC.replace("count: 12", "count: 1")).unwrap();
    let output = preview();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("spec.ron:") && stderr.contains("set 'map': poses.count"),
        "{stderr}"
    );
}

/// Write failures that stop even root (CI runs as root, so permissions do not): a file-size
/// limit (`ulimit -f`; omnisim ignores SIGXFSZ, so writes fail with EFBIG, as on a full disk,
/// instead of the signal killing it silently) that a frame's point cloud exceeds, and an output
/// path through a regular file.
#[test]
fn write_failures_end_with_a_clear_message_and_resume_to_the_same_bytes() {
    let (dir, spec) = project();
    let whole = dir.path().join("whole");
    assert!(dataset(&spec, &whole).status().unwrap().success());

    // 250 KiB: the set files (ray map 222 kB) fit, each frame's 288 kB PLY does not.
    let limited = dir.path().join("limited");
    let script = format!(
        "ulimit -f 250; exec \"$0\" dataset --backend cpu --out '{}' '{}'",
        limited.display(),
        spec.display()
    );
    let output = Command::new("bash")
        .args(["-c", &script, env!("CARGO_BIN_EXE_omnisim")])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        // Writers race: the first PLY to fail may be frame 0's or a later one's.
        stderr.contains(".ply: File too large") && stderr.contains("run the same command again to resume"),
        "{stderr}"
    );
    // The limit behind it is named, once, whichever writer's error carried it.
    assert_eq!(stderr.matches("`ulimit -f`").count(), 1, "{stderr}");
    let partial = snapshot(&limited);
    assert!(
        partial.keys().any(|p| p.ends_with("env1-0000.png")),
        "frame 0 was under way"
    );
    assert!(
        !partial
            .keys()
            .any(|p| p.to_string_lossy().contains("omnisim-tmp") || p.ends_with("env1-0000.ply")),
        "half-written files left: {:?}",
        partial.keys().collect::<Vec<_>>()
    );
    assert!(
        !partial.contains_key(Path::new("map/.frames/000000.json")),
        "frame 0 counted as done"
    );
    let output = dataset(&spec, &limited).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(
        snapshot(&limited) == snapshot(&whole),
        "the resumed run differs from an uninterrupted one"
    );

    let through_file = spec.join("out");
    let output = dataset(&spec, &through_file).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    // The file in the way is named, and resuming is not suggested (it would fail the same way).
    assert!(
        stderr.contains(&format!("{} is a file, not a folder", spec.display())) && !stderr.contains("resume"),
        "{stderr}"
    );
}
