//! SURF keypoints and descriptors (Bay, Tuytelaars & Van Gool 2006, ECCV; the journal version
//! Bay et al. 2008, CVIU 110(3)).
//!
//! - Integral image (§2): box sums in four look-ups, on the 0..255 intensity scale so that
//!   the Hessian threshold means what `OpenCV`'s `hessianThreshold` means.
//! - Fast-Hessian detector (§3): box-filter approximations Dxx, Dyy, Dxy of side L, each
//!   normalised by L², and det(H) = Dxx·Dyy − (w·Dxy)², w = 0.9. Octave o (from 0) and
//!   interval i (from 0) use L = 3·(2^(o+1)·(i + 1) + 1): 9, 15, 21, 27; 15, 27, 39, 51; …
//!   (Fig. 3), sampled every 2^o pixels. Maxima of det above the threshold over their 26
//!   neighbours, refined by the quadratic fit (Brown & Lowe 2002; offsets up to one sample
//!   kept, as `OpenCV`). Scale σ = 1.2·L/9.
//! - Orientation (§4.1): Haar-wavelet responses of side 4σ at samples σ apart within 6σ,
//!   weighted by a Gaussian of 2σ; a sliding window of 60° (stepped by 5°) sums them and the
//!   longest sum gives the angle.
//! - Descriptor (§4.2): a 20σ square turned to that angle, 4 × 4 sub-regions of 5 × 5
//!   samples, Haar responses of side 2σ weighted by a Gaussian of 3.3σ and turned into the
//!   keypoint's frame; per sub-region Σdx, Σ|dx|, Σdy, Σ|dy|; unit length. The wavelets stay
//!   axis-aligned at the turned sample points (as `OpenSURF`), so invariance to rotation is
//!   approximate, as it is in the paper. Upright SURF (U-SURF) skips the orientation.
//!
//! Written here: no maintained Rust crate implements SURF (it was patented until 2020 and
//! `OpenCV` keeps it in the non-free contrib module, absent from the pip wheels).

use rayon::prelude::*;

use crate::keypoints::{Features, Keypoint, QuadraticFit, is_extremum, neighbourhood, normalise};
use crate::{Raster, VisionError, require};

/// SURF's parameters; `Default` gives the paper's values (and `OpenCV`'s threshold).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfParams {
    /// Smallest det(H) of a keypoint, intensities 0..255 (`OpenCV`'s default, 100).
    pub hessian_threshold: f32,
    /// Octaves (4).
    pub octaves: usize,
    /// Filter sizes per octave (4; extrema are sought in the inner ones).
    pub intervals: usize,
    /// Sampling step of the first octave in pixels, doubled every octave (1).
    pub initial_step: usize,
    /// Weight w of Dxy in det(H) (0.9).
    pub hessian_weight: f32,
    /// Skip the orientation: U-SURF, every angle 0.
    pub upright: bool,
    /// Width of the orientation window in degrees (60).
    pub orientation_window: f32,
    /// Step of the orientation window in degrees (5).
    pub orientation_step: f32,
}

impl Default for SurfParams {
    fn default() -> Self {
        Self {
            hessian_threshold: 100.0,
            octaves: 4,
            intervals: 4,
            initial_step: 1,
            hessian_weight: 0.9,
            upright: false,
            orientation_window: 60.0,
            orientation_step: 5.0,
        }
    }
}

impl SurfParams {
    /// Checks every setting (ranges in the messages).
    pub fn validate(&self) -> Result<(), VisionError> {
        require(
            self.hessian_threshold.is_finite() && self.hessian_threshold >= 0.0,
            "hessian_threshold",
            || format!("{} must be 0 or more", self.hessian_threshold),
        )?;
        require((1..=8).contains(&self.octaves), "octaves", || {
            format!("{} must be 1 to 8", self.octaves)
        })?;
        require((3..=8).contains(&self.intervals), "intervals", || {
            format!("{} must be 3 to 8", self.intervals)
        })?;
        require((1..=8).contains(&self.initial_step), "initial_step", || {
            format!("{} must be 1 to 8", self.initial_step)
        })?;
        require(
            self.hessian_weight.is_finite() && self.hessian_weight >= 0.0,
            "hessian_weight",
            || format!("{} must be 0 or more", self.hessian_weight),
        )?;
        require(
            self.orientation_window > 0.0 && self.orientation_window <= 360.0,
            "orientation_window",
            || format!("{} must be in (0, 360]", self.orientation_window),
        )?;
        require(
            self.orientation_step > 0.0 && self.orientation_step <= 360.0,
            "orientation_step",
            || format!("{} must be in (0, 360]", self.orientation_step),
        )
    }
}

