//! Row-wise and 2-D discrete Fourier transforms of images, on rustfft.
//!
//! rustfft transforms 1-D buffers only; the 2-D transform is its row transform, a transpose and
//! the row transform again (what FFTW's and numpy's `fft2` compute, unnormalised forward,
//! 1/(W·H) inverse).

use std::cell::RefCell;
use std::sync::Arc;

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftDirection, FftPlanner};

/// A complex sample in f64.
pub type C64 = Complex<f64>;

thread_local! {
    /// One planner per thread: rustfft's planner keeps every plan it made, so each size and
    /// direction is planned once per thread (gist makes 2 × 32 transforms of one size per image).
    static PLANNER: RefCell<FftPlanner<f64>> = RefCell::new(FftPlanner::new());
}

/// The plan for `len` samples in `direction`, from this thread's planner.
fn plan(len: usize, direction: FftDirection) -> Arc<dyn Fft<f64>> {
    PLANNER.with(|planner| planner.borrow_mut().plan_fft(len, direction))
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

    /// The same size asked twice gets the same cached plan.
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
