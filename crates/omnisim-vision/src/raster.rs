//! f32 images and sub-pixel sampling.
//!
//! Descriptors need f32 arithmetic on grey or colour images of any channel count, so images are
//! held here as one interleaved f32 buffer rather than `image`'s per-pixel-type buffers. Pixel
//! centres are at integer coordinates (`OpenCV`, as in omnisim's cameras).

use crate::VisionError;

/// A row-major image of `channels` interleaved f32 values per pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct Raster {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Values per pixel.
    pub channels: usize,
    /// `width × height × channels` values, row-major, channels interleaved.
    pub data: Vec<f32>,
}

/// How a value between pixel centres is made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Interpolation {
    /// Linear in x and y (2 × 2 pixels).
    Bilinear,
    /// Keys' cubic convolution with a = −0.5 (4 × 4 pixels; Keys 1981, the Catmull-Rom spline):
    /// exact for quadratics, what MATLAB's `imresize`/`interp2 cubic` use.
    #[default]
    Bicubic,
}

impl Interpolation {
    /// The first pixel index and the weights of the pixels from it on, along one axis.
    ///
    /// Written here because neither `image` (bilinear only, no point bicubic) nor a crate that
    /// fits the workspace offers separable bicubic point sampling; imageproc's warp would bring
    /// nalgebra 0.35 (beside the workspace's 0.34) and its own random/text stack.
    pub(crate) fn taps(self, x: f64) -> (i64, [f64; 4]) {
        self.taps_from(x, floor(x))
    }

    /// [`Interpolation::taps`] with `base`, the floor of x, given.
    fn taps_from(self, x: f64, base: f64) -> (i64, [f64; 4]) {
        let t = x - base;
        match self {
            Interpolation::Bilinear => (base as i64, [1.0 - t, t, 0.0, 0.0]),
            Interpolation::Bicubic => {
                const A: f64 = -0.5;
                let near = |s: f64| ((A + 2.0) * s - (A + 3.0)) * s * s + 1.0;
                let far = |s: f64| ((A * s - 5.0 * A) * s + 8.0 * A) * s - 4.0 * A;
                (base as i64 - 1, [far(1.0 + t), near(t), near(1.0 - t), far(2.0 - t)])
            }
        }
    }

    /// Pixels the kernel spans along each axis (of the 4 weights [`Interpolation::taps`] gives).
    pub(crate) fn width(self) -> usize {
        match self {
            Interpolation::Bilinear => 2,
            Interpolation::Bicubic => 4,
        }
    }
}

