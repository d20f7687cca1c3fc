//! Tracing: camera rays through the acceleration structure to hit planes, on the CPU.
//!
//! The layers, each importing only those below it: [`triangle`] (the f64 test that decides
//! every hit, and the closest-hit and any-hit steps), [`counts`] (what `omnisim bench`
//! counts), the walks ([`reference`]: the BVH2, f64 end to end, the accuracy yardstick for the
//! GPU path and the fast tracer; `fast/`: the 8-wide BVH with f32 filters and packets), and
//! here the choice between them ([`CpuTracer`]) and the tiling of frames into rays and packets.
//! The BVHs themselves are built in `accel/`; tracing yields hit planes only, which `shade/`
//! turns into colour.

pub(crate) mod counts;
mod fast;
pub(crate) mod ray_table;
pub(crate) mod reference;
pub(crate) mod triangle;

use std::cell::Cell;
use std::mem::MaybeUninit;
use std::ops::Range;

use glam::{DMat3, DVec2, DVec3};
use rayon::prelude::*;

use crate::accel::SceneBvh;
use crate::camera::{Camera, CameraRay};
use crate::frame::{Frame, Pixel};
use crate::pose::Pose;
use counts::{Counter, TraversalCounts};
pub(crate) use fast::{PACKET, ShadowRays};
use ray_table::CentralRay;
#[cfg(target_arch = "x86_64")]
use ray_table::FourRays;
pub use reference::{closest_hit, occluded};
pub use triangle::Hit;

/// Which CPU tracer traces. Both return the same faces and the same f64 ranges and points,
/// ties included: at exactly equal f64 distance (a ray along a shared edge, coincident faces)
/// the lower face id wins in both (`triangle::wins`; `tests/tests/fast_tracer.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CpuTracer {
    /// An 8-wide BVH with f32 box and triangle filters; the f64 test decides every hit (`fast/`).
    #[default]
    Fast,
    /// [`CpuTracer::Fast`] without AVX2 even where the CPU has it: the portable box tests
    /// (two four-lane halves) that machines without AVX2 run; same faces and ranges. For tests
    /// and A/B measurements.
    FastPortable,
    /// The BVH2 with the f64 test of every triangle reached: the yardstick.
    Reference,
}

