//! The CPU tracers: the f64 reference (the accuracy yardstick for the GPU path and the fast
//! tracer) and the choice between it and the fast tracer (`fast/`).
//!
//! The reference's BVH traversal (`traversal.rs`) uses obvhs's f32 boxes (padded in `bvh.rs`,
//! so they cull conservatively); every triangle test and every returned distance is f64. The
//! fast tracer culls more in f32 but decides every hit with the same f64 test. Tracing yields
//! hit planes only; `shading.rs` turns them into colour.

use glam::{DMat3, DVec2, DVec3};
use rayon::prelude::*;

use crate::bvh::SceneBvh;
use crate::camera::{Camera, CameraRay};
use crate::fast;
use crate::frame::{Frame, Pixel};
use crate::pose::Pose;
use crate::traversal::{BoxRay, Counter, TraversalCounts, Visit, traverse};

/// Which CPU tracer traces. Both return the same faces and the same f64 ranges and points;
/// only at exact ties (two faces at the same f64 distance, a ray along a shared edge) may they
/// name different faces (`tests/tests/fast_tracer.rs` counts them).
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
            Self::Reference => closest_hit_counted(bvh, origin, direction, t_min, counter),
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

    /// Traces one frame's hit planes on all CPU threads.
    pub fn trace(self, bvh: &SceneBvh, camera: &Camera, pose: &Pose) -> Frame {
        self.trace_rays(bvh, camera.size(), pose, |index| camera.pixel_ray(index))
    }

    /// Traces a `size` frame whose pixel `index` (row by row) has the body-frame ray
    /// `ray(index)`, on all CPU threads.
    pub(crate) fn trace_rays(
        self,
        bvh: &SceneBvh,
        (width, height): (u32, u32),
        pose: &Pose,
        ray: impl Fn(usize) -> Option<CameraRay> + Sync,
    ) -> Frame {
        let local = LocalPose::new(bvh, pose);
        // Filled on all threads: the first touch of a large buffer's pages (fresh from the
        // kernel for every frame, unless the allocator keeps freed memory as the `omnisim`
        // binary asks glibc to) costs about as much as tracing a simple scene, and the threads
        // share it (docs/benchmarks.md, "Interval packets and frame buffers").
        let mut hits = Vec::new();
        hits.par_extend(rayon::iter::repeat_n(Pixel::MISS, width as usize * height as usize));
        let row_length = width.max(1) as usize;
        if let Self::Fast | Self::FastPortable = self {
            // Tiles of 8×8 pixels traced as one packet each (`fast::closest_hits`).
            hits.par_chunks_mut(row_length * 8)
                .enumerate()
                .for_each(|(band, pixels)| {
                    let rows = pixels.len() / row_length;
                    for column in (0..row_length).step_by(8) {
                        let columns = (row_length - column).min(8);
                        let mut rays = [(DVec3::ZERO, DVec3::X, 0.0); fast::PACKET];
                        let mut active = 0u64;
                        // Ray r of the packet is pixel (column + r % columns, row r / columns).
                        let tile = (0..rows).flat_map(|row| (0..columns).map(move |c| row * row_length + column + c));
                        for (r, offset) in tile.clone().enumerate() {
                            if let Some(ray) = ray(band * 8 * row_length + offset) {
                                let (origin, direction) = local.ray(&ray);
                                rays[r] = (origin, direction, ray.t_min);
                                active |= 1 << r;
                            }
                        }
                        let found = fast::closest_hits(bvh, &rays, active, self == Self::FastPortable);
                        for (r, offset) in tile.enumerate() {
                            if let Some(hit) = found[r] {
                                let (origin, direction, _) = rays[r];
                                pixels[offset] = pixel(bvh, origin, direction, hit);
                            }
                        }
                    }
                });
            return Frame::from_hits(width, height, hits);
        }
        hits.par_chunks_mut(row_length).enumerate().for_each(|(row, pixels)| {
            for (column, pixel) in pixels.iter_mut().enumerate() {
                *pixel = self.trace_ray(bvh, &local, ray(row * row_length + column), &mut ());
            }
        });
        Frame::from_hits(width, height, hits)
    }

    /// Box and triangle tests of one frame's primary rays, summed: what [`CpuTracer::trace`]
    /// does, counted (for `omnisim bench`; `trace` itself counts nothing).
    pub fn count_tests(self, bvh: &SceneBvh, camera: &Camera, pose: &Pose) -> TraversalCounts {
        let (width, height) = camera.size();
        let local = LocalPose::new(bvh, pose);
        (0..height)
            .into_par_iter()
            .map(|row| {
                let mut counts = TraversalCounts::default();
                for column in 0..width {
                    let ray = camera.ray(DVec2::new(column as f64, row as f64));
                    self.trace_ray(bvh, &local, ray, &mut counts);
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

/// The hit planes of `hit` on the ray from `origin` (scene-local) along `direction`.
fn pixel(bvh: &SceneBvh, origin: DVec3, direction: DVec3, hit: Hit) -> Pixel {
    let face = bvh.face[hit.triangle];
    let normal = bvh.face_normals[face as usize];
    Pixel {
        face,
        range: hit.t as f32,
        point: bvh.offset + origin + hit.t * direction,
        normal: if normal.dot(direction) > 0.0 { -normal } else { normal }.as_vec3(),
    }
}

/// Barycentric slack that closes the gaps f64 rounding leaves along shared edges.
const EDGE_TOLERANCE: f64 = 1e-10;

/// A closest hit: distance along the (unit) ray and triangle index in BVH order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f64,
    /// Triangle index in BVH leaf order.
    pub triangle: usize,
}

/// Möller–Trumbore in f64; returns t where the ray meets the triangle.
#[inline(always)]
pub(crate) fn intersect(corners: &[DVec3; 3], origin: DVec3, direction: DVec3) -> Option<f64> {
    let e1 = corners[1] - corners[0];
    let e2 = corners[2] - corners[0];
    let p = direction.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - corners[0];
    let u = s.dot(p) * inv;
    if !(-EDGE_TOLERANCE..=1.0 + EDGE_TOLERANCE).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = direction.dot(q) * inv;
    if v < -EDGE_TOLERANCE || u + v > 1.0 + EDGE_TOLERANCE {
        return None;
    }
    Some(e2.dot(q) * inv)
}

/// Closest hit with t > `t_min` of a ray given relative to `bvh.offset`, by the reference
/// tracer.
pub fn closest_hit(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_min: f64) -> Option<Hit> {
    closest_hit_counted(bvh, origin, direction, t_min, &mut ())
}

/// [`closest_hit`], counting its box and triangle tests.
fn closest_hit_counted<C: Counter>(
    bvh: &SceneBvh,
    origin: DVec3,
    direction: DVec3,
    t_min: f64,
    counter: &mut C,
) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let ray = BoxRay::new(origin, direction);
    traverse(&bvh.bvh, &ray, f32::INFINITY, counter, |triangle| {
        nearer(bvh, origin, direction, t_min, &mut best, triangle)
    });
    best
}

/// The closest-hit step of both tracers: the f64 test of `triangle`, kept in `best` if it is
/// the nearest hit beyond `t_min` so far.
#[inline(always)]
pub(crate) fn nearer(
    bvh: &SceneBvh,
    origin: DVec3,
    direction: DVec3,
    t_min: f64,
    best: &mut Option<Hit>,
    triangle: usize,
) -> Visit {
    match intersect(&bvh.triangles[triangle], origin, direction) {
        Some(t) if t > t_min && best.is_none_or(|b| t < b.t) => {
            *best = Some(Hit { t, triangle });
            // Rounded up so the f32 culling never discards a nearer candidate.
            Visit::Closer((t * (1.0 + 1e-6)) as f32)
        }
        _ => Visit::Miss,
    }
}

/// Whether anything but face `skip_face` lies on the ray (scene-local origin, unit
/// direction) strictly between t = 0 and `t_max`: the shadow test, by the reference tracer.
/// Any hit ends the search.
pub fn occluded(bvh: &SceneBvh, origin: DVec3, direction: DVec3, t_max: f64, skip_face: u32) -> bool {
    let mut blocked = false;
    let ray = BoxRay::new(origin, direction);
    traverse(&bvh.bvh, &ray, shadow_bound(t_max), &mut (), |triangle| {
        blocks(bvh, origin, direction, t_max, skip_face, &mut blocked, triangle)
    });
    blocked
}

/// `t_max` as an f32 culling bound, rounded up so that culling never drops an occluder the
/// f64 test accepts.
pub(crate) fn shadow_bound(t_max: f64) -> f32 {
    if t_max.is_finite() {
        (t_max * (1.0 + 1e-6) + 1e-6) as f32
    } else {
        f32::INFINITY
    }
}

/// The any-hit step of both tracers: whether `triangle` (not of face `skip_face`) lies on the
/// ray strictly between 0 and `t_max` by the f64 test; sets `blocked` and stops if so.
#[inline(always)]
pub(crate) fn blocks(
    bvh: &SceneBvh,
    origin: DVec3,
    direction: DVec3,
    t_max: f64,
    skip_face: u32,
    blocked: &mut bool,
    triangle: usize,
) -> Visit {
    if bvh.face[triangle] == skip_face {
        return Visit::Miss;
    }
    match intersect(&bvh.triangles[triangle], origin, direction) {
        Some(t) if t > 0.0 && t < t_max => {
            *blocked = true;
            Visit::Stop
        }
        _ => Visit::Miss,
    }
}

/// A pose made ready for tracing: rotation, and the viewpoint relative to the BVH's offset.
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
        (
            self.origin + self.world_from_body * ray.origin,
            self.world_from_body * ray.direction,
        )
    }
}

