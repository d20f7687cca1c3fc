//! End-to-end tests of data sets on a small lit room, on the CPU backend (f64, deterministic).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use glam::{DMat3, DQuat, DVec2, dvec3};

use super::*;
use omnisim::Camera;
use omnisim::{BackendChoice, Planes, Renderer};

const ROOM: &str = r#"Scene(name: "room", objects: [
    Floor(name: "floor", corners: [(-2.0, -1.5), (2.0, -1.5), (2.0, 1.5), (-2.0, 1.5)], colour: (150, 140, 120)),
    Floor(name: "ceiling", corners: [(-2.0, -1.5), (2.0, -1.5), (2.0, 1.5), (-2.0, 1.5)], z: 2.5, colour: (235, 235, 230)),
    Wall(name: "south", from: (-2.0, -1.5), to: (2.0, -1.5), height: 2.5, colour: (200, 190, 160)),
    Wall(name: "east", from: (2.0, -1.5), to: (2.0, 1.5), height: 2.5, colour: (90, 160, 200)),
    Wall(name: "north", from: (2.0, 1.5), to: (-2.0, 1.5), height: 2.5, colour: (200, 120, 90)),
    Wall(name: "west", from: (-2.0, 1.5), to: (-2.0, -1.5), height: 2.5, colour: (185, 210, 170)),
    Box(name: "table", size: (0.8, 0.6, 0.7), position: (1.2, 0.8, 0.0), colour: (150, 60, 40)),
], lighting: (ambient: 10.0, white: 60.0, lights: [
    Point(name: "lamp", position: (0.0, 0.0, 2.2), intensity: 150.0),
    Point(name: "desk", position: (1.2, 0.8, 1.2), intensity: 20.0, colour: (255, 220, 180)),
]))"#;

const SPEC: &str = r#"Dataset(
    scene: "room.ron",
    seed: 11,
    rig: Pinhole(size: (32, 24), hfov: 70.0),
    outputs: (point_cloud: false, segmentation: true),
    sets: [
        Set(
            name: "map",
            poses: Trajectory(through: [(-1.2, -0.8, 1.0), (1.2, -0.8, 1.0), (1.2, 0.0, 1.0)], count: 4),
            noise: (colour: [PoissonGaussian(a: 0.002, b: 0.0001), SaltPepper(probability: 0.01)], depth: (c2: 0.003)),
            layouts: [Tum(rate: 10.0), Euroc(rate: 10.0)],
        ),
        Set(
            name: "test",
            poses: Random(count: 3, low: (-1.5, -1.0, 0.5), high: (1.5, 1.0, 1.5), tilt: 10.0, clearance: 0.3),
            lights: [Flicker(light: "lamp", off: 0.3, jitter: 0.2)],
            colours: [Shift(range: 20, per_frame: true)],
            occluders: [Occluders(shape: Person, count: 1, clearance: 0.3)],
        ),
        Set(
            name: "night",
            poses: List([(0.0, 0.0, 1.0, 0.0, 0.0, 45.0), (2.5, 0.0, 1.0, 0.0, 0.0, 0.0), (1.2, 0.8, 0.3, 0.0, 0.0, 0.0)]),
            lights: [Switch(light: "lamp", on: false)],
            occluders: [Occluders(shape: Box(size: (0.3, 0.3, 0.5)), count: 1, per_frame: false)],
        ),
    ],
)"#;

/// A folder with the room and `spec`.
/// [`SPEC`] with two map frames and one test frame: for tests about folders, not images.
fn small_spec() -> String {
    SPEC.replace("count: 4", "count: 2")
        .replace("count: 3, low", "count: 1, low")
}

fn project(spec: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("room.ron"), ROOM).unwrap();
    let path = dir.path().join("spec.ron");
    std::fs::write(&path, spec).unwrap();
    (dir, path)
}

fn cpu() -> Renderer {
    Renderer::new(BackendChoice::Cpu).unwrap()
}

/// Every file under `dir` (hidden ones included) with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                files.insert(manifest::relative(dir, &path), std::fs::read(&path).unwrap());
            }
        }
    }
    files
}

fn run(dataset: &Dataset, out: &Path, options: RunOptions, stop_after: Option<usize>) -> RunSummary {
    let mut rendered = 0;
    dataset
        .run(&cpu(), out, &options, &mut |frame| {
            rendered += usize::from(frame.rendered);
            match stop_after {
                Some(k) if rendered >= k => ControlFlow::Break(()),
                _ => ControlFlow::Continue(()),
            }
        })
        .unwrap()
}

fn assert_same(a: &BTreeMap<String, Vec<u8>>, b: &BTreeMap<String, Vec<u8>>) {
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (name, bytes) in a {
        assert!(bytes == &b[name], "{name} differs");
    }
}

/// The set's contact sheet is a grid of its `frames` colour frames, each the frame shrunk.
fn assert_contact_sheet_shows_the_frames(out: &Path, set: &str, frames: u32) {
    let sheet = image::open(out.join(set).join("contact-sheet.png")).unwrap().to_rgb8();
    // 32×24 frames become 128×96 thumbnails in 134×150 cells (6 px gaps, 16 px labels).
    assert_eq!(sheet.dimensions(), (6 + frames * 134, 6 + 150));
    let colour_frames: Vec<PathBuf> = std::fs::read_dir(out.join(set))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_str().unwrap().len() == "room-0000.png".len())
        .collect();
    assert_eq!(colour_frames.len() as u32, frames);
    for k in 0..frames {
        let frame = image::open(out.join(set).join(format!("room-{k:04}.png")))
            .unwrap()
            .to_rgb8();
        let thumbnail = image::imageops::resize(&frame, 128, 96, image::imageops::FilterType::Triangle);
        let (x, y) = (6 + k * 134, 6 + 16);
        for (u, v, pixel) in thumbnail.enumerate_pixels() {
            assert_eq!(sheet.get_pixel(x + u, y + v), pixel, "{set} frame {k} at ({u}, {v})");
        }
    }
}

#[test]
fn reruns_resumes_and_merged_shards_give_the_same_bytes() {
    let (dir, spec) = project(SPEC);
    let dataset = Dataset::load(&spec).unwrap();
    // "night" pose 1 is outside the room, pose 2 inside the table.
    assert_eq!(dataset.sets[2].poses.len(), 1);
    assert!(
        dataset.warnings.iter().any(|w| w.contains("set 'night'")
            && w.contains("2 pose(s)")
            && w.contains("outside the scene (#1)")
            && w.contains("inside 'table' (#2)")),
        "{:?}",
        dataset.warnings
    );
    let whole = dir.path().join("whole");
    let summary = run(&dataset, &whole, RunOptions::default(), None);
    assert_eq!((summary.rendered, summary.merged), (8, true));
    let reference = snapshot(&whole);
    assert!(reference.contains_key("manifest.json") && reference.contains_key("map/tum/groundtruth.txt"));
    assert!(reference.contains_key("map/room-0002-noisy.png") && reference.contains_key("map/room-0002.png"));
    assert_contact_sheet_shows_the_frames(&whole, "map", 4);
    assert_contact_sheet_shows_the_frames(&whole, "night", 1);
    let manifest = String::from_utf8_lossy(&reference["manifest.json"]).into_owned();
    assert!(manifest.contains("\"map/contact-sheet.png\"") && manifest.contains("\"overview\""));

    // The same spec again, from scratch, with one writer thread instead of 2-4: the same bytes.
    let again = dir.path().join("again");
    let one_writer = RunOptions {
        writers: Some(1),
        ..RunOptions::default()
    };
    run(&dataset, &again, one_writer, None);
    assert_same(&reference, &snapshot(&again));

    // Stopped after k frames (any k), then resumed: the same bytes; a run over a complete
    // folder renders nothing. With two writers, at most three frames beyond the k-th are done
    // when the run stops (one written, not yet heard of, and one being written, per writer);
    // frames still queued are dropped.
    for k in [1, 3] {
        let resumed = dir.path().join(format!("resumed-{k}"));
        let two_writers = RunOptions {
            writers: Some(2),
            ..RunOptions::default()
        };
        let first = run(&dataset, &resumed, two_writers, Some(k));
        assert!(first.stopped && !first.merged);
        assert!(
            (k..=k + 3).contains(&first.rendered),
            "{} frames written",
            first.rendered
        );
        assert!(!resumed.join("manifest.json").exists());
        let second = run(&dataset, &resumed, RunOptions::default(), None);
        assert_eq!((second.resumed, second.rendered), (first.rendered, 8 - first.rendered));
        assert_same(&reference, &snapshot(&resumed));
    }
    assert_eq!(run(&dataset, &whole, RunOptions::default(), None).rendered, 0);

    // The final check trusts the hashes of frames a run wrote itself, not those of frames an
    // earlier run left: one damaged while the run was stopped is found when it resumes.
    let damaged_run = dir.path().join("damaged-run");
    run(&dataset, &damaged_run, RunOptions::default(), Some(1));
    let victim = damaged_run.join("map/room-0000.png");
    let mut bytes = std::fs::read(&victim).unwrap();
    bytes[40] ^= 1;
    std::fs::write(&victim, bytes).unwrap();
    let found = dataset
        .run(&cpu(), &damaged_run, &RunOptions::default(), &mut |_| {
            ControlFlow::Continue(())
        })
        .unwrap_err();
    assert!(
        matches!(found, DatasetError::Corrupt { .. }) && found.to_string().contains("room-0000.png"),
        "{found}"
    );

    // Three shards into one folder, then merge: the same bytes.
    let shared = dir.path().join("shared");
    for index in 0..3 {
        let summary = run(
            &dataset,
            &shared,
            RunOptions {
                shard: Some(Shard { index, count: 3 }),
                ..RunOptions::default()
            },
            None,
        );
        assert!(!summary.merged && summary.rendered >= 2);
    }
    merge(&shared, &[]).unwrap();
    assert_same(&reference, &snapshot(&shared));

    // Three shards in their own folders, merged into a fourth; an incomplete merge is refused.
    let parts: Vec<PathBuf> = (0..3).map(|k| dir.path().join(format!("part-{k}"))).collect();
    for (index, part) in parts.iter().enumerate() {
        run(
            &dataset,
            part,
            RunOptions {
                shard: Some(Shard { index, count: 3 }),
                ..RunOptions::default()
            },
            None,
        );
    }
    let merged = dir.path().join("merged");
    let refusal = merge(&merged, &parts[..2]).unwrap_err();
    assert!(
        matches!(
            refusal,
            DatasetError::Incomplete {
                missing: 1,
                total: 4,
                first: 2,
                ..
            }
        ),
        "{refusal}"
    );
    merge(&merged, &parts[2..]).unwrap();
    assert_same(&reference, &snapshot(&merged));

    // A damaged file is found by its hash.
    let victim = merged.join("map/room-0001.png");
    let mut bytes = std::fs::read(&victim).unwrap();
    bytes[40] ^= 1;
    std::fs::write(&victim, bytes).unwrap();
    let damaged = merge(&merged, &[]).unwrap_err();
    assert!(
        matches!(damaged, DatasetError::Corrupt { .. }) && damaged.to_string().contains("room-0001.png"),
        "{damaged}"
    );
}

