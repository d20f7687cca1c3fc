//! `omnisim describe` and `omnisim project` on a tiny data set made by `omnisim dataset`: every
//! .npy read back by numpy and checked against its sidecar, the values against what the
//! library computes for the same image, the views against the library's resampling.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use omnisim::camera::Catadioptric;
use omnisim_vision::fourier::{FourierParams, FourierSignature};
use omnisim_vision::hog::{PanoramicHogParams, panoramic_hog};
use omnisim_vision::lmgist::{LmGist, LmGistParams};
use omnisim_vision::radon::{Radon, RadonParams};
use omnisim_vision::sift::{SiftParams, sift};
use omnisim_vision::{Interpolation, Raster, Remap, View};
use serde_json::Value;

const SPEC: &str = r#"Dataset(
    scene: "env1.ron",
    seed: 5,
    rig: Omni(size: (120, 120), mirror: Hyperbolic(a: 0.04, b: 0.16)),
    outputs: (point_cloud: false),
    sets: [
        Set(name: "map", poses: Trajectory(through: [(-2.0, -0.9, 0.4), (2.0, -0.9, 0.4)], count: 4)),
        Set(name: "test", poses: Random(count: 3, low: (-1.5, -1.0, 0.2), high: (1.5, 1.0, 0.6), tilt: 0.0)),
    ],
)"#;

