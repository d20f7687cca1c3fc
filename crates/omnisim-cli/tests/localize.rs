//! `omnisim localize` on a small seeded data set of env1 (64² omni images): the issue's
//! checks. A map tested against itself localizes with zero error for every descriptor and
//! distance; a map turned by whole panorama columns gives zero heading error by the Fourier
//! phases and by Radon + phase-only correlation, and a turn between columns at most half a
//! column (Fourier) or half an angle step (Radon, 3° steps); position error does not fall as noise
//! rises; the report validates against its shipped schema (Python's jsonschema) and the SVG
//! parses; a second run reuses the described sets; SIFT retrieval finds each map image itself
//! and the planar-motion essential matrix of its matches no turn.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// Panorama width: a column is 360/128 = 2.8125°, so 45° is 16 columns (and 45 Radon steps).
const WIDTH: f64 = 128.0;
const SPEC: &str = r#"Dataset(
    scene: "env1.ron",
    seed: 16,
    rig: Omni(size: (64, 64), mirror: Hyperbolic(a: 0.04, b: 0.16)),
    outputs: (point_cloud: false),
    sets: [
        Set(name: "map", poses: Grid(x: (-2.0, 2.0, 1.0), y: (-1.0, 1.0, 1.0), z: [0.4])),
        Set(name: "turned", poses: Grid(x: (-2.0, 2.0, 1.0), y: (-1.0, 1.0, 1.0), z: [0.4], headings: [45.0])),
        Set(name: "between", poses: Grid(x: (-2.0, 2.0, 1.0), y: (-1.0, 1.0, 1.0), z: [0.4], headings: [37.3])),
        Set(name: "clean", poses: Random(count: 12, low: (-2.0, -1.0, 0.4), high: (2.0, 1.0, 0.4), tilt: 0.0, seed: 3)),
        Set(name: "noisy", poses: Random(count: 12, low: (-2.0, -1.0, 0.4), high: (2.0, 1.0, 0.4), tilt: 0.0, seed: 3),
            noise: (colour: [Gaussian(sigma: 0.05)])),
        Set(name: "noisier", poses: Random(count: 12, low: (-2.0, -1.0, 0.4), high: (2.0, 1.0, 0.4), tilt: 0.0, seed: 3),
            noise: (colour: [Gaussian(sigma: 0.2)])),
    ],
)"#;

fn omnisim(args: &[&str], dir: &Path) -> String {
    let output = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "omnisim {args:?}: {stderr}");
    stderr
}

fn dataset(dir: &Path) {
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.join("env1.ron")).unwrap();
    std::fs::write(dir.join("spec.ron"), SPEC).unwrap();
    omnisim(&["dataset", "spec.ron", "--backend", "cpu", "--out", "ds"], dir);
}

/// Radon angle step: 3° (45° is 15 steps); 1° steps on 64² images miss one turn by a step.
const RADON_STEP: f64 = 3.0;
const LOCALIZE: [&str; 23] = [
    "localize",
    "ds",
    "--map",
    "map",
    "--test",
    "map",
    "turned",
    "between",
    "clean",
    "noisy",
    "noisier",
    "--panorama",
    "128x32",
    "-d",
    "fourier",
    "-d",
    "hog",
    "-d",
    "gist",
    "-d",
    "radon:angles=120,line-step=1",
    "-d",
    "pca",
];

fn results<'a>(report: &'a Value, test: &'a str) -> impl Iterator<Item = &'a Value> {
    report["results"]
        .as_array()
        .unwrap()
        .iter()
        .filter(move |r| r["test"] == test)
}

fn f(value: &Value) -> f64 {
    value.as_f64().unwrap_or_else(|| panic!("{value} is not a number"))
}

