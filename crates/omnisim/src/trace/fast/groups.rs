//! Triangles four at a time for the fast tracer: a conservative f32 test that only rejects.
//!
//! Möller–Trumbore on four triangles in the lanes of `Vec4`s (SSE2 on `x86_64`, NEON on
//! aarch64, scalar elsewhere; glam picks). A lane is rejected only when the f32 result is
//! wrong by more than a bound on its rounding error; every lane kept goes to the f64 test,
//! which alone decides hits and distances. So the fast tracer finds exactly the triangles the
//! f64 reference finds.

use glam::Vec4;

use crate::accel::wide::{TriangleGroup, TriangleLanes};

use super::lanes::{Lanes, Wide};

/// Rounding-error budget in units of f32's unit roundoff (2⁻²⁴). The dot and cross products
/// of the test accumulate about 25 such errors of the largest operand (worked out in
/// docs/architecture.md, "The fast CPU tracer"); 64 leaves a margin.
const ERROR_ULPS: f32 = 64.0 * f32::EPSILON / 2.0;

/// Barycentric slack of the f64 test (`triangle::EDGE_TOLERANCE`), rounded up: what the f32 test
/// must let through on top of its own error.
const EDGE: f32 = 1e-9;

/// A ray's quantities as the filter reads them, one ray per lane or one ray in every lane.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RayLanes<L> {
    pub(crate) origin: [L; 3],
    pub(crate) direction: [L; 3],
    /// Absolute error bound of positions along the ray (metres): `ERROR_ULPS` × the largest
    /// coordinate of the ray origin or of the scene ([`position_error`]).
    pub(crate) position_error: L,
}

/// The error bound of positions along a ray from `origin` (f32, scene-local) in a scene whose
/// largest absolute coordinate is `scene_extent`. Keep in step with its eight-ray twin
/// [`position_errors`]: a packet's rays must be the single rays' own, bit for bit (tested by
/// `a_ray_taken_from_the_packet_is_the_single_rays_own`).
pub(crate) fn position_error(origin: glam::Vec3, scene_extent: f32) -> f32 {
    ERROR_ULPS * (1.0 + origin.abs().max_element().max(scene_extent))
}

/// [`position_error`] of eight rays from `origin` at once (the same operations lane by lane;
/// keep the two in step).
#[inline(always)]
pub(crate) fn position_errors<L: Lanes>(origin: &[L; 3], scene_extent: f32) -> L {
    let largest = origin[0].abs().max(origin[1].abs()).max(origin[2].abs());
    L::splat(ERROR_ULPS) * (L::splat(1.0) + largest.max(L::splat(scene_extent)))
}

impl TriangleGroup {
    /// Lanes whose triangle the f64 test might hit at a distance in (`t_lo`, `t_hi`) along
    /// `ray` (broadcast to four lanes): [`filter`] for four triangles (spare lanes included:
    /// callers mask with the lanes their leaf holds).
    #[inline(always)]
    pub(crate) fn candidates(&self, ray: &RayLanes<Vec4>, t_lo: f32, t_hi: f32) -> u32 {
        filter(ray, &self.lanes4, Vec4::splat(t_lo), Vec4::splat(t_hi)) & 0xf
    }

    /// The triangle of `lane` in all eight lanes, to filter eight rays against it.
    #[inline(always)]
    pub(crate) fn broadcast<W: Wide>(&self, lane: usize) -> TriangleLanes<W> {
        // Written out, not `array::map`: `map` is compiled outside the AVX2 walk that calls
        // this, so its lane intrinsics became calls through memory (perf: about 4 % of an
        // env1 omni image).
        let splat = |v: Vec4| W::splat(v[lane]);
        let splat3 = |v: &[Vec4; 3]| [splat(v[0]), splat(v[1]), splat(v[2])];
        let t = &self.lanes4;
        TriangleLanes {
            corner: splat3(&t.corner),
            edge1: splat3(&t.edge1),
            edge2: splat3(&t.edge2),
            longest_edge: splat(t.longest_edge),
        }
    }
}

