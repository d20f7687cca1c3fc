//! Texture filtering: bilinear within a mip level, trilinear across two, at a level of detail
//! chosen from the pixel's footprint in texels. One definition, f64 here; `shaders/texture.wgsl`
//! is its f32 twin (same texel centres, wrap rules, level choice).

use glam::{DVec2, DVec3};

use crate::scene::lighting::srgb_to_linear;
use crate::scene::texture::{MipLevel, Texture, Wrap};

/// Linear colour of a texel.
fn texel(level: &MipLevel, x: u32, y: u32) -> DVec3 {
    DVec3::from_array(level.texel(x, y).map(srgb_to_linear))
}

/// Texel coordinate `t` (texel centres at integer + 0.5 of `size`-texel rows) as the two
/// neighbouring texel indices and the weight of the second; NaN reads texel 0.
fn neighbours(t: f64, size: u32, wrap: Wrap) -> (u32, u32, f64) {
    let x = if t.is_finite() { t * f64::from(size) - 0.5 } else { -0.5 };
    let x0 = x.floor();
    let i = x0 as i64;
    (wrap.index(i, size), wrap.index(i.saturating_add(1), size), x - x0)
}

/// Bilinear sample of one level at texture coordinates `uv`, in linear light.
pub(crate) fn bilinear(level: &MipLevel, wrap: [Wrap; 2], uv: DVec2) -> DVec3 {
    let (x0, x1, fx) = neighbours(uv.x, level.width, wrap[0]);
    let (y0, y1, fy) = neighbours(uv.y, level.height, wrap[1]);
    let top = texel(level, x0, y0).lerp(texel(level, x1, y0), fx);
    let bottom = texel(level, x0, y1).lerp(texel(level, x1, y1), fx);
    top.lerp(bottom, fy)
}

/// Trilinear sample at level of detail `lod` (0 = finest; clamped to the pyramid): the two
/// levels around it, bilinear each, mixed by its fraction.
pub(crate) fn trilinear(texture: &Texture, wrap: [Wrap; 2], uv: DVec2, lod: f64) -> DVec3 {
    let last = (texture.levels.len() - 1) as f64;
    let lod = if lod.is_nan() { last } else { lod.clamp(0.0, last) };
    let fine = lod.floor();
    let fraction = lod - fine;
    let sample = |l: f64| bilinear(&texture.levels[l as usize], wrap, uv);
    if fraction == 0.0 {
        sample(fine)
    } else {
        sample(fine).lerp(sample(fine + 1.0), fraction)
    }
}

/// The level of detail of a footprint whose sides are the texture-coordinate steps `du_dv`
/// (one per image axis) on a texture of `size` texels: log2 of the longer side in texels of
/// the finest level (the isotropic rule of OpenGL's `textureLod` selection). Infinite steps
/// (a neighbouring ray that misses the face's plane) give the coarsest level.
pub(crate) fn level_of_detail(size: (u32, u32), steps: [DVec2; 2]) -> f64 {
    let texels = DVec2::new(f64::from(size.0), f64::from(size.1));
    let longest = (steps[0] * texels).length().max((steps[1] * texels).length());
    if longest.is_nan() {
        f64::INFINITY
    } else {
        longest.max(1.0).log2()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Texture {
        // 4×1 texels 0, 85, 170, 255 in sRGB.
        Texture::from_rgb(4, 1, &[[0; 3], [85; 3], [170; 3], [255; 3]])
    }

    #[test]
    fn bilinear_hits_texel_centres_and_interpolates_between() {
        let t = ramp();
        let wrap = [Wrap::Clamp; 2];
        let at = |u: f64| bilinear(&t.levels[0], wrap, DVec2::new(u, 0.5)).x;
        assert_eq!(at(0.125), srgb_to_linear(0));
        assert_eq!(at(0.375), srgb_to_linear(85));
        let halfway = (srgb_to_linear(85) + srgb_to_linear(170)) / 2.0;
        assert!((at(0.5) - halfway).abs() < 1e-15);
        // Repeat wraps the left edge onto the last texel.
        let repeat = bilinear(&t.levels[0], [Wrap::Repeat; 2], DVec2::new(0.0, 0.5)).x;
        assert!((repeat - (srgb_to_linear(0) + 1.0) / 2.0).abs() < 1e-15);
    }

    #[test]
    fn level_of_detail_is_log2_of_the_longer_footprint_side_in_texels() {
        let steps = [DVec2::new(4.0 / 256.0, 0.0), DVec2::new(0.0, 1.0 / 256.0)];
        assert_eq!(level_of_detail((256, 256), steps), 2.0);
        assert_eq!(level_of_detail((256, 256), [DVec2::ZERO; 2]), 0.0);
        assert_eq!(
            level_of_detail((256, 256), [DVec2::splat(f64::INFINITY), DVec2::ZERO]),
            f64::INFINITY
        );
        let t = ramp();
        // Beyond the pyramid: the 1×1 level, the mean in linear light.
        let coarsest = trilinear(&t, [Wrap::Repeat; 2], DVec2::splat(0.3), 99.0).x;
        assert_eq!(coarsest, srgb_to_linear(t.levels[2].texel(0, 0)[0]));
    }
}