/// Values per SURF descriptor: 4 × 4 sub-regions × (Σdx, Σ|dx|, Σdy, Σ|dy|).
pub const DESCRIPTOR_LENGTH: usize = 64;

/// SURF keypoints and descriptors of an image (colour is converted to grey; values 0..1).
pub fn surf(image: &Raster, params: &SurfParams) -> Result<Features, VisionError> {
    params.validate()?;
    let integral = Integral::new(&image.to_grey());
    let mut keypoints: Vec<Keypoint> = (0..params.octaves)
        .into_par_iter()
        .flat_map_iter(|o| octave_keypoints(&integral, o, params))
        .collect();
    if !params.upright {
        keypoints
            .par_iter_mut()
            .for_each(|k| k.angle = orientation(&integral, k, params));
    }
    let descriptors = keypoints
        .par_iter()
        .flat_map_iter(|k| descriptor(&integral, k))
        .collect();
    Ok(Features {
        keypoints,
        length: DESCRIPTOR_LENGTH,
        descriptors,
    })
}

/// Side of the box filter of octave `o`, interval `i` (Bay et al. 2006 Fig. 3).
fn filter_side(o: usize, i: usize) -> usize {
    3 * ((2 << o) * (i + 1) + 1)
}

/// Summed-area table, (w + 1) × (h + 1), f64 so that sums of large boxes keep their digits.
struct Integral {
    width: usize,
    height: usize,
    sums: Vec<f64>,
}

impl Integral {
    fn new(grey: &Raster) -> Self {
        let (w, h) = (grey.width, grey.height);
        let mut sums = vec![0.0f64; (w + 1) * (h + 1)];
        for y in 0..h {
            let mut row = 0.0;
            for x in 0..w {
                row += 255.0 * f64::from(grey.at(x, y));
                sums[(y + 1) * (w + 1) + x + 1] = sums[y * (w + 1) + x + 1] + row;
            }
        }
        Self {
            width: w,
            height: h,
            sums,
        }
    }

    /// Sum over columns x0..=x1 and rows y0..=y1, clipped to the image.
    fn sum(&self, x0: i64, y0: i64, x1: i64, y1: i64) -> f64 {
        let clip = |v: i64, n: usize| v.clamp(0, n as i64) as usize;
        let (x0, x1) = (clip(x0, self.width), clip(x1 + 1, self.width));
        let (y0, y1) = (clip(y0, self.height), clip(y1 + 1, self.height));
        if x1 <= x0 || y1 <= y0 {
            return 0.0;
        }
        let at = |x: usize, y: usize| self.sums[y * (self.width + 1) + x];
        at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0)
    }

    /// Haar wavelets of even side `side` centred at (x, y): (right − left, bottom − top).
    fn haar(&self, x: i64, y: i64, side: i64) -> (f64, f64) {
        let half = side / 2;
        let dx = self.sum(x, y - half, x + half - 1, y + half - 1) - self.sum(x - half, y - half, x - 1, y + half - 1);
        let dy = self.sum(x - half, y, x + half - 1, y + half - 1) - self.sum(x - half, y - half, x + half - 1, y - 1);
        (dx, dy)
    }

    /// det(H) of the box filters of side `side` at (x, y), normalised by the filter's area.
    fn hessian(&self, x: i64, y: i64, side: usize, weight: f32) -> f32 {
        let lobe = (side / 3) as i64;
        let half = (side as i64 - 1) / 2;
        let centre = (lobe - 1) / 2;
        let dxx = self.sum(x - half, y - lobe + 1, x + half, y + lobe - 1)
            - 3.0 * self.sum(x - centre, y - lobe + 1, x + centre, y + lobe - 1);
        let dyy = self.sum(x - lobe + 1, y - half, x + lobe - 1, y + half)
            - 3.0 * self.sum(x - lobe + 1, y - centre, x + lobe - 1, y + centre);
        let dxy = self.sum(x - lobe, y - lobe, x - 1, y - 1) + self.sum(x + 1, y + 1, x + lobe, y + lobe)
            - self.sum(x + 1, y - lobe, x + lobe, y - 1)
            - self.sum(x - lobe, y + 1, x - 1, y + lobe);
        let area = (side * side) as f64;
        let (dxx, dyy, dxy) = (dxx / area, dyy / area, dxy / area);
        (dxx * dyy - (f64::from(weight) * dxy).powi(2)) as f32
    }
}

