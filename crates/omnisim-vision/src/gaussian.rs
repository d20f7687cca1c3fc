//! Separable Gaussian blur of one-channel f32 images, as `OpenCV`'s `GaussianBlur` makes it for
//! f32 images: kernel radius ⌊(⌊8σ + 1⌉ | 1)/2⌋, taps e^(−t²/2σ²) normalised to sum 1, borders
//! mirrored without repeating the edge pixel (`BORDER_REFLECT_101`).
//!
//! Both passes run along memory: the horizontal one over a row copied once with its mirrored
//! margins, the vertical one adding whole rows, so that every step is one multiply-add over a
//! contiguous run of pixels, which the compiler turns into vector instructions. The kernel is
//! symmetric, so each pair of taps at ±t is added before its one multiply (as `OpenCV`'s
//! vectorised filters do). On x86-64 CPUs with AVX2 the same loops run eight lanes wide; the
//! result is bit for bit that of the baseline build (the same additions and multiplies in the
//! same order, no fused multiply-add).
//!
//! Written here: `image::imageops::blur` is u8/f32 RGBA-oriented with its own kernel extent and
//! border, which would move SIFT's keypoints away from `OpenCV`'s; a recursive (IIR) Gaussian
//! is faster for wide kernels but does not give `OpenCV`'s values.

use rayon::prelude::*;

use crate::{Raster, buffers};

/// Rows one rayon task blurs: enough work to pay for the task, small enough to share rows
/// between threads in the smallest octaves.
const ROWS_PER_TASK: usize = 8;

/// The normalised taps −radius..=radius of the Gaussian of `sigma` (module docs).
fn kernel(sigma: f32) -> Vec<f32> {
    let radius = (((8.0 * sigma + 1.0).round() as usize) | 1) / 2;
    let mut taps: Vec<f32> = (0..=2 * radius)
        .map(|i| {
            let t = i as f32 - radius as f32;
            (-t * t / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let total: f32 = taps.iter().sum();
    taps.iter_mut().for_each(|k| *k /= total);
    taps
}

/// Index `i` of a line of `n` samples mirrored about its ends without repeating them
/// (`BORDER_REFLECT_101`: −1 → 1, n → n − 2).
fn reflect(i: i64, n: usize) -> usize {
    if (0..n as i64).contains(&i) {
        return i as usize;
    }
    let n = n as i64;
    if n == 1 {
        return 0;
    }
    let period = 2 * (n - 1);
    let m = i.rem_euclid(period);
    (if m < n { m } else { period - m }) as usize
}

/// The blurred image (module docs).
pub(crate) fn gaussian_blur(image: &Raster, sigma: f32) -> Raster {
    debug_assert_eq!(image.channels, 1);
    let taps = kernel(sigma);
    let radius = taps.len() / 2;
    let (w, h) = (image.width, image.height);
    let avx2 = has_avx2();
    let mut rows = buffers::take(w * h);
    rows.par_chunks_mut(w * ROWS_PER_TASK)
        .zip(image.data.par_chunks(w * ROWS_PER_TASK))
        .for_each_init(
            || vec![0.0f32; w + 2 * radius],
            |padded, (out, source)| {
                for (out, row) in out.chunks_mut(w).zip(source.chunks(w)) {
                    padded[radius..radius + w].copy_from_slice(row);
                    for i in (0..radius).chain(radius + w..w + 2 * radius) {
                        padded[i] = row[reflect(i as i64 - radius as i64, w)];
                    }
                    let line = |t: i64| &padded[(radius as i64 + t) as usize..][..w];
                    convolve(line, &taps, out, avx2);
                }
            },
        );
    let mut data = buffers::take(w * h);
    data.par_chunks_mut(w * ROWS_PER_TASK)
        .enumerate()
        .for_each(|(task, out)| {
            for (k, out) in out.chunks_mut(w).enumerate() {
                let y = (task * ROWS_PER_TASK + k) as i64;
                let line = |t: i64| &rows[reflect(y + t, h) * w..][..w];
                convolve(line, &taps, out, avx2);
            }
        });
    buffers::keep([rows]);
    Raster {
        width: w,
        height: h,
        channels: 1,
        data,
    }
}

/// Whether this CPU runs the AVX2 builds of the passes.
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// One output line of either pass: `out[x]` = centre·line(0)[x] + Σ taps[j]·(line(−d)[x] +
/// line(d)[x]) with d = radius − j, `line(t)` being the input line t taps away, as long as
/// `out`. With `avx2` (only where [`has_avx2`] is true) eight lanes wide.
fn convolve<'a>(line: impl Fn(i64) -> &'a [f32], taps: &[f32], out: &mut [f32], avx2: bool) {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        #[target_feature(enable = "avx2")]
        fn wide<'a>(line: impl Fn(i64) -> &'a [f32], taps: &[f32], out: &mut [f32]) {
            convolve_in(line, taps, out);
        }
        // SAFETY: the caller passes `avx2` true only where `has_avx2` found AVX2.
        return unsafe { wide(line, taps, out) };
    }
    let _ = avx2; // read only on x86-64
    convolve_in(line, taps, out);
}

