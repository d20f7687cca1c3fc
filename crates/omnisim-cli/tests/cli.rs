//! The `omnisim` binary as a user runs it: a real render writes every promised file; bad
//! input fails with a clear message, a non-zero exit code and no output left behind.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `omnisim` with a command line (split on white space) from the workspace folder.
fn omnisim(line: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args(line.split_whitespace())
        .current_dir(workspace())
        .output()
        .expect("omnisim runs")
}

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn render_writes_image_range_cloud_poses_and_metadata() {
    let out = tempfile::tempdir().unwrap();
    let out_dir = out.path().join("frames");
    let result = omnisim(&format!(
        "render scenes/env1.ron --camera omni --pose 1.5,0,0.4,0,0,60 --pose 0,0,0.4 --backend cpu --out {}",
        out_dir.display()
    ));
    assert!(result.status.success(), "{}", text(&result.stderr));
    let stdout = text(&result.stdout);
    for name in [
        "env1-0000.png",
        "env1-0000-range.exr",
        "env1-0000.ply",
        "env1-0001.png",
        "poses.txt",
        "render.json",
    ] {
        assert!(out_dir.join(name).is_file(), "{name} missing");
        assert!(stdout.contains(name), "{name} not reported");
    }
    let stderr = text(&result.stderr);
    assert!(
        stderr.contains("backend: cpu") && stderr.contains("rendered 2"),
        "{stderr}"
    );
    let poses = std::fs::read_to_string(out_dir.join("poses.txt")).unwrap();
    let second: Vec<f64> = poses
        .lines()
        .nth(2)
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(second, vec![1.0, 0.0, 0.0, 0.4, 0.0, 0.0, 0.0, 1.0]);
    let first: Vec<f64> = poses
        .lines()
        .nth(1)
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!((first[6] - 30f64.to_radians().sin()).abs() < 1e-12 && (first[7] - 30f64.to_radians().cos()).abs() < 1e-12);
    let metadata: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("render.json")).unwrap()).unwrap();
    assert_eq!(metadata["camera"]["model"], "hyperbolic-catadioptric");
    assert_eq!(metadata["frames"].as_array().unwrap().len(), 2);
    // No temporary files remain.
    assert!(
        std::fs::read_dir(&out_dir).unwrap().all(|e| !e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .starts_with(".omnisim-tmp-"))
    );
}

#[test]
fn scene_check_and_export() {
    let out = tempfile::tempdir().unwrap();
    let check = omnisim("scene check scenes/env2.ron");
    assert!(check.status.success());
    assert!(text(&check.stdout).contains("partition"));
    let ply = out.path().join("env2.ply");
    let export = omnisim(&format!("scene export scenes/env2.ron {}", ply.display()));
    assert!(export.status.success(), "{}", text(&export.stderr));
    assert!(std::fs::metadata(&ply).unwrap().len() > 1000);
    let wrong = omnisim(&format!(
        "scene export scenes/env2.ron {}",
        out.path().join("env2.stl").display()
    ));
    assert!(!wrong.status.success() && text(&wrong.stderr).contains(".ply or .obj"));
}

/// An --out that is a file (or lies below one) is named as such, not as the system's "File
/// exists", and nothing is written.
#[test]
fn an_output_folder_that_is_a_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("afile");
    std::fs::write(&file, b"mine").unwrap();
    for out in [file.clone(), file.join("below")] {
        let line = format!(
            "render scenes/env1.ron --camera omni --size 16x16 --pose 0,0,0.4,0,0,0 --out {}",
            out.display()
        );
        let refused = omnisim(&line);
        let stderr = text(&refused.stderr);
        assert!(
            !refused.status.success() && stderr.contains(&format!("{} is a file, not a folder", file.display())),
            "{line}: {stderr}"
        );
        assert_eq!(std::fs::read(&file).unwrap(), b"mine");
    }
}

/// `scene export` and `preview` replace what they wrote before, and refuse any other file at
/// their output's name (a scene's own mesh, a user's picture), leaving it as it was.
#[test]
fn exports_and_previews_never_replace_a_users_file() {
    let out = tempfile::tempdir().unwrap();
    for name in ["mesh.ply", "mesh.obj"] {
        let path = out.path().join(name);
        let line = format!("scene export scenes/env2.ron {}", path.display());
        for _ in 0..2 {
            let again = omnisim(&line);
            assert!(again.status.success(), "{line}: {}", text(&again.stderr));
        }
        let users = b"ply\nformat ascii 1.0\ncomment a user's own mesh\n";
        std::fs::write(&path, users).unwrap();
        let refused = omnisim(&line);
        let stderr = text(&refused.stderr);
        assert!(
            !refused.status.success() && stderr.contains("is not a scene omnisim exported"),
            "{line}: {stderr}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), users);
    }
    let prefix = out.path().join("plan");
    let line = format!("preview scenes/env1-dataset.ron --out {}", prefix.display());
    for _ in 0..2 {
        let again = omnisim(&line);
        assert!(again.status.success(), "{line}: {}", text(&again.stderr));
    }
    let [svg, png] = ["svg", "png"].map(|extension| prefix.with_extension(extension));
    // A user's picture at either name, with or without the preview's other file beside it.
    for (users, other) in [(&png, &svg), (&svg, &png)] {
        std::fs::remove_file(other).ok();
        std::fs::write(users, b"a user's picture").unwrap();
        let refused = omnisim(&line);
        let stderr = text(&refused.stderr);
        assert!(
            !refused.status.success() && stderr.contains("is not a preview omnisim drew"),
            "{line}: {stderr}"
        );
        assert_eq!(std::fs::read(users).unwrap(), b"a user's picture");
        assert!(!other.exists(), "{} written", other.display());
        std::fs::remove_file(users).unwrap();
    }
}

/// Writes `scene` to a temporary folder, renders it, and returns (stderr, whether the output
/// folder exists).
fn render_bad(scene: &str) -> (String, bool) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.ron");
    std::fs::write(&path, scene).unwrap();
    let out_dir = dir.path().join("out");
    let result = omnisim(&format!(
        "render {} --pose 0,0,1 --backend cpu --out {}",
        path.display(),
        out_dir.display()
    ));
    assert!(!result.status.success(), "bad scene accepted: {scene}");
    assert_eq!(result.status.code(), Some(1));
    (text(&result.stderr), Path::new(&out_dir).exists())
}

#[test]
fn bad_scene_files_fail_clearly_and_write_nothing() {
    let cases = [
        (
            "Scene(name: \"t\", objects: [\n  Wall(name: \"w\" from: (0.0, 0.0)),\n])",
            "bad.ron:2:",
            "",
        ),
        (
            "Scene(name: \"t\", objects: [\n  Box(name: \"crate\", size: (1.0, NaN, 1.0), colour: (1,1,1)),\n])",
            "bad.ron:2:7: object 'crate'",
            "finite",
        ),
        (
            "Scene(name: \"t\", objects: [\n  Polygon(name: \"line\", vertices: [(0.0,0.0,0.0),(1.0,0.0,0.0),(2.0,0.0,0.0)], colour: (1,1,1)),\n])",
            "bad.ron:2:11: object 'line'",
            "degenerate",
        ),
        (
            "Scene(name: \"t\", objects: [\n  Polygon(name: \"bent\", vertices: [(0.0,0.0,0.0),(1.0,0.0,0.0),(1.0,1.0,0.0),(0.0,1.0,0.5)], colour: (1,1,1)),\n])",
            "bad.ron:2:11: object 'bent'",
            "not planar",
        ),
        (
            "Scene(name: \"t\", objects: [\n  Floor(name: \"f\", corners: [(0.0,0.0),(1.0,0.0),(1.0,1.0)], colour: (1,1,1), shiny: true),\n])",
            "bad.ron:2:",
            "shiny",
        ),
        (
            "Scene(name: \"t\", objects: [\n  Mesh(name: \"statue\", path: \"statue.obj\", colour: (1,1,1)),\n])",
            "bad.ron:2:8: object 'statue'",
            "not found",
        ),
    ];
    for (scene, location, detail) in cases {
        let (stderr, out_exists) = render_bad(scene);
        assert!(
            stderr.contains(location) && stderr.contains(detail),
            "expected '{location}' and '{detail}' in: {stderr}"
        );
        assert!(!out_exists, "output folder created for a bad scene");
    }
    let missing = omnisim("render scenes/nope.ron --pose 0,0,1");
    assert!(!missing.status.success() && text(&missing.stderr).contains("scenes/nope.ron"));
}

