//! `omnisim localize`: the papers' localization experiment on a data set, one command: every
//! test image against every map image, per descriptor and distance, scored against the
//! manifest's poses, reported as JSON and charts. The algorithms are
//! `omnisim_vision::localize`; this file reads the data set, describes the images (with
//! `describe`'s descriptors, reusing what an earlier run described), and writes the report.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use omnisim::atomic_file::write_atomically;
use omnisim::output::folder::create_real_folder;
use omnisim_dataset::manifest::{FileKind, FrameEntry, Manifest, ManifestSet, hash_file, sha256_hex};
use omnisim_dataset::spec::ColourNoise;
use omnisim_vision::fourier::FourierSignature;
use omnisim_vision::keypoints::Features;
use omnisim_vision::localize::report::{
    Case, DatasetRecord, LOCAL_FEATURES, Report, ResultRecord, SCHEMA, SetRecord, Timing,
};
use omnisim_vision::localize::{self, Described as SetDescribed, Distance, Heading, Method as Localizer, PlanarPose};
use omnisim_vision::pca::Pca;
use omnisim_vision::radon::Radon;
use omnisim_vision::{Raster, npy};
use rayon::prelude::*;
use serde_json::{Value, json};

use super::describe::{Choice, Described, Method, Panorama, PanoramaArgs, Reads, choose};
use super::render::BackendArg;
use super::sweep::{self, Sweep};
use super::vision_input::{InputArgs, InputSet, NamedSettings, read_image};
use crate::progress::Progress;

/// Localize test images against a map by global appearance, as Payá et al. 2010 and 2014,
/// Berenguer et al. 2015 and Amorós et al. 2021 do (docs/localization.md).
///
/// Every image of each --test set is described and compared with every image of the --map
/// set under each distance; its position is the pose of the nearest map image (and, with
/// --neighbours K > 1, also the 1/distance-weighted mean of the K nearest), its heading the
/// nearest map image's heading turned by the Fourier signature's phase shift (fourier) or the
/// Radon transform's phase-only correlation (radon; places are compared by the transform's
/// turn-free signature, |DFT along φ| of each radial sample, 16 coefficients). The
/// manifest's poses of the map are the map; a test image's pose is read only to score it.
/// Poses are planar: position in the floor plane, heading θz (test sets drawn with tilt are
/// scored on θz alone).
///
/// Descriptors [default: fourier, hog, gist, radon, pca] are describe's (`omnisim describe
/// --help`: fourier, hog, vertical-hog, block-hog, gist, grid-gist, lmgist, radon, sift, surf,
/// with their settings; sift and surf retrieve the map image with most ratio-test matches,
/// ratio 0.8, distance "ratio-matches", brute force: slow on large maps; for central cameras
/// their heading is the planar-motion essential matrix of the matches' bearing vectors,
/// by RANSAC) and
///   pca   the panorama's grey pixels projected on the first K principal axes of the map's
///         (Payá et al. 2010) [k=20, at most map images − 1]
/// Test sets with colour noise are read as their noisy copies, maps as ground truth.
///
/// OUT/report.json holds, per map, test set, descriptor and distance: position error (cm:
/// mean, median, p95, max), recall at 10/25/50 cm, heading error (degrees), seconds per image
/// (describe, match), bytes per map image, and every test image's result; its schema is
/// docs/localization-report.schema.json. OUT/report.svg and .png chart the median error per
/// test set, against noise σ, the occluded fraction (from the object-id images, where the data
/// set has them; else occluders per frame) and map spacing, and the heading error.
/// Descriptors are kept in OUT/descriptors/<set>/ with a key of their settings and the
/// images' SHA-256: a re-run describes only what changed.
#[derive(Debug, Clone, Args)]
#[command(
    verbatim_doc_comment,
    after_help = "Examples:\n  \
omnisim localize scenes/env1-localize.ron --sweep step=0.2,0.4 --sweep sigma=0.01,0.05 --sweep people=2 \
--map 'map-${step}' --test test-day test-night 'test-occluded-${people}' 'test-noise-${sigma}' --out loc\n  \
omnisim dataset scenes/env1-dataset.ron --out data/env1\n  \
omnisim localize data/env1 --map map --test test-day test-night --out loc\n  \
omnisim localize data/env1 --map map --test test-day -d fourier:k=32 -d radon:angles=180 \
--distance l1,cosine --neighbours 3 --out loc-knn"
)]
pub(crate) struct LocalizeArgs {
    /// A data-set folder written by `omnisim dataset` (its manifest.json gives the images, the
    /// camera and the poses), or a data-set spec (.ron): then each set named by --map and
    /// --test is rendered first into OUT/sets/<set>/, a data set of its own, resumed and reused
    /// by later runs (its stamp).
    pub dataset: PathBuf,
    /// With a spec: NAME=V1,V2,... makes one set per value of each set whose text holds
    /// ${NAME} (in its name too), e.g. `--sweep sigma=0,0.01,0.05` with
    /// `Set(name: "test-noise-${sigma}", …, noise: (colour: [Gaussian(sigma: ${sigma})]))`;
    /// --map and --test names expand the same way (`--test 'test-noise-${sigma}'`). Repeat
    /// for several sweeps.
    #[arg(long, value_parser = Sweep::parse, value_name = "NAME=V1,V2,...")]
    pub sweep: Vec<Sweep>,
    /// With a spec: the renderer of its sets.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: BackendArg,
    /// The map set; repeat to compare maps (e.g. grids of different steps).
    #[arg(long, required = true)]
    pub map: Vec<String>,
    /// The test sets, each localized against each map.
    #[arg(long, required = true, num_args = 1..)]
    pub test: Vec<String>,
    /// A descriptor and its settings, NAME[:KEY=VALUE,...]; repeat for several.
    #[arg(long = "descriptor", short = 'd', value_parser = NamedSettings::parse)]
    pub descriptors: Vec<NamedSettings>,
    /// Distances between descriptors, comma-separated: l1, l2, cosine, correlation.
    #[arg(long, value_delimiter = ',', default_value = "l1,l2,cosine,correlation", value_parser = parse_distance)]
    pub distance: Vec<Distance>,
    /// Also position each test image at the 1/distance-weighted mean of its K nearest map
    /// images (1: the nearest only).
    #[arg(long, default_value_t = 1, value_name = "K")]
    pub neighbours: usize,
    /// The distance the charts draw.
    #[arg(long, default_value = "l1", value_parser = parse_distance)]
    pub chart_distance: Distance,
    #[command(flatten)]
    pub view: PanoramaArgs,
    /// Output folder (created if missing): report.json, report.svg, report.png, descriptors/.
    #[arg(long)]
    pub out: PathBuf,
}