fn omnisim(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn succeed(args: &[&str], dir: &Path) {
    let output = omnisim(args, dir);
    assert!(
        output.status.success(),
        "omnisim {args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// A data set of 4 + 3 omnidirectional images of 120² pixels in `dir/ds`.
fn dataset(dir: &Path) -> PathBuf {
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.join("env1.ron")).unwrap();
    std::fs::write(dir.join("spec.ron"), SPEC).unwrap();
    succeed(&["dataset", "spec.ron", "--backend", "cpu", "--out", "ds"], dir);
    dir.join("ds")
}

/// Two 64² omnidirectional images of env1 rendered (with segmentation) into `dir/r`, a
/// render folder with the default camera.
fn render_folder(dir: &Path) -> PathBuf {
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.join("env1.ron")).unwrap();
    succeed(
        &[
            "render",
            "env1.ron",
            "--size",
            "64x64",
            "--pose",
            "0,0,0.4",
            "--pose",
            "0.5,0,0.4",
            "--segmentation",
            "--backend",
            "cpu",
            "--out",
            "r",
        ],
        dir,
    );
    dir.join("r")
}

/// The spec's camera, as the library builds it.
fn camera() -> Catadioptric {
    Catadioptric::hyperbolic(120, 120, 0.04, 0.16, Some(20f64.to_radians()))
}

fn grey(path: &Path) -> Raster {
    Raster::from_image(&image::open(path).unwrap()).to_grey()
}

/// The Python with numpy: a test that needs it is ignored where `OMNISIM_PYTHON` was not set at
/// build time (`omnisim_no_python`), and fails where it runs without it.
fn python() -> std::ffi::OsString {
    std::env::var_os("OMNISIM_PYTHON").expect("OMNISIM_PYTHON names no Python: set it to one with tests/readers/requirements.txt (.ci/run makes one) (README, Tests)")
}

fn assert_close(name: &str, got: &[f64], expected: &[f32]) {
    assert_eq!(got.len(), expected.len().min(256), "{name}: length");
    for (i, (g, e)) in got.iter().zip(expected).enumerate() {
        assert!(
            (g - f64::from(*e)).abs() <= 1e-6 * (1.0 + f64::from(e.abs())),
            "{name}[{i}]: numpy read {g}, library {e}"
        );
    }
}

#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn describe_writes_what_numpy_reads_and_the_library_computes() {
    let dir = tempfile::tempdir().unwrap();
    let ds = dataset(dir.path());
    succeed(
        &[
            "describe",
            "ds",
            "-d",
            "fourier:k=8",
            "-d",
            "hog",
            "-d",
            "radon:angles=90,radial-step=2",
            "-d",
            "sift",
            "-d",
            "surf:threshold=50,upright=true",
            "-d",
            "lmgist:size=64,blocks=2",
            "--panorama",
            "256x64",
            "--pca-fit",
            "2",
            "--out",
            "desc",
        ],
        dir.path(),
    );
    let out = dir.path().join("desc");
    let sidecar: Value = serde_json::from_slice(&std::fs::read(out.join("map/fourier.json")).unwrap()).unwrap();
    assert_eq!(sidecar["parameters"]["k"], 8);
    assert_eq!(sidecar["frames"].as_array().unwrap().len(), 4);
    assert_eq!(sidecar["frames"][2]["stem"], "env1-0002");
    assert_eq!(sidecar["pca"]["fitted_on"], "map");
    assert!(sidecar["seconds_per_image"].as_f64().unwrap() > 0.0);
    // Each frame of a descriptor that reads the panorama records its resampling's seconds;
    // one that reads the image has none.
    assert!(sidecar["frames"][2]["panorama_seconds"].as_f64().unwrap() > 0.0);
    let radon_sidecar: Value = serde_json::from_slice(&std::fs::read(out.join("map/radon.json")).unwrap()).unwrap();
    assert!(radon_sidecar["frames"][2].get("panorama_seconds").is_none());
    assert_eq!(radon_sidecar["parameters"]["radial_step_px"], 2.0);
    assert_eq!(radon_sidecar["parameters"]["centre_px"]["u"], camera().cx);
    assert_eq!(radon_sidecar["parameters"]["centre_px"]["v"], camera().cy);

    // Later sets projected with the map's saved basis give the same numbers.
    succeed(
        &[
            "describe",
            "ds",
            "--set",
            "test",
            "-d",
            "hog",
            "--panorama",
            "256x64",
            "--pca-basis",
            "desc",
            "--out",
            "again",
        ],
        dir.path(),
    );
    let (_, fitted) = omnisim_vision::npy::read(&out.join("test/hog-pca.npy")).unwrap();
    let (_, loaded) = omnisim_vision::npy::read(&dir.path().join("again/test/hog-pca.npy")).unwrap();
    assert_eq!(fitted, loaded);

    let python = python();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/check_descriptors.py");
    let report_path = dir.path().join("report.json");
    let status = Command::new(&python)
        .arg(&script)
        .arg(&out)
        .arg(&report_path)
        .status()
        .unwrap();
    assert!(status.success(), "numpy's check of the .npy files failed");
    let report: Value = serde_json::from_slice(&std::fs::read(&report_path).unwrap()).unwrap();
    let first = |set: &str, file: &str| -> Vec<f64> {
        report[set][file]["first"]
            .as_array()
            .unwrap_or_else(|| panic!("{set}/{file} not read"))
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };

    // The library on the test set's first image, as describe read it.
    let image = grey(&ds.join("test/env1-0000.png"));
    let view = View::panorama(256, 64, (-45f64).to_radians(), 15f64.to_radians()).unwrap();
    let panorama = Remap::new(&camera(), &view)
        .unwrap()
        .apply(&image, Interpolation::Bicubic)
        .unwrap();
    let signature = FourierSignature::new(&panorama, FourierParams { coefficients: 8 }).unwrap();
    assert_eq!(report["test"]["fourier.npy"]["shape"], serde_json::json!([3, 64, 8]));
    assert_close("fourier", &first("test", "fourier.npy"), &signature.magnitudes());
    assert_close(
        "fourier phases",
        &first("test", "fourier-phases.npy"),
        &signature.phases(),
    );
    let hog = panoramic_hog(&panorama, PanoramicHogParams::default()).unwrap();
    assert_close("hog", &first("test", "hog.npy"), &hog.values);
    // The Radon transform about the calibration's principal point.
    let params = RadonParams {
        angles: 90,
        radial_step: 2.0,
        centre: Some((camera().cx, camera().cy)),
        ..Default::default()
    };
    assert_close(
        "radon",
        &first("test", "radon.npy"),
        &Radon::new(&image, params).unwrap().values.data,
    );
    // LMgist reads the colour image (it averages the channels itself).
    let colour = Raster::from_image(&image::open(ds.join("test/env1-0000.png")).unwrap());
    let lmgist = LmGist::new(LmGistParams {
        image_size: 64,
        blocks: 2,
        ..Default::default()
    })
    .unwrap();
    assert_close(
        "lmgist",
        &first("test", "lmgist.npy"),
        &lmgist.describe(&colour).unwrap().values,
    );
    let features = sift(&image, &SiftParams::default()).unwrap();
    assert!(!features.keypoints.is_empty(), "the test image gives SIFT keypoints");
    let k = &features.keypoints[0];
    let row = [0.0, k.x, k.y, k.sigma, k.angle, k.response];
    assert_close("sift keypoint", &first("test", "sift-keypoints.npy"), &row);
    assert_close(
        "sift descriptor",
        &first("test", "sift-descriptors.npy"),
        features.descriptor(0),
    );
    assert_eq!(
        report["test"]["sift-descriptors.npy"]["rows_of_first_image"],
        features.keypoints.len()
    );

    // A threshold no keypoint reaches: empty arrays that numpy reads as [0, 6] and [0, 64].
    succeed(
        &[
            "describe",
            "ds",
            "--set",
            "map",
            "-d",
            "surf:threshold=1e12",
            "--out",
            "empty",
        ],
        dir.path(),
    );
    let status = Command::new(&python)
        .arg(&script)
        .arg(dir.path().join("empty"))
        .arg(&report_path)
        .status()
        .unwrap();
    assert!(status.success(), "numpy's check of empty keypoint files failed");
    let report: Value = serde_json::from_slice(&std::fs::read(&report_path).unwrap()).unwrap();
    assert_eq!(report["map"]["surf-keypoints.npy"]["shape"], serde_json::json!([0, 6]));
    assert_eq!(
        report["map"]["surf-descriptors.npy"]["shape"],
        serde_json::json!([0, 64])
    );
}