impl Raster {
    /// A black (all-zero) image.
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        Self {
            width,
            height,
            channels,
            data: vec![0.0; width * height * channels],
        }
    }

    /// Wraps `data`, which must hold `width × height × channels` values.
    pub fn from_vec(width: usize, height: usize, channels: usize, data: Vec<f32>) -> Result<Self, VisionError> {
        if data.len() != width * height * channels || channels == 0 {
            return Err(VisionError::Parameter {
                name: "data",
                reason: format!(
                    "{} values for a {width}×{height} image of {channels} channels",
                    data.len()
                ),
            });
        }
        Ok(Self {
            width,
            height,
            channels,
            data,
        })
    }

    /// 8-bit RGB pixels (omnisim's `Frame::colour`, an `image::RgbImage`'s raw buffer) as 0..1.
    pub fn from_rgb8(width: usize, height: usize, pixels: &[[u8; 3]]) -> Result<Self, VisionError> {
        let data = pixels.iter().flatten().map(|&c| f32::from(c) / 255.0).collect();
        Self::from_vec(width, height, 3, data)
    }

    /// Any `image` image, as RGB 0..1.
    pub fn from_image(image: &image::DynamicImage) -> Self {
        let rgb = image.to_rgb32f();
        Self {
            width: rgb.width() as usize,
            height: rgb.height() as usize,
            channels: 3,
            data: rgb.into_raw(),
        }
    }

    /// 8-bit grey (one channel) or RGB (three) image, values clamped to 0..1.
    pub fn to_image(&self) -> Result<image::DynamicImage, VisionError> {
        let bytes: Vec<u8> = self
            .data
            .iter()
            .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect();
        let (w, h) = (self.width as u32, self.height as u32);
        match self.channels {
            1 => Ok(image::GrayImage::from_raw(w, h, bytes).expect("sized").into()),
            3 => Ok(image::RgbImage::from_raw(w, h, bytes).expect("sized").into()),
            n => Err(VisionError::Parameter {
                name: "channels",
                reason: format!("{n} channels: 8-bit images are written from 1 or 3"),
            }),
        }
    }

    /// Luma Y' = 0.299 R + 0.587 G + 0.114 B (ITU-R BT.601, as `OpenCV`'s and MATLAB's
    /// `rgb2gray`); a one-channel image is returned as it is.
    pub fn to_grey(&self) -> Raster {
        if self.channels == 1 {
            return self.clone();
        }
        let data = self
            .data
            .chunks(self.channels)
            .map(|p| 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2])
            .collect();
        Raster {
            width: self.width,
            height: self.height,
            channels: 1,
            data,
        }
    }

    /// The values of pixel (x, y).
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        let start = (y * self.width + x) * self.channels;
        &self.data[start..start + self.channels]
    }

    /// One-channel value at (x, y).
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }

    /// Row `y` of a one-channel image.
    pub fn row(&self, y: usize) -> &[f32] {
        &self.data[y * self.width..(y + 1) * self.width]
    }

    /// The image turned about a vertical axis as a panorama turns: column u moves to
    /// u + `columns` (mod width).
    pub fn shift_columns(&self, columns: i64) -> Raster {
        let mut out = Raster::new(self.width, self.height, self.channels);
        let shift = columns.rem_euclid(self.width as i64) as usize;
        let row_len = self.width * self.channels;
        for (src, dst) in self.data.chunks(row_len).zip(out.data.chunks_mut(row_len)) {
            let split = (self.width - shift) * self.channels;
            dst[shift * self.channels..].copy_from_slice(&src[..split]);
            dst[..shift * self.channels].copy_from_slice(&src[split..]);
        }
        out
    }

    /// Interpolated values at (x, y) into `out` (one per channel); pixels beyond the border
    /// repeat the border.
    pub fn sample(&self, x: f64, y: f64, interpolation: Interpolation, out: &mut [f32]) {
        match interpolation {
            Interpolation::Bilinear => self.sample_of::<2>(x, y, interpolation, out),
            Interpolation::Bicubic => self.sample_of::<4>(x, y, interpolation, out),
        }
    }

    /// [`Raster::sample`] for a kernel `TAPS` pixels wide (the loops' length known): the
    /// columns clamped once, then each tap's weight times its pixel added, rows in turn.
    #[inline(always)]
    fn sample_of<const TAPS: usize>(&self, x: f64, y: f64, interpolation: Interpolation, out: &mut [f32]) {
        let ((x0, wx), (y0, wy)) = (interpolation.taps(x), interpolation.taps(y));
        let (last_column, last_row) = (self.width as i64 - 1, self.height as i64 - 1);
        let columns: [usize; TAPS] = std::array::from_fn(|i| (x0 + i as i64).clamp(0, last_column) as usize);
        out.fill(0.0);
        for (j, &wyj) in wy[..TAPS].iter().enumerate() {
            let row_start = (y0 + j as i64).clamp(0, last_row) as usize * self.width;
            for (&column, &wxi) in columns.iter().zip(&wx[..TAPS]) {
                let weight = (wxi * wyj) as f32;
                let start = (row_start + column) * self.channels;
                for (o, v) in out.iter_mut().zip(&self.data[start..start + self.channels]) {
                    *o += weight * v;
                }
            }
        }
    }
}

/// `v.floor()`, by truncation where that is the same (0 ≤ v < 9e15, nearly every sample inside
/// an image): `f64::floor` is a call into libm on the baseline x86-64 target. For v = −0 it
/// gives +0, which changes only the sign of zero weights, and a sum that starts at +0 is the
/// same whatever the signs of the zeros added to it.
#[inline]
fn floor(v: f64) -> f64 {
    if (0.0..9e15).contains(&v) {
        (v as i64) as f64
    } else {
        v.floor()
    }
}