#[test]
fn another_spec_is_refused_unless_overwrite_removes_its_files() {
    let (dir, spec) = project(SPEC);
    let out = dir.path().join("out");
    let (_small_dir, small_path) = project(&small_spec());
    let first = Dataset::load(&small_path).unwrap();
    run(&first, &out, RunOptions::default(), None);
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let dataset = Dataset::load(&spec).unwrap();
    let refused = dataset.run(&cpu(), &out, &RunOptions::default(), &mut |_| ControlFlow::Continue(()));
    assert!(
        matches!(refused, Err(DatasetError::AnotherSpec { .. })),
        "{:?}",
        refused.err()
    );
    let summary = run(
        &dataset,
        &out,
        RunOptions {
            overwrite: true,
            ..RunOptions::default()
        },
        None,
    );
    assert!(summary.notes[0].contains("removed"), "{:?}", summary.notes);
    assert!(out.join("notes.txt").exists(), "a file no data set wrote stays");
    let mut files = snapshot(&out);
    files.remove("notes.txt");
    let fresh = dir.path().join("fresh");
    run(&dataset, &fresh, RunOptions::default(), None);
    assert_same(&snapshot(&fresh), &files);
    // A folder with someone's files is refused.
    let theirs = dir.path().join("theirs");
    std::fs::create_dir(&theirs).unwrap();
    std::fs::write(theirs.join("thesis.tex"), "x").unwrap();
    let refused = dataset.run(&cpu(), &theirs, &RunOptions::default(), &mut |_| {
        ControlFlow::Continue(())
    });
    assert!(matches!(refused, Err(DatasetError::Unrecorded { .. })));
}

/// Runs of two specs started at the same moment into one new folder: one claims it, the other
/// is refused (each decides and writes the stamp with the folder's gate held).
#[test]
fn two_specs_started_at_once_into_one_folder_never_both_claim_it() {
    let (dir, spec) = project(SPEC);
    let (_small_dir, small_path) = project(&small_spec());
    let stamps = [Dataset::load(&spec).unwrap(), Dataset::load(&small_path).unwrap()].map(|d| d.stamp(&cpu()));
    for attempt in 0..100 {
        let out = dir.path().join(format!("out{attempt}"));
        let start = std::sync::Barrier::new(2);
        let claims: Vec<bool> = std::thread::scope(|scope| {
            let runs: Vec<_> = stamps
                .iter()
                .map(|stamp| {
                    let (out, start) = (&out, &start);
                    scope.spawn(move || {
                        start.wait();
                        folder::open_folder(out, stamp, false).is_ok()
                    })
                })
                .collect();
            runs.into_iter().map(|run| run.join().unwrap()).collect()
        });
        assert_eq!(
            claims.iter().filter(|&&claimed| claimed).count(),
            1,
            "attempt {attempt}: {claims:?}"
        );
    }
}

/// `--overwrite` never removes a data set while a run (or merge) of it works in the folder;
/// once that run ends (a killed one too: the system drops its locks), it does.
#[test]
fn an_overwrite_is_refused_while_another_data_set_is_being_written() {
    let (dir, spec) = project(SPEC);
    let (_small_dir, small_path) = project(&small_spec());
    let [ours, theirs] = [Dataset::load(&spec).unwrap(), Dataset::load(&small_path).unwrap()].map(|d| d.stamp(&cpu()));
    let out = dir.path().join("out");
    let (_, running) = folder::open_folder(&out, &theirs, false).unwrap();
    // A shard of the same data set joins it.
    let (_, shard) = folder::open_folder(&out, &theirs, false).unwrap();
    let message = match folder::open_folder(&out, &ours, true) {
        Err(e @ DatasetError::Busy { .. }) => e.to_string(),
        other => panic!("not refused as in use: {:?}", other.map(|(notes, _)| notes)),
    };
    assert!(
        message.contains(&out.display().to_string()) && message.contains("wait for it to end"),
        "{message}"
    );
    drop(running);
    assert!(matches!(
        folder::open_folder(&out, &ours, true),
        Err(DatasetError::Busy { .. })
    ));
    drop(shard);
    let (notes, _) = folder::open_folder(&out, &ours, true).unwrap();
    assert!(notes.iter().any(|n| n.contains("removed")), "{notes:?}");
    // A merge holds the folder too.
    let merging = folder::hold(&out).unwrap();
    assert!(matches!(
        folder::open_folder(&out, &theirs, true),
        Err(DatasetError::Busy { .. })
    ));
    drop(merging);
}

/// A data set is never written inside a set's bookkeeping folder, nor inside another data set.
#[test]
fn an_output_folder_inside_bookkeeping_or_another_data_set_is_refused() {
    let (dir, spec) = project(&small_spec());
    let dataset = Dataset::load(&spec).unwrap();
    let attempt = |out: &Path| {
        dataset
            .run(&cpu(), out, &RunOptions::default(), &mut |_| ControlFlow::Continue(()))
            .map(|_| ())
    };
    let frames = dir.path().join("data/.frames");
    let message = match attempt(&frames) {
        Err(e @ DatasetError::InBookkeeping { .. }) => e.to_string(),
        other => panic!("{other:?}"),
    };
    assert!(
        message.contains(&frames.display().to_string()) && message.contains("choose a folder outside it"),
        "{message}"
    );
    assert!(!dir.path().join("data").exists(), "a refused run created its folder");
    let out = dir.path().join("out");
    run(&dataset, &out, RunOptions::default(), None);
    let mut inside = vec![
        (out.join("map/.frames"), true),
        (out.join("map/.frames/more"), true),
        (out.join("map"), false),
        (out.join("elsewhere"), false),
    ];
    #[cfg(unix)]
    {
        let link = dir.path().join("entries");
        std::os::unix::fs::symlink(out.join("map/.frames"), &link).unwrap();
        inside.push((link.join("new"), true));
    }
    for (folder, bookkeeping) in inside {
        match attempt(&folder) {
            Err(DatasetError::InBookkeeping { .. }) if bookkeeping => {}
            Err(DatasetError::InDataSet { outer, .. }) if !bookkeeping => {
                assert_eq!(outer, out.canonicalize().unwrap());
            }
            other => panic!("{}: {other:?}", folder.display()),
        }
        assert!(matches!(
            merge(&folder, std::slice::from_ref(&out)),
            Err(DatasetError::InBookkeeping { .. } | DatasetError::InDataSet { .. })
        ));
    }
    assert!(!out.join("elsewhere").exists());
}

/// An ASCII PLY tetrahedron of edge `size` metres, standing at the origin.
fn tetrahedron(size: f64) -> String {
    format!(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         element face 4\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n{size} 0 0\n0 {size} 0\n0 0 {size}\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"
    )
}

#[test]
fn a_changed_mesh_file_or_another_renderer_is_refused() {
    let spec_text = small_spec();
    let (dir, spec) = project(&spec_text);
    let mesh = dir.path().join("tetra.ply");
    std::fs::write(&mesh, tetrahedron(0.3)).unwrap();
    let with_mesh = ROOM.replace(
        "], lighting:",
        r#"    Mesh(name: "tetra", path: "tetra.ply", colour: (90, 90, 200), position: (-1.0, 0.5, 0.0)),
], lighting:"#,
    );
    std::fs::write(dir.path().join("room.ron"), with_mesh).unwrap();
    let out = dir.path().join("out");
    let first = Dataset::load(&spec).unwrap();
    run(&first, &out, RunOptions::default(), None);
    // Same spec and scene text, another mesh: another data set.
    std::fs::write(&mesh, tetrahedron(0.4)).unwrap();
    let changed = Dataset::load(&spec).unwrap();
    let refused = changed.run(&cpu(), &out, &RunOptions::default(), &mut |_| ControlFlow::Continue(()));
    assert!(
        matches!(refused, Err(DatasetError::AnotherSpec { .. })),
        "{:?}",
        refused.err()
    );
    // Same data set, frames of another renderer: a resume and a merge refuse them.
    let stamp_path = out.join(files::STAMP);
    let mut stamp: serde_json::Value = serde_json::from_slice(&std::fs::read(&stamp_path).unwrap()).unwrap();
    assert_eq!(stamp["renderer"], cpu().renders_with());
    stamp["renderer"] = "gpu: some adapter".into();
    std::fs::write(&stamp_path, serde_json::to_vec(&stamp).unwrap()).unwrap();
    let refused = first.run(&cpu(), &out, &RunOptions::default(), &mut |_| ControlFlow::Continue(()));
    let message = refused.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        message.contains("gpu: some adapter") && message.contains("--backend"),
        "{message}"
    );
    let ours = dir.path().join("ours");
    run(
        &first,
        &ours,
        RunOptions {
            shard: Some(Shard { index: 0, count: 2 }),
            ..RunOptions::default()
        },
        None,
    );
    let merged = merge(&ours, std::slice::from_ref(&out));
    assert!(
        matches!(merged, Err(DatasetError::OtherRenderer { .. })),
        "{:?}",
        merged.err()
    );
    // --overwrite starts the folder afresh with this renderer.
    run(
        &first,
        &out,
        RunOptions {
            overwrite: true,
            ..RunOptions::default()
        },
        None,
    );
    assert!(out.join("manifest.json").exists());
    // A stamp edited to an impossible frame count is refused by a merge, not trusted.
    let mut stamp: serde_json::Value = serde_json::from_slice(&std::fs::read(&stamp_path).unwrap()).unwrap();
    stamp["sets"][0]["frames"] = 1_000_000_000_000_000u64.into();
    std::fs::write(&stamp_path, serde_json::to_vec(&stamp).unwrap()).unwrap();
    let merged = merge(&out, &[]);
    assert!(
        matches!(merged, Err(DatasetError::BadStamp { .. })),
        "{:?}",
        merged.err()
    );
}