#[test]
fn bad_options_are_explained() {
    let huge = omnisim("render scenes/env1.ron --pose 0,0,1 --size 20000x20000");
    assert!(
        !huge.status.success() && text(&huge.stderr).contains("400000000 pixels (400 megapixels)"),
        "{}",
        text(&huge.stderr)
    );
    let no_pose = omnisim("render scenes/env1.ron");
    assert!(!no_pose.status.success() && text(&no_pose.stderr).contains("--pose"));
    let bad_pose = omnisim("render scenes/env1.ron --pose 1,2");
    assert!(!bad_pose.status.success() && text(&bad_pose.stderr).contains("x,y,z"));
    let too_high = omnisim("render scenes/env1.ron --pose 0,0,0 --max-elevation 80");
    assert!(
        !too_high.status.success() && text(&too_high.stderr).contains("asin(b/c)"),
        "{}",
        text(&too_high.stderr)
    );
    // A number out of range is shown as typed, not as 309 digits.
    let wide = omnisim("render scenes/env1.ron --pose 0,0,0.4 --camera pinhole --hfov 1e308");
    assert!(
        !wide.status.success() && text(&wide.stderr).contains("(exclusive), not 1e308"),
        "{}",
        text(&wide.stderr)
    );
}

#[test]
fn stereo_writes_both_images_disparity_and_calibration() {
    let out = tempfile::tempdir().unwrap();
    let dir = out.path().join("stereo");
    let result = omnisim(&format!(
        "render scenes/env1.ron --camera stereo --size 160x120 --baseline 0.2 --pose 0,0,1 --backend cpu --out {}",
        dir.display()
    ));
    assert!(result.status.success(), "{}", text(&result.stderr));
    for name in [
        "env1-0000-left.png",
        "env1-0000-right.png",
        "env1-0000-left-range.exr",
        "env1-0000-disparity.exr",
        "env1-0000-left-depth.png",
        "env1-0000-right-depth.exr",
        "calibration-opencv-stereo.yaml",
        "calibration-kalibr.yaml",
        "raymap-left-origin.exr",
        "raymap-left-direction.exr",
        "raymap-right-origin.exr",
        "raymap-right-direction.exr",
        "raymap-left-all.exr",
        "raymap-right-all.exr",
    ] {
        assert!(dir.join(name).is_file(), "{name} missing");
    }
    let kalibr = std::fs::read_to_string(dir.join("calibration-kalibr.yaml")).unwrap();
    assert!(
        kalibr.contains("cam1:") && kalibr.contains("T_cn_cnm1") && kalibr.contains("-0.2"),
        "{kalibr}"
    );
}

#[test]
fn mirror_options_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("omni");
    let shortcut_misaligned = omnisim(&format!(
        "render scenes/env1.ron --pose 0,0,0.4 --mirror-rays shortcut --misalign-offset 0.001,0,0 --out {}",
        out.display()
    ));
    assert!(!shortcut_misaligned.status.success());
    assert!(
        text(&shortcut_misaligned.stderr).contains("aligned"),
        "{}",
        text(&shortcut_misaligned.stderr)
    );
    let inside_sphere = omnisim(&format!(
        "render scenes/env1.ron --pose 0,0,0.4 --mirror spherical --camera-distance 0.01 --out {}",
        out.display()
    ));
    assert!(!inside_sphere.status.success() && text(&inside_sphere.stderr).contains("outside the sphere"));
    assert!(!out.exists());
    let parabolic = omnisim(&format!(
        "render scenes/env1.ron --pose 0,0,0.4 --mirror parabolic --backend cpu --out {}",
        out.display()
    ));
    assert!(parabolic.status.success(), "{}", text(&parabolic.stderr));
    let omnidir = std::fs::read_to_string(out.join("calibration-opencv-omnidir.yaml")).unwrap();
    assert!(omnidir.contains("\nxi: 1.0\n"), "{omnidir}");
}

#[test]
fn pose_files_for_grids_trajectories_and_random_tests_render() {
    let dir = tempfile::tempdir().unwrap();
    let grid = dir.path().join("grid.txt");
    let made = omnisim(&format!(
        "poses grid --x=-2:2:1 --y=-1:1:1 --z 0.4 --angles 0,0,90 --out {}",
        grid.display()
    ));
    assert!(made.status.success(), "{}", text(&made.stderr));
    let lines: Vec<String> = std::fs::read_to_string(&grid)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(String::from)
        .collect();
    assert_eq!(lines.len(), 15);
    assert_eq!(lines[1], "-1 -1 0.4 0 0 90");

    let trajectory = omnisim("poses trajectory --through=-2,-1,0.4 --through 2,-1,0.4 --spacing 0.5");
    assert!(trajectory.status.success());
    assert_eq!(
        text(&trajectory.stdout).lines().filter(|l| !l.starts_with('#')).count(),
        9
    );

    let random = dir.path().join("random.txt");
    let made = omnisim(&format!(
        "poses random scenes/env2.ron --count 4 --z 0.4 --seed 3 --out {}",
        random.display()
    ));
    assert!(made.status.success());
    let again = omnisim("poses random scenes/env2.ron --count 4 --z 0.4 --seed 3");
    assert_eq!(
        std::fs::read_to_string(&random).unwrap(),
        text(&again.stdout),
        "same seed, same poses"
    );
    let out = dir.path().join("frames");
    let rendered = omnisim(&format!(
        "render scenes/env2.ron --camera equirect --size 64x32 --poses-file {} --backend cpu --no-ply --out {}",
        random.display(),
        out.display()
    ));
    assert!(rendered.status.success(), "{}", text(&rendered.stderr));
    assert!(out.join("env2-0003.png").is_file());

    let impossible = omnisim("poses random scenes/env1.ron --count 3 --clearance 5");
    assert!(!impossible.status.success() && text(&impossible.stderr).contains("--clearance"));
    let backwards = omnisim("poses grid --x 1:0:1 --y 0 --z 0");
    assert!(!backwards.status.success() && text(&backwards.stderr).contains("START:STOP:STEP"));
    // Trajectories: a waypoint where no scene lies, one point twice, and a spacing shown as typed.
    for (line, said) in [
        ("--through 0,0,0 --through 1e300,0,0 --spacing 1e290", "beyond ±1e6 m"),
        ("--through 0,0,0 --through 0,0,0 --spacing 1", "all the same point"),
        (
            "--through 0,0,0 --through 1,0,0 --spacing 1e-300",
            "1 m every 1e-300 m is more than",
        ),
    ] {
        let refused = omnisim(&format!("poses trajectory {line}"));
        let stderr = text(&refused.stderr);
        assert!(!refused.status.success() && stderr.contains(said), "{line}: {stderr}");
    }
}

#[test]
fn render_help_names_every_lens_and_lens_options_are_checked() {
    let help = text(&omnisim("render --help").stdout);
    for model in [
        "kannala-brandt",
        "equidistant",
        "equisolid",
        "stereographic",
        "orthographic",
        "double-sphere",
        "eucm",
        "unified",
        "scaramuzza",
        "radtan",
        "rational",
        "thin-prism",
    ] {
        assert!(help.contains(model), "render --help names no {model}");
    }
    let refused = [
        (
            "--camera fisheye --lens orthographic --fov 200",
            "between 0 and 180.00 degrees",
        ),
        (
            "--camera fisheye --lens double-sphere --xi 1.5",
            "double-sphere xi = 1.5",
        ),
        ("--camera fisheye --lens eucm --beta=-1", "eucm beta"),
        ("--camera fisheye --lens scaramuzza", "--poly"),
        ("--camera fisheye --lens scaramuzza --poly 5,0,0.001", "scaramuzza a0"),
        ("--camera fisheye --lens equisolid --k 0.1,0,0,0", "--k does not apply"),
        (
            "--camera pinhole --distortion rational --dist 0.1,0,0,0",
            "takes 8 coefficients",
        ),
        (
            "--camera stereo --lens equidistant --distortion radtan --dist 0.1,0,0,0",
            "--distortion does not apply to --camera stereo --lens equidistant",
        ),
        (
            "--camera stereo --lens kannala-brandt --hfov 90",
            "--hfov does not apply to --camera stereo --lens kannala-brandt",
        ),
        ("--camera stereo --fov 120", "--fov does not apply to --camera stereo"),
        (
            "--camera omni --lens kannala-brandt --fov 100",
            "--fov does not apply to --camera omni --mirror hyperbolic --lens kannala-brandt",
        ),
        (
            "--camera omni --mirror parabolic --distortion radtan --dist 0.1,0,0,0",
            "the parabolic mirror's camera is orthographic",
        ),
        (
            "--camera omni --lens scaramuzza --poly=-40,0,0.008",
            "the scaramuzza lens sets its own scale",
        ),
        (
            "--camera stereo --lens orthographic --fov 200",
            "between 0 and 180.00 degrees",
        ),
        (
            "--camera stereo --lens scaramuzza --poly=-40,0,0.008 --focal 30",
            "--focal does not apply",
        ),
        (
            "--camera stereo --distortion rational --dist 0.1,0,0,0",
            "takes 8 coefficients",
        ),
        (
            "--camera fisheye --lens kannala-brandt --k 0.1,0",
            "--k (k1,k2,k3,k4) takes 4 numbers",
        ),
    ];
    for (options, message) in refused {
        let result = omnisim(&format!(
            "render scenes/env1.ron {options} --pose 0,0,0.4 --backend cpu --out /nonexistent/never"
        ));
        let stderr = text(&result.stderr);
        assert!(
            !result.status.success() && stderr.contains(message),
            "{options}: {stderr}"
        );
    }
}