impl Raster {
    /// One channel's bilinear value at (x, y), equal bit for bit to [`Raster::sample`] with
    /// [`Interpolation::Bilinear`] (the same products, summed in the same order): the Radon
    /// transform's inner loop, where the general sampler's dispatch cost most of the time.
    #[inline]
    pub fn bilinear_one(&self, x: f64, y: f64) -> f32 {
        debug_assert_eq!(self.channels, 1);
        let (bx, by) = (floor(x), floor(y));
        let (tx, ty) = (x - bx, y - by);
        let (x0, y0) = (bx as i64, by as i64);
        let clamp_x = |i: i64| i.clamp(0, self.width as i64 - 1) as usize;
        let clamp_y = |j: i64| j.clamp(0, self.height as i64 - 1) as usize;
        let (xa, xb, ya, yb) = (clamp_x(x0), clamp_x(x0 + 1), clamp_y(y0), clamp_y(y0 + 1));
        let (row_a, row_b) = (ya * self.width, yb * self.width);
        let (wx, wy) = ([1.0 - tx, tx], [1.0 - ty, ty]);
        let mut value = 0.0f32;
        value += (wx[0] * wy[0]) as f32 * self.data[row_a + xa];
        value += (wx[1] * wy[0]) as f32 * self.data[row_a + xb];
        value += (wx[0] * wy[1]) as f32 * self.data[row_b + xa];
        value += (wx[1] * wy[1]) as f32 * self.data[row_b + xb];
        value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sum of every kernel tap as the sampler was first written (libm's `floor`, every tap
    /// clamped, one channel after another): the reference the faster paths must equal bit for bit.
    fn reference_sample(image: &Raster, x: f64, y: f64, interpolation: Interpolation) -> Vec<f32> {
        let taps = |v: f64| interpolation.taps_from(v, v.floor());
        let ((x0, wx), (y0, wy), n) = (taps(x), taps(y), interpolation.width());
        let mut out = vec![0.0f32; image.channels];
        for (j, &wyj) in wy[..n].iter().enumerate() {
            let yy = (y0 + j as i64).clamp(0, image.height as i64 - 1) as usize;
            for (i, &wxi) in wx[..n].iter().enumerate() {
                let xx = (x0 + i as i64).clamp(0, image.width as i64 - 1) as usize;
                for (o, v) in out.iter_mut().zip(image.pixel(xx, yy)) {
                    *o += (wxi * wyj) as f32 * v;
                }
            }
        }
        out
    }

    /// `sample` equals the reference bit for bit for both kernels and any channel count: inside,
    /// on the border, beyond it (clamped taps), at −0 and at whole pixels (zero weights).
    #[test]
    fn samplers_equal_the_reference() {
        let (w, h) = (9, 7);
        for channels in [1, 3] {
            let data = (0..w * h * channels)
                .map(|i| ((i * 37 % 23) as f32 - 9.0).sin())
                .collect();
            let image = Raster::from_vec(w, h, channels, data).unwrap();
            for interpolation in [Interpolation::Bilinear, Interpolation::Bicubic] {
                let mut points = vec![(-0.0, -0.0), (0.0, 3.0), (4.0, -0.0), (8.0, 6.0), (-0.5, 6.5)];
                points.extend((0..600).map(|k| (-2.3 + f64::from(k % 30) * 0.47, -1.9 + f64::from(k / 30) * 0.53)));
                for (x, y) in points {
                    let expected = reference_sample(&image, x, y, interpolation);
                    let mut out = vec![f32::NAN; channels];
                    image.sample(x, y, interpolation, &mut out);
                    let bits = |v: &[f32]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert_eq!(
                        bits(&out),
                        bits(&expected),
                        "{interpolation:?} ({x}, {y}), {channels} channel(s)"
                    );
                }
            }
        }
    }

    /// The one-channel bilinear fast path equals the general sampler bit for bit, inside the
    /// image, on its border and beyond it.
    #[test]
    fn bilinear_one_equals_sample() {
        let (w, h) = (7, 5);
        let data = (0..w * h).map(|i| ((i * 37 % 11) as f32).sin()).collect();
        let image = Raster::from_vec(w, h, 1, data).unwrap();
        let mut out = [0.0];
        for k in 0..400 {
            let (x, y) = (-1.5 + f64::from(k % 20) * 0.47, -1.2 + f64::from(k / 20) * 0.39);
            image.sample(x, y, Interpolation::Bilinear, &mut out);
            assert_eq!(image.bilinear_one(x, y).to_bits(), out[0].to_bits(), "({x}, {y})");
        }
    }

    /// Both kernels reproduce a linear ramp exactly (partition of unity, linear precision), and
    /// bicubic also a quadratic: a wrong weight or tap offset breaks these.
    #[test]
    fn kernels_reproduce_polynomials() {
        let (w, h) = (12, 9);
        let quad = |x: f64, y: f64| 0.3 + 0.02 * x + 0.05 * y + 0.004 * x * x - 0.003 * y * y;
        let lin = |x: f64, y: f64| 0.3 + 0.02 * x + 0.05 * y;
        for (f, interp, exact_quadratic) in [
            (lin as fn(f64, f64) -> f64, Interpolation::Bilinear, false),
            (quad, Interpolation::Bicubic, true),
        ] {
            let data = (0..h)
                .flat_map(|y| (0..w).map(move |x| f(x as f64, y as f64) as f32))
                .collect();
            let image = Raster::from_vec(w, h, 1, data).unwrap();
            let mut out = [0.0];
            for &(x, y) in &[(3.25, 4.5), (5.9, 2.1), (7.0, 6.0), (2.5, 3.75)] {
                image.sample(x, y, interp, &mut out);
                assert!(
                    (f64::from(out[0]) - f(x, y)).abs() < 1e-5,
                    "{interp:?} at ({x}, {y}): {} vs {} (quadratic {exact_quadratic})",
                    out[0],
                    f(x, y)
                );
            }
        }
    }

    #[test]
    fn column_shift_wraps() {
        let image = Raster::from_vec(4, 1, 2, (0..8).map(|v| v as f32).collect()).unwrap();
        assert_eq!(
            image.shift_columns(1).data,
            vec![6.0, 7.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
        );
        assert_eq!(image.shift_columns(-3), image.shift_columns(1));
    }
}