fn parse_distance(text: &str) -> Result<Distance, String> {
    Distance::parse(text).ok_or_else(|| format!("unknown distance '{text}': give l1, l2, cosine or correlation"))
}

const DEFAULT_DESCRIPTORS: [&str; 5] = ["fourier", "hog", "gist", "radon", "pca"];
/// Coefficients along φ of the Radon transform's turn-free signature, per radial sample
/// (`Radon::signature`), by which places are compared; the transform itself gives the heading.
const RADON_SIGNATURE: usize = 16;
/// The folder of OUT holding the described sets.
const DESCRIPTORS: &str = "descriptors";
/// The folder of OUT holding the sets rendered from a spec, one data set each.
const SETS: &str = "sets";

/// A descriptor as localize uses it: one of describe's, or the panorama's pixels for PCA.
enum Kind {
    Describe(Choice),
    /// Panorama pixels, projected on the map's first `components` axes.
    Pca {
        components: usize,
    },
}

struct Descriptor {
    name: String,
    kind: Kind,
    parameters: Value,
}

impl Descriptor {
    fn reads_panorama(&self) -> bool {
        match &self.kind {
            Kind::Describe(c) => c.reads == Reads::Panorama,
            Kind::Pca { .. } => true,
        }
    }
}

fn descriptors(args: &LocalizeArgs) -> anyhow::Result<Vec<Descriptor>> {
    let given: Vec<NamedSettings> = if args.descriptors.is_empty() {
        DEFAULT_DESCRIPTORS
            .iter()
            .map(|d| NamedSettings::parse(d).map_err(anyhow::Error::msg))
            .collect::<anyhow::Result<_>>()?
    } else {
        args.descriptors.clone()
    };
    let mut out: Vec<Descriptor> = Vec::new();
    for spec in &given {
        if out.iter().any(|d| d.name == spec.name) {
            bail!("--descriptor {} is given twice", spec.name);
        }
        let (kind, parameters) = if spec.name == "pca" {
            spec.check_keys(&["k"])?;
            let components = spec.get("k", 20usize)?;
            if components == 0 {
                bail!("--descriptor pca: k must be at least 1");
            }
            (
                Kind::Pca { components },
                json!({ "k": components, "of": "the panorama's grey pixels" }),
            )
        } else {
            let choice = choose(spec)?;
            let parameters = choice.parameters.clone();
            (Kind::Describe(choice), parameters)
        };
        out.push(Descriptor {
            name: spec.name.clone(),
            kind,
            parameters,
        });
    }
    Ok(out)
}

/// One set as read: its images and the poses the manifest gives.
struct SetData {
    name: String,
    images: InputSet,
    poses: Vec<PlanarPose>,
    noisy: bool,
    record: SetRecord,
    /// SHA-256 of each image read, from the manifest: the cache's key.
    hashes: Vec<String>,
}

/// σ of a set's Gaussian colour noise (the Gaussian terms added in quadrature; 0 without).
fn noise_sigma(set: &ManifestSet) -> f64 {
    set.set
        .noise
        .colour
        .iter()
        .map(|n| match n {
            ColourNoise::Gaussian { sigma } => sigma * sigma,
            _ => 0.0,
        })
        .fold(0.0, |sum, v| sum + v) // not `sum`: an empty f64 sum is −0
        .sqrt()
}

