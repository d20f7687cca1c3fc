//! `omnisim render`: images, range and point clouds from one or many poses.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use omnisim::output::{self, atomic::write_atomically, folder::RunFolder};
use omnisim::{BackendChoice, Camera, Plane, Planes, Pose, Renderer, Scene, calibration};

use crate::camera_args::{CameraArgs, Rig};
use crate::metadata::metadata;
use crate::poses::{parse_pose, read_pose_file};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BackendArg {
    /// A hardware GPU if one opens, else the f64 CPU tracer, which also beats software Vulkan
    /// (llvmpipe) on the same cores; the reason is printed.
    Auto,
    /// wgpu compute shaders (f32); fails if no adapter.
    Gpu,
    /// f64 reference tracer on all cores.
    Cpu,
}

impl From<BackendArg> for BackendChoice {
    fn from(b: BackendArg) -> Self {
        match b {
            BackendArg::Auto => BackendChoice::Auto,
            BackendArg::Gpu => BackendChoice::Gpu,
            BackendArg::Cpu => BackendChoice::Cpu,
        }
    }
}

/// Render a scene through a camera from one or more poses.
///
/// For every pose N it writes <scene>-N.png (colour), <scene>-N-range.exr (f32 metres from the
/// ray origin, channel "Y", header quantity "range", +inf = no hit) and <scene>-N.ply (binary
/// coloured point cloud, world frame); pinhole and stereo also -depth.png (TUM: z × 5000, 16
/// bit) and -depth.exr (z, metres); a stereo rig writes -left and -right of each and
/// -disparity.exr. Once per run: calibration-*.yaml (OpenCV and Kalibr, where the model has a standard form),
/// raymap.exr (every pixel's ray in the body frame), poses.txt (TUM: index tx ty tz qx qy qz
/// qw, world_from_body) and render.json (camera, conventions, backend, every pose).
///
/// A folder holds one run: omnisim-run.txt lists the run and its files, a re-run of the same
/// command replaces them, and another run is refused unless --overwrite.
#[derive(Debug, Clone, Args)]
#[command(after_help = "Examples:\n  \
omnisim render scenes/env1.ron --camera omni --pose 1.5,0,0.4,0,0,60 --out out/\n  \
omnisim render scenes/env2.ron --camera omni --poses-file scenes/paper-omni-poses.txt --out out/env2\n  \
omnisim render scenes/env1.ron --camera equirect --size 2048x1024 --pose 0,0,0.4 --out out/pano")]
pub struct RenderArgs {
    /// Scene file (RON), e.g. scenes/env1.ron.
    pub scene: PathBuf,
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Pose x,y,z,θx,θy,θz: viewpoint in metres, rotation R = Rx·Ry·Rz in degrees. Repeatable.
    #[arg(long = "pose", value_parser = parse_pose, allow_hyphen_values = true)]
    pub poses: Vec<Pose>,
    /// File of poses, one "x y z θx θy θz" per line (metres, degrees; # comments).
    #[arg(long)]
    pub poses_file: Option<PathBuf>,
    /// Output folder (created if missing). It holds one run: another run's files there are
    /// refused unless --overwrite; the same command again replaces its own files.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Remove the files of the run already in --out (only those its omnisim-run.txt lists)
    /// before writing; in a folder no run recorded, write anyway.
    #[arg(long)]
    pub overwrite: bool,
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: BackendArg,
    /// Anti-aliased colour: pixels on face edges are traced again with this many stratified
    /// samples (a square: 1, 4, 16, 64) on the same backend; range and points are unchanged.
    #[arg(long, default_value_t = 1, value_parser = parse_square)]
    pub edge_samples: u32,
    /// Skip the PLY point clouds.
    #[arg(long)]
    pub no_ply: bool,
    /// Also write segmentation: <stem>-object.png and <stem>-face.png (16-bit ids, 0 = nothing
    /// hit) and segmentation.json, the legend of object names and ids (the same for every pose).
    #[arg(long)]
    pub segmentation: bool,
    /// Also write <stem>-normal.exr: unit surface normals in the world frame, turned towards
    /// the camera (channels normal.X/Y/Z, NaN where nothing is hit).
    #[arg(long)]
    pub normals: bool,
    /// Also write <stem>-linear.exr: linear colour before sRGB encoding (channels R, G, B; 1.0 =
    /// full scale), for studies of illumination.
    #[arg(long)]
    pub linear: bool,
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    omnisim::input::check_regular(&args.scene, omnisim::input::SCENE_LIMIT)?;
    let rig = args.camera.build()?;
    let views = views(&rig);
    let mut poses = args.poses.clone();
    if let Some(file) = &args.poses_file {
        poses.extend(read_pose_file(file)?);
    }
    if poses.is_empty() {
        bail!("no pose given: add --pose x,y,z,θx,θy,θz (metres, degrees) or --poses-file FILE");
    }
    let scene = Scene::load(&args.scene)?;
    for warning in &scene.warnings {
        eprintln!("warning: {warning}");
    }
    let renderer = Renderer::new(args.backend.into())?;
    let prepared = renderer.prepare(&scene)?;
    eprintln!(
        "scene '{}': {} faces, {} triangles (BVH built in {:.1} ms)",
        scene.name,
        scene.faces.len(),
        prepared.geometry().triangles.len(),
        prepared.geometry().build_time.as_secs_f64() * 1e3
    );
    eprintln!(
        "backend: {} on {} — {}",
        prepared.backend_name(),
        renderer.device_name(),
        prepared.fallback().unwrap_or(renderer.reason())
    );
    crate::warnings::misplaced_poses(&scene, prepared.geometry(), &poses);
    let mut run = crate::run_folder::open(&args, &poses)?;

