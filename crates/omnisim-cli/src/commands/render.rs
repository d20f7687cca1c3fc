//! `omnisim render`: images, range and point clouds from one or many poses.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use omnisim::advanced::CpuTracer;
use omnisim::metadata::BackendMetadata;
use omnisim::output::ExrCompression;
use omnisim::output::FrameTarget;
use omnisim::{BackendChoice, OutputSet, Pose, PreparedScene, RenderMetadata, Renderer, Rig, Scene};

use crate::camera_args::CameraArgs;
use crate::poses::{parse_pose, read_pose_file};
use crate::progress::Progress;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BackendArg {
    /// A hardware GPU if one opens, else the CPU tracer, which also beats software Vulkan
    /// (llvmpipe) on the same cores; the reason is printed.
    Auto,
    /// wgpu compute shaders (f32); fails if no adapter.
    Gpu,
    /// The CPU tracer (--tracer) on all cores.
    Cpu,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TracerArg {
    /// f32 wide BVH and triangle filters, every hit decided and measured in f64: the
    /// reference's faces and ranges, faster.
    Fast,
    /// The fast tracer without AVX2 (portable box tests), for A/B where the CPU has AVX2.
    FastPortable,
    /// The f64 reference tracer (BVH2, f64 test of every triangle reached).
    Reference,
}

impl From<TracerArg> for CpuTracer {
    fn from(t: TracerArg) -> Self {
        match t {
            TracerArg::Fast => CpuTracer::Fast,
            TracerArg::FastPortable => CpuTracer::FastPortable,
            TracerArg::Reference => CpuTracer::Reference,
        }
    }
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
/// -disparity.exr (rectified ideal pinholes only: a pair with --lens or --distortion writes
/// each camera's calibration and the extrinsics instead). Once per run: calibration-*.yaml (OpenCV and Kalibr, where the model has a standard form),
/// raymap-origin.exr and raymap-direction.exr (every pixel's ray in the body frame, R G B = x y z;
/// stereo: raymap-left-origin.exr ...) and raymap-all.exr (both, channels origin.X … direction.Z,
/// for OpenEXR-based tools), poses.txt (TUM: index tx ty tz qx qy qz
/// qw, world_from_body) and render.json (camera, conventions, backend, every pose).
///
/// A folder holds one run: omnisim-run.txt lists the run and its files, a re-run of the same
/// command replaces them, and another run is refused unless --overwrite.
///
/// Memory: a view's frame holds 48 bytes a pixel of hit planes (face, range, f64 point, normal)
/// and 3 of colour, 12 more with --linear and 4 with --segmentation, while the largest copy one
/// writer makes of a plane is alive (range 4, pinhole depth 8, segmentation 8, normals or
/// linear colour 12); a stereo rig holds both views' frames. The default outputs take 55
/// bytes a pixel (100 megapixels: 5.5 GB, and 0.07 GB besides), stereo 110, every output 79;
/// under ulimit -v, each thread's allocator arena also reserves 64 MiB of address space. The
/// scene's textures take 8 bytes a texel and a third more for their mips (a 2048² image 45 MB),
/// counted too; a scene's textures hold at most 2^29 texels. A render that needs more than this process may use (the address space left under ulimit -v,
/// its cgroup's memory.max, RAM and swap) is refused before anything is written.
#[derive(Debug, Clone, Args)]
#[command(after_help = "Examples:\n  \
omnisim render scenes/env1.ron --camera omni --pose 1.5,0,0.4,0,0,60 --out out/\n  \
omnisim render scenes/env2.ron --camera omni --poses-file scenes/paper-omni-poses.txt --out out/env2\n  \
omnisim render scenes/env1.ron --camera equirect --size 2048x1024 --pose 0,0,0.4 --out out/pano\n  \
omnisim render scenes/env1.ron --camera fisheye --lens kannala-brandt --k 0.02,-0.004,0.0001,0 --fov 200 --pose 1.5,0,0.4,0,0,60 --out out/fisheye\n  \
omnisim render scenes/env1.ron --camera fisheye --lens double-sphere --xi=-0.2 --alpha 0.6 --fov 220 --pose 1.5,0,0.4,0,0,60 --out out/ds\n  \
omnisim render scenes/env1.ron --camera pinhole --distortion radtan --dist=-0.3,0.09,0.001,-0.002 --pose 1.5,0,0.4,0,0,60 --out out/radtan")]
pub(crate) struct RenderArgs {
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
    /// Which tracer the CPU backend uses.
    #[arg(long, value_enum, default_value = "fast")]
    pub tracer: TracerArg,
    /// Anti-aliased colour: pixels on face edges are traced again with this many stratified
    /// samples (a square: 1, 4, 16, 64, ... up to 1024) on the same backend; range and points
    /// are unchanged.
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
    /// the camera (channels R, G, B = x, y, z, header quantity "normal"; NaN where nothing is hit).
    #[arg(long)]
    pub normals: bool,
    /// Also write <stem>-linear.exr: linear colour before sRGB encoding (channels R, G, B; 1.0 =
    /// full scale), for studies of illumination.
    #[arg(long)]
    pub linear: bool,
    /// Compression of every per-frame EXR, all lossless: zip is smallest, rle about ten times
    /// faster to write (little smaller than none except on constant areas), none fastest.
    #[arg(long, value_enum, default_value = "zip")]
    pub exr_compression: ExrCompressionArg,
}

/// `--exr-compression` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExrCompressionArg {
    Zip,
    Rle,
    None,
}

impl From<ExrCompressionArg> for ExrCompression {
    fn from(arg: ExrCompressionArg) -> Self {
        match arg {
            ExrCompressionArg::Zip => Self::Zip,
            ExrCompressionArg::Rle => Self::Rle,
            ExrCompressionArg::None => Self::None,
        }
    }
}

pub(crate) fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    omnisim::input::check_regular(&args.scene, omnisim::input::SCENE_LIMIT)?;
    // Refused before any frame is written, not at render.json after them all.
    super::recordable(&args.scene, "render.json records the scene's file")?;
    let rig_spec = args.camera.spec()?;
    let rig = rig_spec.build()?;
    let views = rig.views();
    let mut poses = args.poses.clone();
    if let Some(file) = &args.poses_file {
        poses.extend(read_pose_file(file)?);
    }
    if poses.is_empty() {
        bail!("no pose given: add --pose x,y,z,θx,θy,θz (metres, degrees) or --poses-file FILE");
    }
    let scene = Scene::load(&args.scene)?;
    for warning in &scene.warnings {
        crate::streams::stderr(format_args!("warning: {warning}"))?;
    }
    let outputs = OutputSet {
        point_cloud: !args.no_ply,
        segmentation: args.segmentation,
        normals: args.normals,
        linear: args.linear,
        exr_compression: args.exr_compression.into(),
        ..OutputSet::default()
    };
    outputs
        .check_scene(&scene)
        .map_err(|message| anyhow::anyhow!("--segmentation: {message}"))?;
    check_memory(&outputs, &rig, &scene, args.backend)?;
    // The output folder is checked before the BVH is built: a refused folder says so at once.
    let chosen = format!(
        "edge_samples={} ply={} segmentation={} normals={} linear={}",
        args.edge_samples, !args.no_ply, args.segmentation, args.normals, args.linear
    );
    let identity = crate::run_folder::identity(&args.scene, &rig_spec, &poses, &chosen)?;
    let mut run = crate::run_folder::open(&args.out, &identity, args.overwrite)?;
    let mut renderer = Renderer::new(args.backend.into())?;
    renderer.set_cpu_tracer(args.tracer.into());
    let mut prepared = renderer.prepare(&scene)?;
    crate::streams::stderr(format_args!(
        "scene '{}': {} faces, {} triangles (BVH built in {:.1} ms)",
        scene.name,
        scene.faces.len(),
        prepared.geometry().triangles().len(),
        prepared.geometry().build_time().as_secs_f64() * 1e3
    ))?;
    crate::streams::stderr(format_args!(
        "backend: {} on {} — {}",
        prepared.backend_name(),
        renderer.device_name(),
        prepared.fallback().unwrap_or(renderer.reason())
    ))?;
    crate::warnings::misplaced_poses(&scene, prepared.geometry(), &poses)?;
    for view in &views {
        if let omnisim::Camera::Lens(lens) = &view.camera {
            let (width, height) = lens.size();
            crate::streams::stderr(format_args!(
                "{} lens: {} of {} pixels lie beyond its field of view ({:.2}° off axis) and are background",
                lens.model.name(),
                lens.pixels_without_ray(),
                u64::from(width) * u64::from(height),
                lens.model.max_angle().to_degrees()
            ))?;
        }
    }

    if let Rig::Stereo(stereo) = &rig
        && !stereo.has_disparity()
    {
        crate::streams::stderr(format_args!(
            "stereo pair with a lens: disparity {}",
            omnisim::camera::NO_DISPARITY
        ))?;
    }

    let mut progress = Progress::new("poses");
    let mut metadata = RenderMetadata::new(&scene, &rig, BackendMetadata::of(&renderer, &prepared));
    metadata.rig = Some(rig_spec);
    let render_started = Instant::now();
    let stem = scene.file_stem();
    for (index, pose) in poses.iter().enumerate() {
        let render = |renderer: &Renderer, prepared: &PreparedScene| {
            views
                .iter()
                .map(|view| {
                    let samples = args.edge_samples.isqrt();
                    renderer.render_antialiased(prepared, &view.camera, pose, outputs.planes(), samples)
                })
                .collect::<Result<Vec<_>, _>>()
        };
        // A lost GPU device (a driver reset, a GPU fault): the pose once more on the device
        // opened in its place, which renders the rest with the same bytes (`reopen`). A render
        // folder does not resume, so a long trajectory goes on rather than start again.
        let frames = match render(&renderer, &prepared) {
            Err(lost) if lost.is_device_lost() => match renderer.reopen() {
                Some(fresh) => {
                    crate::streams::stderr(format_args!(
                        "pose {index}: {lost}; rendering it again on the device opened in its place"
                    ))?;
                    prepared = fresh.prepare_with(&scene, prepared.geometry().clone())?;
                    renderer = fresh;
                    render(&renderer, &prepared)
                }
                None => Err(lost),
            },
            other => other,
        }
        .with_context(|| format!("rendering pose {index}"))?;
        for (view, frame) in views.iter().zip(&frames) {
            crate::warnings::empty_frame(index, view.suffix, frame)?;
        }
        let target = FrameTarget {
            scene: &stem,
            index,
            pose,
        };
        metadata.write_frame(&outputs, &mut run, &target, &rig, &frames)?;
        progress.step(index + 1, poses.len(), false, "")?;
    }
    progress.finish();
    let render_seconds = render_started.elapsed().as_secs_f64();

    let run_files = metadata.write_run_files(&outputs, &mut run, &scene, &rig)?;
    run.finish()?;
    let frame_files = metadata.frames.iter().flat_map(|f| &f.files).map(|f| args.out.join(f));
    for path in frame_files.chain(run_files) {
        crate::streams::stdout(path.display())?;
    }
    let camera = &views[0].camera;
    let (w, h) = camera.size();
    crate::streams::stderr(format_args!(
        "rendered {} pose(s) × {} {}x{} {} image(s) in {:.2} s ({:.1} ms per pose on {}); total {:.2} s",
        poses.len(),
        views.len(),
        w,
        h,
        camera.model_name(),
        render_seconds,
        render_seconds * 1e3 / poses.len() as f64,
        prepared.backend_name(),
        started.elapsed().as_secs_f64()
    ))?;
    Ok(())
}