impl CpuTracer {
    /// What the tracer is, for the user.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Fast => "fast CPU tracer (f32 wide BVH, f64 hits)",
            Self::FastPortable => "fast CPU tracer without AVX2 (f32 wide BVH, f64 hits)",
            Self::Reference => "f64 reference CPU tracer",
        }
    }

    /// Closest hit with t > `t_min` of a ray given relative to `bvh.offset`.
    pub fn closest_hit(self, bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_min: f64) -> Option<Hit> {
        self.closest_hit_counted(bvh, origin, direction, t_min, &mut ())
    }

    fn closest_hit_counted<C: Counter>(
        self,
        bvh: &SceneBvh,
        origin: DVec3,
        direction: DVec3,
        t_min: f64,
        counter: &mut C,
    ) -> Option<Hit> {
        match self {
            Self::Fast => fast::closest_hit(bvh, origin, direction, t_min, counter, false),
            Self::FastPortable => fast::closest_hit(bvh, origin, direction, t_min, counter, true),
            Self::Reference => reference::closest_hit_counted(bvh, origin, direction, t_min, counter),
        }
    }

    /// Whether anything but face `skip_face` lies on the ray strictly between t = 0 and
    /// `t_max` (see [`occluded`]).
    pub fn occluded(self, bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_max: f64, skip_face: u32) -> bool {
        match self {
            Self::Fast => fast::occluded(bvh, origin, direction, t_max, skip_face, false),
            Self::FastPortable => fast::occluded(bvh, origin, direction, t_max, skip_face, true),
            Self::Reference => occluded(bvh, origin, direction, t_max, skip_face),
        }
    }

    /// [`CpuTracer::occluded`] of each ray of `active` in `shadows` (bit r for ray r): the rays
    /// found blocked. The fast tracers walk them as one packet.
    pub(crate) fn occluded_rays(self, bvh: &SceneBvh, shadows: &ShadowRays, active: u64) -> u64 {
        match self {
            Self::Fast | Self::FastPortable => fast::occluded_rays(bvh, shadows, active, self == Self::FastPortable),
            Self::Reference => {
                let mut blocked = 0;
                let mut rest = active;
                while rest != 0 {
                    let r = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    let (origin, direction, _) = shadows.rays[r];
                    if occluded(bvh, origin, direction, shadows.t_max[r], shadows.skip_face[r]) {
                        blocked |= 1 << r;
                    }
                }
                blocked
            }
        }
    }

    /// Traces one frame's hit planes on all CPU threads, with the camera's rays computed for
    /// this frame (what its rays share worked out once: [`Camera::ray_source`]).
    pub fn trace(self, bvh: &SceneBvh, camera: &Camera, pose: &Pose) -> Frame {
        let source = camera.ray_source();
        let rays = FrameRays {
            size: camera.size(),
            shared_origin: source.shared_origin(),
            ray: |index| source.ray(index),
            central: None,
        };
        self.trace_rays(bvh, pose, &rays)
    }

    /// Traces the frame of `rays` on all CPU threads.
    pub(crate) fn trace_rays(
        self,
        bvh: &SceneBvh,
        pose: &Pose,
        rays: &FrameRays<'_, impl Fn(usize) -> Option<CameraRay> + Sync>,
    ) -> Frame {
        let (width, height) = rays.size;
        let pose = LocalPose::new(bvh, pose);
        let local = LocalRays {
            shared_origin: rays.shared_origin.map(|origin| pose.turn_origin(origin)),
            pose,
            ray: &rays.ray,
            central: rays.central,
        };
        // Every pixel is written once, by the thread that traces it, with no fill before: the
        // first touch of a large buffer's pages (fresh from the kernel for every frame, unless
        // the allocator keeps freed memory as the `omnisim` binary asks glibc to) costs about
        // as much as tracing a simple scene, and the threads share it (docs/benchmarks.md,
        // "Interval packets and frame buffers"); a fill of misses first cost env1's omni
        // image a pass over its 3 MB.
        let pixels = width as usize * height as usize;
        let mut hits = Vec::with_capacity(pixels);
        let frame = &mut hits.spare_capacity_mut()[..pixels];
        let row_length = width.max(1) as usize;
        if let Self::Fast | Self::FastPortable = self {
            // Tiles of 8×8 pixels, each traced as one packet (`fast::closest_hits`), whose
            // rays are tested one by one against boxes small against the packet's footprint.
            let portable = self == Self::FastPortable;
            frame
                .par_chunks_mut(row_length * 8)
                .enumerate()
                .for_each(|(band, pixels)| trace_band(bvh, &local, row_length, band, pixels, portable));
        } else {
            frame.par_chunks_mut(row_length).enumerate().for_each(|(row, pixels)| {
                for (column, pixel) in pixels.iter_mut().enumerate() {
                    pixel.write(self.trace_ray(bvh, &local.pose, (local.ray)(row * row_length + column), &mut ()));
                }
            });
        }
        // SAFETY: the loops above wrote each of the first `pixels` entries: the bands (or
        // rows) cover the frame, and a band's tiles cover every pixel of it. A panic in them
        // unwinds past this line, leaving the length 0 (and `Pixel` is `Copy`: nothing to drop).
        unsafe { hits.set_len(pixels) };
        Frame::from_hits(width, height, hits)
    }

    /// Box and triangle tests of one frame's primary rays, summed: what [`CpuTracer::trace`]
    /// does, counted (for `omnisim bench`; `trace` itself counts nothing).
    pub fn count_tests(self, bvh: &SceneBvh, camera: &Camera, pose: &Pose) -> TraversalCounts {
        let (width, height) = camera.size();
        let local = LocalPose::new(bvh, pose);
        let source = camera.ray_source();
        (0..height)
            .into_par_iter()
            .map(|row| {
                let mut counts = TraversalCounts::default();
                for column in 0..width {
                    self.trace_ray(bvh, &local, source.ray_at(column, row), &mut counts);
                }
                counts
            })
            .reduce(TraversalCounts::default, |a, b| a + b)
    }

    /// Traces the camera ray through `pixel` (sub-pixel positions allowed): the hit planes of
    /// that ray, [`Pixel::MISS`] where the pixel has no ray or the ray hits nothing.
    pub(crate) fn trace_pixel(self, bvh: &SceneBvh, camera: &Camera, pose: &LocalPose, pixel: DVec2) -> Pixel {
        self.trace_ray(bvh, pose, camera.ray(pixel), &mut ())
    }

    /// The hit planes of a body-frame camera ray ([`Pixel::MISS`] for none), counted.
    fn trace_ray<C: Counter>(self, bvh: &SceneBvh, pose: &LocalPose, ray: Option<CameraRay>, counter: &mut C) -> Pixel {
        let Some(ray) = ray else {
            return Pixel::MISS;
        };
        let (origin, direction) = pose.ray(&ray);
        let Some(hit) = self.closest_hit_counted(bvh, origin, direction, ray.t_min, counter) else {
            return Pixel::MISS;
        };
        pixel(bvh, origin, direction, hit)
    }
}