#[test]
fn project_writes_the_librarys_views() {
    let dir = tempfile::tempdir().unwrap();
    let ds = dataset(dir.path());
    succeed(
        &[
            "project",
            "ds",
            "--set",
            "map",
            "--view",
            "panorama:width=200,height=50",
            "--view",
            "birds-eye:width=60,height=40,scale=0.05",
            "--out",
            "views",
        ],
        dir.path(),
    );
    let folder = dir.path().join("views/map");
    let sidecar: Value = serde_json::from_slice(&std::fs::read(folder.join("project.json")).unwrap()).unwrap();
    assert_eq!(sidecar["frames"].as_array().unwrap().len(), 4);
    assert_eq!(sidecar["views"][1]["settings"]["metres_per_pixel"], 0.05);
    let omni = Raster::from_image(&image::open(ds.join("map/env1-0001.png")).unwrap());
    for (name, view) in [
        (
            "panorama",
            View::panorama(200, 50, (-45f64).to_radians(), 15f64.to_radians()).unwrap(),
        ),
        ("birds-eye", View::birds_eye(60, 40, 0.05, -0.7).unwrap()),
    ] {
        let expected = Remap::new(&camera(), &view)
            .unwrap()
            .apply(&omni, Interpolation::Bicubic)
            .unwrap();
        let written = Raster::from_image(&image::open(folder.join(format!("env1-0001-{name}.png"))).unwrap());
        assert_eq!((written.width, written.height), (expected.width, expected.height));
        let worst = written
            .data
            .iter()
            .zip(&expected.data)
            .map(|(a, b)| (a - b.clamp(0.0, 1.0)).abs())
            .fold(0.0, f32::max);
        assert!(
            worst <= 0.5 / 255.0 + 1e-6,
            "{name}: differs from the library by {worst}"
        );
        let valid = image::open(folder.join(format!("{name}-valid.png")))
            .unwrap()
            .to_luma8();
        assert!(valid.pixels().any(|p| p.0[0] == 255), "{name}: nothing valid");
    }
}