#[test]
fn localize_meets_the_issues_checks() {
    let dir = tempfile::tempdir().unwrap();
    dataset(dir.path());
    let mut args = LOCALIZE.to_vec();
    args.extend(["--out", "loc"]);
    omnisim(&args, dir.path());
    let report: Value = serde_json::from_slice(&std::fs::read(dir.path().join("loc/report.json")).unwrap()).unwrap();
    let descriptors = ["fourier", "hog", "gist", "radon", "pca"];
    let distances = ["l1", "l2", "cosine", "correlation"];
    // Ideal conditions: every descriptor and distance finds each map image itself.
    assert_eq!(results(&report, "map").count(), descriptors.len() * distances.len());
    for r in results(&report, "map") {
        assert_eq!(
            f(&r["position_error_cm"]["max"]),
            0.0,
            "{} {}",
            r["descriptor"],
            r["distance"]
        );
        assert_eq!(f(&r["recall"]["at_10_cm"]), 1.0);
    }
    // Whole columns: the Fourier phases and Radon POC find the turn exactly, and the
    // turn-invariant descriptors find the place (PCA of pixels is not turn invariant).
    let column = 360.0 / WIDTH;
    for (test, bound) in [("turned", [0.0, 0.0]), ("between", [column / 2.0, RADON_STEP / 2.0])] {
        for r in results(&report, test) {
            let descriptor = r["descriptor"].as_str().unwrap();
            if descriptor != "pca" {
                assert_eq!(
                    f(&r["position_error_cm"]["max"]),
                    0.0,
                    "{test}: {descriptor} {}",
                    r["distance"]
                );
            }
            let bound = match descriptor {
                "fourier" => bound[0],
                "radon" => bound[1],
                _ => {
                    assert!(r["orientation"].is_null());
                    continue;
                }
            };
            let worst = f(&r["orientation"]["error_deg"]["max"]);
            eprintln!("{test}: {descriptor} heading error up to {worst}°");
            assert!(
                worst <= bound + 1e-9,
                "{test}: {descriptor}: heading error {worst}° > {bound}°"
            );
        }
    }
    // Noise: σ = 0, 0.05, 0.2 at the same poses; the mean error may not fall by more than a
    // tenth of the map's spacing from one σ to the next.
    let spacing_cm = 100.0 * f(&report["sets"][0]["spacing_m"]);
    let sigmas: Vec<f64> = ["clean", "noisy", "noisier"]
        .iter()
        .map(|name| {
            let set = report["sets"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["name"] == *name)
                .unwrap();
            f(&set["noise_sigma"])
        })
        .collect();
    assert!(
        sigmas[0] == 0.0 && sigmas[0] < sigmas[1] && sigmas[1] < sigmas[2],
        "{sigmas:?}"
    );
    for descriptor in descriptors {
        let mean = |test: &str| {
            let errors: Vec<f64> = results(&report, test)
                .filter(|r| r["descriptor"] == descriptor)
                .map(|r| f(&r["position_error_cm"]["mean"]))
                .collect();
            errors.iter().sum::<f64>() / errors.len() as f64
        };
        let errors = [mean("clean"), mean("noisy"), mean("noisier")];
        eprintln!("{descriptor}: mean error {errors:?} cm at σ {sigmas:?}");
        for pair in errors.windows(2) {
            assert!(
                pair[1] >= pair[0] - 0.1 * spacing_cm,
                "{descriptor}: error falls with noise: {errors:?}"
            );
        }
    }
    // The charts: an SVG that parses, stamped with the spec's hash and the command.
    let svg = std::fs::read_to_string(dir.path().join("loc/report.svg")).unwrap();
    let document = roxmltree::Document::parse(&svg).unwrap();
    let titles = document
        .descendants()
        .filter(|n| n.attribute("class") == Some("title"))
        .count();
    assert!(titles >= 6, "{titles} title lines");
    let spec_hash = report["dataset"]["spec_sha256"].as_str().unwrap();
    assert!(svg.contains(&spec_hash[..12]) && svg.contains("omnisim localize ds --map map"));
    assert!(std::fs::metadata(dir.path().join("loc/report.png")).unwrap().len() > 1000);

    // Runs again, and returns its report once it has read `cached` sets' descriptors from the
    // cache (the others described again).
    let rerun = |cached: usize| -> Value {
        let stderr = omnisim(&args, dir.path());
        assert_eq!(
            stderr.matches("every descriptor from descriptors/").count(),
            cached,
            "{stderr}"
        );
        serde_json::from_slice(&std::fs::read(dir.path().join("loc/report.json")).unwrap()).unwrap()
    };
    // A second run describes nothing again and reports the same errors.
    assert_same_images(&report, &rerun(6));

    // A damaged cache file is not trusted: that set is described again, with the same results.
    let phases = std::fs::read_dir(dir.path().join("loc/descriptors"))
        .unwrap()
        .map(|set| set.unwrap().path().join("fourier-phases.npy"))
        .find(|path| path.exists())
        .expect("a cached Fourier phases file");
    std::fs::write(&phases, b"not an npy file").unwrap();
    let third = rerun(5);
    assert_eq!(
        report["results"].as_array().unwrap().len(),
        third["results"].as_array().unwrap().len()
    );
    assert_same_images(&report, &third);

    // So is one still well formed whose values were edited (its last value made NaN).
    let values = phases.with_file_name("fourier.npy");
    let mut bytes = std::fs::read(&values).unwrap();
    let end = bytes.len();
    bytes[end - 4..].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(&values, bytes).unwrap();
    assert_same_images(&report, &rerun(5));
}