/// Traces band `band` (≤ 8 rows of `row_length` pixels, `pixels`) tile by tile with the fast
/// tracer, writing every pixel once: built with AVX2 ([`with_avx2`]) where the CPU has it and
/// the portable path was not asked for: the tile loop (ray table, the pose's f64 turn, the
/// pixel writes) was a quarter of env1's omni frame, in SSE2 code (docs/benchmarks.md).
fn trace_band(
    bvh: &SceneBvh,
    local: &LocalRays<impl Fn(usize) -> Option<CameraRay> + Sync>,
    row_length: usize,
    band: usize,
    pixels: &mut [MaybeUninit<Pixel>],
    portable: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if fast::use_avx2(portable) {
        // SAFETY: the CPU has AVX2 (checked on the line above).
        unsafe {
            with_avx2(
                #[inline(always)]
                || trace_band_in(bvh, local, row_length, band, pixels, false),
            );
        }
        return;
    }
    // The build without AVX2 never turns rays four at a time: the table is not handed over.
    let local = &LocalRays {
        central: None,
        ..*local
    };
    trace_band_in(bvh, local, row_length, band, pixels, portable);
}

/// `work()` compiled with AVX2 (it is inlined here): VEX encoding and wider vectors. The f64
/// results are the same bits: Rust neither fuses `a * b + c` into an FMA nor reorders float
/// operations, whatever the target features.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn with_avx2<R>(work: impl FnOnce() -> R) -> R {
    work()
}

/// [`trace_band`]'s work, `portable` as there: the band's tiles compiled once for rays of a
/// shared origin, turned once a frame, and once for rays of their own origins (non-central
/// mirrors), each turned. A test per ray of which it is cost the equirect 1024² frame ~4
/// instructions a pixel (docs/benchmarks.md, "2026-11-26 afternoon (pixel)").
#[inline(always)]
fn trace_band_in(
    bvh: &SceneBvh,
    local: &LocalRays<impl Fn(usize) -> Option<CameraRay>>,
    row_length: usize,
    band: usize,
    pixels: &mut [MaybeUninit<Pixel>],
    portable: bool,
) {
    let band = (row_length, band);
    if let Some(origin) = local.shared_origin {
        let world_origin = bvh.offset + origin;
        trace_tiles(bvh, local, band, pixels, portable, |_| origin, |_| world_origin);
    } else {
        trace_tiles(
            bvh,
            local,
            band,
            pixels,
            portable,
            |origin| local.pose.turn_origin(origin),
            |origin| bvh.offset + origin,
        );
    }
}