    let progress = ProgressBar::new(poses.len() as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} poses, {elapsed} elapsed, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut planes = Planes::COLOUR;
    if args.linear {
        planes = planes.with(Plane::LinearColour);
    }
    if args.segmentation {
        planes = planes.with(Plane::Object);
    }
    let mut written = Vec::new();
    let render_started = Instant::now();
    for (index, pose) in poses.iter().enumerate() {
        let stem = format!("{}-{index:04}", scene.file_stem());
        let mut frames = Vec::with_capacity(views.len());
        for (suffix, camera) in &views {
            let frame = renderer
                .render_antialiased(&prepared, camera, pose, planes, args.edge_samples.isqrt())
                .with_context(|| format!("rendering pose {index}"))?;
            crate::warnings::empty_frame(index, suffix, &frame);
            let png = run.claim(format!("{stem}{suffix}.png"))?;
            output::write_png(&png, &frame)?;
            let exr = run.claim(format!("{stem}{suffix}-range.exr"))?;
            output::write_range_exr(&exr, &frame, camera)?;
            written.extend([png, exr]);
            let size = (frame.width, frame.height);
            if let Camera::Pinhole(pinhole) = camera {
                let depth = pinhole.axial_depth(&frame, pose);
                let depth_png = run.claim(format!("{stem}{suffix}-depth.png"))?;
                output::write_tum_depth_png(&depth_png, size, &depth)?;
                let depth_exr = run.claim(format!("{stem}{suffix}-depth.exr"))?;
                output::write_axial_depth_exr(&depth_exr, size, depth)?;
                written.extend([depth_png, depth_exr]);
            }
            if let Some(objects) = frame.object() {
                let object_png = run.claim(format!("{stem}{suffix}-object.png"))?;
                output::write_id_png(&object_png, size, objects)?;
                let face_png = run.claim(format!("{stem}{suffix}-face.png"))?;
                output::write_id_png(&face_png, size, &output::face_ids(&frame))?;
                written.extend([object_png, face_png]);
            }
            if args.normals {
                let normal_exr = run.claim(format!("{stem}{suffix}-normal.exr"))?;
                output::write_normal_exr(&normal_exr, &frame)?;
                written.push(normal_exr);
            }
            if args.linear {
                let linear_exr = run.claim(format!("{stem}{suffix}-linear.exr"))?;
                output::write_linear_exr(&linear_exr, &frame)?;
                written.push(linear_exr);
            }
            if !args.no_ply {
                let ply = run.claim(format!("{stem}{suffix}.ply"))?;
                let comment = format!(
                    "scene {} camera {}{suffix} pose {}",
                    scene.name,
                    camera.model_name(),
                    describe_pose(pose)
                );
                output::write_point_cloud_ply(&ply, &frame, &comment)?;
                written.push(ply);
            }
            frames.push(frame);
        }
        if let Rig::Stereo(stereo) = &rig {
            let disparity = stereo.disparity(&frames[0], pose);
            let path = run.claim(format!("{stem}-disparity.exr"))?;
            output::write_disparity_exr(&path, (frames[0].width, frames[0].height), disparity)?;
            written.push(path);
        }
        progress.inc(1);
    }
    progress.finish_and_clear();
    let render_seconds = render_started.elapsed().as_secs_f64();