/// Mistakes give a clear message and write nothing: not even the --out folder.
#[test]
fn describe_refuses_bad_requests() {
    let dir = tempfile::tempdir().unwrap();
    let ds = dataset(dir.path());
    // A folder of images named like the PCA bases' folder.
    std::fs::create_dir(dir.path().join("pca")).unwrap();
    for stem in ["env1-0000", "env1-0001"] {
        std::fs::copy(
            ds.join(format!("map/{stem}.png")),
            dir.path().join(format!("pca/{stem}.png")),
        )
        .unwrap();
    }
    let omni = ["--camera", "omni", "--mirror-a", "0.04", "--mirror-b", "0.16"];
    // A folder whose second image is not the camera's size.
    std::fs::create_dir(dir.path().join("mixed")).unwrap();
    std::fs::copy(ds.join("map/env1-0000.png"), dir.path().join("mixed/a.png")).unwrap();
    image::RgbImage::new(60, 60)
        .save(dir.path().join("mixed/b.png"))
        .unwrap();
    // A folder whose only image is an empty file, and one whose PNG header claims 2³¹ − 1 square.
    std::fs::create_dir(dir.path().join("empty")).unwrap();
    std::fs::write(dir.path().join("empty/a.png"), b"").unwrap();
    std::fs::create_dir(dir.path().join("huge")).unwrap();
    std::fs::write(dir.path().join("huge/a.png"), png_claiming(i32::MAX as u32)).unwrap();
    for (args, message) in [
        (
            vec!["describe", "ds", "-d", "sift:sigmaa=2", "--out", "x"],
            "unknown setting 'sigmaa'",
        ),
        (
            vec!["describe", "ds", "-d", "orb", "--out", "x"],
            "unknown descriptor 'orb'",
        ),
        (
            vec!["describe", "ds", "-d", "sift", "--set", "nope", "--out", "x"],
            "no set 'nope'",
        ),
        (
            vec!["describe", "ds", "-d", "sift", "--mirror-a", "0.05", "--out", "x"],
            "camera options are refused",
        ),
        (
            vec!["describe", "ds", "-d", "sift:scales=0", "--out", "x"],
            "scales_per_octave",
        ),
        (
            vec!["describe", "nowhere", "-d", "sift", "--out", "x"],
            "neither a data-set folder",
        ),
        (
            vec!["describe", "ds", "-d", "radon:radial-step=1e-20", "--out", "x"],
            "radial samples",
        ),
        (
            vec!["describe", "ds", "-d", "radon:radial-step=nan", "--out", "x"],
            "radial-step=nan is not a finite number",
        ),
        (
            vec!["describe", "ds", "-d", "radon:step=1", "--out", "x"],
            "unknown setting 'step'",
        ),
        (
            vec!["describe", "ds", "-d", "hog", "-d", "block-hog:clip=0", "--out", "x"],
            "clip",
        ),
        (
            vec!["describe", "ds", "-d", "sift:clamp=inf", "--out", "x"],
            "not a finite number",
        ),
        (
            vec!["describe", "ds", "-d", "sift:descriptor-width=0", "--out", "x"],
            "descriptor_width",
        ),
        (
            vec!["describe", "ds", "-d", "vertical-hog:column-step=0", "--out", "x"],
            "column step",
        ),
        (
            vec!["describe", "ds", "-d", "surf:window=0", "--out", "x"],
            "orientation_window",
        ),
        (vec!["describe", "ds", "-d", "gist:blocks=0", "--out", "x"], "blocks"),
        // Limits set by the image's size, checked from the camera's before any image is read.
        (
            vec!["describe", "ds", "-d", "hog", "-d", "fourier:k=1000", "--out", "x"],
            "fourier on the 512×128 panorama: coefficients",
        ),
        (
            vec!["describe", "ds", "-d", "block-hog:cell=100", "--out", "x"],
            "block-hog on the 120×120 image: block",
        ),
        (
            vec!["describe", "ds", "-d", "radon:radial-samples=2000000", "--out", "x"],
            "radial samples",
        ),
        (
            vec![
                "describe",
                "ds",
                "-d",
                "hog",
                "--pca-fit",
                "9",
                "--map",
                "nope",
                "--out",
                "x",
            ],
            "--map nope",
        ),
        (
            [
                &["describe", "pca"][..],
                &omni,
                &["-d", "hog", "--pca-fit", "1", "--out", "x"],
            ]
            .concat(),
            "share OUT/pca",
        ),
        (
            vec!["project", "ds", "--view", "panorama:low=20,high=10", "--out", "x"],
            "got 20° .. 10°",
        ),
        (
            vec!["project", "ds", "--view", "perspective:hfov=200", "--out", "x"],
            "got 200°",
        ),
        (
            vec!["project", "ds", "--view", "perspective:yaw=inf", "--out", "x"],
            "not a finite number",
        ),
        // Out of range: the message gives the range (radians for degrees, minutes of work).
        (
            vec!["project", "ds", "--view", "perspective:yaw=1e308", "--out", "x"],
            "perspective: direction: needs −360° ≤ yaw ≤ 360° and −90° ≤ pitch ≤ 90°",
        ),
        (
            vec!["project", "ds", "--view", "perspective:pitch=-1000", "--out", "x"],
            "got 0° and -1000°",
        ),
        (
            vec!["project", "ds", "--view", "birds-eye:scale=1e-300", "--out", "x"],
            "birds-eye: metres per pixel: needs 1e-6 to 1000 m, got 1e-300",
        ),
        (
            vec!["project", "ds", "--view", "birds-eye:plane=1e300", "--out", "x"],
            "birds-eye: plane height: needs 1e-6 to 1000 m",
        ),
        (
            vec![
                "project",
                "ds",
                "--view",
                "birds-eye:width=10000,height=10000",
                "--out",
                "x",
            ],
            "10000×10000 pixels: a view has 1 to 16777216 pixels (4096×4096)",
        ),
        (
            vec!["describe", "ds", "-d", "hog", "--panorama", "8192x4096", "--out", "x"],
            "the panorama: view size",
        ),
        (
            [&["project", "mixed"][..], &omni, &["--view", "panorama", "--out", "x"]].concat(),
            "is 60×60 pixels, but the camera's image is 120×120",
        ),
        (
            [&["describe", "empty"][..], &omni, &["-d", "hog", "--out", "x"]].concat(),
            "empty/a.png is an empty file, not an image",
        ),
        (
            vec!["describe", "huge", "-d", "fourier", "--size", "250x250", "--out", "x"],
            "huge/a.png: its header claims an image larger than images are read here",
        ),
        // Without a camera (--size alone) the images' size is met at their panorama: named too.
        (
            vec!["describe", "mixed", "-d", "fourier", "--size", "250x250", "--out", "x"],
            "cannot make the panorama of mixed/a.png: the image is 120×120 pixels, but the camera's image is 250×250",
        ),
    ] {
        let output = omnisim(&args, dir.path());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            !output.status.success() && stderr.contains(message),
            "{args:?}: {stderr}"
        );
        assert!(!dir.path().join("x").exists(), "{args:?} created --out");
    }
}