/// Every result of two reports gives the same per-image estimates.
fn assert_same_images(report: &Value, other: &Value) {
    for (a, b) in report["results"]
        .as_array()
        .unwrap()
        .iter()
        .zip(other["results"].as_array().unwrap())
    {
        assert_eq!(a["images"], b["images"]);
    }
}

#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn report_validates_against_its_schema() {
    let dir = tempfile::tempdir().unwrap();
    dataset(dir.path());
    omnisim(
        &[
            "localize",
            "ds",
            "--map",
            "map",
            "--test",
            "map",
            "clean",
            "noisy",
            "--neighbours",
            "3",
            "-d",
            "fourier",
            "-d",
            "hog",
            "-d",
            "sift",
            "--out",
            "loc",
        ],
        dir.path(),
    );
    let python = std::env::var_os("OMNISIM_PYTHON").expect("OMNISIM_PYTHON names no Python (README, Tests)");
    let schema = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/localization-report.schema.json");
    let check = "import json, sys, jsonschema\n\
schema = json.load(open(sys.argv[1])); report = json.load(open(sys.argv[2]))\n\
jsonschema.Draft202012Validator.check_schema(schema)\n\
jsonschema.validate(report, schema, cls=jsonschema.Draft202012Validator)\n\
bad = dict(report, results=[dict(report['results'][0], distance='l3')])\n\
try:\n    jsonschema.validate(bad, schema, cls=jsonschema.Draft202012Validator)\n    sys.exit('a wrong distance validated')\n\
except jsonschema.ValidationError:\n    pass\n\
print('jsonschema', jsonschema.__version__ if hasattr(jsonschema, '__version__') else '', ': valid')\n";
    let status = Command::new(python)
        .args(["-W", "ignore", "-c", check])
        .arg(&schema)
        .arg(dir.path().join("loc/report.json"))
        .status()
        .unwrap();
    assert!(
        status.success(),
        "the report does not validate against {}",
        schema.display()
    );
    let report: Value = serde_json::from_slice(&std::fs::read(dir.path().join("loc/report.json")).unwrap()).unwrap();
    // k-NN entries beside the nearest neighbour's.
    assert!(results(&report, "clean").any(|r| r["neighbours"] == 3));
    // SIFT retrieves by ratio-test matches: each map image finds itself.
    let sift: Vec<&Value> = results(&report, "map").filter(|r| r["descriptor"] == "sift").collect();
    assert_eq!(sift.len(), 2);
    for r in sift {
        assert_eq!(r["distance"], "ratio-matches");
        if r["neighbours"] == 1 {
            assert_eq!(f(&r["position_error_cm"]["max"]), 0.0);
            // The planar-motion essential matrix of an image matched with itself: no turn.
            assert_eq!(r["orientation"]["method"], "feature-planar-motion");
            assert!(f(&r["orientation"]["error_deg"]["max"]) < 1e-6, "{}", r["orientation"]);
        }
    }
}

/// A spec with two sweeps: map spacing and noise σ, each set rendered into its own folder.
const SWEEP_SPEC: &str = r#"Dataset(
    scene: "env1.ron",
    seed: 16,
    rig: Omni(size: (48, 48), mirror: Hyperbolic(a: 0.04, b: 0.16)),
    outputs: (point_cloud: false, segmentation: true),
    sets: [
        // A comment holding ] and ) does not end the list.
        Set(name: "map-${step}", poses: Grid(x: (-2.0, 2.0, ${step}), y: (-1.0, 1.0, ${step}), z: [0.4])),
        Set(name: "noise-${sigma}", poses: Random(count: 5, low: (-2.0, -1.0, 0.4), high: (2.0, 1.0, 0.4), tilt: 0.0, seed: 3),
            noise: (colour: [Gaussian(sigma: ${sigma})])),
        Set(name: "people-${people}", poses: Random(count: 5, low: (-2.0, -1.0, 0.4), high: (2.0, 1.0, 0.4), tilt: 0.0, seed: 3),
            occluders: [Occluders(shape: Person, count: ${people}, clearance: 0.3)]),
    ],
)"#;

