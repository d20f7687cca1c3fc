//! Texture filtering: bilinear within a mip level, trilinear across two, at a level of detail
//! chosen from the pixel's footprint in texels. One definition: texture coordinates and texel
//! positions in f64 here, weights and colours in f32 (the issue's "f64 coordinates, f32
//! filtering"); `shaders/texture.wgsl` is its f32 twin (same texel centres, wrap rules, level
//! choice).

use glam::{DVec2, Vec3A};

use crate::scene::lighting::srgb_to_linear;
use crate::scene::texture::{MipLevel, Texture, Wrap};

/// Linear value of each sRGB byte, f32: a texel's three look-ups.
static DECODING: std::sync::LazyLock<[f32; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|b| srgb_to_linear(b as u8) as f32));

/// Texel coordinate `t` (texel centres at integer + 0.5 of `size`-texel rows) as the two
/// neighbouring texel indices and the weight of the second; NaN reads texel 0.
#[inline(always)]
fn neighbours(t: f64, size: u32, wrap: Wrap) -> (u32, u32, f32) {
    let x = if t.is_finite() { t * f64::from(size) - 0.5 } else { -0.5 };
    // floor(x) as an integer without a libm call (`as` saturates far out, where every index
    // wraps or clamps the same).
    let truncated = x as i64;
    let i = truncated - i64::from(x < truncated as f64);
    let (a, b) = wrap.pair(i, size);
    (a, b, (x - i as f64) as f32)
}

/// The eight texels a trilinear sample mixes, packed sRGB, and their weights: the corners
/// (x0, y0), (x1, y0), (x0, y1), (x1, y1) of the finer level, then of the coarser.
struct Taps {
    texels: [u32; 8],
    weights: [f32; 8],
}

/// The four corners of the bilinear sample of `level` at `uv` into `texels`, weighted by
/// `weight` (the level's share) into `weights`.
#[inline(always)]
fn bilinear_taps(level: &MipLevel, wrap: [Wrap; 2], uv: DVec2, weight: f32, texels: &mut [u32], weights: &mut [f32]) {
    let (x0, x1, fx) = neighbours(uv.x, level.width, wrap[0]);
    let (y0, y1, fy) = neighbours(uv.y, level.height, wrap[1]);
    let width = level.width as usize;
    let (row0, row1) = (y0 as usize * width, y1 as usize * width);
    let (x0, x1) = (x0 as usize, x1 as usize);
    texels[..4].copy_from_slice(&[
        level.texels[row0 + x0],
        level.texels[row0 + x1],
        level.texels[row1 + x0],
        level.texels[row1 + x1],
    ]);
    let (top, bottom) = (weight * (1.0 - fy), weight * fy);
    weights[..4].copy_from_slice(&[top * (1.0 - fx), top * fx, bottom * (1.0 - fx), bottom * fx]);
}

/// The taps of the trilinear sample at `uv` and level of detail `lod` (0 = finest; clamped to
/// the pyramid, NaN the coarsest): the two levels around it, weighted by its fraction (a whole
/// level repeats its taps with weight zero).
#[inline(always)]
fn trilinear_taps(texture: &Texture, wrap: [Wrap; 2], uv: DVec2, lod: f32) -> Taps {
    let last = (texture.levels.len() - 1) as f32;
    let lod = if lod.is_nan() { last } else { lod.clamp(0.0, last) };
    let fine = lod as usize;
    let fraction = lod - fine as f32;
    let coarse = if fraction > 0.0 { fine + 1 } else { fine };
    let mut taps = Taps {
        texels: [0; 8],
        weights: [0.0; 8],
    };
    let (finer, coarser) = taps.texels.split_at_mut(4);
    let (finer_weights, coarser_weights) = taps.weights.split_at_mut(4);
    bilinear_taps(&texture.levels[fine], wrap, uv, 1.0 - fraction, finer, finer_weights);
    bilinear_taps(&texture.levels[coarse], wrap, uv, fraction, coarser, coarser_weights);
    taps
}