/// Mean distance from each pose to its nearest other pose, metres (the step of a grid).
fn spacing(poses: &[PlanarPose]) -> Option<f64> {
    if poses.len() < 2 {
        return None;
    }
    let nearest = |p: &PlanarPose| {
        poses
            .iter()
            .filter(|q| !std::ptr::eq(*q, p))
            .map(|q| (p.x - q.x).hypot(p.y - q.y))
            .fold(f64::INFINITY, f64::min)
    };
    Some(poses.iter().map(nearest).sum::<f64>() / poses.len() as f64)
}

/// The sets named by --map and --test, with the sweeps' values put in.
struct Roles {
    map: Vec<String>,
    test: Vec<String>,
}

/// Whether `name` is one plain folder name (a set's name becomes a folder under --out).
fn plain_folder_name(name: &str) -> bool {
    matches!(
        Path::new(name).components().collect::<Vec<_>>()[..],
        [std::path::Component::Normal(_)]
    )
}

/// The fraction of a frame's pixels that see something which its own occluders cover, counted
/// in its object-id image; `None` where the data set has none (rendered without segmentation).
fn occluded_fraction(folder: &Path, entry: &FrameEntry) -> anyhow::Result<Option<f64>> {
    let Some(file) = entry
        .files
        .iter()
        .find(|f| f.kind == FileKind::GroundTruth && f.path.ends_with("-object.png"))
    else {
        return Ok(None);
    };
    let ids: Vec<u64> = entry.perturbations["occluders"].as_array().map_or_else(Vec::new, |o| {
        o.iter().filter_map(|o| o["segment"]["id"].as_u64()).collect()
    });
    let path = folder.join(&file.path);
    let objects = image::open(&path)
        .with_context(|| format!("cannot read the object-id image {}", path.display()))?
        .into_luma16();
    let (mut seen, mut covered) = (0usize, 0usize);
    for &image::Luma([id]) in objects.pixels() {
        if id != 0 {
            seen += 1;
            covered += usize::from(ids.contains(&u64::from(id)));
        }
    }
    Ok(Some(covered as f64 / seen.max(1) as f64))
}

/// Reads the sets of `roles` from the first of `datasets` (folder, manifest) that has each.
fn read_sets(roles: &Roles, datasets: &[(PathBuf, Manifest)]) -> anyhow::Result<(Vec<SetData>, omnisim::Camera)> {
    let mut names: Vec<(&str, &str)> = Vec::new();
    let mut seen: Vec<(&str, &str)> = Vec::new();
    for (name, role) in roles
        .map
        .iter()
        .map(|m| (m.as_str(), "map"))
        .chain(roles.test.iter().map(|t| (t.as_str(), "test")))
    {
        if seen.contains(&(name, role)) {
            bail!("--{role} {name} is given twice");
        }
        seen.push((name, role));
        // A map can be its own test set (ideal conditions): read once, as a map.
        if !names.iter().any(|(n, _)| *n == name) {
            names.push((name, role));
        }
    }
    let mut out = Vec::new();
    let mut camera = None;
    for (name, role) in names {
        let Some((folder, set)) = datasets
            .iter()
            .find_map(|(folder, m)| Some((folder, m.sets.iter().find(|s| s.set.name == name)?)))
        else {
            let have: Vec<&str> = datasets
                .iter()
                .flat_map(|(_, m)| m.sets.iter().map(|s| s.set.name.as_str()))
                .collect();
            bail!("the data set has no set '{name}' (--{role}); it has {have:?}");
        };
        // The name becomes a folder under --out (the descriptor cache): one plain name only.
        if !plain_folder_name(name) {
            bail!("the manifest's set name {name:?} is not a plain folder name; was manifest.json edited?");
        }
        let sigma = noise_sigma(set);
        let noisy = role == "test" && !set.set.noise.colour.is_empty();
        let input = InputArgs::dataset(folder.clone(), vec![name.to_string()], noisy).read()?;
        if *camera.get_or_insert(input.camera.clone()) != input.camera {
            bail!("set '{name}' was rendered with another camera than the sets before it");
        }
        let images = input.sets.into_iter().next().context("the set was read")?;
        let kind = if noisy { FileKind::Noisy } else { FileKind::GroundTruth };
        let mut poses = Vec::new();
        let mut hashes = Vec::new();
        let mut occluders = 0usize;
        let mut occluded = Some(0.0);
        for (frame, entry) in images.frames.iter().zip(&set.frame_entries) {
            let [x, y, _] = entry.pose.position;
            poses.push(PlanarPose {
                x,
                y,
                yaw: entry.pose.angles_deg[2].to_radians(),
            });
            let file = entry
                .files
                .iter()
                .find(|f| f.kind == kind && frame.path.ends_with(&f.path))
                .with_context(|| format!("set '{name}' frame {}: its image is not in the manifest", entry.index))?;
            hashes.push(file.sha256.clone());
            occluders += entry.perturbations["occluders"].as_array().map_or(0, Vec::len);
            occluded = match (occluded, occluded_fraction(folder, entry)?) {
                (Some(sum), Some(fraction)) => Some(sum + fraction),
                _ => None,
            };
        }
        if images.frames.is_empty() {
            bail!("set '{name}' has no images");
        }
        let frames = images.frames.len();
        out.push(SetData {
            name: name.to_string(),
            record: SetRecord {
                name: name.to_string(),
                roles: [("map", &roles.map), ("test", &roles.test)]
                    .into_iter()
                    .filter(|(_, names)| names.iter().any(|n| n == name))
                    .map(|(role, _)| role.to_string())
                    .collect(),
                frames,
                noise_sigma: sigma,
                occluders_per_frame: occluders as f64 / frames as f64,
                occluded_fraction: occluded.map(|sum| sum / frames as f64),
                spacing_m: if role == "map" { spacing(&poses) } else { None },
            },
            images,
            poses,
            noisy,
            hashes,
        });
    }
    Ok((out, camera.context("no set was read")?))
}