/// A PNG of one black pixel whose header claims `side` × `side` RGB pixels (its chunks' CRCs
/// right, so that only the claimed size is wrong).
fn png_claiming(side: u32) -> Vec<u8> {
    let crc = |bytes: &[u8]| {
        !bytes.iter().fold(!0_u32, |crc, &byte| {
            (0..8).fold(crc ^ u32::from(byte), |c, _| {
                if c & 1 == 1 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 }
            })
        })
    };
    let chunk = |kind: &[u8], data: &[u8]| {
        let body = [kind, data].concat();
        [&(data.len() as u32).to_be_bytes()[..], &body, &crc(&body).to_be_bytes()].concat()
    };
    let header = [&side.to_be_bytes()[..], &side.to_be_bytes(), &[8, 2, 0, 0, 0]].concat();
    // A stored (uncompressed) deflate block of one filtered row: filter byte and one pixel.
    let data = [
        0x78, 0x01, 0x01, 0x04, 0x00, 0xfb, 0xff, 0, 0, 0, 0, 0x00, 0x04, 0x00, 0x01,
    ];
    [
        &b"\x89PNG\r\n\x1a\n"[..],
        &chunk(b"IHDR", &header),
        &chunk(b"IDAT", &data),
        &chunk(b"IEND", b""),
    ]
    .concat()
}

/// Links planted in the output folder are replaced (a file) or refused (a set folder), never
/// written through.
#[cfg(unix)]
#[test]
fn describe_and_project_never_write_through_links() {
    let dir = tempfile::tempdir().unwrap();
    dataset(dir.path());
    let victim = dir.path().join("victim.txt");
    std::fs::write(&victim, "mine").unwrap();
    std::fs::create_dir_all(dir.path().join("d/map")).unwrap();
    std::os::unix::fs::symlink(&victim, dir.path().join("d/map/fourier.npy")).unwrap();
    succeed(
        &["describe", "ds", "--set", "map", "-d", "fourier", "--out", "d"],
        dir.path(),
    );
    assert_eq!(std::fs::read(&victim).unwrap(), b"mine");
    let written = std::fs::symlink_metadata(dir.path().join("d/map/fourier.npy")).unwrap();
    assert!(written.is_file(), "the link was replaced by the output");
    let elsewhere = dir.path().join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::fs::create_dir_all(dir.path().join("v")).unwrap();
    std::os::unix::fs::symlink(&elsewhere, dir.path().join("v/map")).unwrap();
    for command in [
        &["describe", "ds", "--set", "map", "-d", "fourier", "--out", "v"][..],
        &["project", "ds", "--set", "map", "--view", "panorama", "--out", "v"][..],
    ] {
        let output = omnisim(command, dir.path());
        assert!(!output.status.success());
        assert!(String::from_utf8_lossy(&output.stderr).contains("is a link"));
    }
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0);
}