/// The data points (markers outside the legend) of each chart of a report's SVG whose title
/// holds `title`.
fn chart_markers(svg: &str, title: &str) -> Vec<usize> {
    let document = roxmltree::Document::parse(svg).unwrap();
    document
        .root_element()
        .children()
        .filter(|c| c.has_tag_name("svg"))
        .filter(|chart| {
            chart
                .descendants()
                .any(|n| n.attribute("class") == Some("title") && n.text().is_some_and(|t| t.contains(title)))
        })
        .map(|chart| {
            chart
                .descendants()
                .filter(|n| n.has_tag_name("circle") && n.attribute("class") == Some("marker"))
                .filter(|n| !n.ancestors().any(|a| a.attribute("class") == Some("legend")))
                .count()
        })
        .collect()
}

/// `omnisim localize SPEC --sweep`: one run renders every swept set, describes and localizes
/// them and charts error against noise σ and map spacing with one point per value and
/// descriptor; a re-run renders and describes nothing; a sweep that gains a value renders that
/// set alone.
#[test]
fn a_sweep_renders_its_sets_once_and_charts_one_point_per_value() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.path().join("env1.ron")).unwrap();
    std::fs::write(dir.path().join("sweep.ron"), SWEEP_SPEC).unwrap();
    let run = |sigmas: &str| {
        omnisim(
            &[
                "localize",
                "sweep.ron",
                "--backend",
                "cpu",
                "--sweep",
                &format!("sigma={sigmas}"),
                "--sweep",
                "step=1.0,2.0",
                "--sweep",
                "people=1,3",
                "--map",
                "map-${step}",
                "--test",
                "noise-${sigma}",
                "people-${people}",
                "--panorama",
                "64x16",
                "-d",
                "fourier",
                "-d",
                "hog",
                "--distance",
                "l1",
                "--out",
                "loc",
            ],
            dir.path(),
        )
    };
    let first = run("0,0.05,0.2");
    for set in ["map-1.0", "map-2.0", "noise-0", "noise-0.05", "noise-0.2"] {
        assert!(
            first.contains(&format!("set '{set}': ")) && !first.contains(&format!("set '{set}': 0 frame(s) rendered")),
            "{set} was not rendered: {first}"
        );
        assert!(
            dir.path().join("loc/sets").join(set).join("manifest.json").is_file(),
            "{set}"
        );
    }
    let report: Value = serde_json::from_slice(&std::fs::read(dir.path().join("loc/report.json")).unwrap()).unwrap();
    let sets = report["sets"].as_array().unwrap();
    let sigma = |name: &str| f(&sets.iter().find(|s| s["name"] == name).unwrap()["noise_sigma"]);
    assert_eq!(
        (sigma("noise-0"), sigma("noise-0.05"), sigma("noise-0.2")),
        (0.0, 0.05, 0.2)
    );
    let spacing = |name: &str| f(&sets.iter().find(|s| s["name"] == name).unwrap()["spacing_m"]);
    // Grid steps (a pose inside furniture is skipped, which can only widen the spacing).
    assert!(spacing("map-1.0") >= 1.0 - 1e-9 && spacing("map-2.0") >= 2.0 - 1e-9);
    assert!(spacing("map-1.0") < spacing("map-2.0"));
    // Occlusion as the fraction of the seeing pixels that the frame's people cover, counted in
    // the object-id images.
    let occluded = |name: &str| f(&sets.iter().find(|s| s["name"] == name).unwrap()["occluded_fraction"]);
    assert_eq!(occluded("noise-0.05"), 0.0);
    let (one, three) = (occluded("people-1"), occluded("people-3"));
    assert!(
        0.0 < one && one < 1.0 && 0.0 < three && three < 1.0 && one != three,
        "{one} {three}"
    );
    // 2 maps × 5 test sets × 2 descriptors × 1 distance.
    assert_eq!(report["results"].as_array().unwrap().len(), 20);
    let svg = std::fs::read_to_string(dir.path().join("loc/report.svg")).unwrap();
    assert_eq!(
        chart_markers(&svg, "against noise"),
        [2 * 3],
        "one point per σ and descriptor"
    );
    assert_eq!(
        chart_markers(&svg, "against map density"),
        [2 * 2],
        "one point per step and descriptor"
    );
    // Occluded fractions 0 (the noise sets: the first given is drawn), people-1's, people-3's.
    assert_eq!(chart_markers(&svg, "against occlusion"), [2 * 3]);
    assert!(svg.contains("occluded fraction of the image"));

    let again = run("0,0.05,0.2");
    for set in [
        "map-1.0",
        "map-2.0",
        "noise-0",
        "noise-0.05",
        "noise-0.2",
        "people-1",
        "people-3",
    ] {
        assert!(
            again.contains(&format!("set '{set}': 0 frame(s) rendered"))
                && again.contains(&format!("set '{set}': every descriptor from descriptors/")),
            "{set} was rendered or described again: {again}"
        );
    }
    let same: Value = serde_json::from_slice(&std::fs::read(dir.path().join("loc/report.json")).unwrap()).unwrap();
    let estimates = |r: &Value| -> Vec<Value> {
        r["results"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x["images"].clone())
            .collect()
    };
    assert!(estimates(&report) == estimates(&same), "a re-run localizes differently");

    let more = run("0,0.05,0.1,0.2");
    assert!(more.contains("set 'noise-0.1': 5 frame(s) rendered"), "{more}");
    assert!(more.contains("set 'noise-0.2': 0 frame(s) rendered"), "{more}");
    let svg = std::fs::read_to_string(dir.path().join("loc/report.svg")).unwrap();
    assert_eq!(chart_markers(&svg, "against noise"), [2 * 4]);
}

