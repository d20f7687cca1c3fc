//! gist: mean Gabor energy over blocks of the image (Oliva & Torralba 2001; the filter bank
//! of Torralba's reference `LMgist` code), standard (an n × n grid) and panoramic (k horizontal
//! blocks spanning the full width: rotation invariant, Payá et al. 2014, Sensors 14(2);
//! Amorós et al. 2021, Sensors 21(10), §2.3).
//!
//! Filter (scale s = 0.., orientation o of `n_o`), in the frequency domain:
//! G(f, θ) = `exp(−10·0.35·(|f|/f_s` − 1)² − `2π·(16·n_o²/32²)·wrap(θ` + `π·o/n_o)²`), with
//! `f_s` = 0.3/1.85^s cycles per pixel, |f| and θ the radial frequency and its angle. `LMgist`
//! measures both frequency axes in bins of the image width; here fx is in cycles per pixel
//! along x and fy along y, the same for square images and right for panoramas.
//!
//! Borders: the filtering is a product in the 2-D DFT, which is circular in both axes. Along x
//! that is what a 360° panorama is across its seam, so columns stay circular (and the
//! panoramic variant is exactly invariant to column shifts); along y the top and bottom rows
//! of a panorama are far apart, so the image is padded above and below with
//! [`PADDING`] mirrored rows (`LMgist`'s `padarray(…, 'symmetric')` of 32 pixels) and the padding
//! is cropped after filtering. Other differences from `LMgist`: no resize to 256², no padding in
//! x (`LMgist` pads both axes), no whitening prefilter. Energy is the mean amplitude
//! |image ∗ g| per block, as `LMgist`.

use rustfft::FftDirection;

use crate::fft::{self, C64};
use crate::{Descriptor, Raster, VisionError, require};

/// Scales, orientations and blocks; the default is the standard gist, 4 scales × 8
/// orientations on a 4 × 4 grid (512 values).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GistParams {
    /// Gabor scales (peak frequency 0.3/1.85^s cycles per pixel).
    pub scales: usize,
    /// Orientations per scale.
    pub orientations: usize,
    /// How the filtered images are averaged.
    pub blocks: Blocks,
}

/// How the filtered images are averaged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Blocks {
    /// n × n blocks.
    Grid(usize),
    /// k horizontal blocks, each the full width (panoramas; 16 by default as Payá et al.).
    Horizontal(usize),
}

impl Blocks {
    /// Blocks across and down.
    fn counts(self) -> (usize, usize) {
        match self {
            Blocks::Grid(n) => (n, n),
            Blocks::Horizontal(k) => (1, k),
        }
    }
}

impl Default for GistParams {
    fn default() -> Self {
        Self {
            scales: 4,
            orientations: 8,
            blocks: Blocks::Grid(4),
        }
    }
}

impl GistParams {
    /// Checks the settings that do not depend on the image: 1–16 scales, 1–64 orientations,
    /// at least one block.
    pub fn validate(&self) -> Result<(), VisionError> {
        // Beyond 16 scales the peak frequency is below 1e-4 cycles per pixel; each filter costs a
        // full-image transform, so the bank is bounded.
        check_bank(self.scales, self.orientations)?;
        let (nx, ny) = self.blocks.counts();
        require(nx >= 1 && ny >= 1, "blocks", || "needs at least one block".to_string())
    }

    /// Checks everything, for a `width × height` image: also that the blocks fit it.
    pub fn fits(&self, width: usize, height: usize) -> Result<(), VisionError> {
        self.validate()?;
        let (nx, ny) = self.blocks.counts();
        require(nx <= width && ny <= height, "blocks", || {
            format!("{nx}×{ny} blocks do not fit a {width}×{height} image")
        })
    }

    /// The panoramic variant: 4 scales × 8 orientations over 16 horizontal blocks.
    pub fn panoramic() -> Self {
        Self {
            blocks: Blocks::Horizontal(16),
            ..Default::default()
        }
    }
}

