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

use omnisim::avx2::Avx2;
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
    // Lines the passes read are whole runs long (`convolve`): the horizontal pass's padded row
    // and the intermediate rows end in columns past the image's, which no output keeps.
    let stride = w.div_ceil(RUN) * RUN;
    let avx2 = Avx2::detected();
    let mut rows = buffers::take(stride * h);
    // The horizontal pass's lines are the padded row from each tap's offset: the same for
    // every row.
    let shifts: Vec<usize> = (0..taps.len()).collect();
    rows.par_chunks_mut(stride * ROWS_PER_TASK)
        .zip(image.data.par_chunks(w * ROWS_PER_TASK))
        .for_each_init(
            || vec![0.0f32; stride + 2 * radius],
            |padded, (out, source)| {
                for (out, row) in out.chunks_mut(stride).zip(source.chunks(w)) {
                    padded[radius..radius + w].copy_from_slice(row);
                    for i in (0..radius).chain(radius + w..w + 2 * radius) {
                        padded[i] = row[reflect(i as i64 - radius as i64, w)];
                    }
                    convolve(padded, &shifts, &taps, out, avx2);
                }
            },
        );
    let mut data = buffers::take(w * h);
    data.par_chunks_mut(w * ROWS_PER_TASK)
        .enumerate()
        .for_each_init(Vec::new, |starts, (task, out)| {
            for (k, out) in out.chunks_mut(w).enumerate() {
                let y = (task * ROWS_PER_TASK + k) as i64;
                starts.clear();
                starts.extend((-(radius as i64)..=radius as i64).map(|t| reflect(y + t, h) * stride));
                convolve(&rows, starts, &taps, out, avx2);
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

/// `work()`, compiled for AVX2 where `avx2` proves the CPU has it ([`Avx2::detected`]): its
/// loops then run eight lanes wide, with the same results (the same operations in the same
/// order, no fused multiply-add). Only where `work` is inlined, so callers mark the closure
/// `#[inline(always)]`: left out of line, it is compiled without AVX2.
#[inline(always)]
pub(crate) fn with_avx2<R>(avx2: Option<Avx2>, work: impl FnOnce() -> R) -> R {
    match avx2 {
        Some(proof) => proof.run(work),
        None => work(),
    }
}

/// One output line of either pass: `out[x]` = centre·line(0)[x] + Σ taps[j]·(line(−d)[x] +
/// line(d)[x]) with d = radius − j, line(t) being the input line t taps away, which starts at
/// `source[starts[radius + t]]` and is `out`'s length rounded up to whole [`RUN`]s long (the
/// last run's extra sums are not stored). With `avx2` (a proof the CPU has it) eight lanes
/// wide.
///
/// # Panics
/// If a line does not fit in `source`, or `starts` is not one per tap.
fn convolve(source: &[f32], starts: &[usize], taps: &[f32], out: &mut [f32], avx2: Option<Avx2>) {
    let length = out.len().div_ceil(RUN) * RUN;
    assert!(
        starts.len() == taps.len()
            && taps.len() % 2 == 1
            && starts
                .iter()
                .all(|&start| source.len().checked_sub(length).is_some_and(|last| start <= last)),
        "every line of the blur lies inside its source"
    );
    with_avx2(
        avx2,
        #[inline(always)]
        || convolve_in(source, starts, taps, out),
    );
}

/// Outputs [`convolve_in`] sums over every tap before storing them: a run this long stays in
/// vector registers (8 of AVX2's 16), where reading and writing the whole output line back for
/// each tap had the loads and stores outnumber the arithmetic. Lines are whole runs long, so
/// the last outputs of a line are a run too: a partial run summed sample by sample cost a
/// third as much as all the whole runs (callgrind, omni 250² SIFT).
const RUN: usize = 64;

/// [`convolve`] once its lines are checked. Its runs read the lines without bounds checks:
/// checking two slices per tap and run cost a quarter as much as the arithmetic (callgrind,
/// omni 250² SIFT), for lines `convolve` has checked whole.
#[inline(always)]
fn convolve_in(source: &[f32], starts: &[usize], taps: &[f32], out: &mut [f32]) {
    let radius = taps.len() / 2;
    let centre = taps[radius];
    let (before, after) = (&starts[..radius], &starts[radius + 1..]);
    for (k, run) in out.chunks_mut(RUN).enumerate() {
        let at = |start: usize| -> &[f32; RUN] {
            // SAFETY: `convolve` checked that each line, `start` + the runs of `out` rounded up,
            // lies inside `source`; this run is one of them.
            unsafe { &*source.as_ptr().add(start + k * RUN).cast::<[f32; RUN]>() }
        };
        let mut sum: [f32; RUN] = at(starts[radius]).map(|v| centre * v);
        // Tap j pairs line −d (before[j]) with line d (after[radius − 1 − j]), d = radius − j.
        for ((&tap, &minus), &plus) in taps[..radius].iter().zip(before).zip(after.iter().rev()) {
            for ((o, &a), &b) in sum.iter_mut().zip(at(minus)).zip(at(plus)) {
                *o += tap * (a + b);
            }
        }
        run.copy_from_slice(&sum[..run.len()]);
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
    /// [`RUN`] (150: two runs and a partial one), exactly one run wide (64), one column or one
    /// row, and shorter than the kernel (mirrored more than once); the AVX2 and portable builds
    /// agree bit for bit.
    #[test]
    fn blur_equals_the_direct_sum_with_mirrored_borders() {
        for (w, h) in [(37, 13), (13, 70), (150, 9), (64, 5), (1, 9), (9, 1)] {
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
                let stride = w.div_ceil(RUN) * RUN;
                let padded: Vec<Vec<f32>> = (0..h)
                    .map(|y| {
                        (0..stride)
                            .map(|x| if x < w { image.at(x, y) } else { f32::NAN })
                            .collect()
                    })
                    .collect();
                let source: Vec<f32> = padded.concat();
                let starts: Vec<usize> = (-r..=r).map(|t| reflect(5 + t, h) * stride).collect();
                let (mut portable, mut wide) = (vec![0.0; w], vec![0.0; w]);
                convolve(&source, &starts, &taps, &mut portable, None);
                convolve(&source, &starts, &taps, &mut wide, Avx2::detected());
                assert_eq!(portable, wide);
            }
        }
        assert_eq!(
            (reflect(-1, 5), reflect(5, 5), reflect(-9, 5), reflect(3, 1)),
            (1, 3, 1, 0)
        );
    }

    /// A line that would end past its source is refused before any run reads it: the runs
    /// read without bounds checks.
    #[test]
    #[should_panic(expected = "every line of the blur lies inside its source")]
    fn a_line_past_its_source_is_refused() {
        let taps = kernel(1.0);
        let source = vec![0.0; RUN + taps.len() - 2];
        let starts: Vec<usize> = (0..taps.len()).collect();
        convolve(&source, &starts, &taps, &mut [0.0; 3], Avx2::detected());
    }
}