#[test]
fn merges_and_overwrites_say_what_they_met() {
    let small = small_spec();
    let (dir, spec) = project(&small);
    let dataset = Dataset::load(&spec).unwrap();
    let (out, empty) = (dir.path().join("out"), dir.path().join("empty"));
    std::fs::create_dir(&empty).unwrap();
    let merged = merge(&empty, &[]);
    assert!(
        matches!(merged, Err(DatasetError::NotADataSet { .. })),
        "{:?}",
        merged.err()
    );
    assert!(merged.err().unwrap().needs_a_change());
    // A shard of another spec.
    let (_other_dir, other_spec) = project(&small.replace("seed: 11", "seed: 12"));
    let other = dir.path().join("other");
    run(
        &Dataset::load(&other_spec).unwrap(),
        &other,
        RunOptions::default(),
        None,
    );
    run(&dataset, &out, RunOptions::default(), None);
    let merged = merge(&out, std::slice::from_ref(&other));
    assert!(
        matches!(merged, Err(DatasetError::ShardOfAnotherSpec { .. })),
        "{:?}",
        merged.err()
    );
    // An unreadable stamp: refused, then --overwrite renders over it.
    std::fs::write(out.join(files::STAMP), "{").unwrap();
    let refused = dataset.run(&cpu(), &out, &RunOptions::default(), &mut |_| ControlFlow::Continue(()));
    assert!(
        refused
            .err()
            .is_some_and(|e| matches!(e, DatasetError::BadStamp { .. }) && e.needs_a_change())
    );
    let overwrite = RunOptions {
        overwrite: true,
        ..RunOptions::default()
    };
    let summary = run(&dataset, &out, overwrite, None);
    assert!(
        summary.notes.iter().any(|n| n.contains("unreadable")),
        "{:?}",
        summary.notes
    );
    assert!(merge(&out, &[]).is_ok());
    // A shard whose frame entry was edited: the shard's entry is named (the one to delete or
    // restore), and nothing of it is copied over the destination's.
    let shard = dir.path().join("shard");
    run(&dataset, &shard, RunOptions::default(), None);
    let edited = files::entry_path(&shard.join("map"), 0);
    let text = std::fs::read_to_string(&edited).unwrap();
    std::fs::write(&edited, text.replacen("\"index\": 0,", "\"index\": 1,", 1)).unwrap();
    let ours = std::fs::read(files::entry_path(&out.join("map"), 0)).unwrap();
    let merged = merge(&out, std::slice::from_ref(&shard));
    let error = merged.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        error.starts_with(&format!("{}:", edited.display())) && error.contains("index or stem"),
        "{error}"
    );
    assert_eq!(std::fs::read(files::entry_path(&out.join("map"), 0)).unwrap(), ours);
}

#[cfg(unix)]
#[test]
fn links_and_strangers_files_in_the_folder_are_never_written_through() {
    let spec_text = small_spec();
    let (dir, spec) = project(&spec_text);
    let dataset = Dataset::load(&spec).unwrap();
    let elsewhere = dir.path().join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("contact-sheet.png"), "mine").unwrap();
    // A set folder that is a link: refused, nothing written there.
    let out = dir.path().join("out");
    run(&dataset, &out, RunOptions::default(), None);
    std::fs::remove_dir_all(out.join("map")).unwrap();
    std::os::unix::fs::symlink(&elsewhere, out.join("map")).unwrap();
    let refused = dataset.run(&cpu(), &out, &RunOptions::default(), &mut |_| ControlFlow::Continue(()));
    assert!(refused.err().is_some_and(|e| e.to_string().contains("is a link")));
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 1);
    assert_eq!(std::fs::read(elsewhere.join("contact-sheet.png")).unwrap(), b"mine");
    // A layout folder that is a link: refused before anything is made in it; --overwrite
    // removes nothing through it.
    let (out, moved) = (dir.path().join("out2"), dir.path().join("moved-tum"));
    run(&dataset, &out, RunOptions::default(), None);
    std::fs::rename(out.join("map/tum"), &moved).unwrap();
    std::os::unix::fs::symlink(&moved, out.join("map/tum")).unwrap();
    let before = snapshot(&moved);
    let refused = dataset.run(&cpu(), &out, &RunOptions::default(), &mut |_| ControlFlow::Continue(()));
    assert!(matches!(refused, Err(DatasetError::Link { .. })), "{:?}", refused.err());
    let (_other_dir, other_spec) = project(&spec_text.replace("seed: 11", "seed: 12"));
    let other = Dataset::load(&other_spec).unwrap();
    let overwrite = RunOptions {
        overwrite: true,
        ..RunOptions::default()
    };
    let _ = other.run(&cpu(), &out, &overwrite, &mut |_| ControlFlow::Continue(()));
    assert!(
        snapshot(&moved) == before,
        "files were removed or written through the link"
    );
    // A merge into a folder of someone else's files: refused.
    let (shard, theirs) = (dir.path().join("shard"), dir.path().join("theirs"));
    let one_shard = RunOptions {
        shard: Some(Shard { index: 0, count: 1 }),
        ..RunOptions::default()
    };
    run(&dataset, &shard, one_shard, None);
    std::fs::create_dir(&theirs).unwrap();
    std::fs::write(theirs.join("notes.txt"), "mine").unwrap();
    let merged = merge(&theirs, std::slice::from_ref(&shard));
    assert!(
        matches!(merged, Err(DatasetError::Unrecorded { .. })),
        "{:?}",
        merged.err()
    );
}

#[test]
fn sets_with_one_random_seed_share_their_poses_and_none_is_drawn_inside_furniture() {
    // Low enough to draw positions inside the table (0.8 × 0.6 × 0.7 m): 4.5 % of the region.
    let random = "Random(count: 60, low: (-1.9, -1.4, 0.05), high: (1.9, 1.4, 0.65), clearance: 0.02";
    let text = format!(
        r#"Dataset(scene: "room.ron", seed: 3, rig: Pinhole(size: (8, 6), hfov: 60.0), sets: [
        Set(name: "day", poses: {random}, seed: 9)),
        Set(name: "night", poses: {random}, seed: 9)),
        Set(name: "other", poses: {random})),
    ])"#
    );
    let (_dir, spec) = project(&text);
    let dataset = Dataset::load(&spec).unwrap();
    assert_eq!(dataset.sets[0].poses, dataset.sets[1].poses);
    assert_ne!(dataset.sets[0].poses, dataset.sets[2].poses);
    for set in &dataset.sets {
        assert_eq!((set.poses.len(), set.skipped.len()), (60, 0), "{:?}", set.skipped);
    }
    // The preview's legend says where the day set's markers went.
    let svg = preview::draw(&dataset).unwrap().svg;
    assert!(svg.contains("day: 60 poses, under night's<"), "{svg}");
    assert!(svg.contains("other: 60 poses<"));
}

#[test]
fn edge_samples_smooth_the_colour_edges_alone_and_the_mirror_rays_are_the_specs() {
    let small = small_spec();
    let rendered = |text: &str| {
        let (dir, spec) = project(text);
        let out = dir.path().join("out");
        run(&Dataset::load(&spec).unwrap(), &out, RunOptions::default(), None);
        let read = |name: &str| std::fs::read(out.join("map").join(name)).unwrap();
        (read("room-0000.png"), read("room-0000-range.exr"))
    };
    let (sharp, sharp_range) = rendered(&small);
    let (smooth, smooth_range) = rendered(&small.replace("seed: 11,", "seed: 11, edge_samples: 16,"));
    assert_eq!(sharp_range, smooth_range, "range is not anti-aliased");
    let (a, b) = (
        image::load_from_memory(&sharp).unwrap().into_rgb8(),
        image::load_from_memory(&smooth).unwrap().into_rgb8(),
    );
    let changed = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    assert!(
        changed > 0 && changed < a.pixels().len() / 2,
        "{changed} of {} pixels",
        a.pixels().len()
    );
    // Not a square: a located error.
    let (_dir, spec) = project(&small.replace("seed: 11,", "seed: 11, edge_samples: 3,"));
    let message = Dataset::load(&spec).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        message.contains("spec.ron:3:") && message.contains("edge_samples: must be a square"),
        "{message}"
    );
    // The reference paper's mirror rays, as `render --mirror-rays shortcut`.
    let omni = small
        .replace(
            "Pinhole(size: (32, 24), hfov: 70.0)",
            "Omni(size: (32, 32), mirror_rays: Shortcut)",
        )
        .replace(", Euroc(rate: 10.0)]", "]")
        .replace("[Tum(rate: 10.0)]", "[Euroc(rate: 10.0)]");
    let (_dir, spec) = project(&omni);
    let dataset = Dataset::load(&spec).unwrap();
    let Camera::Catadioptric(camera) = &dataset.rig.views()[0].camera else {
        panic!("omni")
    };
    assert_eq!(camera.rays, omnisim::camera::MirrorRays::Shortcut);
}