/// One set described by one descriptor: rows, what gives the heading, seconds per image.
struct Rows {
    rows: Vec<Vec<f32>>,
    /// Fourier: phases (same shape as the rows); Radon: nothing more (the rows are the transform).
    phases: Option<Vec<Vec<f32>>>,
    /// Local features (SIFT, SURF), one per image; described on every run (not cached).
    features: Vec<Features>,
    shape: Vec<usize>,
    seconds: f64,
}

/// The cache key of a set described by a descriptor: its settings, the panorama and every
/// image's SHA-256.
fn cache_key(descriptor: &Descriptor, panorama: &Value, set: &SetData) -> String {
    let key = json!({
        "descriptor": descriptor.name, "parameters": descriptor.parameters,
        "panorama": if descriptor.reads_panorama() { panorama.clone() } else { Value::Null },
        "noisy": set.noisy, "images": set.hashes, "version": env!("CARGO_PKG_VERSION"),
    });
    sha256_hex(key.to_string().as_bytes())
}

/// What the cache keeps beside the .npy files.
#[derive(serde::Serialize, serde::Deserialize)]
struct CacheRecord {
    key: String,
    shape: Vec<usize>,
    seconds_per_image: f64,
    /// SHA-256 of the values' file and of the phases' file where there is one, as written: a
    /// file edited or damaged since (NaN written over its values, say) is described again.
    values_sha256: String,
    phases_sha256: Option<String>,
}

fn cache_files(out: &Path, set: &str, name: &str) -> (PathBuf, PathBuf, PathBuf) {
    let folder = out.join(DESCRIPTORS).join(set);
    (
        folder.join(format!("{name}.npy")),
        folder.join(format!("{name}-phases.npy")),
        folder.join(format!("{name}.json")),
    )
}

/// The cached rows of `images` images, or `None` (describe again) where the record, the values
/// or a phases file that exists do not agree with each other and with the set: a stale or
/// edited cache is never trusted.
fn load_cached(out: &Path, set: &str, name: &str, key: &str, images: usize) -> Option<Rows> {
    let (values, phases, record) = cache_files(out, set, name);
    let record: CacheRecord = serde_json::from_slice(&std::fs::read(record).ok()?).ok()?;
    if record.key != key {
        return None;
    }
    let (shape, data) = npy::read(&values).ok()?;
    let unchanged = |path: &Path, sha256: &str| hash_file(path).is_ok_and(|(_, hash)| hash == sha256);
    if !unchanged(&values, &record.values_sha256) {
        return None;
    }
    let agrees = |shape: &[usize]| shape.first() == Some(&images) && shape[1..] == record.shape[..];
    if !agrees(&shape) || record.shape.contains(&0) {
        return None;
    }
    let length: usize = shape.iter().skip(1).product();
    let rows_of = |data: Vec<f32>| -> Vec<Vec<f32>> { data.chunks(length).map(<[f32]>::to_vec).collect() };
    let phases = match npy::read(&phases) {
        Ok((s, p))
            if s == shape
                && record
                    .phases_sha256
                    .as_ref()
                    .is_some_and(|hash| unchanged(&phases, hash)) =>
        {
            Some(rows_of(p))
        }
        Ok(_) => return None,
        Err(_) if phases.exists() => return None,
        Err(_) => None,
    };
    Some(Rows {
        rows: rows_of(data),
        phases,
        features: Vec::new(),
        shape: record.shape,
        seconds: record.seconds_per_image,
    })
}