#[test]
fn every_example_in_render_help_runs() {
    let help = text(&omnisim("render --help").stdout);
    let examples: Vec<&str> = help
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("omnisim render "))
        .collect();
    assert!(examples.len() >= 3, "{help}");
    let dir = tempfile::tempdir().unwrap();
    for (i, example) in examples.iter().enumerate() {
        // Same command, written to a temporary folder, on the CPU so it runs anywhere.
        let words: Vec<&str> = example.split_whitespace().skip(1).collect();
        let out_at = words.iter().position(|w| *w == "--out").expect("examples name --out");
        let mut line = words[..out_at].join(" ");
        line += &format!(
            " --out {} --backend cpu --no-ply",
            dir.path().join(i.to_string()).display()
        );
        let result = omnisim(&line);
        assert!(result.status.success(), "{example}: {}", text(&result.stderr));
    }
}

#[test]
fn render_writes_segmentation_normals_and_linear_colour_on_request() {
    let out = tempfile::tempdir().unwrap();
    let result = omnisim(&format!(
        "render scenes/env1.ron --camera stereo --size 64x48 --pose 0,0,0.6,0,0,30 --backend cpu \
         --segmentation --normals --linear --no-ply --out {}",
        out.path().display()
    ));
    assert!(result.status.success(), "{}", text(&result.stderr));
    for side in ["left", "right"] {
        for suffix in ["object.png", "face.png", "normal.exr", "linear.exr"] {
            let name = format!("env1-0000-{side}-{suffix}");
            assert!(out.path().join(&name).is_file(), "{name} missing");
        }
    }
    let legend: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("segmentation.json")).unwrap()).unwrap();
    let objects = legend["objects"].as_array().unwrap();
    assert_eq!(objects[0]["name"], "floor");
    assert_eq!(objects[0]["id"], 1);
    assert_eq!(objects.len(), 17);
}

/// `omnisim render` under a shell's `ulimit -v` of `kib` KiB, from the workspace.
#[cfg(target_os = "linux")]
fn render_limited(kib: u64, args: &str) -> Output {
    Command::new("bash")
        .args(["-c", &format!("ulimit -v {kib} && exec \"$0\" render {args}")])
        .arg(env!("CARGO_BIN_EXE_omnisim"))
        .current_dir(workspace())
        .output()
        .unwrap()
}

/// README's largest image (100 megapixels) under a 4 GiB address-space limit was killed for
/// memory part-way; it is refused before anything is written, stating what it needs and the
/// limit, and `render --help` states the need. An ordinary render under a limit still runs.
#[cfg(target_os = "linux")]
#[test]
fn a_render_that_cannot_fit_its_memory_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big");
    let big = render_limited(
        4 << 20,
        &format!(
            "scenes/env1.ron --camera omni --size 10000x10000 --pose 1.5,0,0.4,0,0,60 --backend cpu --out {}",
            out.display()
        ),
    );
    let stderr = text(&big.stderr);
    assert_eq!(big.status.code(), Some(1), "{stderr}");
    // 55 bytes a pixel (the figure OutputSet::bytes_per_pixel gives, tested in the library),
    // 5.5 GB and a little more, against what 4 GiB leaves.
    assert!(
        stderr.contains("a 10000x10000 render of 1 view(s) (55 bytes a pixel: hit planes 48, colour 3, range writer 4")
            && stderr.contains("needs about 5.")
            && stderr.contains("of it the threads' allocator arenas, reserved and hardly used), more than the address space left under ulimit -v (4."),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing is written");
    let help = text(&omnisim("render --help").stdout);
    assert!(
        help.contains("The default outputs take 55 bytes a pixel (100 megapixels: 5.5 GB"),
        "{help}"
    );
    let small = render_limited(
        1 << 20,
        &format!(
            "scenes/env1.ron --camera omni --size 200x200 --pose 1.5,0,0.4,0,0,60 --backend cpu --out {}",
            dir.path().join("small").display()
        ),
    );
    assert!(small.status.success(), "{}", text(&small.stderr));
}

/// A textured scene's render is refused naming the share of its textures' texels (env1-textured:
/// six baked patterns, 7 427 384 bytes with their mips, as `scene check` lists them) and how to
/// need less.
#[cfg(target_os = "linux")]
#[test]
fn a_textured_render_that_cannot_fit_names_its_textures_share() {
    let dir = tempfile::tempdir().unwrap();
    let refused = |backend: &str| {
        let big = render_limited(
            4 << 20,
            &format!(
                "scenes/env1-textured.ron --camera omni --size 10000x10000 --pose 1.5,0,0.4,0,0,60 --backend {backend} \
                 --out {}",
                dir.path().join(backend).display()
            ),
        );
        let stderr = text(&big.stderr);
        assert_eq!(big.status.code(), Some(1), "{stderr}");
        stderr
    };
    let stderr = refused("cpu");
    assert!(
        stderr.contains("MB for the program and scene, 7.4 MB of it the texels of 6 texture(s) with their mips)")
            && stderr.contains("besides the 0.01 GB already loaded, more than the address space left under ulimit -v")
            && stderr.contains("or scale the scene's textures down (8 bytes a texel, a third more for the mips)"),
        "{stderr}"
    );
    // On the GPU (or `auto`, which may pick it) the upload's host copy of the texels counts too:
    // 4 bytes a texel and mip, half of the 7.4 MB.
    let stderr = refused("gpu");
    assert!(
        stderr.contains(
            "7.4 MB of it the texels of 6 texture(s) with their mips, 3.7 MB their sRGB copy for the GPU upload)"
        ) && stderr.contains("(8 bytes a texel and 4 for the GPU upload, a third more for the mips)"),
        "{stderr}"
    );
}

/// The regular files in `dir` (hidden ones too), sorted.
fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_type().unwrap().is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A folder another run works in now (it holds the folder's lock: here this test does) is
/// refused, and nothing is written; once the lock is let go the same run goes ahead. Two
/// renders started together into one folder both found it free and mixed their files.
#[test]
fn a_folder_in_use_by_another_run_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let held = std::fs::File::open(&out).unwrap();
    if held.try_lock().is_err() {
        eprintln!("this file system cannot lock a folder: nothing to test");
        return;
    }
    let render = format!(
        "render scenes/env1.ron --pose 0,0,0.4 --size 32x32 --backend cpu --out {}",
        out.display()
    );
    let refused = omnisim(&render);
    let stderr = text(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("is in use by another omnisim run now"), "{stderr}");
    assert!(files_in(&out).is_empty(), "nothing written: {:?}", files_in(&out));
    drop(held);
    assert!(succeeds(&render), "the same run once the folder is free");
}