/// Outputs [`convolve_in`] sums over every tap before storing them: a run this long stays in
/// vector registers (8 of AVX2's 16), where reading and writing the whole output line back for
/// each tap had the loads and stores outnumber the arithmetic.
const RUN: usize = 64;

#[inline(always)]
fn convolve_in<'a>(line: impl Fn(i64) -> &'a [f32], taps: &[f32], out: &mut [f32]) {
    let radius = taps.len() / 2;
    let centre = taps[radius];
    let whole = out.len() / RUN * RUN;
    let (runs, tail) = out.split_at_mut(whole);
    for (k, run) in runs.chunks_exact_mut(RUN).enumerate() {
        let at = |t: i64| -> &[f32; RUN] { line(t)[k * RUN..][..RUN].try_into().expect("a whole run") };
        let mut sum: [f32; RUN] = at(0).map(|v| centre * v);
        for (j, &tap) in taps[..radius].iter().enumerate() {
            let d = (radius - j) as i64;
            for ((o, &a), &b) in sum.iter_mut().zip(at(-d)).zip(at(d)) {
                *o += tap * (a + b);
            }
        }
        run.copy_from_slice(&sum);
    }
    // The same sums, in the same order, for the last partial run.
    let rest = |t: i64| &line(t)[whole..];
    for (o, &v) in tail.iter_mut().zip(rest(0)) {
        *o = centre * v;
    }
    for (j, &tap) in taps[..radius].iter().enumerate() {
        let d = (radius - j) as i64;
        for ((o, &a), &b) in tail.iter_mut().zip(rest(-d)).zip(rest(d)) {
            *o += tap * (a + b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blur keeps a constant image, and blurring an impulse gives the normalised Gaussian
    /// of the asked σ (its second moment is σ²).
    #[test]
    fn blur_of_an_impulse() {
        let mut impulse = Raster::new(41, 41, 1);
        impulse.data[20 * 41 + 20] = 1.0;
        let sigma = 2.5f32;
        let blurred = gaussian_blur(&impulse, sigma);
        let total: f32 = blurred.data.iter().sum();
        let variance: f32 = (0..41)
            .map(|x| blurred.at(x, 20) / blurred.row(20).iter().sum::<f32>() * (x as f32 - 20.0).powi(2))
            .sum();
        assert!((total - 1.0).abs() < 1e-5, "{total}");
        assert!((variance - sigma * sigma).abs() < 0.01 * sigma * sigma, "{variance}");
        let flat = gaussian_blur(&Raster::from_vec(7, 5, 1, vec![0.3; 35]).unwrap(), 1.6);
        assert!(flat.data.iter().all(|v| (v - 0.3).abs() < 1e-6));
    }

    /// Against the direct 2-D sum Σ k(i)·k(j)·f(reflect(x + i), reflect(y + j)) in f64, on
    /// seeded images whose sides are not multiples of the vector width, the task's rows or
    /// [`RUN`] (150: two runs and a tail), and shorter than the kernel (mirrored more than
    /// once); the AVX2 and portable builds agree bit for bit.
    #[test]
    fn blur_equals_the_direct_sum_with_mirrored_borders() {
        for (w, h) in [(37, 13), (13, 70), (150, 9)] {
            let data: Vec<f32> = (0..w * h).map(|i| ((i * 7919 % 103) as f32) / 103.0).collect();
            let image = Raster::from_vec(w, h, 1, data).unwrap();
            for sigma in [0.8f32, 1.6, 3.1] {
                let blurred = gaussian_blur(&image, sigma);
                let taps = kernel(sigma);
                let r = (taps.len() / 2) as i64;
                for y in 0..h {
                    for x in 0..w {
                        let mut direct = 0.0f64;
                        for i in -r..=r {
                            for j in -r..=r {
                                let value = image.at(reflect(x as i64 + j, w), reflect(y as i64 + i, h));
                                direct += f64::from(taps[(i + r) as usize])
                                    * f64::from(taps[(j + r) as usize])
                                    * f64::from(value);
                            }
                        }
                        let got = f64::from(blurred.at(x, y));
                        assert!(
                            (got - direct).abs() < 1e-6,
                            "σ {sigma} at ({x}, {y}): {got} vs {direct}"
                        );
                    }
                }
                let line = |t: i64| &image.data[reflect(5 + t, h) * w..][..w];
                let (mut portable, mut wide) = (vec![0.0; w], vec![0.0; w]);
                convolve(line, &taps, &mut portable, false);
                convolve(line, &taps, &mut wide, has_avx2());
                assert_eq!(portable, wide);
            }
        }
        assert_eq!(
            (reflect(-1, 5), reflect(5, 5), reflect(-9, 5), reflect(3, 1)),
            (1, 3, 1, 0)
        );
    }
}