/// Σ weight · decoded channel over the taps, each channel (shift 0, 8, 16 of the packed texel)
/// summed in one order: lanes k and k + 4, then those sums' 0 + 2 and 1 + 3, then the two
/// (the order of an eight-lane vector's halves, so [`mix_avx2`] gives the same bits).
#[inline(always)]
fn mix(taps: &Taps, decoding: &[f32; 256]) -> Vec3A {
    let channel = |shift: u32| {
        let v: [f32; 8] =
            std::array::from_fn(|k| taps.weights[k] * decoding[((taps.texels[k] >> shift) & 0xff) as usize]);
        let halves: [f32; 4] = std::array::from_fn(|k| v[k] + v[k + 4]);
        (halves[0] + halves[2]) + (halves[1] + halves[3])
    };
    Vec3A::new(channel(0), channel(8), channel(16))
}

/// [`mix`] with AVX2: the eight taps as one vector, each channel's decoded values gathered from
/// the table, the same products and sums in the same order.
///
/// # Safety
/// The CPU must have AVX2 (`is_x86_feature_detected!("avx2")`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn mix_avx2(taps: &Taps, decoding: &[f32; 256]) -> Vec3A {
    use std::arch::x86_64::{
        __m256i, _mm_add_ps, _mm_add_ss, _mm_cvtss_f32, _mm_movehl_ps, _mm_shuffle_ps, _mm256_and_si256,
        _mm256_castps256_ps128, _mm256_extractf128_ps, _mm256_i32gather_ps, _mm256_loadu_ps, _mm256_loadu_si256,
        _mm256_mul_ps, _mm256_set1_epi32, _mm256_srli_epi32,
    };
    // SAFETY: the loads read the taps' two eight-element arrays; every gather index is masked
    // to 0..=255, inside the 256-entry table; AVX2 is this function's precondition.
    unsafe {
        let texels = _mm256_loadu_si256(taps.texels.as_ptr().cast::<__m256i>());
        let weights = _mm256_loadu_ps(taps.weights.as_ptr());
        let bytes = _mm256_set1_epi32(0xff);
        let sum = |indices: __m256i| {
            let v = _mm256_mul_ps(weights, _mm256_i32gather_ps::<4>(decoding.as_ptr(), indices));
            let halves = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
            let pairs = _mm_add_ps(halves, _mm_movehl_ps(halves, halves));
            _mm_cvtss_f32(_mm_add_ss(pairs, _mm_shuffle_ps::<1>(pairs, pairs)))
        };
        Vec3A::new(
            sum(_mm256_and_si256(texels, bytes)),
            sum(_mm256_and_si256(_mm256_srli_epi32::<8>(texels), bytes)),
            sum(_mm256_and_si256(_mm256_srli_epi32::<16>(texels), bytes)),
        )
    }
}

/// Trilinear sample at level of detail `lod` (0 = finest; clamped to the pyramid): the two
/// levels around it, bilinear each, mixed by its fraction, in linear light. With AVX2 (checked
/// per call, as the fast tracer does) the mixing runs on eight lanes, to the same bits.
pub(crate) fn trilinear(texture: &Texture, wrap: [Wrap; 2], uv: DVec2, lod: f32) -> Vec3A {
    let taps = trilinear_taps(texture, wrap, uv, lod);
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 was just detected.
        return unsafe { mix_avx2(&taps, &DECODING) };
    }
    mix(&taps, &DECODING)
}