/// 1–16 scales and 1–64 orientations: the bounds of a Gabor bank (here and in `LMgist`).
pub(crate) fn check_bank(scales: usize, orientations: usize) -> Result<(), VisionError> {
    require(
        (1..=16).contains(&scales) && (1..=64).contains(&orientations),
        "filters",
        || format!("needs 1–16 scales and 1–64 orientations, got {scales} and {orientations}"),
    )
}

/// Transfer function of filter (scale, orientation) at frequency (fx, fy), cycles per pixel.
fn gabor(scale: usize, orientation: usize, orientations: usize, fx: f64, fy: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let centre = 0.3 / 1.85f64.powi(scale as i32);
    let width = 16.0 * (orientations * orientations) as f64 / (32.0 * 32.0);
    let angle = (fy.atan2(fx) + PI * orientation as f64 / orientations as f64 + PI).rem_euclid(TAU) - PI;
    let radial = fx.hypot(fy) / centre - 1.0;
    (-10.0 * 0.35 * radial * radial - 2.0 * width * PI * angle * angle).exp()
}

/// Rows mirrored above and below the image before filtering (`LMgist`'s boundary extension).
pub const PADDING: usize = 32;

/// Source row of padded row `r` (`PADDING` rows above the image), mirrored at the borders as
/// MATLAB's `padarray(…, 'symmetric')`: …, 1, 0 | 0, 1, …, h − 1 | h − 1, h − 2, ….
fn mirrored_row(r: usize, h: usize) -> usize {
    symmetric_index(r as isize - PADDING as isize, h)
}

/// Index `i` (any integer) of an axis of `n` samples extended by MATLAB's
/// `padarray(…, 'symmetric')`: reflected about both ends, edge sample repeated, period 2n.
pub(crate) fn symmetric_index(i: isize, n: usize) -> usize {
    let i = i.rem_euclid(2 * n as isize) as usize;
    if i < n { i } else { 2 * n - 1 - i }
}

/// Frequency of DFT bin k of n, cycles per sample, in [−½, ½).
fn frequency(k: usize, n: usize) -> f64 {
    let k = if 2 * k >= n { k as f64 - n as f64 } else { k as f64 };
    k / n as f64
}

/// Means of a one-channel `width × height` buffer over `nx × ny` blocks, block i spanning
/// ⌊i·n/count⌋ .. ⌊(i+1)·n/count⌋; row-major [ny, nx].
fn block_means(values: &[f64], width: usize, height: usize, nx: usize, ny: usize) -> Vec<f32> {
    let mut sums = vec![0.0f64; nx * ny];
    let mut counts = vec![0usize; nx * ny];
    for (i, v) in values.iter().enumerate() {
        let block = (i / width * ny / height) * nx + (i % width * nx / width);
        sums[block] += v;
        counts[block] += 1;
    }
    sums.iter().zip(&counts).map(|(s, &c)| (s / c as f64) as f32).collect()
}

/// A filter bank: one transfer function per (scale, orientation), scale-major.
pub(crate) type Bank = std::sync::Arc<Vec<Vec<f64>>>;

/// What a bank is made for: (width, padded height, scales, orientations).
type BankSize = (usize, usize, usize, usize);