/// Traces one frame's hit planes with the reference tracer, on all CPU threads.
pub fn trace(bvh: &SceneBvh, camera: &Camera, pose: &Pose) -> Frame {
    CpuTracer::Reference.trace(bvh, camera, pose)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_rays_with_negative_zero_components_hit_the_walls() {
        let text = r#"Scene(name: "cube", objects: [Box(name: "room", size: (4.0, 2.0, 2.0), colour: (9, 9, 9))])"#;
        let scene = crate::scene::Scene::from_ron(text, std::path::Path::new("cube.ron")).unwrap();
        let bvh = SceneBvh::build(&scene);
        let origin = DVec3::new(0.1, 0.2, 0.9) - bvh.offset;
        // −DVec3::X is (−1, −0, −0): signed zeros must not change what a ray hits.
        let expected = [
            (DVec3::X, 1.9),
            (-DVec3::X, 2.1),
            (DVec3::Y, 0.8),
            (-DVec3::Y, 1.2),
            (DVec3::Z, 1.1),
            (-DVec3::Z, 0.9),
        ];
        for (direction, distance) in expected {
            let hit = closest_hit(&bvh, origin, direction, 0.0).unwrap_or_else(|| panic!("{direction} escaped"));
            assert!((hit.t - distance).abs() < 1e-12, "{direction}: {} vs {distance}", hit.t);
        }
    }
}