#[test]
fn a_folder_holds_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let omni = format!(
        "render scenes/env1.ron --camera omni --pose 0,0,0.4 --backend cpu --out {}",
        out.display()
    );
    assert!(succeeds(&omni), "first run");
    assert!(succeeds(&omni), "the same command again replaces its own files");
    let omni_files = files_in(&out);
    assert!(omni_files.contains(&"calibration-opencv-omnidir.yaml".to_string()));
    std::fs::write(out.join("notes.txt"), "the user's own").unwrap();

    let pinhole = format!(
        "render scenes/env2.ron --camera pinhole --size 64x48 --pose 0,0,0.4 --backend cpu --out {}",
        out.display()
    );
    let refused = omnisim(&pinhole);
    let stderr = text(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("another run") && stderr.contains("--camera omni") && stderr.contains("--overwrite"),
        "{stderr}"
    );
    let mut expected = omni_files.clone();
    expected.push("notes.txt".into());
    expected.sort();
    assert_eq!(files_in(&out), expected, "a refused run writes nothing");

    let replaced = omnisim(&format!("{pinhole} --overwrite"));
    assert!(replaced.status.success(), "{}", text(&replaced.stderr));
    let mut expected: Vec<String> = text(&replaced.stdout)
        .lines()
        .map(|l| Path::new(l).file_name().unwrap().to_string_lossy().into_owned())
        .chain(["notes.txt".into(), "omnisim-run.txt".into()])
        .collect();
    expected.sort();
    assert_eq!(
        files_in(&out),
        expected,
        "no file of the omni run remains, the user's stays"
    );

    // A folder of files no run recorded is not written into either.
    let foreign = dir.path().join("foreign");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("render.json"), "{}").unwrap();
    let refused = omnisim(&format!(
        "render scenes/env2.ron --camera pinhole --size 64x48 --pose 0,0,0.4 --backend cpu --out {}",
        foreign.display()
    ));
    assert!(
        text(&refused.stderr).contains("no omnisim run recorded"),
        "{}",
        text(&refused.stderr)
    );
    assert_eq!(files_in(&foreign), vec!["render.json".to_string()]);
}

fn succeeds(line: &str) -> bool {
    let result = omnisim(line);
    if !result.status.success() {
        eprintln!("{}", text(&result.stderr));
    }
    result.status.success()
}

#[test]
fn temporaries_left_by_a_killed_run_are_cleaned_by_the_next() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let render = format!(
        "render scenes/env1.ron --camera equirect --size 32x16 --pose 0,0,0.4 --backend cpu --out {}",
        out.display()
    );
    assert!(succeeds(&render));
    // u32::MAX is no process's id: its writer on this host (and process-id namespace) is gone.
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
    let namespace = std::fs::read_link("/proc/self/ns/pid").unwrap_or_default();
    let namespace: String = namespace
        .to_string_lossy()
        .chars()
        .filter(char::is_ascii_alphanumeric)
        .collect();
    let stale = out.join(format!(".omnisim-tmp-4294967295@{}.{namespace}@abcdef", host.trim()));
    std::fs::write(&stale, vec![0u8; 1000]).unwrap();
    let again = omnisim(&render);
    assert!(again.status.success());
    assert!(!stale.exists(), "stale temporary removed");
    assert!(
        text(&again.stderr).contains("removed 1 temporary file"),
        "{}",
        text(&again.stderr)
    );
    // Single-file outputs clean their folder too.
    std::fs::write(&stale, b"x").unwrap();
    let poses = omnisim(&format!(
        "poses grid --x 0 --y 0 --z 0.4 --out {}",
        out.join("grid.txt").display()
    ));
    assert!(poses.status.success() && !stale.exists());
}

#[test]
fn a_closed_or_full_standard_output_is_no_crash() {
    for line in [
        "scene check scenes/env1.ron",
        "poses grid --x=-2:2:0.01 --y=-2:2:0.01 --z 0.4",
    ] {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let closed = Command::new(env!("CARGO_BIN_EXE_omnisim"))
            .args(line.split_whitespace())
            .current_dir(workspace())
            .stdout(writer)
            .output()
            .unwrap();
        let stderr = text(&closed.stderr);
        assert!(
            closed.status.success() && stderr.is_empty(),
            "{line} | closed: {:?} {stderr}",
            closed.status
        );

        let full = Command::new(env!("CARGO_BIN_EXE_omnisim"))
            .args(line.split_whitespace())
            .current_dir(workspace())
            .stdout(std::fs::File::create("/dev/full").unwrap())
            .output()
            .unwrap();
        let stderr = text(&full.stderr);
        assert_eq!(full.status.code(), Some(1), "{line} > /dev/full: {stderr}");
        assert!(
            stderr.contains("cannot write to standard output") && !stderr.contains("panicked"),
            "{stderr}"
        );
    }
}

/// Every command ends with code 1 and no panic when standard error is full, or standard
/// output for the commands that print files (`eprintln!` and `println!` panicked, and with
/// standard error full the panic's message failed too: code 101, nothing said).
#[test]
fn a_full_standard_error_is_no_crash() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display();
    std::fs::copy(workspace().join("scenes/env1.ron"), dir.path().join("env1.ron")).unwrap();
    std::fs::write(
        dir.path().join("spec.ron"),
        r#"Dataset(scene: "env1.ron", rig: Omni(size: (32, 32)), sets: [Set(name: "map", poses: Grid(x: (0.0, 0.0, 1.0), y: (0.0, 0.0, 1.0), z: [0.4]))])"#,
    )
    .unwrap();
    let images = omnisim(&format!(
        "render scenes/env1.ron --size 32x32 --pose 0,0,0.4 --backend cpu --out {d}/images"
    ));
    assert!(images.status.success(), "{}", text(&images.stderr));
    let run = |line: &str, stdout: &str, stderr: &str| {
        Command::new(env!("CARGO_BIN_EXE_omnisim"))
            .args(line.split_whitespace())
            .current_dir(workspace())
            .stdout(std::fs::File::create(stdout).unwrap())
            .stderr(std::fs::File::create(stderr).unwrap())
            .status()
            .unwrap()
    };
    for line in [
        format!("render scenes/env1.ron --size 32x32 --pose 0,0,0.4 --backend cpu --out {d}/r"),
        format!("dataset {d}/spec.ron --backend cpu --out {d}/ds"),
        format!("preview scenes/env1-dataset.ron --out {d}/preview"),
        format!("describe {d}/images -d hog --out {d}/described"),
        format!("project {d}/images --view panorama --out {d}/views"),
        format!("poses grid --x 0 --y 0 --z 0.4 --out {d}/grid.txt"),
        "render scenes/nope.ron".to_string(),
    ] {
        let status = run(&line, "/dev/null", "/dev/full");
        assert_eq!(status.code(), Some(1), "{line} 2> /dev/full");
        // The line itself is good: the same again with standard error to a file succeeds.
        let errors = dir.path().join("errors.txt");
        let again = run(&line, "/dev/null", errors.to_str().unwrap());
        let expected = if line.contains("nope") { Some(1) } else { Some(0) };
        assert_eq!(
            again.code(),
            expected,
            "{line}: {}",
            std::fs::read_to_string(&errors).unwrap()
        );
    }
    let preview = format!("preview scenes/env1-dataset.ron --out {d}/preview");
    let errors = dir.path().join("errors.txt");
    let status = run(&preview, "/dev/full", errors.to_str().unwrap());
    let stderr = std::fs::read_to_string(&errors).unwrap();
    assert_eq!(status.code(), Some(1), "{preview} > /dev/full: {stderr}");
    assert!(
        stderr.contains("cannot write to standard output") && !stderr.contains("panicked"),
        "{stderr}"
    );
}

#[test]
fn single_file_outputs_create_their_folder_before_working() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("a/b/env2.ply");
    let export = omnisim(&format!("scene export scenes/env2.ron {}", ply.display()));
    assert!(export.status.success() && ply.is_file(), "{}", text(&export.stderr));
    let poses = dir.path().join("c/grid.txt");
    let made = omnisim(&format!("poses grid --x 0 --y 0 --z 0.4 --out {}", poses.display()));
    assert!(made.status.success() && poses.is_file(), "{}", text(&made.stderr));
    let chart = dir.path().join("d/chart.svg");
    let drawn = omnisim(&format!(
        "bench scenes/env1.ron --camera omni --size 32x32 --pose 0,0,0.4 --runs 1 --chart {}",
        chart.display()
    ));
    assert!(drawn.status.success() && chart.is_file(), "{}", text(&drawn.stderr));
    // An impossible destination fails before anything is measured.
    std::fs::write(dir.path().join("file"), "x").unwrap();
    let impossible = omnisim(&format!(
        "bench scenes/env1.ron --camera omni --size 32x32 --runs 1 --chart {}",
        dir.path().join("file/chart.svg").display()
    ));
    assert_eq!(impossible.status.code(), Some(1));
    assert!(impossible.stdout.is_empty(), "measured before failing");
}