fn store(out: &Path, set: &str, name: &str, key: &str, rows: &Rows) -> anyhow::Result<()> {
    let (values, phases, record) = cache_files(out, set, name);
    let folder = out.join(DESCRIPTORS).join(set);
    create_real_folder(out, &out.join(DESCRIPTORS))?;
    create_real_folder(out, &folder)?;
    let full: Vec<usize> = std::iter::once(rows.rows.len())
        .chain(rows.shape.iter().copied())
        .collect();
    npy::write(&values, &full, &rows.rows.concat())?;
    if let Some(p) = &rows.phases {
        npy::write(&phases, &full, &p.concat())?;
    }
    let text = serde_json::to_vec_pretty(&CacheRecord {
        key: key.to_string(),
        shape: rows.shape.clone(),
        seconds_per_image: rows.seconds,
        values_sha256: hash_file(&values)?.1,
        phases_sha256: rows
            .phases
            .as_ref()
            .map(|_| hash_file(&phases))
            .transpose()?
            .map(|(_, hash)| hash),
    })?;
    write_atomically(&record, |w| w.write_all(&text)).with_context(|| format!("cannot write {}", record.display()))
}

/// Frames described at once between progress reports.
const FRAMES_PER_BATCH: usize = 32;

/// One frame described by one descriptor, and the seconds it took (with the panorama's, for
/// descriptors that read it).
struct FrameDescribed {
    values: Described,
    seconds: f64,
}

/// The image at `path` described by each of `descriptors[chosen]`.
fn describe_frame(
    path: &Path,
    size: (usize, usize),
    panorama: Option<&Panorama>,
    descriptors: &[Descriptor],
    chosen: &[usize],
) -> anyhow::Result<Vec<FrameDescribed>> {
    let image = read_image(path, Some(size))?;
    let grey = image.to_grey();
    let pano = (panorama.map(|p| p.of(&grey)).transpose())
        .with_context(|| format!("cannot make the panorama of {}", path.display()))?;
    chosen
        .iter()
        .map(|&i| {
            let d = &descriptors[i];
            let clock = Instant::now();
            let values = match &d.kind {
                Kind::Pca { .. } => {
                    let (p, _) = pano.as_ref().context("the panorama")?;
                    Described::Values {
                        shape: vec![p.height, p.width],
                        values: p.data.clone(),
                        phases: None,
                    }
                }
                Kind::Describe(choice) => choice
                    .describe(choice.source(&image, &grey, pano.as_ref().map(|p| &p.0)))
                    .with_context(|| format!("{} of {}", d.name, path.display()))?,
            };
            let panorama_seconds = match &pano {
                Some((_, Some(seconds))) if d.reads_panorama() => *seconds,
                _ => 0.0,
            };
            Ok(FrameDescribed {
                values,
                seconds: clock.elapsed().as_secs_f64() + panorama_seconds,
            })
        })
        .collect()
}

/// Describes every set by every descriptor, from the cache where its key matches.
fn describe_sets(
    args: &LocalizeArgs,
    sets: &[SetData],
    descriptors: &[Descriptor],
    panorama: Option<&Panorama>,
    image_size: (usize, usize),
) -> anyhow::Result<Vec<Vec<Rows>>> {
    let panorama_record = panorama.map_or(Value::Null, |p| p.sidecar.clone());
    let mut progress = Progress::new("images");
    let total: usize = sets.iter().map(|s| s.images.frames.len()).sum();
    let mut done = 0;
    let mut all = Vec::new();
    for set in sets {
        let keys: Vec<String> = descriptors
            .iter()
            .map(|d| cache_key(d, &panorama_record, set))
            .collect();
        let mut per: Vec<Option<Rows>> = descriptors
            .iter()
            .zip(&keys)
            .map(|(d, key)| load_cached(&args.out, &set.name, &d.name, key, set.images.frames.len()))
            .collect();
        let missing: Vec<usize> = (0..descriptors.len()).filter(|&i| per[i].is_none()).collect();
        if missing.is_empty() {
            done += set.images.frames.len();
            crate::streams::stderr(format_args!("set '{}': every descriptor from {DESCRIPTORS}/", set.name))?;
            all.push(per.into_iter().flatten().collect());
            continue;
        }
        let mut fresh: Vec<Rows> = missing
            .iter()
            .map(|_| Rows {
                rows: Vec::new(),
                phases: None,
                features: Vec::new(),
                shape: Vec::new(),
                seconds: 0.0,
            })
            .collect();
        // Frames in parallel (rayon's pool, one thread per core), a batch at a time so that
        // progress is reported and the frames' results join in order.
        for batch in set.images.frames.chunks(FRAMES_PER_BATCH) {
            let described: Vec<Vec<FrameDescribed>> = batch
                .par_iter()
                .map(|frame| describe_frame(&frame.path, image_size, panorama, descriptors, &missing))
                .collect::<anyhow::Result<_>>()?;
            for frame in described {
                for (rows, one) in fresh.iter_mut().zip(frame) {
                    rows.seconds += one.seconds;
                    match one.values {
                        Described::Values { shape, values, phases } => {
                            rows.rows.push(values);
                            if let Some(p) = phases {
                                rows.phases.get_or_insert_with(Vec::new).push(p);
                            }
                            rows.shape = shape;
                        }
                        Described::Features(features) => {
                            rows.features.push(features);
                            rows.rows.push(Vec::new());
                        }
                    }
                }
            }
            done += batch.len();
            progress.step(done, total, false, &set.name)?;
        }
        for (&i, mut rows) in missing.iter().zip(fresh) {
            rows.seconds /= rows.rows.len().max(1) as f64;
            if rows.features.is_empty() {
                store(&args.out, &set.name, &descriptors[i].name, &keys[i], &rows)?;
            }
            per[i] = Some(rows);
        }
        all.push(per.into_iter().flatten().collect());
    }
    progress.finish();
    Ok(all)
}