/// The refined maxima of one octave.
fn octave_keypoints(integral: &Integral, o: usize, params: &SurfParams) -> Vec<Keypoint> {
    let step = params.initial_step << o;
    let (gw, gh) = (integral.width.div_ceil(step), integral.height.div_ceil(step));
    // det(H) on the sample grid, NaN where the filter does not fit in the image.
    let layers: Vec<Vec<f32>> = (0..params.intervals)
        .map(|i| {
            let side = filter_side(o, i);
            let reach = (side - 1) / 2;
            let mut det = vec![f32::NAN; gw * gh];
            det.par_chunks_mut(gw).enumerate().for_each(|(gy, row)| {
                let y = gy * step;
                if y < reach || y + reach >= integral.height {
                    return;
                }
                for (gx, value) in row.iter_mut().enumerate() {
                    let x = gx * step;
                    if x >= reach && x + reach < integral.width {
                        *value = integral.hessian(x as i64, y as i64, side, params.hessian_weight);
                    }
                }
            });
            det
        })
        .collect();
    let mut found = Vec::new();
    if gw < 3 || gh < 3 {
        return found;
    }
    for i in 1..params.intervals - 1 {
        let three = [&layers[i - 1][..], &layers[i][..], &layers[i + 1][..]];
        for gy in 1..gh - 1 {
            for gx in 1..gw - 1 {
                let value = layers[i][gy * gw + gx];
                // NaN (no filter here) fails this test too.
                if value.is_nan() || value <= params.hessian_threshold {
                    continue;
                }
                let Some(n) = neighbourhood(three, gw, gx, gy) else {
                    continue;
                };
                if !is_extremum(&n, true) {
                    continue;
                }
                let fit = QuadraticFit::new(&n);
                let Some(offset) = fit.offset() else { continue };
                if offset.iter().any(|c| c.abs() > 1.0) {
                    continue;
                }
                let side = filter_side(o, i) as f32 + offset.z * (filter_side(o, i + 1) - filter_side(o, i)) as f32;
                found.push(Keypoint {
                    x: (gx as f32 + offset.x) * step as f32,
                    y: (gy as f32 + offset.y) * step as f32,
                    sigma: 1.2 * side / 9.0,
                    angle: 0.0,
                    response: value + fit.gain(&offset),
                    octave: o as i32,
                });
            }
        }
    }
    found
}

/// Bay et al. 2006 §4.1: the keypoint's angle in degrees (+x towards +y).
fn orientation(integral: &Integral, keypoint: &Keypoint, params: &SurfParams) -> f32 {
    let s = keypoint.sigma;
    let side = (2.0 * (2.0 * s).round()).max(2.0) as i64;
    let mut responses = Vec::with_capacity(113);
    for j in -6i64..=6 {
        for i in -6i64..=6 {
            if i * i + j * j > 36 {
                continue;
            }
            let x = (keypoint.x + i as f32 * s).round() as i64;
            let y = (keypoint.y + j as f32 * s).round() as i64;
            let weight = (-((i * i + j * j) as f64) / (2.0 * 2.0 * 2.0)).exp();
            let (dx, dy) = integral.haar(x, y, side);
            let (dx, dy) = (weight * dx, weight * dy);
            responses.push((dy.atan2(dx).to_degrees().rem_euclid(360.0), dx, dy));
        }
    }
    let half = f64::from(params.orientation_window) / 2.0;
    let mut best = (0.0, 0.0f64);
    let mut start = 0.0f64;
    while start < 360.0 {
        let (mut sx, mut sy) = (0.0, 0.0);
        for &(angle, dx, dy) in &responses {
            let d = (angle - start).abs();
            if d < half || d > 360.0 - half {
                sx += dx;
                sy += dy;
            }
        }
        let length = sx * sx + sy * sy;
        if length > best.1 {
            best = (sy.atan2(sx).to_degrees().rem_euclid(360.0), length);
        }
        start += f64::from(params.orientation_step);
    }
    best.0 as f32
}

