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

/// Linear colour of texel (x, y) of `level`, decoded through `decoding`.
#[inline(always)]
fn texel(level: &MipLevel, decoding: &[f32; 256], x: u32, y: u32) -> Vec3A {
    let packed = level.texels[y as usize * level.width as usize + x as usize];
    Vec3A::new(
        decoding[(packed & 0xff) as usize],
        decoding[((packed >> 8) & 0xff) as usize],
        decoding[((packed >> 16) & 0xff) as usize],
    )
}

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

/// Bilinear sample of one level at texture coordinates `uv`, in linear light.
#[inline(always)]
fn bilinear(level: &MipLevel, decoding: &[f32; 256], wrap: [Wrap; 2], uv: DVec2) -> Vec3A {
    let (x0, x1, fx) = neighbours(uv.x, level.width, wrap[0]);
    let (y0, y1, fy) = neighbours(uv.y, level.height, wrap[1]);
    let top = texel(level, decoding, x0, y0).lerp(texel(level, decoding, x1, y0), fx);
    let bottom = texel(level, decoding, x0, y1).lerp(texel(level, decoding, x1, y1), fx);
    top.lerp(bottom, fy)
}

/// Trilinear sample at level of detail `lod` (0 = finest; clamped to the pyramid): the two
/// levels around it, bilinear each, mixed by its fraction.
pub(crate) fn trilinear(texture: &Texture, wrap: [Wrap; 2], uv: DVec2, lod: f32) -> Vec3A {
    let decoding = &*DECODING;
    let last = (texture.levels.len() - 1) as f32;
    let lod = if lod.is_nan() { last } else { lod.clamp(0.0, last) };
    let fine = lod as usize;
    let fraction = lod - fine as f32;
    let sample = |l: usize| bilinear(&texture.levels[l], decoding, wrap, uv);
    if fraction == 0.0 {
        sample(fine)
    } else {
        sample(fine).lerp(sample(fine + 1), fraction)
    }
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
        let at = |u: f64| f64::from(bilinear(&t.levels[0], &DECODING, wrap, DVec2::new(u, 0.5)).x);
        let linear = |b: u8| f64::from(srgb_to_linear(b) as f32);
        assert_eq!(at(0.125), linear(0));
        assert_eq!(at(0.375), linear(85));
        let halfway = (linear(85) + linear(170)) / 2.0;
        assert!((at(0.5) - halfway).abs() < 1e-7);
        // Repeat wraps the left edge onto the last texel.
        let repeat = f64::from(bilinear(&t.levels[0], &DECODING, [Wrap::Repeat; 2], DVec2::new(0.0, 0.5)).x);
        assert!((repeat - (linear(0) + 1.0) / 2.0).abs() < 1e-7);
        // Coordinates far out and negative wrap as near ones do (the integer floor).
        let far = bilinear(
            &t.levels[0],
            &DECODING,
            [Wrap::Repeat; 2],
            DVec2::new(-1e6 + 0.375, 0.5),
        )
        .x;
        assert_eq!(f64::from(far), linear(85));
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
        // Beyond the pyramid: the 1×1 level, the mean in linear light.
        let coarsest = trilinear(&t, [Wrap::Repeat; 2], DVec2::splat(0.3), 99.0).x;
        assert_eq!(coarsest, srgb_to_linear(t.levels[2].texel(0, 0)[0]) as f32);
    }
}