/// A single output file whose destination is a device or a FIFO is refused, and the device
/// left as it was: the rename that puts the file in place replaced it with a regular file.
#[cfg(unix)]
#[test]
fn single_file_outputs_never_replace_a_device_or_fifo() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    // Named .ply so that `scene export` takes them.
    let fifo = dir.path().join("fifo.ply");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let mut specials = vec![(fifo, "a FIFO (named pipe)")];
    // A character device standing in for /dev/null, where the system lets us make one (root).
    let device = dir.path().join("null.ply");
    if Command::new("mknod")
        .arg(&device)
        .args(["c", "1", "3"])
        .status()
        .is_ok_and(|s| s.success())
    {
        specials.push((device, "a device"));
    }
    let fifo_png = dir.path().join("plan.png");
    assert!(Command::new("mkfifo").arg(&fifo_png).status().unwrap().success());
    let mut lines: Vec<(String, &Path, &str)> = vec![(
        format!(
            "preview scenes/env1-dataset.ron --out {}",
            dir.path().join("plan").display()
        ),
        &fifo_png,
        "a FIFO (named pipe)",
    )];
    for (special, kind) in &specials {
        lines.push((
            format!(
                "bench scenes/env1.ron --camera omni --size 32x32 --runs 1 --warmup 0 --backend cpu --chart {}",
                special.display()
            ),
            special,
            kind,
        ));
        lines.push((
            format!("scene export scenes/env1.ron {}", special.display()),
            special,
            kind,
        ));
    }
    for (line, special, kind) in &lines {
        let result = omnisim(line);
        let stderr = text(&result.stderr);
        assert!(
            result.status.code() == Some(1) && stderr.contains(&format!("is {kind}, not a regular file")),
            "{line}: {stderr}"
        );
        let file_type = std::fs::symlink_metadata(special).unwrap().file_type();
        assert!(
            file_type.is_fifo() || file_type.is_char_device(),
            "{line} replaced {}",
            special.display()
        );
    }
}

#[test]
fn gpu_probes_keep_stderr_clean() {
    let dir = tempfile::tempdir().unwrap();
    let result = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args([
            "render",
            "scenes/env1.ron",
            "--camera",
            "equirect",
            "--size",
            "32x16",
            "--pose",
            "0,0,0.4",
        ])
        .args(["--backend", "gpu", "--out"])
        .arg(dir.path().join("out"))
        .env_remove("XDG_RUNTIME_DIR")
        .current_dir(workspace())
        .output()
        .unwrap();
    let stderr = text(&result.stderr);
    assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{stderr}");
}

/// A scene whose file name is not UTF-8 is refused before any frame (render.json records the
/// scene's file in JSON), not after every frame is written.
#[cfg(unix)]
#[test]
fn a_scene_name_that_is_not_utf8_is_refused_before_rendering() {
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join(std::ffi::OsStr::from_bytes(b"env1\xff.ron"));
    std::fs::copy(workspace().join("scenes/env1.ron"), &scene).unwrap();
    let out = dir.path().join("out");
    let result = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .arg("render")
        .arg(&scene)
        .args(["--pose", "0,0,0.4", "--backend", "cpu", "--out"])
        .arg(&out)
        .current_dir(workspace())
        .output()
        .unwrap();
    let stderr = text(&result.stderr);
    assert_eq!(result.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("is not a UTF-8 name: render.json records the scene's file"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing written");
}

/// wgpu's variables that choose no adapter are named in a plain error (wgpu's own helper
/// panics on a `WGPU_ADAPTER_NAME` that matches nothing), and `auto` renders on the CPU.
#[test]
#[cfg(target_os = "linux")] // no Metal adapter exists there, whatever the machine
fn gpu_variables_that_choose_no_adapter_are_named() {
    for (variable, value) in [
        ("WGPU_ADAPTER_NAME", "no-such-adapter-omnisim"),
        ("WGPU_BACKEND", "metal"),
    ] {
        for backend in ["gpu", "auto"] {
            let dir = tempfile::tempdir().unwrap();
            let result = Command::new(env!("CARGO_BIN_EXE_omnisim"))
                .args(["render", "scenes/env1.ron", "--size", "32x32", "--pose", "0,0,0.4"])
                .args(["--backend", backend, "--out"])
                .arg(dir.path().join("out"))
                .env(variable, value)
                .current_dir(workspace())
                .output()
                .unwrap();
            let stderr = text(&result.stderr);
            assert!(!stderr.contains("panicked"), "{variable} {backend}: {stderr}");
            if backend == "gpu" {
                assert_eq!(result.status.code(), Some(1), "{variable}: {stderr}");
                assert!(stderr.contains(&format!("{variable}={value}")), "{stderr}");
                assert!(
                    stderr.contains(&format!("unset {variable}")) || stderr.contains("unset it"),
                    "{stderr}"
                );
            } else {
                assert!(result.status.success(), "{variable} auto: {stderr}");
                assert!(dir.path().join("out/render.json").exists(), "{variable} auto");
            }
        }
    }
}

/// The outputs opened by the readers people use (`OpenCV`, imageio, `OpenEXR`, plyfile, `PyYAML`,
/// evo), in the Python environment .ci/run makes; see `tests/readers/check_outputs.py`. Every
/// EXR, normals and ray maps included, must open in `OpenCV` and imageio.
#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn outputs_open_in_the_readers_people_use() {
    let python = std::env::var_os("OMNISIM_PYTHON").expect("OMNISIM_PYTHON names no Python: set it to one with tests/readers/requirements.txt (.ci/run makes one) (README, Tests)");
    let dir = tempfile::tempdir().unwrap();
    let poses = "--pose 1.5,0,0.4,0,0,60 --pose 0.3,-0.4,0.5,5,-10,30 --backend cpu --normals";
    for (name, camera) in [
        ("omni", "--camera omni"),
        ("omni-down", "--camera omni --mount down --size 200x200"),
        ("parabolic", "--camera omni --mirror parabolic --size 200x200"),
        ("spherical", "--camera omni --mirror spherical --size 120x120"),
        ("pinhole", "--camera pinhole --size 160x120"),
        ("stereo", "--camera stereo --size 160x120"),
        ("equirect", "--camera equirect --size 128x64"),
        // The faster lossless EXR compressions open in the same readers.
        ("omni-rle", "--camera omni --size 120x120 --exr-compression rle"),
        (
            "stereo-uncompressed",
            "--camera stereo --size 160x120 --exr-compression none",
        ),
        // Lenses: each calibration file they write must put the points on their pixels.
        (
            "fisheye-kb",
            "--camera fisheye --lens kannala-brandt --k 0.02,-0.004,0.0001,0 --fov 200 --size 120x120",
        ),
        (
            "fisheye-ds",
            "--camera fisheye --lens double-sphere --fov 220 --size 120x120",
        ),
        (
            "fisheye-unified",
            "--camera fisheye --lens unified --xi 1.3 --dist=-0.05,0.01,0.0001,-0.0002 --fov 200 --size 120x120",
        ),
        (
            "fisheye-scaramuzza",
            "--camera fisheye --lens scaramuzza --poly=-40,0,0.008,-3e-5,1.5e-8 --size 120x100",
        ),
        // A mirror seen through a distorted lens: cv::omnidir's and Kalibr's radtan express it.
        (
            "omni-radtan",
            "--camera omni --size 160x160 --distortion radtan --dist=-0.1,0.02,0.001,-0.002",
        ),
        // Stereo pairs with a lens: each camera's files, R and T, T_cn_cnm1; no disparity.
        (
            "stereo-kb",
            "--camera stereo --lens kannala-brandt --k 0.02,-0.004,0.0001,0 --fov 200 --size 120x100",
        ),
        (
            "stereo-ds",
            "--camera stereo --lens double-sphere --fov 220 --size 120x100 --baseline 0.3",
        ),
        (
            "stereo-radtan",
            "--camera stereo --distortion radtan --dist=-0.2,0.05,0.001,-0.002 --size 120x100",
        ),
        (
            "pinhole-thin-prism",
            "--camera pinhole --distortion thin-prism --size 160x120 \
             --dist=-0.28,0.07,0.001,-0.002,0.01,0.02,-0.01,0.005,0.001,-0.001,0.002,0.0005",
        ),
    ] {
        let result = omnisim(&format!(
            "render scenes/env1.ron {camera} {poses} --out {}",
            dir.path().join(name).display()
        ));
        assert!(result.status.success(), "{name}: {}", text(&result.stderr));
    }
    let check = Command::new(python)
        .arg("tests/readers/check_outputs.py")
        .arg(dir.path())
        .current_dir(workspace())
        .output()
        .expect("the reader check's Python runs");
    eprintln!("{}", text(&check.stdout));
    assert!(check.status.success(), "{}", text(&check.stderr));
    // Two poses each: one normal map per view (13 single cameras, 5 stereo rigs), one ray map
    // (origin, direction, and both in one file) per view.
    assert!(
        text(&check.stdout).contains("checks passed in 18 folders (46 normal maps, 23 ray maps)"),
        "{}",
        text(&check.stdout)
    );
}

#[test]
fn a_hostile_scene_name_writes_nothing_outside_the_output_folder() {
    let dir = tempfile::tempdir().unwrap();
    let inner = dir.path().join("a/b");
    std::fs::create_dir_all(&inner).unwrap();
    for name in ["../escaped", "../../escaped", "/tmp/omnisim-escaped", "a\\u{0}b"] {
        let scene = inner.join("s.ron");
        std::fs::write(
            &scene,
            format!("Scene(name: \"{name}\", objects: [Wall(name: \"w\", from: (0.0, 0.0), to: (1.0, 0.0), height: 1.0, colour: (1, 1, 1))])"),
        )
        .unwrap();
        let out = inner.join("out");
        let result = omnisim(&format!(
            "render {} --camera equirect --size 16x8 --pose 0,-1,0.5 --backend cpu --out {}",
            scene.display(),
            out.display()
        ));
        assert!(
            !result.status.success() && text(&result.stderr).contains("s.ron:1:7: the scene name"),
            "{}",
            text(&result.stderr)
        );
        let everything: Vec<_> = walk(dir.path());
        assert_eq!(everything, vec![scene.clone()], "{name}");
        assert!(!Path::new("/tmp/omnisim-escaped-0000.png").exists());
    }
}

/// Every file under `dir`.
fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(walk(&path));
        } else {
            files.push(path);
        }
    }
    files
}