    written.extend(write_calibration(&mut run, &rig, &views)?);
    if args.segmentation {
        let legend_path = run.claim("segmentation.json")?;
        let legend = output::SegmentationLegend::of(&scene);
        write_atomically(&legend_path, |out| {
            serde_json::to_writer_pretty(&mut *out, &legend).map_err(std::io::Error::other)
        })
        .with_context(|| format!("cannot write {}", legend_path.display()))?;
        written.push(legend_path);
    }
    let poses_path = run.claim("poses.txt")?;
    write_atomically(&poses_path, |out| {
        use std::io::Write;
        writeln!(
            out,
            "# omnisim poses, TUM format: index tx ty tz qx qy qz qw (world_from_body; metres)"
        )?;
        for (index, pose) in poses.iter().enumerate() {
            let t = pose.position;
            let [qx, qy, qz, qw] = pose.quaternion_xyzw();
            writeln!(out, "{index} {} {} {} {qx} {qy} {qz} {qw}", t.x, t.y, t.z)?;
        }
        Ok(())
    })
    .with_context(|| format!("cannot write {}", poses_path.display()))?;
    let metadata_path = run.claim("render.json")?;
    let metadata = metadata(&scene, &args.scene, &rig, &poses, (&renderer, &prepared));
    write_atomically(&metadata_path, |out| {
        serde_json::to_writer_pretty(&mut *out, &metadata).map_err(std::io::Error::other)
    })
    .with_context(|| format!("cannot write {}", metadata_path.display()))?;
    written.push(poses_path);
    written.push(metadata_path);

    run.finish()?;
    for path in &written {
        crate::stdout::line(path.display())?;
    }
    let (w, h) = views[0].1.size();
    eprintln!(
        "rendered {} pose(s) × {} {}x{} {} image(s) in {:.2} s ({:.1} ms per pose on {}); total {:.2} s",
        poses.len(),
        views.len(),
        w,
        h,
        views[0].1.model_name(),
        render_seconds,
        render_seconds * 1e3 / poses.len() as f64,
        prepared.backend_name(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The images one pose produces: (file-name suffix, camera).
fn views(rig: &Rig) -> Vec<(&'static str, Camera)> {
    match rig {
        Rig::Single(camera) => vec![("", camera.clone())],
        Rig::Stereo(stereo) => {
            let [left, right] = stereo.cameras();
            vec![("-left", Camera::Pinhole(left)), ("-right", Camera::Pinhole(right))]
        }
    }
}

/// Calibration in the formats robotics tools read, and a ray map per view; returns the paths.
fn write_calibration(run: &mut RunFolder, rig: &Rig, views: &[(&'static str, Camera)]) -> anyhow::Result<Vec<PathBuf>> {
    let mut files: Vec<(&str, String)> = Vec::new();
    match rig {
        Rig::Single(Camera::Pinhole(pinhole)) => {
            files.push(("calibration-opencv.yaml", calibration::opencv_pinhole(pinhole)));
            files.push(("calibration-kalibr.yaml", calibration::kalibr_pinhole(pinhole)));
        }
        Rig::Stereo(stereo) => {
            files.push(("calibration-opencv-stereo.yaml", calibration::opencv_stereo(stereo)));
            files.push(("calibration-kalibr.yaml", calibration::kalibr_stereo(stereo)));
        }
        Rig::Single(Camera::Catadioptric(mirror)) => {
            if let (Some(omnidir), Some(kalibr)) =
                (calibration::opencv_omnidir(mirror), calibration::kalibr_omni(mirror))
            {
                files.push(("calibration-opencv-omnidir.yaml", omnidir));
                files.push(("calibration-kalibr.yaml", kalibr));
            }
        }
        Rig::Single(Camera::Equirectangular(_) | Camera::Cylindrical(_)) => {}
    }
    let mut written = Vec::new();
    for (name, text) in files {
        let path = run.claim(name)?;
        write_atomically(&path, |file| std::io::Write::write_all(file, text.as_bytes()))
            .with_context(|| format!("cannot write {}", path.display()))?;
        written.push(path);
    }
    for (suffix, camera) in views {
        let path = run.claim(format!("raymap{suffix}.exr"))?;
        output::write_ray_map_exr(&path, camera)?;
        written.push(path);
    }
    Ok(written)
}

fn parse_square(text: &str) -> Result<u32, String> {
    match text.parse::<u32>() {
        Ok(n) if (1..=1024).contains(&n) && n.isqrt() * n.isqrt() == n => Ok(n),
        _ => Err(format!(
            "'{text}' is not a square number of samples from 1 to 1024 (1, 4, 16, 64, ...)"
        )),
    }
}

fn describe_pose(pose: &Pose) -> String {
    let (t, a) = (pose.position, pose.angles_degrees());
    format!(
        "x={} y={} z={} m, theta_x={} theta_y={} theta_z={} deg",
        t.x, t.y, t.z, a.x, a.y, a.z
    )
}