#[test]
fn bad_specs_get_located_errors() {
    let cases = [
        (
            SPEC.replace("count: 4)", "count: 4, speed: 2.0)"),
            "spec.ron:9:",
            "set 'map'",
            "speed",
        ),
        (
            SPEC.replace(r#"light: "lamp", off"#, r#"light: "lampe", off"#),
            "spec.ron:16:",
            "set 'test': lights[0]",
            "no light 'lampe'",
        ),
        (
            SPEC.replace("tilt: 10.0", "tilt: 100.0"),
            "spec.ron:15:",
            "set 'test': poses.tilt",
            "0 to 90",
        ),
        (
            SPEC.replace(r#"name: "night""#, r#"name: "map""#),
            "spec.ron:8:",
            "set 'map': name",
            "another set",
        ),
        (
            SPEC.replace(r#"name: "night""#, r#"name: "Manifest.json""#),
            "spec.ron:21:",
            "set 'Manifest.json': name",
            "manifest file",
        ),
        (
            SPEC.replace("range: 20", "range: 300"),
            "spec.ron:17:",
            "set 'test': range",
            "",
        ),
        (
            SPEC.replace("(1.2, 0.8, 0.3, 0.0, 0.0, 0.0)", "(1.2, 0.8, 0.3, 0.0, 0.0, 1e300)"),
            "spec.ron:22:",
            "set 'night': poses.List",
            "within ±1e9",
        ),
        (
            SPEC.replace("Euroc(rate: 10.0)", "Euroc(rate: 10.0), Euroc(rate: 20.0)"),
            "spec.ron:11:",
            "set 'map': layouts[2]",
            "one layout of each kind",
        ),
        (
            SPEC.replace("Euroc(rate: 10.0)", "Euroc(rate: 1e300)"),
            "spec.ron:11:",
            "set 'map': layouts[1].rate",
            "not 1e300",
        ),
        (
            SPEC.replace("hfov: 70.0", "hfov: 200.0"),
            "spec.ron:4:",
            "rig",
            "between 0 and 180",
        ),
        (
            SPEC.replace("room.ron", "../room.ron"),
            "spec.ron:2:",
            "scene",
            "stay inside",
        ),
        (
            SPEC.replace("Tum(rate: 10.0)", "Tum(rate: -1.0)"),
            "spec.ron:11:",
            "layouts[0].rate",
            "from 0.01 to 1000000 frames per second, not -1",
        ),
        (
            SPEC.replace("Pinhole(size: (32, 24), hfov: 70.0)", "Omni(size: (32, 32))"),
            "spec.ron:11:",
            "set 'map': layouts[0]",
            "for this rig use Euroc",
        ),
        (
            SPEC.replace(
                "outputs: (point_cloud: false, segmentation: true)",
                "outputs: (colour: false, range: false, depth: false, point_cloud: false, disparity: true)",
            ),
            "spec.ron:5:",
            "outputs",
            "no output is written for this rig's frames",
        ),
    ];
    for (text, at, place, what) in cases {
        let (_dir, spec) = project(&text);
        let message = match Dataset::load(&spec) {
            Ok(_) => panic!("accepted: {what}"),
            Err(e) => e.to_string(),
        };
        assert!(
            message.contains(at) && message.contains(place) && message.contains(what),
            "{message}"
        );
    }
    // More sets than a data set holds: refused at the list, before any is checked.
    let many = (0..=crate::spec::MAX_SETS).fold(String::new(), |mut text, k| {
        let _ = write!(
            text,
            "Set(name: \"s{k}\", poses: List([(0.0, 0.0, 1.0, 0.0, 0.0, 0.0)])),"
        );
        text
    });
    let (_dir, spec) = project(&SPEC.replace("sets: [", &format!("sets: [{many}")));
    let message = Dataset::load(&spec).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        message.contains("spec.ron:6:") && message.contains("sets") && message.contains("more than 1000"),
        "{message}"
    );
    let refuse = SPEC.replace("lights: [Switch", "misplaced: Refuse, lights: [Switch");
    let (_dir, spec) = project(&refuse);
    let message = Dataset::load(&spec).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        message.contains("set 'night': poses") && message.contains("Refuse"),
        "{message}"
    );
}

/// Occluders that cannot all be placed are a spec error found at load, before anything
/// renders, located at their entry like every other; per-frame ones in every frame.
#[test]
fn occluders_without_room_are_located_spec_errors_before_anything_renders() {
    let cases = [
        (
            SPEC.replace(
                "Person, count: 1, clearance: 0.3",
                "Person, count: 1000, clearance: 0.3",
            ),
            "spec.ron:18:",
            "set 'test': occluders[0]: frame 0: no free place for occluder",
        ),
        (
            SPEC.replace("count: 1, per_frame: false", "count: 1000, per_frame: false"),
            "spec.ron:24:",
            "set 'night': occluders[0]: no free place for occluder",
        ),
        (
            // Room for one beside the first frame's camera only: a later frame has none.
            SPEC.replace(
                "Person, count: 1, clearance: 0.3)",
                "Box(size: (0.2, 0.2, 0.2)), count: 1, clearance: 1.0, region: ((-1.9, -1.4), (-1.3, -0.6)))",
            )
            .replace(
                "Random(count: 3, low: (-1.5, -1.0, 0.5), high: (1.5, 1.0, 1.5), tilt: 10.0, clearance: 0.3)",
                "List([(-0.3, -0.7, 1.0, 0.0, 0.0, 0.0), (-1.6, -1.0, 1.0, 0.0, 0.0, 0.0)])",
            ),
            "spec.ron:18:",
            "set 'test': occluders[0]: frame 1: no free place",
        ),
    ];
    for (text, at, what) in cases {
        let (_dir, spec) = project(&text);
        let message = match Dataset::load(&spec) {
            Ok(_) => panic!("accepted: {what}"),
            Err(e) => e.to_string(),
        };
        assert!(message.contains(at) && message.contains(what), "{message}");
    }
}

/// README's spec example parses, and the shipped example loads with its scene.
#[test]
fn readme_and_shipped_specs_are_valid() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md")).unwrap();
    let start = readme.find("```ron\nDataset(").expect("README has a spec example") + "```ron\n".len();
    let example = &readme[start..start + readme[start..].find("```").unwrap()];
    spec::parse(example, Path::new("README.md")).unwrap_or_else(|e| panic!("README's spec: {e}"));
    let shipped = Dataset::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/env1-dataset.ron"
    )))
    .unwrap();
    assert_eq!(shipped.sets.len(), 4);
}