#[test]
fn lenient_command_lines_and_nonsense_cameras_are_refused() {
    for (line, expected) in [
        ("render scenes/env1.ron --pose=1,,2,3", "empty value between commas"),
        (
            "render scenes/env1.ron --pose 0,0,0 --camera equirect --mirror-a=0",
            "--mirror-a does not apply to --camera equirect",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --camera omni --mirror spherical --mirror-h 0.1",
            "--mirror-h does not apply to --camera omni --mirror spherical",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --camera pinhole --vfov 40",
            "--vfov does not apply",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --rim 1e-9",
            "rim radius = 1e-9 m is outside its valid range, 1e-6 to 1000 m",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --focal 1e-300",
            "focal = 1e-300 px is outside its valid range",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --misalign-tilt 180,0,0",
            "no pixel",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --hidden-centre inf",
            "hidden centre = inf px is outside its valid range",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --mirror spherical --camera-distance 1e300",
            "camera distance (outside the sphere) = 1e300 m",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --camera stereo --baseline 1e300",
            "baseline = 1e300 m is outside its valid range",
        ),
        (
            "render scenes/env1.ron --pose 0,0,0 --camera equirect --size 10001x10000",
            "(100.01 megapixels)",
        ),
    ] {
        let result = omnisim(line);
        let stderr = text(&result.stderr);
        assert!(
            !result.status.success() && stderr.contains(expected),
            "{line}: {stderr}"
        );
        assert!(!stderr.contains("is 100 megapixels"), "{stderr}");
    }
}

#[test]
fn first_hour_errors_are_brief_and_in_order() {
    // A missing scene is named first, even with other mistakes on the line, and the OS error once.
    let missing = text(&omnisim("render scenes/nope.ron --camera equirect --mirror-a=0").stderr);
    assert!(missing.contains("cannot read scenes/nope.ron"), "{missing}");
    assert_eq!(missing.matches("os error 2").count(), 1, "{missing}");
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.txt");
    std::fs::write(&poses, format!("0 0 0.4\n1 2 {}\n", "7".repeat(10_000_000))).unwrap();
    let long = omnisim(&format!("render scenes/env1.ron --poses-file {}", poses.display()));
    let stderr = text(&long.stderr);
    assert!(
        !long.status.success() && stderr.contains("poses.txt:2:") && stderr.len() < 1000,
        "{} bytes",
        stderr.len()
    );
    // A FIFO as pose file fails at once instead of waiting for a writer.
    let fifo = dir.path().join("fifo.txt");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let started = std::time::Instant::now();
    let blocked = omnisim(&format!("render scenes/env1.ron --poses-file {}", fifo.display()));
    assert!(
        text(&blocked.stderr).contains("is a FIFO (named pipe), not a regular file"),
        "{}",
        text(&blocked.stderr)
    );
    assert!(started.elapsed().as_secs() < 20);
}

#[test]
fn numbers_people_read_carry_no_float_noise() {
    let trajectory = text(
        &omnisim("poses trajectory --through=-2,-1,0.4 --through 2,-1,0.4 --through 2,1,0.4 --spacing 0.1").stdout,
    );
    for value in trajectory
        .lines()
        .filter(|l| !l.starts_with('#'))
        .flat_map(|l| l.split(' '))
    {
        assert!(value.len() <= 12, "noisy number {value} in:\n{trajectory}");
    }
    let check = text(&omnisim("scene check scenes/env1.ron").stdout);
    assert!(check.contains("z [-0.3, 2.3] m"), "{check}");
    let dir = tempfile::tempdir().unwrap();
    let result = omnisim(&format!(
        "render scenes/env1.ron --camera equirect --size 16x8 --pose 0,0,0.4,0,0,30 --backend cpu --out {}",
        dir.path().display()
    ));
    assert!(result.status.success(), "{}", text(&result.stderr));
    let metadata: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("render.json")).unwrap()).unwrap();
    assert_eq!(metadata["frames"][0]["angles_deg"], serde_json::json!([0.0, 0.0, 30.0]));
}

#[test]
fn unsatisfiable_random_poses_fail_fast() {
    let started = std::time::Instant::now();
    let result = omnisim("poses random scenes/env1.ron --count 10000000 --clearance 3");
    let stderr = text(&result.stderr);
    assert!(
        !result.status.success() && stderr.contains("only 0 of 10000 positions drawn were clear"),
        "{stderr}"
    );
    assert!(started.elapsed().as_secs() < 20, "{:?}", started.elapsed());
}