thread_local! {
    /// The banks this thread made, by (width, padded height, scales, orientations): a data
    /// set's images share one size, and evaluating the bank (an exp and an atan2 per bin and
    /// filter) took half of each image's time. At most [`BANKS_KEPT`] sizes are kept.
    static BANKS: std::cell::RefCell<Vec<(BankSize, Bank)>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Filter banks kept per thread.
const BANKS_KEPT: usize = 4;

/// The bank for a `w × padded` spectrum, made once per thread and size.
pub(crate) fn bank(w: usize, padded: usize, scales: usize, orientations: usize) -> Bank {
    let key = (w, padded, scales, orientations);
    BANKS.with(|banks| {
        let mut banks = banks.borrow_mut();
        if let Some((_, bank)) = banks.iter().find(|(k, _)| *k == key) {
            return bank.clone();
        }
        let bank: Bank = std::sync::Arc::new(
            (0..scales)
                .flat_map(|s| (0..orientations).map(move |o| (s, o)))
                .map(|(s, o)| {
                    (0..w * padded)
                        .map(|i| gabor(s, o, orientations, frequency(i % w, w), frequency(i / w, padded)))
                        .collect()
                })
                .collect(),
        );
        if banks.len() == BANKS_KEPT {
            banks.remove(0);
        }
        banks.push((key, bank.clone()));
        bank
    })
}

/// gist of a one-channel image: shape [scales, orientations, `blocks_y`, `blocks_x`] (`blocks_x` =
/// 1 for horizontal blocks), row-major.
pub fn gist(image: &Raster, params: GistParams) -> Result<Descriptor, VisionError> {
    require(image.channels == 1, "channels", || {
        format!("gist reads one channel, got {}", image.channels)
    })?;
    params.fits(image.width, image.height)?;
    let (nx, ny) = params.blocks.counts();
    let (w, h) = (image.width, image.height);
    // Padded in y only (module docs): `padded` rows, the image's at PADDING..PADDING + h.
    let padded = h + 2 * PADDING;
    let rows: Vec<f32> = (0..padded)
        .flat_map(|r| image.data[mirrored_row(r, h) * w..][..w].iter().copied())
        .collect();
    let mut spectrum = fft::complex(&rows);
    fft::fft2(&mut spectrum, w, padded, FftDirection::Forward);
    let mut values = Vec::with_capacity(params.scales * params.orientations * nx * ny);
    let mut filtered = vec![C64::default(); w * padded];
    for filter in bank(w, padded, params.scales, params.orientations).iter() {
        for ((out, &input), &g) in filtered.iter_mut().zip(&spectrum).zip(filter) {
            *out = input * g;
        }
        fft::fft2(&mut filtered, w, padded, FftDirection::Inverse);
        let amplitude: Vec<f64> = filtered[PADDING * w..(PADDING + h) * w]
            .iter()
            // √(re² + im²), not `norm` (libm's hypot, which guards against overflow that
            // amplitudes of an image cannot reach): it was a tenth of a localization run.
            .map(|c| c.norm_sqr().sqrt())
            .collect();
        values.extend(block_means(&amplitude, w, h, nx, ny));
    }
    Ok(Descriptor {
        shape: vec![params.scales, params.orientations, ny, nx],
        values,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: usize, height: usize, f: impl Fn(f64, f64) -> f64) -> Raster {
        let data = (0..width * height)
            .map(|i| f((i % width) as f64, (i / width) as f64) as f32)
            .collect();
        Raster::from_vec(width, height, 1, data).unwrap()
    }

    /// Every filter peaks at 1 at its own centre frequency and angle.
    #[test]
    fn filters_peak_at_one() {
        for (s, o) in [(0usize, 0usize), (1, 3), (3, 7)] {
            let f = 0.3 / 1.85f64.powi(s as i32);
            let angle = -std::f64::consts::PI * o as f64 / 8.0;
            assert!((gabor(s, o, 8, f * angle.cos(), f * angle.sin()) - 1.0).abs() < 1e-12);
            assert!(gabor(s, o, 8, 1.3 * f * angle.cos(), 1.3 * f * angle.sin()) < 0.9);
        }
    }

    /// A grating at scale 1's frequency and orientation 3's angle: the standard gist is
    /// 4 × 8 × 4 × 4 = 512 values, the largest in filter (1, 3), and its amplitude is half
    /// the grating's (the one-sided filter keeps one of cos's two exponentials) times the
    /// filter's gain at the grating's frequency, in the middle two rows of blocks (the top
    /// and bottom ones see the mirrored padding, where the grating is not a grating).
    #[test]
    fn grating_excites_its_own_filter() {
        let n = 128;
        let angle = -3.0 * std::f64::consts::PI / 8.0;
        let f = 0.3 / 1.85;
        // The nearest whole-cycle frequency, so the grating is periodic in the image.
        let (kx, ky) = (
            (f * angle.cos() * n as f64).round(),
            (f * angle.sin() * n as f64).round(),
        );
        let grating = image(n, n, |x, y| {
            (std::f64::consts::TAU * (kx * x + ky * y) / n as f64).cos()
        });
        let Descriptor { shape, values } = gist(&grating, GistParams::default()).unwrap();
        assert_eq!(shape, vec![4, 8, 4, 4]);
        assert_eq!(values.len(), 512);
        let best = (0..32)
            .max_by(|&a, &b| values[a * 16].total_cmp(&values[b * 16]))
            .unwrap();
        assert_eq!((best / 8, best % 8), (1, 3));
        let gain = gabor(1, 3, 8, kx / n as f64, ky / n as f64);
        for v in &values[best * 16 + 4..best * 16 + 12] {
            assert!((f64::from(*v) - 0.5 * gain).abs() < 1e-4, "{v} vs {}", 0.5 * gain);
        }
    }

    /// The panoramic variant is unchanged by whole-column shifts; shape scales × orientations
    /// × 16 × 1.
    #[test]
    fn panoramic_gist_is_invariant_to_column_shifts() {
        let panorama = image(128, 32, |x, y| {
            ((0.3 * x).sin() * (0.2 * y).cos() + 0.01 * x * y).fract()
        });
        let Descriptor {
            shape,
            values: reference,
        } = gist(&panorama, GistParams::panoramic()).unwrap();
        assert_eq!(shape, vec![4, 8, 16, 1]);
        for shift in [1, 40, 127] {
            let shifted = gist(&panorama.shift_columns(shift), GistParams::panoramic())
                .unwrap()
                .values;
            for (a, b) in reference.iter().zip(&shifted) {
                assert!((a - b).abs() <= 1e-5 * a.abs().max(1.0), "shift {shift}: {a} vs {b}");
            }
        }
        let standard = gist(&panorama, GistParams::default()).unwrap().values;
        let standard_shifted = gist(&panorama.shift_columns(40), GistParams::default()).unwrap().values;
        // Largest change of one value relative to the largest value: the panoramic variant's is
        // below 1e-5; the grid's blocks see other columns.
        let largest = standard.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let change = standard
            .iter()
            .zip(&standard_shifted)
            .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()))
            / largest;
        eprintln!("grid gist, 40-column shift: largest relative change {change:.3}");
        assert!(change > 0.25, "the grid variant should see the shift: {change}");
    }

    /// The padding mirrors rows as MATLAB's 'symmetric' does, for any height.
    #[test]
    fn rows_are_mirrored() {
        let rows: Vec<usize> = (PADDING - 3..PADDING + 6).map(|r| mirrored_row(r, 3)).collect();
        assert_eq!(rows, [2, 1, 0, 0, 1, 2, 2, 1, 0]);
        // Padding deeper than the image keeps reflecting: period 2h.
        assert!((0..PADDING).all(|r| mirrored_row(r, 3) == mirrored_row(r + 6, 3)));
    }

    /// A panorama's top and bottom rows are far apart: texture in the top 8 rows gives the
    /// bottom block almost no energy. Measured, worst filter's bottom/top ratio: 5.5e-3 (the
    /// filters' tails: their transfer function jumps at f = 0), 1.45 without the padding (a
    /// circular transform in y makes the top and bottom rows neighbours).
    #[test]
    fn top_and_bottom_rows_do_not_touch() {
        let panorama = image(128, 64, |x, y| if y < 8.0 { (0.9 * x + 0.7 * y).sin() } else { 0.0 });
        let values = gist(&panorama, GistParams::panoramic()).unwrap().values;
        // [scales, orientations, 16, 1]: block 0 is the top, block 15 the bottom.
        let worst = values.chunks(16).map(|f| f[15] / f[0].max(1e-6)).fold(0.0f32, f32::max);
        assert!(worst < 0.02, "bottom/top block energy up to {worst}");
        assert!(values.chunks(16).any(|filter| filter[0] > 0.05));
    }
}