/// The level of detail of a footprint whose longer axis is `length` metres on a face of
/// `texels_per_metre_squared` (`UvMap::texels_per_metre_squared`): log2 of that axis in texels of
/// the finest level (the isotropic rule of OpenGL's `textureLod` selection), taken as half
/// the log2 of its square. A NaN length (a degenerate footprint) gives the coarsest level.
pub(crate) fn level_of_detail(texels_per_metre_squared: f32, length: f32) -> f32 {
    let squared = texels_per_metre_squared * length * length;
    // As the GPU's `squared < FAR`.
    if squared.is_nan() {
        f32::INFINITY
    } else {
        0.5 * squared.max(1.0).log2()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::surface::UvMap;
    use glam::DVec3;

    fn ramp() -> Texture {
        // 4×1 texels 0, 85, 170, 255 in sRGB.
        Texture::from_rgb(4, 1, &[[0; 3], [85; 3], [170; 3], [255; 3]])
    }

    #[test]
    fn bilinear_hits_texel_centres_and_interpolates_between() {
        let t = ramp();
        let wrap = [Wrap::Clamp; 2];
        let at = |u: f64| f64::from(trilinear(&t, wrap, DVec2::new(u, 0.5), 0.0).x);
        let linear = |b: u8| f64::from(srgb_to_linear(b) as f32);
        assert_eq!(at(0.125), linear(0));
        assert_eq!(at(0.375), linear(85));
        let halfway = (linear(85) + linear(170)) / 2.0;
        assert!((at(0.5) - halfway).abs() < 1e-7);
        // Repeat wraps the left edge onto the last texel.
        let repeat = f64::from(trilinear(&t, [Wrap::Repeat; 2], DVec2::new(0.0, 0.5), 0.0).x);
        assert!((repeat - (linear(0) + 1.0) / 2.0).abs() < 1e-7);
        // Coordinates far out and negative wrap as near ones do (the integer floor).
        let far = trilinear(&t, [Wrap::Repeat; 2], DVec2::new(-1e6 + 0.375, 0.5), 0.0).x;
        assert_eq!(f64::from(far), linear(85));
        // Between levels: the levels' bilinear samples mixed by the fraction (level 1 of the
        // ramp is two texels, the means of 0, 85 and of 170, 255 in linear light).
        let (u, fraction) = (0.3, 0.25);
        let mixed = f64::from(trilinear(&t, wrap, DVec2::new(u, 0.5), 1.0 + fraction).x);
        let level = |l: f32| f64::from(trilinear(&t, wrap, DVec2::new(u, 0.5), l).x);
        let expected = level(1.0) * (1.0 - f64::from(fraction)) + level(2.0) * f64::from(fraction);
        assert!((mixed - expected).abs() < 1e-6, "{mixed} vs {expected}");
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_avx2_mix_gives_the_portable_mix_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for _ in 0..10_000 {
            let taps = Taps {
                texels: std::array::from_fn(|_| next() as u32 & 0xff_ffff),
                weights: std::array::from_fn(|_| (next() % 1_000_001) as f32 / 1e6),
            };
            // SAFETY: AVX2 was detected above.
            let avx = unsafe { mix_avx2(&taps, &DECODING) };
            assert_eq!(
                avx.to_array().map(f32::to_bits),
                mix(&taps, &DECODING).to_array().map(f32::to_bits)
            );
        }
    }

    #[test]
    fn level_of_detail_is_log2_of_the_longer_footprint_axis_in_texels() {
        // 256 texels per metre along u, 64 along v (an anisotropic map takes the larger).
        let map = |gradient| UvMap {
            texture: 0,
            wrap: [Wrap::Repeat; 2],
            at_anchor: DVec2::ZERO,
            gradient,
        };
        let scale = map([DVec3::X, DVec3::Y * 0.25]).texels_per_metre_squared((256, 256));
        assert_eq!(scale, 256.0 * 256.0);
        let rotated = map([DVec3::new(0.6, 0.8, 0.0), DVec3::new(-0.8, 0.6, 0.0)]);
        assert!((rotated.texels_per_metre_squared((256, 256)) - 256.0 * 256.0).abs() < 1e-9);
        assert_eq!(level_of_detail(scale as f32, 4.0 / 256.0), 2.0);
        assert_eq!(level_of_detail(scale as f32, 0.0), 0.0);
        assert_eq!(level_of_detail(scale as f32, f32::INFINITY), f32::INFINITY);
        // NaN: the coarsest level too.
        assert_eq!(level_of_detail(scale as f32, f32::NAN), f32::INFINITY);
        let t = ramp();
        // Beyond the pyramid: the 1×1 level, the mean in linear light (its four taps' f32
        // weights sum to 1 within rounding).
        let coarsest = trilinear(&t, [Wrap::Repeat; 2], DVec2::splat(0.3), 99.0).x;
        let mean = srgb_to_linear(t.levels[2].texel(0, 0)[0]) as f32;
        assert!(
            (coarsest - mean).abs() <= 2.0 * f32::EPSILON * mean,
            "{coarsest} vs {mean}"
        );
    }
}