/// [`trace_band_in`]'s tiles, each ray's scene-local origin given by `turn_origin` of its
/// body-frame one, and its world position by `world_origin` of the scene-local one (the
/// shared origin's once a frame: callgrind, docs/benchmarks.md, "2026-11-26 night (small)").
/// Each ray is converted to f32 into `room` as it is turned, and its packet made there in
/// place (docs/benchmarks.md, "2026-11-27 (walk)"). Where the rays are a central table's
/// (`local.central`, which `trace_band` hands over to the AVX2 build only) with their shared
/// origin, its tile rows of eight are turned and converted four rays at a time
/// ([`LocalPose::turn_four`]; docs/benchmarks.md, "2026-11-27 morning (walk)").
#[inline(always)]
fn trace_tiles(
    bvh: &SceneBvh,
    local: &LocalRays<impl Fn(usize) -> Option<CameraRay>>,
    (row_length, band): (usize, usize),
    pixels: &mut [MaybeUninit<Pixel>],
    portable: bool,
    turn_origin: impl Fn(DVec3) -> DVec3,
    world_origin: impl Fn(DVec3) -> DVec3,
) {
    let rows = pixels.len() / row_length;
    // The packet's hits, every entry written by each tile.
    let mut found = [None; PACKET];
    let pose = &local.pose;
    let first_pixel = band * 8 * row_length;
    // The thread's packet room, taken for the band and given back after it (made afresh per
    // band, its ~8 kB were zeroed 32 times a 250² frame: docs/benchmarks.md, "2026-11-27
    // morning (walk)"; once a rayon job, it measured 0.1–0.4 % more, "2026-11-27 (walk)"):
    // each tile's rays kept in f64 and converted to f32 as they are turned, and its packet
    // made from them in place. Every tile sets all it reads, so what a room holds is never
    // read by the next band.
    let mut room = ROOM.take().unwrap_or_default();
    #[cfg(target_arch = "x86_64")]
    let central = local.central.zip(local.shared_origin);
    for column in (0..row_length).step_by(8) {
        // The tile's rows as ranges of the band, walked by plain loops: [`tile`]'s flat
        // iterator cost 15 instructions a ray.
        let (columns, rows_of_tile) = tile_rows(row_length, rows, column);
        let mut active = 0u64;
        let mut r = 0;
        for offsets in rows_of_tile.clone() {
            #[cfg(target_arch = "x86_64")]
            if let Some((entries, origin)) = central
                && offsets.len() == 8
            {
                let row = &entries[first_pixel + offsets.start..][..8];
                for four in [&row[..4], &row[4..]] {
                    // SAFETY: the CPU has AVX2: `local.central` is a table only where
                    // `trace_band` found AVX2 and runs this in `with_avx2` (its other arm
                    // hands over none).
                    unsafe {
                        let rays = pose.turn_four(FourRays::of(four));
                        active |= u64::from(room.set_four(r, origin, &rays)) << r;
                    }
                    r += 4;
                }
                continue;
            }
            for offset in offsets {
                if let Some(ray) = (local.ray)(first_pixel + offset) {
                    room.set(
                        r,
                        turn_origin(ray.origin),
                        pose.turn_direction(ray.direction),
                        ray.t_min,
                    );
                    active |= 1 << r;
                } else {
                    room.clear(r);
                }
                r += 1;
            }
        }
        // A tile at the frame's right or bottom edge has fewer rays: the rest are zero rays.
        for r in r..PACKET {
            room.clear(r);
        }
        // A tile outside the image circle of a mirror or fisheye has no rays.
        match active {
            0 => found = [None; PACKET],
            _ => fast::closest_hits(bvh, active, portable, &mut found, &mut room),
        }
        fetch_faces_ahead(bvh, &found);
        for (offsets, first_ray) in rows_of_tile.zip((0..PACKET).step_by(columns)) {
            let rays_of_row = first_ray..first_ray + columns;
            for ((pixel_out, found), r) in pixels[offsets]
                .iter_mut()
                .zip(&found[rays_of_row.clone()])
                .zip(rays_of_row)
            {
                pixel_out.write(match *found {
                    Some(hit) => {
                        let (origin, direction, _) = room.rays.ray(r);
                        pixel_from(bvh, world_origin(origin), direction, hit)
                    }
                    None => Pixel::MISS,
                });
            }
        }
    }
    ROOM.set(Some(room));
}