/// Bay et al. 2006 §4.2: the 64 values of one keypoint.
fn descriptor(integral: &Integral, keypoint: &Keypoint) -> Vec<f32> {
    let s = f64::from(keypoint.sigma);
    let (sin, cos) = f64::from(keypoint.angle).to_radians().sin_cos();
    let side = (2.0 * s.round()).max(2.0) as i64;
    let mut out = vec![0.0f32; DESCRIPTOR_LENGTH];
    for v in 0..20 {
        for u in 0..20 {
            // Sample centre in the keypoint's frame, in units of s.
            let (fu, fv) = (u as f64 - 9.5, v as f64 - 9.5);
            let x = f64::from(keypoint.x) + s * (fu * cos - fv * sin);
            let y = f64::from(keypoint.y) + s * (fu * sin + fv * cos);
            let weight = (-(fu * fu + fv * fv) / (2.0 * 3.3 * 3.3)).exp();
            let (dx, dy) = integral.haar(x.round() as i64, y.round() as i64, side);
            let along = weight * (dx * cos + dy * sin);
            let across = weight * (-dx * sin + dy * cos);
            let region = &mut out[((v / 5) * 4 + u / 5) * 4..][..4];
            region[0] += along as f32;
            region[1] += along.abs() as f32;
            region[2] += across as f32;
            region[3] += across.abs() as f32;
        }
    }
    normalise(&mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box sums of the integral image against direct sums, the filter sides of the
    /// paper's Fig. 3, and the Haar wavelets' signs on a ramp.
    #[test]
    fn integral_image_and_filters() {
        let (w, h) = (13, 11);
        let data: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 11) as f32 / 10.0).collect();
        let image = Raster::from_vec(w, h, 1, data.clone()).unwrap();
        let integral = Integral::new(&image);
        let direct: f64 = (2..=7)
            .flat_map(|y| (3..=9).map(move |x| (x, y)))
            .map(|(x, y)| 255.0 * f64::from(data[y * w + x]))
            .sum();
        assert!((integral.sum(3, 2, 9, 7) - direct).abs() < 1e-6);
        assert_eq!([0, 1, 2, 3].map(|i| filter_side(1, i)), [15, 27, 39, 51]);
        assert_eq!(filter_side(3, 3), 195);
        let ramp = Raster::from_vec(20, 20, 1, (0..400).map(|i| (i % 20) as f32 / 20.0).collect()).unwrap();
        let (dx, dy) = Integral::new(&ramp).haar(10, 10, 4);
        assert!(dx > 0.0 && dy.abs() < 1e-9, "{dx} {dy}");
    }

    /// Gaussian blobs of σ₀ = 4 and 8 px: the strongest keypoint sits at the blob's centre, its
    /// scale doubles with the blob's (scale covariance, within 10 %) and its descriptor has
    /// unit length. The ideal scale-normalised determinant of the Hessian peaks at σ = σ₀
    /// (Lindeberg 1998); the paper's σ = 1.2·L/9 of a box filter of side L reads 0.75·σ₀
    /// (the filters' lobes are wider than those of a Gaussian of that σ), asserted 0.65–0.85.
    #[test]
    fn a_blob_is_a_keypoint_at_its_centre_and_scale() {
        let (size, cx, cy) = (160usize, 80.0f32, 78.0f32);
        let found: Vec<f32> = [4.0f32, 8.0]
            .iter()
            .map(|&sigma0| {
                let data = (0..size * size)
                    .map(|i| {
                        let (x, y) = ((i % size) as f32, (i / size) as f32);
                        0.2 + 0.6 * (-((x - cx).powi(2) + (y - cy).powi(2)) / (2.0 * sigma0 * sigma0)).exp()
                    })
                    .collect();
                let features = surf(&Raster::from_vec(size, size, 1, data).unwrap(), &SurfParams::default()).unwrap();
                let best = features
                    .keypoints
                    .iter()
                    .max_by(|a, b| a.response.total_cmp(&b.response))
                    .unwrap();
                assert!((best.x - cx).hypot(best.y - cy) < 1.0, "{best:?}");
                assert!((0.65..0.85).contains(&(best.sigma / sigma0)), "{best:?} vs σ₀ {sigma0}");
                let norm: f32 = features.descriptor(0).iter().map(|v| v * v).sum::<f32>().sqrt();
                assert!((norm - 1.0).abs() < 1e-4);
                best.sigma
            })
            .collect();
        assert!((found[1] / found[0] - 2.0).abs() < 0.2, "{found:?}");
    }

    #[test]
    fn bad_parameters_are_refused() {
        let bad = SurfParams {
            intervals: 2,
            ..SurfParams::default()
        };
        assert!(matches!(
            surf(&Raster::new(32, 32, 1), &bad),
            Err(VisionError::Parameter { name: "intervals", .. })
        ));
        assert!(
            surf(&Raster::new(4, 4, 1), &SurfParams::default())
                .unwrap()
                .keypoints
                .is_empty()
        );
    }
}