/// A render folder's images are read through the camera its render.json records: by default,
/// and a camera given that differs from it is refused.
#[test]
fn a_render_folder_is_described_through_its_own_camera_only() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.path().join("env1.ron")).unwrap();
    succeed(
        &[
            "render",
            "env1.ron",
            "--camera",
            "omni",
            "--mirror",
            "parabolic",
            "--size",
            "64x64",
            "--pose",
            "0,0,0.4",
            "--backend",
            "cpu",
            "--out",
            "r",
        ],
        dir.path(),
    );
    let output = omnisim(
        &["describe", "r", "-d", "fourier", "--mirror", "hyperbolic", "--out", "d"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("records a parabolic-catadioptric camera"),
        "{stderr}"
    );
    assert!(!dir.path().join("d").exists(), "nothing written");
    succeed(
        &["describe", "r", "-d", "fourier", "--mirror", "parabolic", "--out", "d"],
        dir.path(),
    );
    succeed(&["describe", "r", "-d", "fourier", "--out", "d2"], dir.path());
    let (given, recorded) = (
        std::fs::read(dir.path().join("d/r/fourier.npy")).unwrap(),
        std::fs::read(dir.path().join("d2/r/fourier.npy")).unwrap(),
    );
    assert_eq!(given, recorded, "the recorded camera is the one the options give");
}

/// An output folder that is the images' own folder is refused: a second run would read its
/// outputs as images.
#[test]
fn outputs_never_land_among_the_input_images() {
    let dir = tempfile::tempdir().unwrap();
    dataset(dir.path());
    for command in [
        &["describe", "ds", "--set", "map", "-d", "fourier", "--out", "ds"][..],
        &["project", "ds", "--set", "map", "--view", "panorama", "--out", "ds"][..],
    ] {
        let output = omnisim(command, dir.path());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            !output.status.success() && stderr.contains("where its images are read from"),
            "{stderr}"
        );
    }
    assert!(!dir.path().join("ds/map/fourier.npy").exists());
}

/// Two images whose names differ only in the extension's case would give the same views: the
/// second would replace the first's, silently.
#[test]
fn project_refuses_images_that_share_a_stem() {
    let dir = tempfile::tempdir().unwrap();
    let rendered = render_folder(dir.path());
    std::fs::create_dir(dir.path().join("imgs")).unwrap();
    std::fs::copy(rendered.join("env1-0000.png"), dir.path().join("imgs/a.png")).unwrap();
    std::fs::copy(rendered.join("env1-0001.png"), dir.path().join("imgs/a.PNG")).unwrap();
    let output = omnisim(
        &["project", "imgs", "--view", "panorama:width=64,height=16", "--out", "v"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success()
            && stderr.contains("would both give the views a-NAME.png")
            && stderr.contains("rename"),
        "{stderr}"
    );
    assert!(!dir.path().join("v").exists(), "nothing written");
}

/// A file or folder name that is not UTF-8 cannot be recorded in the JSON sidecars: refused
/// with the name, never a panic.
#[cfg(unix)]
#[test]
fn names_that_are_not_utf8_are_refused_not_a_panic() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let rendered = render_folder(dir.path());
    let odd = OsStr::from_bytes(b"b\xff");
    for folder in [OsStr::new("good"), OsStr::new("odd-image"), odd] {
        std::fs::create_dir(dir.path().join(folder)).unwrap();
        std::fs::copy(rendered.join("env1-0000.png"), dir.path().join(folder).join("a.png")).unwrap();
    }
    let image = dir.path().join("odd-image").join(odd).with_extension("png");
    std::fs::copy(rendered.join("env1-0001.png"), image).unwrap();
    let describe: &[&OsStr] = &["describe".as_ref(), "-d".as_ref(), "hog".as_ref()];
    let project: &[&OsStr] = &["project".as_ref(), "--view".as_ref(), "panorama".as_ref()];
    let basis: &[&OsStr] = &["good".as_ref(), "--pca-basis".as_ref(), odd];
    for args in [
        [describe, &["odd-image".as_ref()]].concat(),
        [project, &["odd-image".as_ref()]].concat(),
        [describe, &[odd]].concat(),
        [project, &[odd]].concat(),
        [describe, basis].concat(),
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_omnisim"))
            .args(&args)
            .args(["--out", "x"])
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains("is not a UTF-8 name"), "{args:?}: {stderr}");
    }
}