thread_local! {
    /// Each thread's packet room between the bands it traces (`trace_tiles`).
    static ROOM: Cell<Option<Box<fast::PacketRoom>>> = const { Cell::new(None) };
}

/// Starts reading the faces and face normals of a tile's hits before [`pixel`] needs them: in
/// a big scene both miss the cache, and read one pixel after another each normal waits for its
/// face id; read here, the ids' loads overlap, and so do the normals' prefetches.
#[inline(always)]
fn fetch_faces_ahead(bvh: &SceneBvh, found: &[Option<Hit>; PACKET]) {
    #[cfg(target_arch = "x86_64")]
    if bvh.face.len() >= FETCH_FACES_FROM {
        for hit in found.iter().flatten() {
            let face = bvh.face[hit.triangle] as usize;
            if let Some(normal) = bvh.face_normals.get(face) {
                use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
                // SAFETY: a prefetch only hints; the address is that of a live normal.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(std::ptr::from_ref(normal).cast::<i8>()) };
            }
        }
    }
}

/// Triangles from which [`fetch_faces_ahead`] reads ahead: below this the BVH's faces and
/// normals stay in cache and the extra pass would only cost.
const FETCH_FACES_FROM: usize = 1 << 16;

/// A frame's body-frame rays: pixel `index`'s ray (row by row) is `ray(index)`, and
/// `shared_origin`, where given, is every ray's origin bit for bit (a central ray table's, a
/// panorama's): it is turned once a frame, and no ray's origin is compared with the last one
/// turned (docs/benchmarks.md, "2026-11-26 afternoon (pixel)").
pub(crate) struct FrameRays<'a, F> {
    pub(crate) size: (u32, u32),
    pub(crate) shared_origin: Option<DVec3>,
    pub(crate) ray: F,
    /// The same rays as a central ray table's entries, where they are (`ray` reads them
    /// too): the tile loop then turns them four at a time (`shared_origin` is the table's).
    pub(crate) central: Option<&'a [CentralRay]>,
}

/// [`FrameRays`] made ready for tracing at one pose: the shared origin, if any, turned into
/// the scene-local frame.
struct LocalRays<'a, F> {
    pose: LocalPose,
    shared_origin: Option<DVec3>,
    ray: &'a F,
    /// [`FrameRays::central`]; `None` in the tile loop's build without AVX2 (`trace_band`).
    #[cfg_attr(
        not(target_arch = "x86_64"),
        expect(dead_code, reason = "only the x86_64 AVX2 tile loop turns four rays at a time")
    )]
    central: Option<&'a [CentralRay]>,
}

/// The pixels of the 8×8 tile at `column` of a band of `rows` ≤ 8 rows of `row_length` pixels,
/// as offsets into the band: ray r of the tile's packet is pixel (column + r % columns, row
/// r / columns), with min(8, `row_length` − column) columns.
pub(crate) fn tile(row_length: usize, rows: usize, column: usize) -> impl Iterator<Item = usize> + Clone {
    tile_rows(row_length, rows, column).1.flatten()
}