#[test]
fn scheduled_light_changes_apply_to_their_frames_only_and_keep_the_flicker_draws() {
    let lit = |lights: &str| {
        let text = SPEC.replace(r#"lights: [Flicker(light: "lamp", off: 0.3, jitter: 0.2)]"#, lights);
        let (_dir, spec) = project(&text);
        let dataset = Dataset::load(&spec).unwrap();
        let set = &dataset.sets[1].spec;
        (0..3)
            .map(|index| {
                let (_, record) =
                    appearance::frame_appearance(&dataset.scene, dataset.scene.objects.len(), set, 11, index);
                let lighting = record.lighting.unwrap();
                let state = |name: &str| {
                    let light = lighting.lights.iter().find(|l| l.name == name).unwrap();
                    let omnisim::scene::lighting::LightKind::Point { intensity, .. } = light.kind else {
                        panic!("point light")
                    };
                    (light.on, intensity)
                };
                (state("lamp"), state("desk"))
            })
            .collect::<Vec<_>>()
    };
    let always = lit(r#"lights: [Flicker(light: "desk", off: 0.5, jitter: 0.5)]"#);
    let scheduled = lit(
        r#"lights: [Switch(light: "lamp", on: false, frames: (1, 2)), Flicker(light: "desk", off: 0.5, jitter: 0.5, frames: (2, 3))]"#,
    );
    let lamp: Vec<bool> = scheduled.iter().map(|(lamp, _)| lamp.0).collect();
    assert_eq!(lamp, [true, false, true]);
    // The desk lamp flickers in frame 2 only, exactly as it does there without a schedule.
    let desk = (20.0, true);
    assert_eq!((scheduled[0].1.1, scheduled[0].1.0), desk);
    assert_eq!((scheduled[1].1.1, scheduled[1].1.0), desk);
    assert_eq!(scheduled[2].1, always[2].1);
    assert_ne!(always[2].1.1, 20.0, "the flicker draw changes the intensity");
    // A scheduled flicker draws in every frame: the flicker after it does not move.
    let both = lit(
        r#"lights: [Flicker(light: "lamp", off: 0.5, jitter: 0.5), Flicker(light: "desk", off: 0.5, jitter: 0.5)]"#,
    );
    let first_scheduled = lit(
        r#"lights: [Flicker(light: "lamp", off: 0.5, jitter: 0.5, frames: (2, 3)), Flicker(light: "desk", off: 0.5, jitter: 0.5)]"#,
    );
    for index in 0..3 {
        assert_eq!(first_scheduled[index].1, both[index].1, "desk, frame {index}");
    }
    assert_eq!(first_scheduled[2].0, both[2].0);
    assert_eq!(first_scheduled[0].0, (true, 150.0), "the lamp as the scene has it");
    // A schedule that holds no frame is a located error.
    let (_dir, spec) = project(&SPEC.replace("jitter: 0.2)]", "jitter: 0.2, frames: (3, 3))]"));
    let message = Dataset::load(&spec).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        message.contains("set 'test': lights[0].frames") && message.contains("holds no frame"),
        "{message}"
    );
}

#[test]
fn switching_a_lamp_off_changes_exactly_the_pixels_it_lit() {
    let (_dir, spec) = project(SPEC);
    let dataset = Dataset::load(&spec).unwrap();
    let renderer = cpu();
    let mut prepared = renderer.prepare(&dataset.scene).unwrap();
    let camera = omnisim::Camera::Pinhole(omnisim::camera::Pinhole::with_horizontal_fov(64, 48, 1.5));
    let pose = omnisim::Pose::from_degrees(dvec3(-1.0, -0.5, 1.2), dvec3(0.0, 20.0, 30.0));
    let on = renderer
        .render(
            &prepared,
            &camera,
            &pose,
            Planes::COLOUR.with(omnisim::Plane::LinearColour),
        )
        .unwrap();
    let night = &dataset.sets[2].spec;
    let (appearance, _) = appearance::frame_appearance(&dataset.scene, dataset.scene.objects.len(), night, 0, 0);
    renderer.set_appearance(&mut prepared, appearance).unwrap();
    let off = renderer
        .render(
            &prepared,
            &camera,
            &pose,
            Planes::COLOUR.with(omnisim::Plane::LinearColour),
        )
        .unwrap();
    let bvh = prepared.geometry();
    let lamp = dvec3(0.0, 0.0, 2.2);
    let (mut lit, mut dark) = (0, 0);
    for (i, hit) in on.pixels().iter().enumerate() {
        let changed = on.linear_colour().unwrap()[i] != off.linear_colour().unwrap()[i];
        let lamp_lights_it = hit.is_hit() && {
            let towards = (lamp - hit.point).normalize();
            let facing = hit.normal.as_dvec3().dot(towards) > 0.0;
            let origin = hit.point - bvh.offset() + hit.normal.as_dvec3() * 1e-7;
            facing && !omnisim::advanced::occluded(bvh, origin, towards, (lamp - hit.point).length(), hit.face)
        };
        assert_eq!(changed, lamp_lights_it, "pixel {i}");
        if changed {
            lit += 1;
            assert!(off.linear_colour().unwrap()[i][0] < on.linear_colour().unwrap()[i][0]);
        } else {
            dark += usize::from(hit.is_hit());
        }
    }
    assert!(lit > 1000 && dark > 0, "lit {lit}, unlit by the lamp {dark}");
}

/// Rotation of a TUM/EuRoC quaternion.
fn rotation(q: [f64; 4]) -> DMat3 {
    DMat3::from_quat(DQuat::from_xyzw(q[0], q[1], q[2], q[3]))
}

#[test]
fn tum_and_euroc_files_parse_and_their_poses_reproduce_the_images() {
    let (dir, spec) = project(SPEC);
    let dataset = Dataset::load(&spec).unwrap();
    let out = dir.path().join("out");
    run(&dataset, &out, RunOptions::default(), None);
    let tum = out.join("map/tum");
    let lines = |path: &Path| -> Vec<Vec<String>> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| {
                l.split([' ', ','])
                    .filter(|s| !s.is_empty())
                    .map(str::to_string)
                    .collect()
            })
            .collect()
    };
    let rgb = lines(&tum.join("rgb.txt"));
    let truth = lines(&tum.join("groundtruth.txt"));
    assert_eq!((rgb.len(), lines(&tum.join("depth.txt")).len(), truth.len()), (4, 4, 4));
    assert_eq!(rgb[1], ["0.100000", "rgb/0.100000.png"]);
    let Camera::Pinhole(pinhole) = &dataset.rig.views()[0].camera else {
        panic!("pinhole")
    };
    let renderer = cpu();
    let prepared = renderer.prepare(&dataset.scene).unwrap();
    for (index, row) in truth.iter().enumerate() {
        assert!(tum.join(&rgb[index][1]).exists());
        let v: Vec<f64> = row.iter().map(|s| s.parse().unwrap()).collect();
        let (t, r) = (dvec3(v[1], v[2], v[3]), rotation([v[4], v[5], v[6], v[7]]));
        // A hit seen at pixel (u, v) projects back there through the optical-frame pose and K.
        let frame = renderer
            .render(
                &prepared,
                &dataset.rig.views()[0].camera,
                &dataset.sets[0].poses[index],
                Planes::HITS,
            )
            .unwrap();
        for (u, w) in [(3u32, 4u32), (16, 12), (30, 20)] {
            let p = r.transpose() * (frame.pixel(u, w).point - t);
            let pixel = DVec2::new(pinhole.fx * p.x / p.z + pinhole.cx, pinhole.fy * p.y / p.z + pinhole.cy);
            assert!(
                pixel.distance(DVec2::new(f64::from(u), f64::from(w))) < 1e-6,
                "frame {index}: {pixel} for ({u}, {w})"
            );
        }
    }
    let euroc = out.join("map/mav0");
    let csv = lines(&euroc.join("cam0/data.csv"));
    assert_eq!(csv[2], ["200000000", "200000000.png"]);
    assert!(euroc.join("cam0/data/200000000.png").exists());
    let state = lines(&euroc.join("state_groundtruth_estimate0/data.csv"));
    assert_eq!(state.len(), 4);
    assert_eq!(state[0].len(), 17);
    let body: Vec<f64> = state[3].iter().map(|s| s.parse().unwrap()).collect();
    let pose = &dataset.sets[0].poses[3];
    assert!(dvec3(body[1], body[2], body[3]).distance(pose.position) < 1e-12);
    let r = rotation([body[5], body[6], body[7], body[4]]);
    assert!(
        (r - pose.world_from_body_rotation())
            .to_cols_array()
            .iter()
            .all(|e| e.abs() < 1e-12)
    );
    // sensor.yaml: T_BS rows take optical-frame vectors into the body frame.
    let yaml = std::fs::read_to_string(euroc.join("cam0/sensor.yaml")).unwrap();
    assert!(
        yaml.contains("data: [0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]"),
        "{yaml}"
    );
    assert!(yaml.contains("rate_hz: 10") && yaml.contains("camera_model: pinhole"));
    // The manifest lists every file with its hash; noisy and exact files are told apart.
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["spec_sha256"], manifest::sha256_hex(SPEC.as_bytes()));
    // Rust readers get it back typed, nothing lost.
    let typed = manifest::Manifest::read(&out.join("manifest.json")).unwrap();
    assert_eq!(serde_json::to_value(&typed).unwrap(), manifest);
    assert_eq!(typed.renderer, cpu().renders_with());
    let files = &manifest["sets"][0]["frame_entries"][2]["files"];
    let kind = |name: &str| {
        files
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["path"] == name)
            .map(|f| f["kind"].clone())
    };
    assert_eq!(kind("map/room-0002-noisy.png"), Some("noisy".into()));
    assert_eq!(kind("map/room-0002.png"), Some("ground-truth".into()));
    assert_eq!(kind("map/tum/rgb/0.200000.png"), Some("layout".into()));
    let occluded = &manifest["sets"][1]["frame_entries"][0]["perturbations"];
    assert_eq!(occluded["occluders"][0]["shape"], "person");
    assert!(occluded["colour_shifts"]["table"].is_array());
    // Per-frame occluders are not in the set's legend: each frame's entry gives their ids,
    // and the frames' object images hold no other id.
    let legend: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("test/segmentation.json")).unwrap()).unwrap();
    let listed = legend["objects"].as_array().unwrap().len() as u64;
    let mut seen = 0;
    for entry in manifest["sets"][1]["frame_entries"].as_array().unwrap() {
        let segment = &entry["perturbations"]["occluders"][0]["segment"];
        assert_eq!(segment["id"], listed + 1, "{entry}");
        assert_eq!(segment["name"], entry["perturbations"]["occluders"][0]["name"]);
        let stem = entry["stem"].as_str().unwrap();
        let ids = image::open(out.join(format!("test/{stem}-object.png")))
            .unwrap()
            .into_luma16();
        assert!(ids.pixels().all(|p| u64::from(p.0[0]) <= listed + 1));
        seen += ids.pixels().filter(|p| u64::from(p.0[0]) == listed + 1).count();
    }
    assert!(seen > 0, "no frame of the test set sees its occluder");
}

#[test]
fn shards_are_disjoint_and_cover_every_frame() {
    for count in 1..6 {
        let mut seen = [0; 17];
        for index in 0..count {
            let shard: Shard = format!("{index}/{count}").parse().unwrap();
            for (n, slot) in seen.iter_mut().enumerate() {
                *slot += usize::from(shard.takes(n));
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
    }
    for bad in ["3/3", "1", "a/2", "-1/2", "0/0"] {
        assert!(bad.parse::<Shard>().is_err(), "{bad}");
    }
}

/// The elements of a preview's SVG whose `class` attribute is exactly `class`.
fn elements_of_class<'a, 'input>(
    svg: &'a roxmltree::Document<'input>,
    class: &str,
) -> Vec<roxmltree::Node<'a, 'input>> {
    svg.descendants()
        .filter(|n| n.attribute("class") == Some(class))
        .collect()
}

#[test]
fn the_preview_marks_every_pose_and_skipped_pose_where_the_plan_view_puts_it() {
    let (_dir, path) = project(SPEC);
    let dataset = Dataset::load(&path).unwrap();
    let picture = preview::draw(&dataset).unwrap();
    let svg = roxmltree::Document::parse(&picture.svg).expect("the preview is well-formed XML");
    let with_class = |class: &str| elements_of_class(&svg, class);
    let markers = with_class("pose-marker");
    assert_eq!(markers.len(), dataset.frame_count());
    assert_eq!(picture.poses, dataset.frame_count());
    for set in &dataset.sets {
        let groups: Vec<_> = with_class("pose")
            .into_iter()
            .filter(|g| g.attribute("data-set") == Some(set.spec.name.as_str()))
            .collect();
        assert_eq!(groups.len(), set.poses.len(), "set {}", set.spec.name);
        for (i, (group, pose)) in groups.iter().zip(&set.poses).enumerate() {
            assert_eq!(group.attribute("data-frame"), Some(i.to_string().as_str()));
            let circle = group.children().find(|c| c.has_tag_name("circle")).unwrap();
            let at = picture.view.to_picture(pose.position.truncate());
            let centre = |name| circle.attribute(name).unwrap().parse::<f64>().unwrap();
            assert!((centre("cx") - at.x).abs() < 0.01 && (centre("cy") - at.y).abs() < 0.01);
        }
    }
    // The night set's two misplaced poses: one outside the room, one inside the table.
    let crosses = with_class("skipped");
    assert_eq!(dataset.sets[2].skipped.len(), 2);
    assert_eq!((crosses.len(), picture.skipped), (2, 2));
    let indices: Vec<_> = crosses
        .iter()
        .map(|c| c.attribute("data-source-index").unwrap())
        .collect();
    assert_eq!(indices, ["1", "2"]);
    // The test set's per-frame person (one per frame) and the night set's per-set box.
    assert_eq!(with_class("occluder per-frame").len(), dataset.sets[1].poses.len());
    assert_eq!(with_class("occluder").len(), 1);
    let lights: Vec<_> = with_class("light")
        .iter()
        .map(|l| l.attribute("data-light").unwrap())
        .collect();
    assert_eq!(lights, ["lamp", "desk"]);

    let png = image::load_from_memory(&picture.png().unwrap()).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), picture.view.size);
    let pixel = |world: DVec2| {
        let p = picture.view.to_picture(world);
        png.get_pixel(p.x as u32, p.y as u32).0
    };
    let near = |a: [u8; 3], b: [u8; 3]| a.iter().zip(b).all(|(&x, y)| x.abs_diff(y) <= 12);
    let map_colour = [31, 119, 180];
    for pose in &dataset.sets[0].poses {
        let centre = pose.position.truncate();
        assert!(near(pixel(centre), map_colour), "{:?} at {centre}", pixel(centre));
        // 10 cm behind the camera (the arrow points ahead) lies the floor, not the marker.
        let behind = centre - (pose.world_from_body_rotation() * glam::DVec3::X).truncate() * 0.1;
        assert!(!near(pixel(behind), map_colour), "{:?} behind {centre}", pixel(behind));
    }
    for skipped in &dataset.sets[2].skipped {
        let at = DVec2::new(skipped.position[0], skipped.position[1]);
        assert!(near(pixel(at), [230, 0, 0]), "{:?} at the cross {at}", pixel(at));
    }
}

