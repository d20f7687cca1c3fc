//! The f64 triangle test both CPU tracers decide every hit with, and the closest-hit and
//! any-hit steps built on it: the leaf of the tracer, below every walk.

use glam::DVec3;

use crate::accel::SceneBvh;

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

/// Whether a hit at `t` on `triangle` beats `best`, by the one rule both CPU tracers and the
/// GPU (`shaders/bvh.wgsl`, `wins`) share: the nearer hit, and at exactly equal distance (a
/// ray along an edge two faces share, coincident faces) the lower scene face id, then the
/// lower triangle (BVH leaf order, the same on every backend). Traversal order, which differs
/// between the walks, therefore never decides a hit.
#[inline(always)]
pub(crate) fn wins(bvh: &SceneBvh, t: f64, triangle: usize, best: Hit) -> bool {
    t < best.t || (t == best.t && (bvh.face[triangle], triangle) < (bvh.face[best.triangle], best.triangle))
}

/// The closest-hit step of both tracers: the f64 test of `triangle`, kept in `best` if it
/// [`wins`] against the best hit beyond `t_min` so far.
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
        Some(t) if t > t_min && best.is_none_or(|b| wins(bvh, t, triangle, b)) => {
            *best = Some(Hit { t, triangle });
            // Rounded up so the f32 culling never discards a nearer or equally near candidate.
            Visit::Closer((t * (1.0 + 1e-6)) as f32)
        }
        _ => Visit::Miss,
    }
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

/// What to do with a primitive the traversal reached.
pub(crate) enum Visit {
    /// No hit nearer than the current bound.
    Miss,
    /// A hit: boxes entered beyond this f32 distance are skipped from now on.
    Closer(f32),
    /// Stop the traversal (an any-hit query found its answer).
    Stop,
}