/// A set's rows and heading data for the localizer, projected with `pca` where given.
fn prepare(descriptor: &Descriptor, rows: &Rows, pca: Option<&Pca>, view_width: usize) -> anyhow::Result<SetDescribed> {
    let heading = match (&descriptor.kind, &rows.phases) {
        (Kind::Describe(c), Some(phases)) if matches!(c.method, Method::Fourier(_)) => {
            let [height, k] = rows.shape[..] else {
                bail!("a Fourier signature of shape {:?}", rows.shape);
            };
            Some(Heading::Fourier(
                rows.rows
                    .iter()
                    .zip(phases)
                    .map(|(m, p)| FourierSignature {
                        rows: height,
                        coefficients: k,
                        width: view_width,
                        values: m
                            .iter()
                            .zip(p)
                            .map(|(&m, &p)| omnisim_vision::fft::C64::from_polar(f64::from(m), f64::from(p)))
                            .collect(),
                    })
                    .collect(),
            ))
        }
        (
            Kind::Describe(Choice {
                method: Method::Radon(p),
                ..
            }),
            _,
        ) => {
            let radial_step = p.radial_step;
            let [angles, radial] = rows.shape[..] else {
                bail!("a Radon descriptor of shape {:?}", rows.shape);
            };
            Some(Heading::Radon(
                rows.rows
                    .iter()
                    .map(|r| {
                        Ok(Radon {
                            values: Raster::from_vec(radial, angles, 1, r.clone())?,
                            radial_step,
                        })
                    })
                    .collect::<anyhow::Result<_>>()?,
            ))
        }
        _ => None,
    };
    let rows = match (pca, &heading) {
        (Some(pca), _) => rows
            .rows
            .iter()
            .map(|r| pca.project(r, pca.components()))
            .collect::<Result<_, _>>()?,
        // The transform turns with the image: places are compared by its turn-free signature.
        (None, Some(Heading::Radon(transforms))) => transforms
            .iter()
            .map(|r| r.signature(RADON_SIGNATURE.min(r.values.height / 2 + 1)))
            .collect::<Result<_, _>>()?,
        (None, _) => rows.rows.clone(),
    };
    Ok(SetDescribed { rows, heading })
}

/// Seconds to describe one image with descriptor `d`, over map `m` and test set `t`.
fn describe_seconds(sets: &[SetData], described: &[Vec<Rows>], m: usize, t: usize, d: usize) -> f64 {
    let (nm, nt) = (sets[m].images.frames.len() as f64, sets[t].images.frames.len() as f64);
    (described[m][d].seconds * nm + described[t][d].seconds * nt) / (nm + nt)
}

/// Lowe's ratio for local features' matches.
const RATIO: f32 = 0.8;

/// Every test set localized against map `m` by local features `d`: retrieval by the count of
/// ratio-test matches.
fn localize_features(
    args: &LocalizeArgs,
    camera: &omnisim::Camera,
    sets: &[SetData],
    described: &[Vec<Rows>],
    (m, d): (usize, usize),
    tests: &[usize],
    name: &str,
) -> anyhow::Result<Vec<ResultRecord>> {
    let map = &described[m][d].features;
    let bytes = map
        .iter()
        .map(|f| 4 * (f.descriptors.len() + 5 * f.keypoints.len()))
        .sum::<usize>()
        / map.len().max(1);
    let neighbour_counts: Vec<usize> = if args.neighbours > 1 {
        vec![1, args.neighbours]
    } else {
        vec![1]
    };
    let mut out = Vec::new();
    for &t in tests {
        for &neighbours in &neighbour_counts {
            let clock = Instant::now();
            let test = &described[t][d].features;
            let mut retrieved = localize::localize_by_matches(map, &sets[m].poses, test, RATIO, neighbours)?;
            if camera.is_central() {
                let bearing = |x: f32, y: f32| {
                    camera
                        .ray(omnisim::glam::DVec2::new(f64::from(x), f64::from(y)))
                        .map(|ray| ray.direction)
                };
                localize::add_feature_headings(&mut retrieved, map, &sets[m].poses, test, &bearing);
            }
            let estimates: Vec<localize::Estimate> = retrieved.into_iter().map(|r| r.estimate).collect();
            let matching = clock.elapsed().as_secs_f64() / estimates.len().max(1) as f64;
            let scores = localize::score(&estimates, &sets[t].poses);
            let case = Case {
                map: &sets[m].name,
                test: &sets[t].name,
                descriptor: name,
                distance: LOCAL_FEATURES,
                neighbours,
                heading: camera.is_central().then_some(localize::FEATURE_HEADING),
            };
            let timing = Timing {
                describe: describe_seconds(sets, described, m, t, d),
                matching,
            };
            out.extend(ResultRecord::new(&case, &estimates, &scores, timing, bytes));
        }
    }
    Ok(out)
}

