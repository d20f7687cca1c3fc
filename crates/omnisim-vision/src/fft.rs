//! Row-wise and 2-D discrete Fourier transforms of images, on rustfft (and realfft, its
//! maintainer's real-input transform, for rows of real values).
//!
//! rustfft transforms 1-D buffers only; the 2-D transform is its row transform, a transpose and
//! the row transform again (what FFTW's and numpy's `fft2` compute, unnormalised forward,
//! 1/(W·H) inverse).

use std::cell::RefCell;
use std::sync::Arc;

use realfft::{RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftDirection, FftPlanner};

/// A complex sample in f64.
pub type C64 = Complex<f64>;

thread_local! {
    /// One planner per thread: rustfft's planner keeps every plan it made, so each size and
    /// direction is planned once per thread (gist makes 2 × 32 transforms of one size per image).
    static PLANNER: RefCell<FftPlanner<f64>> = RefCell::new(FftPlanner::new());
}

thread_local! {
    /// The same for transforms of real samples, which `realfft` computes as a complex transform
    /// of half the length: half the work of a complex transform of the samples.
    static REAL_PLANNER: RefCell<RealFftPlanner<f64>> = RefCell::new(RealFftPlanner::new());
}

/// The plan for `len` samples in `direction`, from this thread's planner.
fn plan(len: usize, direction: FftDirection) -> Arc<dyn Fft<f64>> {
    PLANNER.with(|planner| planner.borrow_mut().plan_fft(len, direction))
}

/// The first `keep` (at most `width / 2 + 1`) forward DFT coefficients of every row of the
/// row-major real `width`-wide `values`, row after row: coefficients k ≤ width/2 of a real row
/// are all its spectrum holds (the rest are their conjugates), so a real transform gives them
/// for half a complex one's work.
///
/// # Panics
/// If `width` is 0, `keep` exceeds `width / 2 + 1`, or `values` is not whole rows.
pub fn real_rows(values: &[f32], width: usize, keep: usize) -> Vec<C64> {
    assert!(
        width >= 1 && keep <= width / 2 + 1 && values.len().is_multiple_of(width),
        "real_rows needs width ≥ 1, keep ≤ width/2 + 1 and whole rows: width {width}, keep {keep}, {} values",
        values.len()
    );
    if width.is_multiple_of(2) && (1..=width / 4).contains(&keep) {
        return low_bins_of_even_rows(values, width, keep);
    }
    let plan: Arc<dyn RealToComplex<f64>> = REAL_PLANNER.with(|planner| planner.borrow_mut().plan_fft_forward(width));
    let mut row = plan.make_input_vec();
    let mut spectrum = plan.make_output_vec();
    let mut scratch = plan.make_scratch_vec();
    let mut kept = Vec::with_capacity(values.len() / width * keep);
    for samples in values.chunks_exact(width) {
        row.iter_mut().zip(samples).for_each(|(r, &s)| *r = f64::from(s));
        plan.process_with_scratch(&mut row, &mut spectrum, &mut scratch)
            .expect("the row, spectrum and scratch lengths are the plan's own");
        kept.extend_from_slice(&spectrum[..keep]);
    }
    kept
}

/// [`real_rows`] for an even `width` and 1 ≤ `keep` ≤ width/4: what `realfft`'s even-length
/// transform computes (the row's sample pairs as one complex FFT of width/2 points, then
/// twiddled sums of bins k and width/2 − k), the same operations in the same order, so the
/// same bits; but only the kept bins are unpacked, where `realfft` unpacks all width/2 + 1
/// (at k = 16 of 512, the unpacking was a third of the Fourier signature's instructions).
fn low_bins_of_even_rows(values: &[f32], width: usize, keep: usize) -> Vec<C64> {
    let half = width / 2;
    let fft = plan(half, FftDirection::Forward);
    // realfft's `compute_twiddle(k, width) * 0.5`.
    let twiddles: Vec<C64> = (1..keep)
        .map(|k| {
            let angle = -2f64 * std::f64::consts::PI / width as f64 * k as f64;
            C64::new(angle.cos(), angle.sin()) * 0.5
        })
        .collect();
    let mut pairs = vec![C64::default(); half];
    let mut spectrum = vec![C64::default(); half];
    let mut scratch = vec![C64::default(); fft.get_outofplace_scratch_len()];
    let mut kept = Vec::with_capacity(values.len() / width * keep);
    for samples in values.chunks_exact(width) {
        for (pair, samples) in pairs.iter_mut().zip(samples.chunks_exact(2)) {
            *pair = C64::new(f64::from(samples[0]), f64::from(samples[1]));
        }
        fft.process_outofplace_with_scratch(&mut pairs, &mut spectrum, &mut scratch);
        kept.push(C64::new(spectrum[0].re + spectrum[0].im, 0.0));
        for (k, twiddle) in (1..keep).zip(&twiddles) {
            let (sum, diff) = (spectrum[k] + spectrum[half - k], spectrum[k] - spectrum[half - k]);
            let real = sum.im * twiddle.re + diff.re * twiddle.im;
            let imaginary = sum.im * twiddle.im - diff.re * twiddle.re;
            kept.push(C64::new(0.5 * sum.re + real, 0.5 * diff.im + imaginary));
        }
    }
    kept
}

/// Transforms every row of the row-major `width`-wide `data` in place.
pub fn rows(data: &mut [C64], width: usize, direction: FftDirection) {
    plan(width, direction).process(data);
}