/// Bytes of the BVH built for each face of a mesh, after the scene is loaded: what
/// `SceneBvh::heap_bytes` (`omnisim bench`'s `bvh_bytes`) measures, 210–221 a triangle from 10k
/// to 1 M with triangle groups dense in leaf order (docs/benchmarks.md, 2026-11-27 evening
/// (walk)), rounded up.
const BVH_BYTES_PER_FACE: u64 = 225;

/// Refuses, before the output folder is touched, a render whose frames and writers (and the
/// scene's BVH, still to be built) would not fit the memory this process may use
/// (`memory::check`). A backend that may be the GPU counts the host copy of the texels its
/// upload builds as well.
fn check_memory(outputs: &OutputSet, rig: &Rig, scene: &Scene, backend: BackendArg) -> anyhow::Result<()> {
    let parts = outputs.bytes_per_pixel(rig);
    let per_pixel: usize = parts.iter().map(|(_, bytes)| bytes).sum();
    let (width, height) = rig.first_camera().size();
    // The textures are loaded already: 8 bytes a texel, and their mips (`Texture::bytes`).
    let textures = &scene.surfaces.textures;
    let texture_bytes: u64 = textures.iter().map(|t| t.bytes() as u64).sum();
    // The GPU upload's copy of them on the host (`Texture::gpu_words`, 4 bytes each).
    let upload_bytes = match backend {
        BackendArg::Cpu => 0,
        BackendArg::Auto | BackendArg::Gpu => textures.iter().map(|t| 4 * t.gpu_words() as u64).sum(),
    };
    let besides =
        crate::memory::FIXED_BYTES + scene.faces.len() as u64 * BVH_BYTES_PER_FACE + texture_bytes + upload_bytes;
    let resident = u64::from(width) * u64::from(height) * per_pixel as u64 + besides;
    let parts: Vec<String> = parts.iter().map(|(name, bytes)| format!("{name} {bytes}")).collect();
    let upload_share = if upload_bytes > 0 {
        format!(
            ", {:.1} MB their sRGB copy for the GPU upload",
            upload_bytes as f64 / 1e6
        )
    } else {
        String::new()
    };
    let texture_share = if texture_bytes > 0 {
        format!(
            ", {:.1} MB of it the texels of {} texture(s) with their mips{upload_share}",
            texture_bytes as f64 / 1e6,
            textures.len()
        )
    } else {
        String::new()
    };
    let what = format!(
        "a {width}x{height} render of {} view(s) ({per_pixel} bytes a pixel: {}; and {} MB for the program and \
         scene{texture_share})",
        rig.views().len(),
        parts.join(", "),
        besides / 1_000_000
    );
    let fix = if texture_bytes > 0 {
        format!(
            "{}, or scale the scene's textures down (8 bytes a texel{}, a third more for the mips)",
            crate::memory::SMALLER_RENDER,
            if upload_bytes > 0 {
                " and 4 for the GPU upload"
            } else {
                ""
            }
        )
    } else {
        crate::memory::SMALLER_RENDER.to_string()
    };
    let need = crate::memory::Need {
        resident,
        address_space: crate::memory::address_space(resident),
        loaded: texture_bytes,
        what: &what,
        fix: &fix,
    };
    crate::memory::check(&need, &crate::memory::limits())
}

fn parse_square(text: &str) -> Result<u32, String> {
    match text.parse::<u32>() {
        Ok(n) if (1..=1024).contains(&n) && n.isqrt() * n.isqrt() == n => Ok(n),
        _ => Err(format!(
            "'{text}' is not a square number of samples from 1 to 1024 (1, 4, 16, 64, ...)"
        )),
    }
}