/// A set whose name in the manifest is not one plain folder name (`../../x`, an edited
/// manifest) is refused before localize names a folder for it, and nothing is written outside
/// --out.
#[test]
fn a_set_name_that_leaves_the_output_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::copy(scenes.join("env1.ron"), dir.path().join("env1.ron")).unwrap();
    let plain = SWEEP_SPEC
        .replace("${step}", "2.0")
        .replace("map-2.0", "map")
        .replace("noise-${sigma}", "noise")
        .replace("${sigma}", "0.1")
        .replace("${people}", "1");
    std::fs::write(dir.path().join("plain.ron"), plain).unwrap();
    omnisim(
        &["dataset", "plain.ron", "--backend", "cpu", "--out", "nested/ds"],
        dir.path(),
    );
    let manifest = dir.path().join("nested/ds/manifest.json");
    let mut edited: Value = serde_json::from_slice(&std::fs::read(&manifest).unwrap()).unwrap();
    let set = edited["sets"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|s| s["name"] == "map")
        .unwrap();
    set["name"] = Value::from("../../x");
    std::fs::write(&manifest, serde_json::to_vec(&edited).unwrap()).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args([
            "localize",
            "nested/ds",
            "--map",
            "../../x",
            "--test",
            "../../x",
            "-d",
            "fourier",
            "--out",
            "nested/loc",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(stderr.contains("not a plain folder name"), "{stderr}");
    assert!(!dir.path().join("x").exists() && !dir.path().join("nested/x").exists());
}

/// A non-UTF-8 argument (here the output folder's name) is recorded in the report's command as
/// near as UTF-8 can, not a panic after all the work (`std::env::args` panicked on it).
#[cfg(unix)]
#[test]
fn an_argument_that_is_not_utf8_is_recorded_lossily() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    dataset(dir.path());
    let out = OsStr::from_bytes(b"loc\xff");
    let output = Command::new(env!("CARGO_BIN_EXE_omnisim"))
        .args([
            "localize", "ds", "--map", "map", "--test", "clean", "-d", "fourier", "--out",
        ])
        .arg(out)
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    let report: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join(out).join("report.json")).unwrap()).unwrap();
    let command: Vec<&str> = report["command"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a.as_str().unwrap())
        .collect();
    assert_eq!(command.last(), Some(&"loc\u{fffd}"), "{command:?}");
}