/// The sets of the spec `args.dataset` that `roles` name, expanded over the sweeps and rendered
/// into OUT/sets/<set>/ where not already there: each (folder, manifest), and the spec's SHA-256.
fn render_spec(args: &LocalizeArgs, roles: &Roles) -> anyhow::Result<(Vec<(PathBuf, Manifest)>, String)> {
    let text = omnisim::input::read_text(&args.dataset, omnisim::input::SCENE_LIMIT)?;
    let specs = sweep::sets(&text, &args.dataset, &args.sweep)?;
    let names: Vec<String> = roles.map.iter().chain(&roles.test).cloned().collect();
    if let Some(bad) = names.iter().find(|n| !plain_folder_name(n)) {
        bail!("set name {bad:?} is not a plain folder name");
    }
    create_real_folder(&args.out, &args.out)?;
    let renderer = omnisim::Renderer::new(args.backend.into())?;
    let folders = sweep::render(&args.dataset, &specs, &names, &args.out.join(SETS), &renderer)?;
    let datasets = folders
        .into_values()
        .map(|folder| {
            let manifest = Manifest::read(&folder.join("manifest.json"))
                .with_context(|| format!("the data set rendered into {}", folder.display()))?;
            Ok((folder, manifest))
        })
        .collect::<anyhow::Result<_>>()?;
    Ok((datasets, sha256_hex(text.as_bytes())))
}