/// `omnisim` run in `dir`, killed (and the test failed) if it runs for more than 60 s: a read
/// that blocks must fail the test, not hang it.
fn omnisim_within_a_minute(args: &[&str], dir: &Path) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args(args)
        .current_dir(dir)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > std::time::Duration::from_secs(60) {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("omnisim {args:?} still ran after 60 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

/// A FIFO where an image or a PCA basis file is expected is refused at once: opening it would
/// wait for a writer for ever.
#[cfg(unix)]
#[test]
fn fifos_among_the_inputs_are_refused_not_waited_on() {
    let dir = tempfile::tempdir().unwrap();
    let ds = dataset(dir.path());
    succeed(
        &[
            "describe",
            "ds",
            "--set",
            "map",
            "-d",
            "hog",
            "--pca-fit",
            "2",
            "--out",
            "fit",
        ],
        dir.path(),
    );
    let fifo = |path: &Path| {
        std::fs::remove_file(path).unwrap();
        assert!(Command::new("mkfifo").arg(path).status().unwrap().success());
    };
    let basis = dir.path().join("fit/pca/hog");
    fifo(&ds.join("map/env1-0001.png"));
    for (path, args) in [
        (None, &["describe", "ds", "--set", "map", "-d", "hog", "--out", "x"][..]),
        (
            None,
            &["project", "ds", "--set", "map", "--view", "panorama", "--out", "x"][..],
        ),
        (
            Some(basis.join("pca.json")),
            &[
                "describe",
                "ds",
                "--set",
                "test",
                "-d",
                "hog",
                "--pca-basis",
                "fit",
                "--out",
                "x",
            ][..],
        ),
        (
            Some(basis.join("mean.npy")),
            &[
                "describe",
                "ds",
                "--set",
                "test",
                "-d",
                "hog",
                "--pca-basis",
                "fit",
                "--out",
                "x",
            ][..],
        ),
    ] {
        if let Some(path) = &path {
            fifo(path);
        }
        let output = omnisim_within_a_minute(args, dir.path());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            !output.status.success() && stderr.contains("is a FIFO (named pipe), not a regular file"),
            "{args:?}: {stderr}"
        );
    }
}

/// Of a render folder, the colour images its render.json lists are read: the object and face
/// id PNGs of `--segmentation` were read as images too (three rows per pose, black views).
#[test]
fn a_render_folders_id_pngs_are_not_images() {
    let dir = tempfile::tempdir().unwrap();
    render_folder(dir.path());
    succeed(&["describe", "r", "-d", "hog", "--out", "d"], dir.path());
    let sidecar: Value = serde_json::from_slice(&std::fs::read(dir.path().join("d/r/hog.json")).unwrap()).unwrap();
    assert_eq!(sidecar["shape"][0], 2, "one row per pose");
    let files: Vec<&str> = sidecar["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["file"].as_str().unwrap())
        .collect();
    assert_eq!(files, ["r/env1-0000.png", "r/env1-0001.png"]);
    succeed(&["project", "r", "--view", "panorama", "--out", "v"], dir.path());
    let mut written: Vec<String> = std::fs::read_dir(dir.path().join("v/r"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    written.sort();
    assert_eq!(
        written,
        [
            "env1-0000-panorama.png",
            "env1-0001-panorama.png",
            "panorama-valid.png",
            "project.json"
        ]
    );
    // A render.json that is not render's says so instead of guessing from the names.
    std::fs::write(dir.path().join("r/render.json"), "{}").unwrap();
    let output = omnisim(&["describe", "r", "-d", "hog", "--out", "d2"], dir.path());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("is not the render.json of an omnisim render"),
        "{stderr}"
    );
}

/// One rig description: `render --rig FILE.ron` takes a data-set spec's `rig:` text, records it
/// in render.json, and `describe` rebuilds that camera from render.json with no camera option
/// (a parabolic mirror, not the default hyperbolic one, so a default camera would differ). The
/// same rig spelt as flags is the same run; a misspelt field is located.
#[test]
fn a_rig_file_renders_is_recorded_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.path().join("env1.ron")).unwrap();
    let rig = "Omni(size: (48, 48), mirror: Parabolic(a: 0.04, h: 0.02), max_elevation: Some(10.0))";
    std::fs::write(dir.path().join("rig.ron"), rig).unwrap();
    let pose = ["--pose", "0,0,0.4", "--backend", "cpu", "--out", "r"];
    succeed(
        &[&["render", "env1.ron", "--rig", "rig.ron"][..], &pose].concat(),
        dir.path(),
    );
    let render: Value = serde_json::from_slice(&std::fs::read(dir.path().join("r/render.json")).unwrap()).unwrap();
    let recorded = &render["rig"]["Omni"];
    assert_eq!(recorded["mirror"]["Parabolic"]["h"], 0.02, "{recorded}");
    assert_eq!(recorded["max_elevation"], 10.0);
    assert_eq!(
        render["camera"]["model"], "parabolic-catadioptric",
        "{}",
        render["camera"]
    );

    // The same rig as flags is the same run: the folder takes it without --overwrite.
    let flags = ["--size", "48x48", "--mirror", "parabolic", "--max-elevation", "10"];
    succeed(&[&["render", "env1.ron"][..], &flags, &pose].concat(), dir.path());

    succeed(&["describe", "r", "-d", "fourier:k=4", "--out", "d"], dir.path());
    let sidecar: Value = serde_json::from_slice(&std::fs::read(dir.path().join("d/r/fourier.json")).unwrap()).unwrap();
    assert_eq!(sidecar["shape"][0], 1, "{sidecar}");

    std::fs::write(
        dir.path().join("bad.ron"),
        "Omni(\n  size: (48, 48),\n  mirorr: Parabolic(a: 0.04, h: 0.02))",
    )
    .unwrap();
    let refused = omnisim(
        &[
            "render", "env1.ron", "--rig", "bad.ron", "--pose", "0,0,0.4", "--out", "b",
        ],
        dir.path(),
    );
    let message = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && message.contains("bad.ron:3:3") && message.contains("mirorr"),
        "{message}"
    );
    assert!(!dir.path().join("b").exists(), "a refused rig wrote its folder");
}