/// Lights in the preview: a point light a set moves is drawn at its new place in the set's
/// colour and joined to the old one, a directional light by an arrow along its travel, and each
/// set's light changes are listed in the legend.
#[test]
fn the_preview_shows_moved_and_directional_lights_and_each_sets_light_changes() {
    let (dir, path) = project(
        r#"Dataset(scene: "room.ron", rig: Pinhole(size: (32, 24), hfov: 70.0), sets: [
            Set(name: "day", poses: List([(0.0, 0.0, 1.0, 0.0, 0.0, 0.0)])),
            Set(name: "evening", poses: List([(0.5, 0.0, 1.0, 0.0, 0.0, 90.0)]),
                lights: [Switch(light: "lamp", on: false), Move(light: "desk", position: (-1.0, -1.0, 1.5))]),
        ])"#,
    );
    let with_sun = ROOM.replace(
        "lights: [",
        r#"lights: [Directional(name: "sun", direction: (1.0, 0.5, -2.0), illuminance: 20000.0), "#,
    );
    std::fs::write(dir.path().join("room.ron"), with_sun).unwrap();
    let dataset = Dataset::load(&path).unwrap();
    let picture = preview::draw(&dataset).unwrap();
    let svg = roxmltree::Document::parse(&picture.svg).expect("the preview is well-formed XML");
    let with_class = |class: &str| elements_of_class(&svg, class);
    let number = |node: roxmltree::Node, name: &str| node.attribute(name).unwrap().parse::<f64>().unwrap();

    let moved = with_class("light moved");
    assert_eq!(moved.len(), 1);
    assert_eq!(
        (moved[0].attribute("data-light"), moved[0].attribute("data-set")),
        (Some("desk"), Some("evening"))
    );
    let disc = moved[0].children().find(|c| c.has_tag_name("circle")).unwrap();
    let at = picture.view.to_picture(DVec2::new(-1.0, -1.0));
    assert!((number(disc, "cx") - at.x).abs() < 0.01 && (number(disc, "cy") - at.y).abs() < 0.01);
    assert_eq!(
        disc.attribute("stroke"),
        Some("rgb(255,127,14)"),
        "outlined in the second set's colour"
    );

    let sun = with_class("light directional");
    assert_eq!(sun.len(), 1);
    assert_eq!(sun[0].attribute("data-light"), Some("sun"));
    let line = sun[0].children().find(|c| c.has_tag_name("line")).unwrap();
    let travel = DVec2::new(
        number(line, "x2") - number(line, "x1"),
        number(line, "y1") - number(line, "y2"),
    );
    assert!(
        travel.normalize().distance(DVec2::new(1.0, 0.5).normalize()) < 1e-3,
        "{travel}"
    );
    let label = sun[0]
        .children()
        .find(|c| c.has_tag_name("text"))
        .unwrap()
        .text()
        .unwrap();
    // Travelling along (1, 0.5, −2): atan(2 / √1.25) = 60.8° above the horizon.
    assert!(label.contains("sun (directional, 61° up)"), "{label}");

    let changes = with_class("light-changes");
    assert_eq!(changes.len(), 1, "only the set that changes lights lists them");
    assert_eq!(changes[0].attribute("data-set"), Some("evening"));
    assert_eq!(changes[0].text(), Some("lights: lamp off, desk moved"));

    let png = image::load_from_memory(&picture.png().unwrap()).unwrap().to_rgb8();
    let p = picture.view.to_picture(DVec2::new(-1.0, -1.0));
    let pixel = png.get_pixel(p.x as u32, p.y as u32).0;
    assert!(
        pixel.iter().zip([255u8, 215, 0]).all(|(&a, b)| a.abs_diff(b) <= 12),
        "{pixel:?} at the moved desk lamp"
    );
}

/// A spec whose pinhole looks at the east wall (x = 2 m) from x = 0, 0.5 and 1 m at the
/// height of the room's middle: every pixel of the image's upper half sees that wall, at
/// depth z = 2, 1.5 and 1 m exactly.
const WALL: &str = r#"Dataset(
    scene: "room.ron",
    rig: Pinhole(size: (32, 24), hfov: 70.0),
    sets: [Set(name: "wall", poses: List([(0.0, 0.0, 1.0, 0.0, 0.0, 0.0), (0.5, 0.0, 1.0, 0.0, 0.0, 0.0),
        (1.0, 0.0, 1.0, 0.0, 0.0, 0.0)]), layouts: [Tum(rate: 30.0), Euroc(rate: 30.0)])],
)"#;

/// evo reads both trajectories (`frames` poses each) with the Python `python`.
fn evo_reads(python: &Path, tum: &Path, euroc: &Path, frames: usize) {
    let evo_traj = python.with_file_name("evo_traj");
    for (format, file) in [("tum", tum), ("euroc", euroc)] {
        let output = std::process::Command::new(&evo_traj)
            .arg(format)
            .arg(file)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&output.stdout).to_string() + &String::from_utf8_lossy(&output.stderr);
        assert!(
            output.status.success() && text.contains(&format!("{frames} poses")),
            "evo_traj {format}: {text}"
        );
    }
}

#[test]
#[cfg_attr(omnisim_no_python, ignore = "needs OMNISIM_PYTHON (README, Tests)")]
fn open3d_and_evo_read_the_tum_and_euroc_layouts() {
    let python = PathBuf::from(std::env::var_os("OMNISIM_PYTHON").expect(
        "OMNISIM_PYTHON names no Python: set it to one with tests/readers/requirements.txt (.ci/run makes one) \
         (README, Tests)",
    ));
    let (dir, spec) = project(WALL);
    let out = dir.path().join("out");
    run(&Dataset::load(&spec).unwrap(), &out, RunOptions::default(), None);
    let tum = out.join("wall/tum");
    let readers = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/readers");
    let output = std::process::Command::new(&python)
        .arg(readers.join("check_tum_open3d.py"))
        .arg(&tum)
        .args((0..3).map(|k| out.join(format!("wall/room-{k:04}-depth.exr"))))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let pairs: Vec<serde_json::Value> = stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(pairs.len(), 3);
    for (k, (pair, wall)) in pairs.iter().zip([2.0, 1.5, 1.0]).enumerate() {
        let number = |v: &serde_json::Value| v.as_f64().unwrap();
        assert_eq!(pair["size"], serde_json::json!([32, 24]));
        assert_eq!(pair["colour_size"], serde_json::json!([24, 32, 3]));
        // Timestamps are written to the microsecond.
        assert!(
            (number(&pair["timestamps"][0]) - k as f64 / 30.0).abs() < 1e-6,
            "{pair}"
        );
        // 16-bit z × 5000: within half a step (0.1 mm) of the exact depth and of the EXR.
        for end in [0, 1] {
            let depth = number(&pair["upper_half_depth"][end]);
            assert!(
                (depth - wall).abs() <= 1e-4 + 1e-9,
                "pair {k}: {depth} m, wall at {wall} m"
            );
        }
        assert!(number(&pair["max_error_vs_exr"]) <= 1e-4 + 1e-7, "pair {k}: {pair}");
        assert_eq!(pair["zero_where_no_depth"], true);
    }
    // evo_ape reads groundtruth.txt against a copy moved 1 cm along x: APE RMSE 0.01 m.
    let truth = tum.join("groundtruth.txt");
    let moved: String = std::fs::read_to_string(&truth)
        .unwrap()
        .lines()
        .map(|line| {
            if line.starts_with('#') {
                format!("{line}\n")
            } else {
                let mut fields: Vec<String> = line.split(' ').map(str::to_string).collect();
                fields[1] = format!("{:.6}", fields[1].parse::<f64>().unwrap() + 0.01);
                fields.join(" ") + "\n"
            }
        })
        .collect();
    let estimate = dir.path().join("moved.txt");
    std::fs::write(&estimate, moved).unwrap();
    let output = std::process::Command::new(&python)
        .arg(python.with_file_name("evo_ape"))
        .arg("tum")
        .args([&truth, &estimate])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let rmse: f64 = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("rmse"))
        .unwrap_or_else(|| panic!("no rmse in {text}"))
        .trim()
        .parse()
        .unwrap();
    assert!((rmse - 0.01).abs() < 1e-6, "APE RMSE {rmse}");
    evo_reads(
        &python,
        &truth,
        &out.join("wall/mav0/state_groundtruth_estimate0/data.csv"),
        3,
    );
}