#[test]
fn readme_pose_examples_stay_out_of_the_furniture() {
    let readme = std::fs::read_to_string(workspace().join("README.md")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for kind in ["grid", "trajectory"] {
        let line = readme
            .lines()
            .find(|l| l.contains(&format!("-- poses {kind} ")))
            .expect("README example");
        let arguments = line.split(&format!("-- poses {kind} ")).nth(1).unwrap();
        let arguments = arguments.split(" --out").next().unwrap();
        let poses = dir.path().join(format!("{kind}.txt"));
        assert!(
            omnisim(&format!("poses {kind} {arguments} --out {}", poses.display()))
                .status
                .success()
        );
        let rendered = omnisim(&format!(
            "render scenes/env1.ron --camera equirect --size 8x4 --no-ply --backend cpu --poses-file {} --out {}",
            poses.display(),
            dir.path().join(kind).display()
        ));
        let stderr = text(&rendered.stderr);
        assert!(
            rendered.status.success() && !stderr.contains("warning"),
            "{kind}: {stderr}"
        );
    }
}

/// What the README tells users to type is true: the install uses the lock file, the data-set
/// spec example parses with every field where the spec takes it, and each `evo_traj` example
/// reads a layout the shipped spec's set has.
#[test]
fn readme_install_spec_and_evo_examples_are_true() {
    let readme = std::fs::read_to_string(workspace().join("README.md")).unwrap();
    for line in readme.lines().filter(|l| l.contains("cargo install")) {
        assert!(line.contains("--locked"), "{line}");
    }
    let start = readme.find("## Data sets: one spec, many sets").unwrap();
    let block = readme[start..].split("```ron\n").nth(1).unwrap();
    let block = block.split("```").next().unwrap();
    let outputs = block.lines().find(|l| l.trim_start().starts_with("outputs:")).unwrap();
    assert!(
        outputs.contains("exr_compression:"),
        "exr_compression belongs in outputs: {outputs}"
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(workspace().join("scenes/env1-lit.ron"), dir.path().join("env1-lit.ron")).unwrap();
    std::fs::write(dir.path().join("spec.ron"), block).unwrap();
    let preview = omnisim(&format!(
        "preview {} --out {}",
        dir.path().join("spec.ron").display(),
        dir.path().join("plan").display()
    ));
    assert!(preview.status.success(), "{}", text(&preview.stderr));
    let shipped = std::fs::read_to_string(workspace().join("scenes/env1-dataset.ron")).unwrap();
    let mut examples = 0;
    let flowing = readme.split_whitespace().collect::<Vec<_>>().join(" ");
    for example in flowing.split("evo_traj ").skip(1) {
        let (kind, rest) = example.split_once(" DIR/").unwrap();
        let set = rest.split('/').next().unwrap();
        if set == "SET" {
            continue;
        }
        let layout = if kind == "tum" { "Tum(" } else { "Euroc(" };
        let of_set = shipped
            .split(&format!("name: \"{set}\""))
            .nth(1)
            .expect("a set of the shipped spec");
        let of_set = of_set.split("name: \"").next().unwrap();
        assert!(
            of_set.contains(layout),
            "evo_traj {kind} DIR/{set}: the shipped set has no {layout}..)"
        );
        examples += 1;
    }
    assert!(examples > 0);
}

#[test]
fn bench_finds_scenes_by_name_and_counts_tests_per_ray() {
    let measured =
        omnisim("bench env1 --camera equirect --size 32x16 --pose 0,0,0.4 --backend cpu --runs 1 --warmup 0");
    assert!(measured.status.success(), "{}", text(&measured.stderr));
    let record: serde_json::Value = serde_json::from_slice(&measured.stdout).unwrap();
    assert_eq!(record["scene"], "env1");
    // At least the root and its two children per ray; every ray hits a wall of the room.
    assert!(record["node_tests_per_ray"].as_f64().unwrap() >= 3.0, "{record}");
    assert!(record["triangle_tests_per_ray"].as_f64().unwrap() >= 1.0, "{record}");
    assert!(record["bvh_bytes"].as_u64().unwrap() > 0, "{record}");
    if cfg!(target_os = "linux") {
        assert!(record["peak_rss_mb"].as_f64().unwrap() > 0.0, "{record}");
    }
    // `threads` is the pool the CPU backend ran on (RAYON_NUM_THREADS), not the machine's cores.
    let pooled = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args("bench env1 --camera omni --size 32x32 --backend cpu --runs 1 --warmup 0".split_whitespace())
        .env("RAYON_NUM_THREADS", "3")
        .current_dir(workspace())
        .output()
        .expect("omnisim runs");
    assert!(pooled.status.success(), "{}", text(&pooled.stderr));
    let record: serde_json::Value = serde_json::from_slice(&pooled.stdout).unwrap();
    assert_eq!(record["threads"], 3, "{record}");
    assert!(record["device"].as_str().unwrap().ends_with("on 3 threads"), "{record}");
    let unknown = omnisim("bench no-such-anchor --backend cpu --runs 1");
    assert_eq!(unknown.status.code(), Some(1));
    assert!(
        text(&unknown.stderr).contains("bench/compare.sh"),
        "{}",
        text(&unknown.stderr)
    );
    // The script it names ships in the repository; no text names a folder beside it.
    assert!(workspace().join("bench/compare.sh").is_file());
    let help = omnisim("bench --help");
    for said in [text(&unknown.stderr), text(&help.stdout)] {
        assert!(!said.contains("../"), "{said}");
    }
    assert!(text(&help.stdout).contains("bench/compare.sh"));
}

/// Thread settings beyond what works are kept in range with a warning: a pool beyond four
/// threads a core (99,999 took longer to start than the render and, under a limited address
/// space, never started: a panic), by either of rayon's variables; worker stacks below 2 MiB
/// (16 KiB overflowed) or above 64 MiB (refused).
#[test]
fn thread_settings_beyond_what_works_are_kept_in_range() {
    // --help names the variables read, with their limits.
    let help = text(&omnisim("--help").stdout);
    for variable in ["RAYON_NUM_THREADS", "WGPU_ADAPTER_NAME", "OMNISIM_PROGRESS_SECONDS"] {
        assert!(help.contains(variable), "{help}");
    }
    assert!(help.contains("at most four a core"), "{help}");
    let cores = std::thread::available_parallelism().unwrap().get();
    for variable in ["RAYON_NUM_THREADS", "RAYON_RS_NUM_CPUS"] {
        let capped = Command::new(env!("CARGO_BIN_EXE_omnisim"))
            .args("bench env1 --camera omni --size 32x32 --backend cpu --runs 1 --warmup 0".split_whitespace())
            .env_remove("RAYON_NUM_THREADS")
            .env(variable, "99999")
            .current_dir(workspace())
            .output()
            .expect("omnisim runs");
        assert!(capped.status.success(), "{}", text(&capped.stderr));
        let record: serde_json::Value = serde_json::from_slice(&capped.stdout).unwrap();
        assert_eq!(record["threads"], 4 * cores, "{variable}: {record}");
        assert!(
            text(&capped.stderr).contains(&format!(
                "{variable}=99999 is more than 4 threads for each of this machine's {cores} cores; using {}",
                4 * cores
            )),
            "{}",
            text(&capped.stderr)
        );
    }
    // Threads the system refuses (here 64 MiB stacks for eight or more threads under a 300 MB
    // address space) end the command with what to lower, not a panic at the first parallel call.
    #[cfg(target_os = "linux")]
    {
        let refused = Command::new("bash")
            .args([
                "-c",
                "ulimit -v 300000; exec \"$0\" --version",
                env!("CARGO_BIN_EXE_omnisim"),
            ])
            .env("RUST_MIN_STACK", (64 << 20).to_string())
            .env("RAYON_NUM_THREADS", "8")
            .output()
            .unwrap();
        let stderr = text(&refused.stderr);
        assert_eq!(refused.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains("worker threads") && stderr.contains("set RAYON_NUM_THREADS to fewer"),
            "{stderr}"
        );
    }
    for (stack, kept) in [("16384", 2 << 20), ("100000000000", 64 << 20), ("lots", 2 << 20)] {
        let dir = tempfile::tempdir().unwrap();
        let rendered = Command::new(env!("CARGO_BIN_EXE_omnisim"))
            .args(
                "render scenes/env1.ron --pose 1.5,0,0.4,0,0,60 --size 300x300 --backend cpu --out".split_whitespace(),
            )
            .arg(dir.path().join("out"))
            .env("RUST_MIN_STACK", stack)
            .current_dir(workspace())
            .output()
            .expect("omnisim runs");
        let stderr = text(&rendered.stderr);
        assert!(rendered.status.success(), "RUST_MIN_STACK={stack}: {stderr}");
        assert!(
            stderr.contains(&format!(
                "RUST_MIN_STACK={stack} is not a stack size from 2097152 to 67108864 bytes; using {kept}"
            )),
            "{stderr}"
        );
    }
}

/// docs/speed-accuracy.svg is what `bench --chart --chart-from` draws from the figures beside
/// it, so the shipped chart follows the chart code; `--chart-from` alone is refused.
#[test]
fn the_shipped_speed_chart_is_drawn_from_its_figures() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("chart.svg");
    let drawn = omnisim(&format!(
        "bench scenes/env1.ron --camera omni --chart {} --chart-from docs/speed-accuracy.jsonl",
        svg.display()
    ));
    assert!(drawn.status.success(), "{}", text(&drawn.stderr));
    let shipped = std::fs::read_to_string(workspace().join("docs/speed-accuracy.svg")).unwrap();
    assert!(
        std::fs::read_to_string(&svg).unwrap() == shipped,
        "docs/speed-accuracy.svg is out of date: redraw it with bench --chart docs/speed-accuracy.svg --chart-from docs/speed-accuracy.jsonl"
    );
    let alone = omnisim("bench scenes/env1.ron --chart-from docs/speed-accuracy.jsonl");
    assert!(!alone.status.success() && text(&alone.stderr).contains("--chart"));
}

/// The comparison scripts `bench --help` points to ship in bench/ and print their usage without
/// Python.
#[test]
fn bench_scripts_print_their_usage() {
    for script in ["bench/compare.sh", "bench/same_rays.sh"] {
        let usage = Command::new("bash")
            .args([script, "--help"])
            .current_dir(workspace())
            .output()
            .unwrap();
        assert!(usage.status.success(), "{script}: {}", text(&usage.stderr));
        assert!(
            text(&usage.stdout).contains(&format!("OMNISIM=target/release/omnisim {script}")),
            "{}",
            text(&usage.stdout)
        );
    }
}

/// With the reader check's Python (it has `Open3D` and `OpenEXR`), `same_rays.py` reads the rays
/// of a render's two ray-map files, as many as the image has pixels with a ray.
#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn same_rays_reads_a_renders_ray_maps() {
    let python = std::env::var_os("OMNISIM_PYTHON").expect("OMNISIM_PYTHON names the reader check's Python");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("omni");
    let result = omnisim(&format!(
        "render scenes/env1.ron --camera omni --size 40x40 --pose 0,0,0.4 --backend cpu --no-ply --out {}",
        out.display()
    ));
    assert!(result.status.success(), "{}", text(&result.stderr));
    let read = Command::new(python)
        .args([
            "-c",
            "import sys; sys.path.insert(0, 'bench'); import same_rays, numpy as np; \
             o, d = same_rays.read_raymap(sys.argv[1]); \
             assert np.allclose(np.linalg.norm(d, axis=1), 1, atol=1e-6); print(len(o))",
        ])
        .arg(&out)
        .current_dir(workspace())
        .output()
        .unwrap();
    assert!(read.status.success(), "{}", text(&read.stderr));
    let rays: usize = text(&read.stdout).trim().parse().unwrap();
    // The omni image's disc: some pixels have a ray, the corners outside the mirror none.
    assert!(rays > 40 * 40 / 2 && rays < 40 * 40, "{rays} rays");
}