/// A stereo render folder is read through its left camera (the one its colour images come
/// from), with no camera option; a progress interval too large for a clock does not crash.
#[test]
fn a_stereo_render_folder_is_described_through_its_left_camera() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.path().join("env1.ron")).unwrap();
    let render = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args([
            "render", "env1.ron", "--camera", "stereo", "--size", "32x24", "--pose", "0,0,0.6",
        ])
        .args(["--backend", "cpu", "--out", "st"])
        .env("OMNISIM_PROGRESS_SECONDS", "1e19")
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(render.status.success(), "{}", String::from_utf8_lossy(&render.stderr));
    succeed(&["describe", "st", "-d", "block-hog", "--out", "d"], dir.path());
    let sidecar: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("d/st/block-hog.json")).unwrap()).unwrap();
    assert_eq!(sidecar["shape"][0], 1, "one left image per pose: {sidecar}");
}

/// describe writes nothing before every image is described, but learns first that --out cannot
/// take files: here --out lies below a file, and the refusal comes before the images are read
/// (one of which is not an image, which would fail the work with another message).
#[test]
fn describe_refuses_an_unwritable_out_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("images");
    std::fs::create_dir(&images).unwrap();
    let rendered = render_folder(dir.path());
    std::fs::copy(rendered.join("env1-0000.png"), images.join("a.png")).unwrap();
    std::fs::write(images.join("b.png"), b"not a PNG").unwrap();
    std::fs::write(dir.path().join("taken"), b"a file").unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args(["describe", "images", "-d", "hog", "--out", "taken/out"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("taken is a file, not a folder"), "{stderr}");
    assert!(!stderr.contains("b.png"), "refused before reading the images: {stderr}");
}