pub(crate) fn run(args: &LocalizeArgs) -> anyhow::Result<()> {
    if args.neighbours == 0 {
        bail!("--neighbours must be at least 1");
    }
    let started = Instant::now();
    let descriptors = descriptors(args)?;
    let roles = Roles {
        map: sweep::expand_names(&args.map, &args.sweep),
        test: sweep::expand_names(&args.test, &args.sweep),
    };
    let (datasets, spec_sha256) = if args.dataset.is_file() {
        render_spec(args, &roles)?
    } else {
        if !args.sweep.is_empty() {
            bail!(
                "--sweep needs a data-set spec (.ron), not the data-set folder {}",
                args.dataset.display()
            );
        }
        let manifest = Manifest::read(&args.dataset.join("manifest.json")).with_context(|| {
            format!(
                "{} is not a data set written by `omnisim dataset` (no readable manifest.json) nor a spec file",
                args.dataset.display()
            )
        })?;
        let hash = manifest.spec_sha256.clone();
        (vec![(args.dataset.clone(), manifest)], hash)
    };
    let manifest = &datasets.first().context("no data set")?.1;
    let (sets, camera) = read_sets(&roles, &datasets)?;
    let panorama = Panorama::new(&camera, &args.view, descriptors.iter().any(Descriptor::reads_panorama))?;
    let (w, h) = camera.size();
    let image_size = (w as usize, h as usize);
    let view_size = panorama.as_ref().map_or(image_size, |p| p.size(image_size));
    let mut descriptors = descriptors;
    for d in &mut descriptors {
        if let Kind::Describe(choice) = &mut d.kind {
            if let (Method::Radon(p), omnisim::Camera::Catadioptric(omni)) = (&mut choice.method, &camera) {
                p.centre = Some((omni.cx, omni.cy));
                d.parameters["centre_px"] = json!({ "u": omni.cx, "v": omni.cy });
            }
            let size = if choice.reads == Reads::Panorama {
                view_size
            } else {
                image_size
            };
            choice.method.fits(Some(size)).with_context(|| {
                format!(
                    "--descriptor {} on the {}×{} {}",
                    d.name,
                    size.0,
                    size.1,
                    choice.reads.name()
                )
            })?;
        }
    }
    create_real_folder(&args.out, &args.out)?;
    let described = describe_sets(args, &sets, &descriptors, panorama.as_ref(), image_size)?;
    let maps: Vec<usize> = roles
        .map
        .iter()
        .filter_map(|m| sets.iter().position(|s| &s.name == m))
        .collect();
    let tests: Vec<usize> = roles
        .test
        .iter()
        .filter_map(|t| sets.iter().position(|s| &s.name == t))
        .collect();
    // A set is prepared once for every map that it meets, except under PCA, whose projection
    // is the map's.
    let mut prepared: BTreeMap<(usize, usize), Rc<SetDescribed>> = BTreeMap::new();
    let mut prepare_once = |set: usize, d: usize, pca: Option<&Pca>| -> anyhow::Result<Rc<SetDescribed>> {
        if let (None, Some(done)) = (pca, prepared.get(&(set, d))) {
            return Ok(done.clone());
        }
        let done = Rc::new(prepare(&descriptors[d], &described[set][d], pca, view_size.0)?);
        if pca.is_none() {
            prepared.insert((set, d), done.clone());
        }
        Ok(done)
    };
    let mut results = Vec::new();
    for &m in &maps {
        for (d, descriptor) in descriptors.iter().enumerate() {
            let pca = match descriptor.kind {
                Kind::Pca { components } => {
                    let fitted = Pca::fit(&described[m][d].rows, components)
                        .with_context(|| format!("PCA of set '{}'", sets[m].name))?;
                    Some(fitted)
                }
                Kind::Describe(_) => None,
            };
            if !described[m][d].features.is_empty() {
                results.extend(localize_features(
                    args,
                    &camera,
                    &sets,
                    &described,
                    (m, d),
                    &tests,
                    &descriptor.name,
                )?);
                continue;
            }
            let map = prepare_once(m, d, pca.as_ref())?;
            // What a map image keeps: the compared values, and the phases or transform the
            // heading needs.
            let heading_values = match &map.heading {
                Some(Heading::Fourier(_)) => described[m][d]
                    .phases
                    .as_ref()
                    .and_then(|p| p.first())
                    .map_or(0, Vec::len),
                Some(Heading::Radon(_)) => described[m][d].rows.first().map_or(0, Vec::len),
                None => 0,
            };
            let bytes = 4 * (map.rows.first().map_or(0, Vec::len) + heading_values);
            for &t in &tests {
                let test = prepare_once(t, d, pca.as_ref())?;
                let truth = &sets[t].poses;
                let neighbour_counts: Vec<usize> = if args.neighbours > 1 {
                    vec![1, args.neighbours]
                } else {
                    vec![1]
                };
                for &distance in &args.distance {
                    for &neighbours in &neighbour_counts {
                        let clock = Instant::now();
                        let estimates =
                            localize::localize(&map, &sets[m].poses, &test, Localizer { distance, neighbours })?;
                        let matching = clock.elapsed().as_secs_f64() / estimates.len().max(1) as f64;
                        let scores = localize::score(&estimates, truth);
                        let case = Case {
                            map: &sets[m].name,
                            test: &sets[t].name,
                            descriptor: &descriptor.name,
                            distance: distance.name(),
                            neighbours,
                            heading: map.heading.as_ref().map(Heading::name),
                        };
                        let timing = Timing {
                            describe: describe_seconds(&sets, &described, m, t, d),
                            matching,
                        };
                        results.extend(ResultRecord::new(&case, &estimates, &scores, timing, bytes));
                    }
                }
            }
        }
    }
    let settings: BTreeMap<&str, Value> = descriptors
        .iter()
        .map(|d| (d.name.as_str(), d.parameters.clone()))
        .collect();
    let report = Report {
        schema: SCHEMA.to_string(),
        tool: "omnisim".to_string(),
        version: env!("CARGO_PKG_VERSION").to_string(),
        command: crate::run_folder::command_line(),
        dataset: DatasetRecord {
            folder: args.dataset.display().to_string(),
            spec_sha256,
            geometry_sha256: manifest.geometry_sha256.clone(),
            renderer: manifest.renderer.clone(),
            version: manifest.version.clone(),
        },
        settings: json!({
            "descriptors": settings, "panorama": panorama.as_ref().map(|p| p.sidecar.clone()),
            "distances": args.distance, "neighbours": args.neighbours, "chart_distance": args.chart_distance,
            "sweeps": args.sweep.iter().map(|s| (s.name.clone(), s.values.clone())).collect::<BTreeMap<_, _>>(),
        }),
        sets: sets.iter().map(|s| s.record.clone()).collect(),
        results,
    };
    write_report(&args.out, &report, args.chart_distance)?;
    crate::streams::stderr(format_args!(
        "localized {} test set(s) against {} map(s), {} descriptor(s), in {:.1} s: {}",
        tests.len(),
        maps.len(),
        descriptors.len(),
        started.elapsed().as_secs_f64(),
        args.out.join("report.json").display()
    ))?;
    Ok(())
}

fn write_report(out: &Path, report: &Report, distance: Distance) -> anyhow::Result<()> {
    let mut text = serde_json::to_vec_pretty(report)?;
    text.push(b'\n');
    let svg = report.charts(distance);
    let png = omnisim_dataset::preview::rasterise(&svg, None).context("drawing the report's PNG")?;
    for (name, bytes) in [
        ("report.json", &text[..]),
        ("report.svg", svg.as_bytes()),
        ("report.png", &png[..]),
    ] {
        let path = out.join(name);
        write_atomically(&path, |w| w.write_all(bytes)).with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}