/// [`tile`] row by row: its number of columns, and each row's pixels as a range of offsets.
fn tile_rows(row_length: usize, rows: usize, column: usize) -> (usize, impl Iterator<Item = Range<usize>> + Clone) {
    let columns = (row_length - column).min(8);
    let start = move |row| row * row_length + column;
    (columns, (0..rows).map(move |row| start(row)..start(row) + columns))
}

/// The hit planes of `hit` on the ray from `origin` (scene-local) along `direction`.
fn pixel(bvh: &SceneBvh, origin: DVec3, direction: DVec3, hit: Hit) -> Pixel {
    pixel_from(bvh, bvh.offset + origin, direction, hit)
}

/// [`pixel`] of the ray whose origin is at `world_origin` (`bvh.offset` + its scene-local
/// origin, the same bits).
#[inline(always)]
fn pixel_from(bvh: &SceneBvh, world_origin: DVec3, direction: DVec3, hit: Hit) -> Pixel {
    let face = bvh.face[hit.triangle];
    let normal = bvh.face_normals[face as usize];
    Pixel {
        face,
        range: hit.t as f32,
        point: world_origin + hit.t * direction,
        normal: if normal.dot(direction) > 0.0 { -normal } else { normal }.as_vec3(),
    }
}

/// A pose made ready for tracing: rotation, and the viewpoint relative to the BVH's offset.
#[derive(Clone, Copy)]
pub(crate) struct LocalPose {
    world_from_body: DMat3,
    origin: DVec3,
}

impl LocalPose {
    pub(crate) fn new(bvh: &SceneBvh, pose: &Pose) -> Self {
        Self {
            world_from_body: pose.world_from_body_rotation(),
            origin: pose.position - bvh.offset,
        }
    }

    /// A body-frame camera ray as (origin, direction) in the scene-local frame the BVH uses.
    fn ray(&self, ray: &CameraRay) -> (DVec3, DVec3) {
        (self.turn_origin(ray.origin), self.turn_direction(ray.direction))
    }

    /// A body-frame ray origin in the scene-local frame.
    #[inline(always)]
    fn turn_origin(&self, origin: DVec3) -> DVec3 {
        self.origin + self.world_from_body * origin
    }

    /// A body-frame ray direction in the scene-local frame.
    #[inline(always)]
    fn turn_direction(&self, direction: DVec3) -> DVec3 {
        self.world_from_body * direction
    }

    /// [`LocalPose::turn_direction`] of four rays' directions at once, lane by lane the same
    /// products and sums in the same order (glam's `DMat3 * DVec3`: the x, then y, then z
    /// column, no fused multiply-add), so the same bits.
    ///
    /// # Safety
    /// The CPU has AVX2 (this is compiled into the tile loop's AVX2 build, [`with_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn turn_four(&self, rays: FourRays) -> FourRays {
        use std::arch::x86_64::{_mm256_add_pd, _mm256_mul_pd, _mm256_set1_pd};
        let [x, y, z] = rays.direction;
        let m = &self.world_from_body;
        // A loop, not closures, which are compiled without AVX (their intrinsics calls).
        let mut direction = rays.direction;
        for (k, turned) in direction.iter_mut().enumerate() {
            // SAFETY: AVX2 as the caller promises.
            *turned = unsafe {
                let res = _mm256_mul_pd(_mm256_set1_pd(m.x_axis[k]), x);
                let res = _mm256_add_pd(res, _mm256_mul_pd(_mm256_set1_pd(m.y_axis[k]), y));
                _mm256_add_pd(res, _mm256_mul_pd(_mm256_set1_pd(m.z_axis[k]), z))
            };
        }
        FourRays {
            direction,
            t_min: rays.t_min,
        }
    }
}

/// Traces one frame's hit planes with the reference tracer, on all CPU threads.
pub fn trace(bvh: &SceneBvh, camera: &Camera, pose: &Pose) -> Frame {
    CpuTracer::Reference.trace(bvh, camera, pose)
}