/// Counts that size allocations or loops are bounded before anything runs.
#[test]
fn bench_refuses_counts_it_could_not_finish() {
    for option in [
        "--runs 18446744073709551615",
        "--runs 0",
        "--warmup 4294967296",
        "--synthetic-triangles 4000000000",
    ] {
        let output = omnisim(&format!("bench scenes/env1.ron {option}"));
        assert_eq!(output.status.code(), Some(2), "{option}");
        assert!(text(&output.stderr).contains("is not a whole number from"), "{option}");
    }
}

/// `poses --out` replaces its own pose files, never another file (a scene, say).
#[test]
fn poses_never_replace_a_file_they_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.ron");
    std::fs::copy(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/env1.ron"), &scene).unwrap();
    let before = std::fs::read(&scene).unwrap();
    let output = omnisim(&format!("poses grid --x 0 --y 0 --z 0.4 --out {}", scene.display()));
    assert!(!output.status.success() && text(&output.stderr).contains("is not a pose file omnisim wrote"));
    assert_eq!(std::fs::read(&scene).unwrap(), before);
    let poses = dir.path().join("poses.txt");
    for _ in 0..2 {
        assert!(succeeds(&format!(
            "poses grid --x 0 --y 0 --z 0.4 --out {}",
            poses.display()
        )));
    }
}

/// An angle that looks like radians renders (it is a valid angle in degrees) with a hint, and
/// --hfov beside --focal, which it cannot change, is refused.
#[test]
fn angles_that_look_like_radians_get_a_hint() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display();
    for (options, hint) in [
        (
            "--camera pinhole --size 32x24 --hfov 1.047",
            Some("warning: --hfov 1.047 is taken in degrees; if it is in radians, give --hfov 59.99"),
        ),
        (
            "--max-elevation 0.35 --size 32x32",
            Some("warning: --max-elevation 0.35 is taken in degrees; if it is in radians, give --max-elevation 20.05"),
        ),
        (
            "--camera cylindrical --size 64x16 --vfov 1.5",
            Some("give --vfov 85.94"),
        ),
        ("--camera pinhole --size 32x24 --hfov 60", None),
        ("--max-elevation 20 --size 32x32", None),
    ] {
        let result = omnisim(&format!(
            "render scenes/env1.ron {options} --pose 0,0,0.4 --backend cpu --overwrite --out {d}/r"
        ));
        let stderr = text(&result.stderr);
        assert!(result.status.success(), "{options}: {stderr}");
        match hint {
            Some(hint) => assert!(stderr.contains(hint), "{options}: {stderr}"),
            None => assert!(!stderr.contains("radians"), "{options}: {stderr}"),
        }
    }
    let both = omnisim("render scenes/env1.ron --camera pinhole --hfov 60 --focal 500 --pose 0,0,0.4");
    let stderr = text(&both.stderr);
    assert!(
        !both.status.success() && stderr.contains("'--hfov <HFOV>' cannot be used with '--focal <FOCAL>'"),
        "{stderr}"
    );
}

/// A render with no terminal prints plain progress lines with the rate (every 10 s; here,
/// with `OMNISIM_PROGRESS_SECONDS=0`, after every pose): a long render was silent.
#[test]
fn a_render_without_a_terminal_reports_progress() {
    let dir = tempfile::tempdir().unwrap();
    let result = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args(
            "render scenes/env1.ron --size 32x32 --pose 0,0,0.4 --pose 0.5,0,0.4 --pose 1,0,0.4 --backend cpu --no-ply"
                .split_whitespace(),
        )
        .arg("--out")
        .arg(dir.path().join("r"))
        .env("OMNISIM_PROGRESS_SECONDS", "0")
        .current_dir(workspace())
        .output()
        .unwrap();
    let stderr = text(&result.stderr);
    assert!(result.status.success(), "{stderr}");
    for done in 1..=3 {
        assert!(stderr.contains(&format!("\n{done}/3 poses, ")), "{stderr}");
    }
    assert!(stderr.contains("/s\n"), "the rate: {stderr}");
    // Without the variable, a render this short says nothing until its summary.
    let quiet = omnisim(&format!(
        "render scenes/env1.ron --size 32x32 --pose 0,0,0.4 --backend cpu --no-ply --out {}",
        dir.path().join("q").display()
    ));
    assert!(!text(&quiet.stderr).contains("poses, "), "{}", text(&quiet.stderr));
    // A value that is no number of seconds is said once, and the default kept.
    for odd in ["-1", "abc", "NaN"] {
        let warned = Command::new(env!("CARGO_BIN_EXE_omnisim"))
            .args(
                "render scenes/env1.ron --size 32x32 --pose 0,0,0.4 --backend cpu --no-ply --overwrite --out"
                    .split_whitespace(),
            )
            .arg(dir.path().join("w"))
            .env("OMNISIM_PROGRESS_SECONDS", odd)
            .current_dir(workspace())
            .output()
            .unwrap();
        let stderr = text(&warned.stderr);
        assert!(warned.status.success(), "{stderr}");
        let warning = format!("warning: OMNISIM_PROGRESS_SECONDS={odd} is not a number of seconds (0 or more)");
        assert_eq!(stderr.matches(&warning).count(), 1, "{stderr}");
    }
}

#[test]
fn scene_check_lists_each_texture_with_its_source_size_mips_bytes_and_users() {
    let check = text(&omnisim("scene check scenes/env1-textured.ron").stdout);
    // Six patterns; the floor's wood is 512² with 10 levels: 8 bytes × (4^10 − 1) / 3 texels.
    assert!(check.contains("textures: 6, "), "{check}");
    let used_by = |object: &str| {
        let user = format!("used by {object};");
        check
            .lines()
            .find(|l| l.contains(&user))
            .unwrap_or_else(|| panic!("{check}"))
    };
    let floor = used_by("floor");
    assert!(
        floor.contains("512×512 texels, 10 mip levels, 2796200 bytes") && floor.contains("from pattern Wood"),
        "{floor}"
    );
    // The rug's checker is baked at 192²: levels 192, 96, 48, 24, 12, 6, 3, 1.
    let rug = used_by("rug");
    assert!(
        rug.contains("192×192 texels, 8 mip levels") && rug.contains("Checker"),
        "{rug}"
    );
    // An untextured scene lists none; a mesh's image names its file.
    assert!(!text(&omnisim("scene check scenes/env1.ron").stdout).contains("texture"));
    for (scene, source) in [
        ("textured-obj", "from image scenes/meshes/crate.png"),
        ("textured-gltf", "from image 0 inside scenes/meshes/crate.glb"),
    ] {
        let check = text(&omnisim(&format!("scene check scenes/{scene}.ron")).stdout);
        assert!(check.contains(&format!("used by crate; {source}")), "{check}");
    }
}