#[test]
fn random_poses_draw_each_angle_in_its_own_range() {
    let spec = |angles: &str| {
        format!(
            r#"Dataset(scene: "room.ron", rig: Pinhole(size: (8, 6)), sets: [Set(name: "test",
                poses: Random(count: 200, low: (-1.5, -1.0, 0.5), high: (1.5, 1.0, 1.5), {angles}))])"#
        )
    };
    let (_dir, path) = project(&spec("angles: ((-5.0, 5.0), (10.0, 20.0), (90.0, 90.0))"));
    let dataset = Dataset::load(&path).unwrap();
    let angles: Vec<_> = dataset.sets[0]
        .poses
        .iter()
        .map(omnisim::Pose::angles_degrees)
        .collect();
    assert_eq!(angles.len(), 200);
    let spread = |axis: fn(&glam::DVec3) -> f64| {
        let values: Vec<f64> = angles.iter().map(axis).collect();
        (
            values.iter().copied().fold(f64::MAX, f64::min),
            values.iter().copied().fold(f64::MIN, f64::max),
        )
    };
    let (x, y, z) = (spread(|a| a.x), spread(|a| a.y), spread(|a| a.z));
    // Inside each range, and spread over it (200 uniform draws leave gaps of ~1/200).
    assert!(
        x.0 >= -5.0 - 1e-9 && x.1 <= 5.0 + 1e-9 && x.0 < -4.5 && x.1 > 4.5,
        "{x:?}"
    );
    assert!(
        y.0 >= 10.0 - 1e-9 && y.1 <= 20.0 + 1e-9 && y.0 < 10.5 && y.1 > 19.5,
        "{y:?}"
    );
    assert!((z.0 - 90.0).abs() < 1e-9 && (z.1 - 90.0).abs() < 1e-9, "{z:?}");

    let (_dir, path) = project(&spec("tilt: 5.0, angles: ((0.0, 1.0), (0.0, 1.0), (0.0, 1.0))"));
    let message = Dataset::load(&path).err().unwrap().to_string();
    assert!(
        message.contains("set 'test': poses.angles: give tilt or per-axis angles, not both"),
        "{message}"
    );
    let (_dir, path) = project(&spec("angles: ((0.0, 1.0), (3.0, 2.0), (0.0, 1.0))"));
    let message = Dataset::load(&path).err().unwrap().to_string();
    assert!(
        message.contains("spec.ron:") && message.contains("θy: (3, 2)"),
        "{message}"
    );
}

#[test]
fn the_preview_of_a_large_set_draws_an_even_spread_of_its_poses() {
    // 100 × 60 = 6000 poses over the room, none inside the table (z = 1.0 is above it).
    let (_dir, path) = project(
        r#"Dataset(scene: "room.ron", rig: Pinhole(size: (8, 6)), sets: [Set(name: "grid",
            poses: Grid(x: (-1.98, 1.98, 0.04), y: (-1.475, 1.475, 0.05), z: [1.0]))])"#,
    );
    let dataset = Dataset::load(&path).unwrap();
    assert_eq!(dataset.sets[0].poses.len(), 6000);
    let picture = preview::draw(&dataset).unwrap();
    let svg = roxmltree::Document::parse(&picture.svg).unwrap();
    let frames: Vec<usize> = svg
        .descendants()
        .filter(|n| n.attribute("class") == Some("pose"))
        .map(|n| n.attribute("data-frame").unwrap().parse().unwrap())
        .collect();
    assert_eq!((frames.len(), picture.poses), (5000, 5000));
    assert_eq!((frames[0], frames[4999]), (0, 5999));
    assert!(frames.windows(2).all(|w| (1..=2).contains(&(w[1] - w[0]))));
    assert!(picture.svg.contains("grid: 6000 poses (5000 drawn)"));
}

#[test]
fn a_stereo_fisheye_pair_writes_each_cameras_lens_and_no_disparity() {
    let stereo = small_spec()
        .replace(
            "rig: Pinhole(size: (32, 24), hfov: 70.0)",
            "rig: Stereo(size: (32, 24), lens: KannalaBrandt(k: (0.01, -0.002, 0.0001, 0.0)), fov: 200.0)",
        )
        .replace(
            "layouts: [Tum(rate: 10.0), Euroc(rate: 10.0)]",
            "layouts: [Euroc(rate: 10.0)]",
        );
    let (dir, spec) = project(&stereo);
    let dataset = Dataset::load(&spec).unwrap();
    let out = dir.path().join("out");
    run(&dataset, &out, RunOptions::default(), None);
    for (cam, x) in [("cam0", "0.06"), ("cam1", "-0.06")] {
        let sensor = std::fs::read_to_string(out.join(format!("map/mav0/{cam}/sensor.yaml"))).unwrap();
        assert!(
            sensor.contains("camera_model: pinhole") && sensor.contains("distortion_model: equidistant"),
            "{sensor}"
        );
        // T_BS places each eye on body y.
        assert!(
            sensor.contains(&format!("0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, {x}")),
            "{sensor}"
        );
    }
    let files: Vec<String> = snapshot(&out).into_keys().collect();
    assert!(
        files
            .iter()
            .any(|f| f.ends_with("map/calibration-opencv-fisheye-right.yaml")),
        "{files:?}"
    );
    assert!(!files.iter().any(|f| f.contains("disparity")), "{files:?}");
    // Neither disparity noise nor TUM's optical-axis depth applies to the pair.
    for (change, message) in [
        ("depth: (c2: 0.003)", "depth: (c2: 0.003), disparity: (sigma: 0.1)"),
        ("layouts: [Euroc(rate: 10.0)]", "layouts: [Tum(rate: 10.0)]"),
    ] {
        let (dir, spec) = project(&stereo.replace(change, message));
        let error = match Dataset::load(&spec) {
            Ok(_) => panic!("{message}: refused"),
            Err(error) => error.to_string(),
        };
        assert!(
            error.contains("without a fisheye lens") || error.contains("has no disparity"),
            "{error}"
        );
        drop(dir);
    }
}

/// [`small_spec`]'s data set, and the folder it was run into to the end.
fn done_small_data_set() -> (tempfile::TempDir, Dataset, PathBuf) {
    let (dir, spec) = project(&small_spec());
    let dataset = Dataset::load(&spec).unwrap();
    let out = dir.path().join("out");
    run(&dataset, &out, RunOptions::default(), None);
    (dir, dataset, out)
}

/// A run over a done folder replaces none of the files its manifest vouches for: the set
/// files and `set.json` keep their inodes (an unsynced rename over them could leave, after a
/// power cut, cut-short files under names the manifest vouches for).
#[cfg(unix)]
#[test]
fn a_run_over_a_done_folder_leaves_the_set_files_in_place() {
    use std::os::unix::fs::MetadataExt;
    let (dir, dataset, out) = done_small_data_set();
    let set_files = |out: &Path| -> BTreeMap<PathBuf, (u64, Vec<u8>)> {
        let paths = set_file_paths(out);
        let found = |path: &PathBuf| (std::fs::metadata(path).unwrap().ino(), std::fs::read(path).unwrap());
        paths.into_iter().map(|path| (path.clone(), found(&path))).collect()
    };
    let before = set_files(&out);
    assert!(before.keys().any(|path| path.ends_with("map/segmentation.json")));
    let again = run(&dataset, &out, RunOptions::default(), None);
    assert_eq!((again.rendered, again.resumed, again.merged), (0, 4, true));
    assert_eq!(set_files(&out), before, "a set file was replaced");
    // Changed set files are replaced (synced, with the same bytes as before): one edited,
    // one edited to other bytes of the same length, one a link to a file outside the folder
    // with the same bytes (replaced by a regular file; the file outside untouched).
    let mut calibrations = (before.keys()).filter(|path| !path.ends_with(files::SET_ENTRY));
    let (edited, same_length, linked) = (
        calibrations.next().unwrap(),
        calibrations.next().unwrap(),
        calibrations.next().unwrap(),
    );
    std::fs::write(edited, "edited").unwrap();
    let mut flipped = before[same_length].1.clone();
    flipped[0] ^= 1;
    std::fs::write(same_length, flipped).unwrap();
    let outside = dir.path().join("outside");
    std::fs::write(&outside, &before[linked].1).unwrap();
    let outside_inode = std::fs::metadata(&outside).unwrap().ino();
    std::fs::remove_file(linked).unwrap();
    std::os::unix::fs::symlink(&outside, linked).unwrap();
    run(&dataset, &out, RunOptions::default(), None);
    for path in [edited, same_length, linked] {
        assert_eq!(std::fs::read(path).unwrap(), before[path].1, "{}", path.display());
    }
    assert!(
        std::fs::symlink_metadata(linked).unwrap().is_file(),
        "the link is replaced"
    );
    assert_eq!(std::fs::read(&outside).unwrap(), before[linked].1);
    assert_eq!(std::fs::metadata(&outside).unwrap().ino(), outside_inode);
}

/// Every set file of `out` (as its sets' `set.json` name them), and the `set.json`s.
fn set_file_paths(out: &Path) -> Vec<PathBuf> {
    let mut paths = Vec::new();
    for set in ["map", "test", "night"] {
        let own = out.join(set).join(files::ENTRIES).join(files::SET_ENTRY);
        let entry: manifest::SetEntry = files::read_json(&own).unwrap();
        paths.extend(entry.files.iter().map(|file| out.join(&file.path)));
        paths.push(own);
    }
    paths
}