/// Scene `name` (say "env1") of the repository's `scenes/` folder, loaded, and its BVH: the
/// geometry the trace tests walk.
#[cfg(test)]
pub(crate) fn test_scene(name: &str) -> (crate::scene::Scene, SceneBvh) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../scenes/{name}.ron"));
    let scene = crate::scene::Scene::load(&path).unwrap();
    let bvh = SceneBvh::build(&scene).unwrap();
    (scene, bvh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    /// Packets of shadow rays give every ray the answer of the f64 test of every triangle
    /// (no BVH), on each tracer: rays from one small patch and from all over the room, towards
    /// one lamp or along one sun direction, some rays left out, each skipping a face of its
    /// own. Packets whose rays are all blocked (a patch behind a wall) end the walk early.
    #[test]
    fn shadow_packets_give_each_rays_own_answer() {
        let (scene, bvh) = test_scene("env2");
        let (lo, hi) = scene.bounds().unwrap();
        let mut rng = StdRng::seed_from_u64(21);
        let point = |rng: &mut StdRng| DVec3::from_array(std::array::from_fn(|k| rng.random_range(lo[k]..hi[k])));
        let (mut blocked_rays, mut rays_cast, mut all_blocked) = (0, 0, 0);
        for _ in 0..300 {
            let patch = rng.random_bool(0.5);
            let centre = point(&mut rng);
            let lamp = point(&mut rng);
            let sun = rng
                .random_bool(0.2)
                .then(|| DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 1.0).normalize());
            let mut shadows = ShadowRays {
                rays: [(DVec3::ZERO, DVec3::X, 0.0); PACKET],
                t_max: [0.0; PACKET],
                skip_face: [0; PACKET],
            };
            for r in 0..PACKET {
                let start = match patch {
                    true => centre + DVec3::from_array(std::array::from_fn(|_| rng.random_range(-0.05..0.05))),
                    false => point(&mut rng),
                } - bvh.offset;
                let (direction, distance) = if let Some(towards) = sun {
                    (towards, f64::INFINITY)
                } else {
                    let offset = lamp - bvh.offset - start;
                    (offset / offset.length(), offset.length())
                };
                shadows.rays[r] = (start, direction, 0.0);
                shadows.t_max[r] = distance;
                shadows.skip_face[r] = rng.random_range(0..scene.faces.len() as u32);
            }
            let active = if rng.random_bool(0.5) {
                u64::MAX
            } else {
                rng.random::<u64>()
            };
            // Blocked: some triangle of another face than the ray skips lies strictly between
            // 0 and its `t_max`, by the f64 test alone.
            let blocked_by_any = |r: usize| {
                let (origin, direction, _) = shadows.rays[r];
                bvh.triangles.iter().enumerate().any(|(triangle, corners)| {
                    bvh.face[triangle] != shadows.skip_face[r]
                        && triangle::intersect(corners, origin, direction)
                            .is_some_and(|t| t > 0.0 && t < shadows.t_max[r])
                })
            };
            let want = (0..PACKET)
                .filter(|&r| active & (1 << r) != 0)
                .filter(|&r| blocked_by_any(r))
                .fold(0u64, |bits, r| bits | 1 << r);
            for tracer in [CpuTracer::Fast, CpuTracer::FastPortable, CpuTracer::Reference] {
                assert_eq!(tracer.occluded_rays(&bvh, &shadows, active), want, "{tracer:?}");
            }
            blocked_rays += want.count_ones();
            rays_cast += active.count_ones();
            all_blocked += usize::from(active != 0 && want == active);
        }
        assert!(
            blocked_rays > rays_cast / 20 && blocked_rays < rays_cast * 19 / 20,
            "{blocked_rays} of {rays_cast} rays blocked: a poor test"
        );
        assert!(all_blocked >= 10, "{all_blocked} packets wholly blocked: a poor test");
    }
}