/// Lanes whose (ray, triangle) pair the f64 test might hit at a distance in (`t_lo`, `t_hi`):
/// every lane but those the f32 test rejects with a margin above its rounding error.
/// Möller–Trumbore; the same operations in every lane whatever `L` is. Bits above the lane
/// count are set: callers mask with the lanes they hold.
#[inline(always)]
pub(crate) fn filter<L: Lanes>(ray: &RayLanes<L>, triangle: &TriangleLanes<L>, t_lo: L, t_hi: L) -> u32 {
    let [dx, dy, dz] = ray.direction;
    let [e1x, e1y, e1z] = triangle.edge1;
    let [e2x, e2y, e2z] = triangle.edge2;
    let px = dy * e2z - dz * e2y;
    let py = dz * e2x - dx * e2z;
    let pz = dx * e2y - dy * e2x;
    let det = e1x * px + e1y * py + e1z * pz;
    let sx = ray.origin[0] - triangle.corner[0];
    let sy = ray.origin[1] - triangle.corner[1];
    let sz = ray.origin[2] - triangle.corner[2];
    let u = sx * px + sy * py + sz * pz;
    let qx = sy * e1z - sz * e1y;
    let qy = sz * e1x - sx * e1z;
    let qz = sx * e1y - sy * e1x;
    let v = dx * qx + dy * qy + dz * qz;
    let t = e2x * qx + e2y * qy + e2z * qz;
    // Unnormalised barycentrics and distance, turned so that det ≥ 0.
    let sign = det.signum();
    let (det, u, v, t) = (det * sign, u * sign, v * sign, t * sign);
    // Error bounds: positions carry `position_error`, so u and v (position × edge) carry
    // that times the edge length, det (edge × edge) the relative error times its square,
    // and t (position × edge × edge) the position error times the square.
    let edge = triangle.longest_edge;
    let two = L::splat(2.0);
    let uv_error = ray.position_error * edge + det * L::splat(EDGE);
    let det_error = L::splat(ERROR_ULPS) * edge * edge;
    let t_error = ray.position_error * edge * edge;
    let decided = det.greater(det_error * two);
    let outside = u.less(-uv_error) | v.less(-uv_error) | (u + v).greater(det + uv_error * two + det_error);
    let beyond = t.greater(det * t_hi + t_error + det_error * t_hi) | t.less(det * t_lo - t_error - det_error * t_lo);
    !(decided & (outside | beyond))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::fast::rays::LaneRay;
    use crate::trace::triangle::intersect;
    use glam::DVec3;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    /// The filter's one promise: it never rejects a triangle the f64 test hits in range. Rays
    /// aimed within 1e-7 (barycentric) of an edge or corner, near-grazing ones included, at
    /// triangles from 1 mm to 10 m across placed up to 10 km from the origin, from origins up to
    /// 10 km away.
    #[test]
    fn the_f32_filter_keeps_every_triangle_the_f64_test_hits() {
        let mut rng = StdRng::seed_from_u64(5);
        let unit =
            |rng: &mut StdRng| DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0))).normalize();
        let (mut hits, mut clear_misses, mut kept_clear_misses) = (0, 0, 0);
        for _ in 0..200_000 {
            let size = 10f64.powf(rng.random_range(-3.0..1.0));
            let place = unit(&mut rng) * 10f64.powf(rng.random_range(-2.0..4.0));
            let corners = [place, place + unit(&mut rng) * size, place + unit(&mut rng) * size];
            // A target on or next to the boundary: barycentrics snapped to an edge, nudged.
            let (mut u, mut v) = (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            match rng.random_range(0..4) {
                0 => u = 0.0,
                1 => v = 0.0,
                2 => v = 1.0 - u,
                _ => (u, v) = ([0.0, 1.0][rng.random_range(0..2)], 0.0),
            }
            let nudge = |rng: &mut StdRng| rng.random_range(-1e-7..1e-7);
            let (mut u, v) = (u + nudge(&mut rng), v + nudge(&mut rng));
            // One ray in eight aims clearly outside, where the filter should reject.
            let clearly_outside = rng.random_range(0..8) == 0;
            if clearly_outside {
                u = -rng.random_range(0.01..0.5);
            }
            let target = corners[0] + u * (corners[1] - corners[0]) + v * (corners[2] - corners[0]);
            let distance = 10f64.powf(rng.random_range(-3.0..4.0));
            let grazing = rng.random_range(0..4) == 0;
            let direction = if grazing {
                // Nearly in the triangle's plane.
                let normal = (corners[1] - corners[0]).cross(corners[2] - corners[0]).normalize();
                (unit(&mut rng).reject_from(normal).normalize() + normal * rng.random_range(-1e-4..1e-4)).normalize()
            } else {
                unit(&mut rng)
            };
            let origin = target - direction * distance;
            let extent = corners.iter().fold(0.0f64, |m, p| m.max(p.abs().max_element())) as f32;
            let group = TriangleGroup::new(&[corners]);
            let ray = LaneRay::new(origin, direction, extent);
            let kept = group.candidates(&ray.lanes, 0.0, f32::INFINITY) & 1 == 1;
            match intersect(&corners, origin, direction) {
                Some(t) if t > 0.0 => {
                    hits += 1;
                    assert!(
                        kept,
                        "dropped a hit at t = {t}: {corners:?}, from {origin} along {direction}"
                    );
                }
                // Counted where f32 can tell: a triangle large against the rounding of the
                // coordinates, a ray not close to its plane.
                _ if clearly_outside && !grazing && size > 1e-4 * (1.0 + place.length() + distance) => {
                    clear_misses += 1;
                    kept_clear_misses += usize::from(kept);
                }
                _ => {}
            }
        }
        // The test must exercise hits, and the filter must still reject what is clearly off.
        assert!(
            hits > 50_000 && clear_misses > 5_000,
            "{hits} hits, {clear_misses} clear misses"
        );
        assert!(
            kept_clear_misses * 10 < clear_misses,
            "{kept_clear_misses} of {clear_misses} clear misses kept"
        );
    }

    /// [`filter`] of every batch of `rays` against the triangle of `lane`, on eight lanes in
    /// one AVX register as the AVX2 packet walk runs it.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn filter_avx(
        rays: &[(DVec3, DVec3, f64); crate::trace::fast::PACKET],
        group: &TriangleGroup,
        lane: usize,
        t_hi: &[f32],
    ) -> [u32; crate::trace::fast::rays::BATCHES] {
        use crate::trace::fast::lanes::{Avx8, Wide};
        let packet = crate::trace::fast::rays::PacketRays::<Avx8>::new(rays, u64::MAX, 10.0);
        let triangle = group.broadcast::<Avx8>(lane);
        std::array::from_fn(|b| {
            filter(
                &packet.batches[b],
                &triangle,
                packet.t_lo[b],
                Avx8::load(&t_hi[8 * b..]),
            )
        })
    }

    /// One triangle against eight rays gives, pair by pair, the answer of four triangles
    /// against one ray: the batchings (and the AVX lanes, where the CPU has AVX2) run the same
    /// f32 operations.
    #[test]
    fn eight_rays_at_a_time_filter_as_one_ray_at_a_time() {
        use crate::trace::fast::PACKET;
        use crate::trace::fast::lanes::Lanes8;
        use crate::trace::fast::rays::PacketRays;
        let mut rng = StdRng::seed_from_u64(7);
        let unit =
            |rng: &mut StdRng| DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0))).normalize();
        let mut kept = 0;
        for _ in 0..300 {
            let place = unit(&mut rng) * rng.random_range(0.0..5.0);
            let triangles: Vec<[DVec3; 3]> = (0..4)
                .map(|_| {
                    let a = place + unit(&mut rng) * rng.random_range(0.0..2.0);
                    [a, a + unit(&mut rng), a + unit(&mut rng) * 0.3]
                })
                .collect();
            let group = TriangleGroup::new(&triangles);
            let origin = unit(&mut rng) * rng.random_range(0.0..3.0);
            let rays: [(DVec3, DVec3, f64); PACKET] = std::array::from_fn(|_| {
                let towards = place + unit(&mut rng) * rng.random_range(0.0..2.0);
                (origin, (towards - origin).normalize(), rng.random_range(0.0..0.5))
            });
            let t_hi: Vec<f32> = (0..PACKET).map(|_| rng.random_range(0.5..20.0)).collect();
            let packet = PacketRays::<Lanes8>::new(&rays, u64::MAX, 10.0);
            for lane in 0..4 {
                let triangle = group.broadcast::<Lanes8>(lane);
                #[cfg(target_arch = "x86_64")]
                // SAFETY: called only where the CPU has AVX2.
                let avx = std::arch::is_x86_feature_detected!("avx2")
                    .then(|| unsafe { filter_avx(&rays, &group, lane, &t_hi) });
                for r in 0..PACKET {
                    let single = LaneRay::new(rays[r].0, rays[r].1, 10.0);
                    let t_lo = crate::trace::fast::rays::t_lo(rays[r].2);
                    let one = group.candidates(&single.lanes, t_lo, t_hi[r]) >> lane & 1;
                    let (b, k) = (r / 8, r % 8);
                    let eight = filter(
                        &packet.batches[b],
                        &triangle,
                        packet.t_lo[b],
                        Lanes8::load(&t_hi[8 * b..]),
                    ) >> k
                        & 1;
                    assert_eq!(one, eight, "ray {r}, triangle {lane}");
                    #[cfg(target_arch = "x86_64")]
                    if let Some(avx) = avx {
                        assert_eq!(one, avx[b] >> k & 1, "ray {r}, triangle {lane}, AVX");
                    }
                    kept += one;
                }
            }
        }
        assert!(kept > 500 && kept < 300 * 4 * 64 - 1_000, "{kept} pairs kept");
    }
}