/// Syncing through `sync` (the folder's own sync unless it returns an error) in one-frame
/// batches, so that tests can fail a batch or hold it while the run goes on.
fn one_frame_batches<'s>(
    sync: &'s (dyn Fn(&omnisim::atomic_file::DurableFolder, &[PathBuf]) -> std::io::Result<()> + Sync),
) -> run::Syncing<'s> {
    run::Syncing {
        make_durable: sync,
        batches: run::BatchLimits {
            frames: 1,
            ..run::Syncing::DISK.batches
        },
    }
}

/// The error of a run over `out` in one-frame batches made durable by `sync`, which must fail it.
fn failed_run(
    dataset: &Dataset,
    out: &Path,
    sync: &(dyn Fn(&omnisim::atomic_file::DurableFolder, &[PathBuf]) -> std::io::Result<()> + Sync),
) -> String {
    let result = dataset.run_syncing(
        &cpu(),
        out,
        &RunOptions::default(),
        &mut |_| ControlFlow::Continue(()),
        &one_frame_batches(sync),
    );
    result.expect_err("the failed sync is the run's error").to_string()
}

/// Makes frame `index` of `set` not done and its files gone, as if no run had written it;
/// returns its files.
fn forget(out: &Path, set: &str, index: usize) -> Vec<PathBuf> {
    let entry_path = files::entry_path(&out.join(set), index);
    let entry: manifest::FrameEntry = files::read_json(&entry_path).unwrap();
    std::fs::remove_file(entry_path).unwrap();
    let paths: Vec<PathBuf> = entry.files.iter().map(|file| out.join(&file.path)).collect();
    for path in &paths {
        std::fs::remove_file(path).unwrap();
    }
    paths
}

/// Waits (up to 10 s) until `ready`; whether it became so.
fn wait_until(ready: impl Fn() -> bool) -> bool {
    let start = std::time::Instant::now();
    while !ready() {
        if start.elapsed() > std::time::Duration::from_secs(10) {
            return false;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    true
}

/// Every frame file some entry of `out` vouches for.
fn vouched_files(out: &Path) -> Vec<PathBuf> {
    let mut vouched = Vec::new();
    for set in ["map", "test", "night"] {
        for path in files::read_entry_paths(&out.join(set).join(files::ENTRIES)).unwrap() {
            let entry: manifest::FrameEntry = files::read_json(&path).unwrap();
            vouched.extend(entry.files.iter().map(|file| out.join(&file.path)));
        }
    }
    vouched
}

/// A failed sync of the first batch is the run's error, no entry vouches for its files, and
/// the next run renders its frames again into the same bytes.
#[test]
fn a_failed_batch_sync_is_an_error_and_vouches_for_nothing() {
    let (dir, dataset, reference) = done_small_data_set();
    let out = dir.path().join("again");
    let failed = std::sync::Mutex::new(Vec::new());
    let sync = |folder: &omnisim::atomic_file::DurableFolder, files: &[PathBuf]| {
        let mut failed = failed.lock().unwrap();
        if failed.is_empty() {
            failed.extend_from_slice(files);
            // Like Linux's syncfs: a lost write-back is reported once.
            return Err(std::io::Error::other("write-back failed"));
        }
        folder.make_durable(files)
    };
    let error = failed_run(&dataset, &out, &sync);
    assert!(
        error.contains("durable") && error.contains("write-back failed"),
        "{error}"
    );
    let failed = failed.into_inner().unwrap();
    assert!(
        failed.iter().any(|path| path.ends_with("map/.frames/set.json")),
        "the set files go with the first batch"
    );
    // Gone, so that the next run writes them anew (their bytes may sit in clean pages).
    let set_files = set_file_paths(&reference);
    for path in &set_files {
        let here = out.join(path.strip_prefix(&reference).unwrap());
        assert!(failed.contains(&here) && !here.exists(), "{}", here.display());
    }
    let vouched = vouched_files(&out);
    assert!(
        failed.iter().all(|path| !vouched.contains(path)),
        "an entry vouches for a file whose sync failed"
    );
    let again = run(&dataset, &out, RunOptions::default(), None);
    assert!(again.merged && again.rendered >= 1);
    assert_same(&snapshot(&reference), &snapshot(&out));
}

/// A run whose only batch fails its sync makes no other sync call: that batch took the set
/// files and nothing was written after it (before, the failure path made one more call with
/// an empty list: a `syncfs` of the whole file system on Linux).
#[test]
fn a_failed_run_with_nothing_left_unsynced_makes_no_more_sync_calls() {
    let (_dir, dataset, out) = done_small_data_set();
    // The last frame, so that its batch is the run's only one.
    forget(&out, "night", 0);
    let calls = std::sync::Mutex::new(Vec::new());
    let sync = |_: &omnisim::atomic_file::DurableFolder, files: &[PathBuf]| {
        calls.lock().unwrap().push(files.len());
        Err(std::io::Error::other("write-back failed"))
    };
    let error = failed_run(&dataset, &out, &sync);
    assert!(error.contains("write-back failed"), "{error}");
    let calls = calls.into_inner().unwrap();
    assert!(calls.len() == 1 && calls[0] > 0, "files per sync call: {calls:?}");
}

/// A batch whose sync fails after the callback stopped the run is still the run's error
/// (the end-of-run sync of the same handle would not report it again).
#[test]
fn a_failed_batch_sync_after_a_stop_is_still_an_error() {
    let (_dir, dataset, out) = done_small_data_set();
    // Frames in order: map 0 (rendered), map 1, test 0 (resumed), night 0 (rendered).
    let first = forget(&out, "map", 0);
    let last = forget(&out, "night", 0);
    let all_exist = |paths: &[PathBuf]| paths.iter().all(|path| path.exists());
    // map 0's batch is held until night 0 is written, so that night 0's batch goes (at the
    // end of the render loop) before map 0's entry is heard of and stops the run.
    let sync = |folder: &omnisim::atomic_file::DurableFolder, files: &[PathBuf]| {
        if files.iter().any(|path| last.contains(path)) {
            return Err(std::io::Error::other("write-back failed"));
        }
        if files.iter().any(|path| first.contains(path)) {
            assert!(wait_until(|| all_exist(&last)), "night 0 was never written");
        }
        folder.make_durable(files)
    };
    let result = dataset.run_syncing(
        &cpu(),
        &out,
        &RunOptions::default(),
        &mut |frame| {
            if !frame.rendered && frame.set == "test" {
                // map 0 written and heard of before night 0's turn: its batch goes first.
                assert!(wait_until(|| all_exist(&first)), "map 0 was never written");
                std::thread::sleep(std::time::Duration::from_millis(50));
            }
            if frame.rendered {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        },
        &one_frame_batches(&sync),
    );
    let error = result.expect_err("the failed sync is the run's error").to_string();
    assert!(
        error.contains("night 0") && error.contains("write-back failed") && !error.contains("map 0"),
        "{error}"
    );
    assert!(!files::entry_path(&out.join("night"), 0).exists());
    // map 0's entry, which stopped the run, came before the failure was heard.
    assert!(files::entry_path(&out.join("map"), 0).exists());
}

/// The callback stops the run while a batch is being synced: the batch gets no entries, the
/// run says it stopped, and the next run renders its frame again into the same bytes.
#[test]
fn a_stop_while_a_batch_is_synced_leaves_its_frames_to_the_next_run() {
    let (_dir, dataset, out) = done_small_data_set();
    let reference = snapshot(&out);
    let first = forget(&out, "map", 0);
    let (syncing, stopped) = (AtomicBool::new(false), AtomicBool::new(false));
    let sync = |folder: &omnisim::atomic_file::DurableFolder, files: &[PathBuf]| {
        if files.iter().any(|path| first.contains(path)) {
            syncing.store(true, Ordering::SeqCst);
            assert!(wait_until(|| stopped.load(Ordering::SeqCst)), "the run never stopped");
        }
        folder.make_durable(files)
    };
    let summary = dataset
        .run_syncing(
            &cpu(),
            &out,
            &RunOptions::default(),
            &mut |frame| match (frame.set, frame.index) {
                // map 0 written and heard of, so its batch goes at the next frame's turn.
                ("map", 1) => {
                    assert!(
                        wait_until(|| first.iter().all(|path| path.exists())),
                        "map 0 was never written"
                    );
                    std::thread::sleep(std::time::Duration::from_millis(50));
                    ControlFlow::Continue(())
                }
                ("night", 0) => {
                    assert!(
                        wait_until(|| syncing.load(Ordering::SeqCst)),
                        "map 0's batch never went"
                    );
                    stopped.store(true, Ordering::SeqCst);
                    ControlFlow::Break(())
                }
                _ => ControlFlow::Continue(()),
            },
            &one_frame_batches(&sync),
        )
        .unwrap();
    assert!(summary.stopped && !summary.merged);
    assert_eq!((summary.rendered, summary.resumed), (0, 3));
    assert!(!files::entry_path(&out.join("map"), 0).exists());
    let again = run(&dataset, &out, RunOptions::default(), None);
    assert_eq!((again.rendered, again.resumed, again.merged), (1, 3, true));
    assert_same(&reference, &snapshot(&out));
}

/// A failed end-of-run sync (no batch: every frame done) is the run's error and removes the
/// set files it covered, so that the next run writes them anew instead of finding their bytes
/// in pages a failed write-back left clean.
#[test]
fn a_failed_sync_of_the_set_files_removes_them() {
    let (_dir, dataset, out) = done_small_data_set();
    let reference = snapshot(&out);
    let set_files = set_file_paths(&out);
    let sync = |_: &omnisim::atomic_file::DurableFolder, files: &[PathBuf]| {
        assert!(set_files.iter().all(|path| files.contains(path)));
        Err(std::io::Error::other("write-back failed"))
    };
    let error = failed_run(&dataset, &out, &sync);
    assert!(error.contains("write-back failed"), "{error}");
    for path in &set_files {
        assert!(!path.exists(), "{} is left", path.display());
    }
    let again = run(&dataset, &out, RunOptions::default(), None);
    assert_eq!((again.rendered, again.resumed, again.merged), (0, 4, true));
    assert_same(&reference, &snapshot(&out));
}