/// 2-D transform of a row-major `width × height` buffer, in place; the inverse divides by
/// `width × height` so that `inverse(forward(x)) = x`.
pub fn fft2(data: &mut [C64], width: usize, height: usize, direction: FftDirection) {
    rows(data, width, direction);
    let mut transposed = transpose(data, width, height);
    rows(&mut transposed, height, direction);
    data.copy_from_slice(&transpose(&transposed, height, width));
    if direction == FftDirection::Inverse {
        let scale = 1.0 / (width * height) as f64;
        data.iter_mut().for_each(|v| *v *= scale);
    }
}

/// Side of the square tiles [`transpose`] copies one at a time: 32 × 32 complex values read and
/// 32 rows written stay in the first-level cache, where a row-by-row copy strides through the
/// whole output for every input row (it was a tenth of a localization run's time, in gist).
const TILE: usize = 32;

fn transpose(data: &[C64], width: usize, height: usize) -> Vec<C64> {
    let mut out = vec![C64::default(); data.len()];
    for y0 in (0..height).step_by(TILE) {
        for x0 in (0..width).step_by(TILE) {
            for y in y0..(y0 + TILE).min(height) {
                let row = &data[y * width..(y + 1) * width];
                for x in x0..(x0 + TILE).min(width) {
                    out[x * height + y] = row[x];
                }
            }
        }
    }
    out
}

/// A real one-channel buffer as complex numbers.
pub fn complex(values: &[f32]) -> Vec<C64> {
    values.iter().map(|&v| C64::new(f64::from(v), 0.0)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A single 2-D frequency (kx, ky) transforms to one bin of magnitude W·H/2 at (kx, ky)
    /// and its mirror, and the inverse gives the input back.
    #[test]
    fn fft2_of_a_plane_wave() {
        let (w, h, kx, ky) = (8, 6, 3, 2);
        let input: Vec<C64> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let phase = std::f64::consts::TAU * (kx as f64 * x / w as f64 + ky as f64 * y / h as f64);
                C64::new(phase.cos(), 0.0)
            })
            .collect();
        let mut data = input.clone();
        fft2(&mut data, w, h, FftDirection::Forward);
        for (i, v) in data.iter().enumerate() {
            let (x, y) = (i % w, i / w);
            let expected = if (x, y) == (kx, ky) || (x, y) == (w - kx, h - ky) {
                (w * h) as f64 / 2.0
            } else {
                0.0
            };
            assert!((v.norm() - expected).abs() < 1e-9, "bin ({x}, {y}) = {v}");
        }
        fft2(&mut data, w, h, FftDirection::Inverse);
        for (a, b) in data.iter().zip(&input) {
            assert!((a - b).norm() < 1e-12);
        }
    }

    /// The real transform's kept coefficients are the complex transform's, for even and odd
    /// widths, up to the Nyquist bin.
    #[test]
    fn real_rows_match_the_complex_transform() {
        for (width, height) in [(512, 3), (45, 2), (1, 4), (2, 1)] {
            let values: Vec<f32> = (0..width * height)
                .map(|i| ((i * 37 % 101) as f32 / 7.0).sin())
                .collect();
            let keep = width / 2 + 1;
            let kept = real_rows(&values, width, keep);
            let mut full = complex(&values);
            rows(&mut full, width, FftDirection::Forward);
            assert_eq!(kept.len(), height * keep);
            for (row, expected) in kept.chunks(keep).zip(full.chunks(width)) {
                for (k, (a, b)) in row.iter().zip(expected).enumerate() {
                    assert!(
                        (a - b).norm() < 1e-12 * width as f64,
                        "{width}×{height}, k = {k}: {a} vs {b}"
                    );
                }
            }
        }
    }

    /// The kept low bins of even widths (width/4 of them or fewer, unpacked here) are
    /// `realfft`'s bit for bit: widths that are multiples of 4 and not, one bin and width/4.
    #[test]
    fn low_bins_equal_realfft_bit_for_bit() {
        for (width, height) in [(512, 3), (46, 2), (8, 2), (4, 1), (6, 2)] {
            let values: Vec<f32> = (0..width * height)
                .map(|i| ((i * 53 % 97) as f32 / 5.0).cos() - 0.25)
                .collect();
            let plan = RealFftPlanner::<f64>::new().plan_fft_forward(width);
            for keep in [1, width / 4] {
                let kept = low_bins_of_even_rows(&values, width, keep);
                for (row, samples) in kept.chunks(keep).zip(values.chunks(width)) {
                    let mut input: Vec<f64> = samples.iter().map(|&v| f64::from(v)).collect();
                    let mut spectrum = plan.make_output_vec();
                    plan.process(&mut input, &mut spectrum).unwrap();
                    for (k, (a, b)) in row.iter().zip(&spectrum).enumerate() {
                        let bits = |v: &C64| (v.re.to_bits(), v.im.to_bits());
                        assert_eq!(bits(a), bits(b), "width {width}, keep {keep}, bin {k}");
                    }
                }
            }
        }
    }

    /// Tiled, and sizes that are not whole tiles: every value lands at (x, y) → (y, x).
    #[test]
    fn transpose_moves_every_value() {
        for (w, h) in [(45, 70), (1, 33), (64, 32), (3, 1)] {
            let data: Vec<C64> = (0..w * h).map(|i| C64::new(i as f64, -(i as f64))).collect();
            let out = transpose(&data, w, h);
            for y in 0..h {
                for x in 0..w {
                    assert_eq!(out[x * h + y], data[y * w + x], "{w}×{h} at ({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn plans_are_cached() {
        let (a, b) = (plan(48, FftDirection::Forward), plan(48, FftDirection::Forward));
        assert!(Arc::ptr_eq(&a, &b));
        assert!(!Arc::ptr_eq(&a, &plan(48, FftDirection::Inverse)));
    }
}
