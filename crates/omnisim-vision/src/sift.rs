//! SIFT keypoints and descriptors (Lowe 2004, IJCV 60(2)), with `OpenCV`'s choices where the
//! paper leaves one open, so that the features agree with `cv2.SIFT_create()`.
//!
//! - Scale space (§3): the image, optionally doubled by bilinear interpolation (§3.3), is
//!   blurred to σ = 1.6 assuming the input carries σ = 0.5; each octave holds s + 3 Gaussian
//!   images spaced by k = 2^(1/s) and s + 2 differences of Gaussians (`DoG`); the next octave
//!   starts from the image of blur 2σ taken every second pixel. Gaussian kernels reach
//!   ±⌊(8σ + 1)/2⌋ pixels with mirrored borders (`OpenCV`'s `GaussianBlur`).
//! - Extrema (§4): samples above 0.5·c/s that are strict maxima or minima of their 26
//!   neighbours, moved by the quadratic fit (§4) up to 5 times until the offset is below
//!   ½ sample; kept if |D(x̂)|·s ≥ c (c = 0.04: `OpenCV` divides the contrast threshold by the
//!   scales per octave) and if tr(H)²/det(H) < (r + 1)²/r, r = 10 (§4.1).
//! - Orientation (§5): 36-bin histogram of gradient directions in a Gaussian window of
//!   1.5·σ (radius 3·1.5·σ), smoothed with [1 4 6 4 1]/16; every peak within 80 % of the
//!   highest gives a keypoint, its angle refined by a parabola through three bins.
//! - Descriptor (§6): 4 × 4 cells of 3σ pixels, 8 orientation bins, samples in a Gaussian
//!   window of half the descriptor's width, trilinear votes; unit length, values clamped at
//!   0.2, unit length again. `OpenCV` then scales by 512 and rounds to bytes; these stay f32.
//!
//! Written here: the one SIFT crate (`sift-features` 0.1, one release in 2024) is
//! unmaintained and brings imageproc 0.25 with ndarray and a second nalgebra; imageproc and
//! kornia have no SIFT.

use rayon::prelude::*;

use crate::angle::atan2_degrees;
use crate::gaussian::{gaussian_blur, with_avx2};
use crate::keypoints::{Features, Keypoint, QuadraticFit, neighbourhood, normalise};
use crate::{Raster, VisionError, buffers, require};
use omnisim::avx2::Avx2;

/// SIFT's parameters; `Default` gives Lowe's (and `OpenCV`'s) values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SiftParams {
    /// σ of the first image of each octave (1.6).
    pub sigma: f32,
    /// Blur the input image is assumed to carry already (0.5: a sampled image).
    pub input_sigma: f32,
    /// Scales s per octave at which extrema are sought (3).
    pub scales_per_octave: usize,
    /// Contrast threshold c on the 0..1 intensity scale, divided by s as `OpenCV` does (0.04).
    pub contrast_threshold: f32,
    /// Largest ratio r of principal curvatures (10).
    pub edge_ratio: f32,
    /// Bins of the orientation histogram (36).
    pub orientation_bins: usize,
    /// Peaks within this fraction of the highest also give keypoints (0.8).
    pub peak_ratio: f32,
    /// Cells per side of the descriptor (4).
    pub descriptor_width: usize,
    /// Orientation bins per cell (8).
    pub descriptor_bins: usize,
    /// Descriptor values are clamped here after the first normalisation (0.2).
    pub magnitude_clamp: f32,
    /// Double the image first (§3.3; `OpenCV` does by default).
    pub upsample: bool,
    /// Keypoints closer than this to an octave's border are dropped (5 pixels of the octave).
    pub border: usize,
}

impl Default for SiftParams {
    fn default() -> Self {
        Self {
            sigma: 1.6,
            input_sigma: 0.5,
            scales_per_octave: 3,
            contrast_threshold: 0.04,
            edge_ratio: 10.0,
            orientation_bins: 36,
            peak_ratio: 0.8,
            descriptor_width: 4,
            descriptor_bins: 8,
            magnitude_clamp: 0.2,
            upsample: true,
            border: 5,
        }
    }
}

impl SiftParams {
    /// Checks every setting (ranges in the messages).
    pub fn validate(&self) -> Result<(), VisionError> {
        let positive = |v: f32| v.is_finite() && v > 0.0;
        // A σ of 50 already blurs with a 401-tap kernel; beyond it an octave holds no feature.
        require(positive(self.sigma) && self.sigma <= 50.0, "sigma", || {
            format!("{} must be in (0, 50]", self.sigma)
        })?;
        require(
            self.input_sigma.is_finite() && self.input_sigma >= 0.0,
            "input_sigma",
            || format!("{} must be 0 or more", self.input_sigma),
        )?;
        require((1..=16).contains(&self.scales_per_octave), "scales_per_octave", || {
            format!("{} must be 1 to 16", self.scales_per_octave)
        })?;
        require(
            self.contrast_threshold.is_finite() && self.contrast_threshold >= 0.0,
            "contrast_threshold",
            || format!("{} must be 0 or more", self.contrast_threshold),
        )?;
        require(
            self.edge_ratio.is_finite() && self.edge_ratio >= 1.0,
            "edge_ratio",
            || format!("{} must be 1 or more", self.edge_ratio),
        )?;
        require((4..=360).contains(&self.orientation_bins), "orientation_bins", || {
            format!("{} must be 4 to 360", self.orientation_bins)
        })?;
        require(
            positive(self.peak_ratio) && self.peak_ratio <= 1.0,
            "peak_ratio",
            || format!("{} must be in (0, 1]", self.peak_ratio),
        )?;
        require((1..=16).contains(&self.descriptor_width), "descriptor_width", || {
            format!("{} must be 1 to 16", self.descriptor_width)
        })?;
        require((1..=64).contains(&self.descriptor_bins), "descriptor_bins", || {
            format!("{} must be 1 to 64", self.descriptor_bins)
        })?;
        require(positive(self.magnitude_clamp), "magnitude_clamp", || {
            format!("{} must be positive", self.magnitude_clamp)
        })?;
        require(self.border >= 1, "border", || "must be at least 1 pixel".to_string())
    }
}

/// SIFT keypoints and descriptors of an image (colour is converted to grey; values 0..1).
/// An image too small for one octave gives no features.
pub fn sift(image: &Raster, params: &SiftParams) -> Result<Features, VisionError> {
    params.validate()?;
    // Run on one of rayon's threads: the ~80 parallel loops of a run then start there, each
    // without handing work over from a thread outside the pool and waiting for it (a tenth of
    // a 250² image's time on one thread).
    Ok(rayon::scope(|_| features(image, params)))
}

/// [`sift`] once its parameters are checked.
fn features(image: &Raster, params: &SiftParams) -> Features {
    let grey = image.to_grey();
    let s = params.scales_per_octave;
    let smallest_octave = 2 * params.border + 3;
    // Too small for one octave inside the border (the blur keeps the size, the upsampling
    // doubles it): no features, and nothing to blur. An empty image is among them (rayon's
    // chunks of a zero-width row would panic).
    let upsampling = if params.upsample { 2 } else { 1 };
    if grey.width.min(grey.height) * upsampling < smallest_octave {
        return Features {
            keypoints: Vec::new(),
            length: descriptor_length(params),
            descriptors: Vec::new(),
        };
    }
    let first_octave = if params.upsample { -1 } else { 0 };
    let (unblurred, input_sigma) = if params.upsample {
        (upsample(&grey), 2.0 * params.input_sigma)
    } else {
        (grey, params.input_sigma)
    };
    let mut base = gaussian_blur(
        &unblurred,
        (params.sigma.powi(2) - input_sigma.powi(2)).max(0.01).sqrt(),
    );
    let shortest = base.width.min(base.height);
    // OpenCV's count (log2 of the side − 2), then only octaves that leave room inside the border.
    let octaves = ((shortest as f32).log2() - 2.0).round().max(1.0) as usize;
    let octaves = (0..octaves).take_while(|o| shortest >> o >= smallest_octave).count();

    let increments = blur_increments(params.sigma, s);
    let mut gaussians: Vec<Vec<Raster>> = Vec::with_capacity(octaves);
    for o in 0..octaves {
        let mut layers = Vec::with_capacity(s + 3);
        layers.push(if o == 0 {
            std::mem::replace(&mut base, Raster::new(0, 0, 1))
        } else {
            decimate(&gaussians[o - 1][s])
        });
        for &increment in &increments {
            let next = gaussian_blur(layers.last().expect("first layer pushed"), increment);
            layers.push(next);
        }
        gaussians.push(layers);
    }
    let dogs: Vec<Vec<Raster>> = gaussians
        .iter()
        .map(|layers| layers.windows(2).map(|pair| difference(&pair[1], &pair[0])).collect())
        .collect();

    let avx2 = Avx2::detected();
    let candidates: Vec<(usize, usize)> = (0..octaves)
        .flat_map(|o| (1..=s).map(move |layer| (o, layer)))
        .collect();
    let mut keypoints: Vec<(Keypoint, usize, usize)> = candidates
        .par_iter()
        .map_init(Scratch::default, |scratch, &(o, layer)| {
            let scale = 2f32.powi(o as i32 + first_octave);
            // Doubling samples the input at (u + ½)/2 − ½: doubled pixel u sits at u/2 − ¼.
            let shift = if params.upsample { -0.25 } else { 0.0 };
            let mut found = Vec::new();
            for e in extrema(&dogs[o], layer, params, avx2) {
                let octave_sigma = params.sigma * 2f32.powf(e.scale / s as f32);
                orientations(&gaussians[o][e.layer], e.x, e.y, octave_sigma, params, scratch);
                found.extend(scratch.angles.iter().map(|&angle| {
                    let keypoint = Keypoint {
                        x: e.x * scale + shift,
                        y: e.y * scale + shift,
                        sigma: octave_sigma * scale,
                        angle,
                        response: e.contrast.abs(),
                        octave: o as i32 + first_octave,
                    };
                    (keypoint, o, e.layer)
                }));
            }
            found
        })
        .flatten_iter()
        .collect();
    // Two extrema can converge on the same point (OpenCV's removeDuplicatedSorted).
    keypoints.sort_by(|a, b| {
        let key = |k: &Keypoint| [k.x, k.y, k.sigma, k.angle];
        key(&a.0).partial_cmp(&key(&b.0)).expect("finite keypoints")
    });
    keypoints.dedup_by(|a, b| a.0 == b.0);

    let length = descriptor_length(params);
    let mut descriptors = vec![0.0; keypoints.len() * length];
    descriptors.par_chunks_mut(length).zip(&keypoints).for_each_init(
        Scratch::default,
        |scratch, (out, (k, o, layer))| {
            let scale = 2f32.powi(*o as i32 + first_octave);
            let shift = if params.upsample { -0.25 } else { 0.0 };
            let (x, y) = ((k.x - shift) / scale, (k.y - shift) / scale);
            let image = &gaussians[*o][*layer];
            with_avx2(
                avx2,
                #[inline(always)]
                || descriptor(image, (x, y), k.angle, k.sigma / scale, params, scratch, out),
            );
        },
    );
    buffers::keep(gaussians.into_iter().chain(dogs).flatten().map(|layer| layer.data));
    Features {
        keypoints: keypoints.into_iter().map(|(k, _, _)| k).collect(),
        length,
        descriptors,
    }
}

fn descriptor_length(params: &SiftParams) -> usize {
    params.descriptor_width * params.descriptor_width * params.descriptor_bins
}

/// The σ that takes each Gaussian image of an octave to the next: `σ_i` = √(σ_{i}² − σ_{i−1}²)
/// with `σ_i` = k^i·σ.
fn blur_increments(sigma: f32, s: usize) -> Vec<f32> {
    let k = 2f32.powf(1.0 / s as f32);
    (1..s + 3)
        .map(|i| {
            let previous = k.powi(i as i32 - 1) * sigma;
            let total = previous * k;
            (total * total - previous * previous).sqrt()
        })
        .collect()
}

/// A scale-space extremum after refinement, in its octave's pixels and scale steps.
struct Extremum {
    x: f32,
    y: f32,
    /// Layer index plus the fitted offset (0..s+1).
    scale: f32,
    /// The Gaussian layer it was found at (for orientation and descriptor).
    layer: usize,
    contrast: f32,
}

/// Refined extrema of `DoG` layer `layer` of one octave. With `avx2` (a proof the CPU has it)
/// the scan's block tests run eight lanes wide; the extrema are the same.
fn extrema(dogs: &[Raster], layer: usize, params: &SiftParams, avx2: Option<Avx2>) -> Vec<Extremum> {
    with_avx2(
        avx2,
        #[inline(always)]
        || extrema_in(dogs, layer, params, avx2),
    )
}

/// [`extrema`]'s scan: each whole block of [`SCAN_BLOCK`] samples of a row is first tested at
/// once by [`block_candidates`], and only the samples it keeps (few: a fiftieth on a 250² omni
/// image) by the exact test; the partial block at a row's end is tested sample by sample.
#[inline(always)]
fn extrema_in(dogs: &[Raster], layer: usize, params: &SiftParams, avx2: Option<Avx2>) -> Vec<Extremum> {
    let s = params.scales_per_octave;
    let (w, h) = (dogs[layer].width, dogs[layer].height);
    let b = params.border;
    let threshold = 0.5 * params.contrast_threshold / s as f32;
    let layers = [
        &dogs[layer - 1].data[..],
        &dogs[layer].data[..],
        &dogs[layer + 1].data[..],
    ];
    let mut found = Vec::new();
    for y in b..h - b {
        let row = dogs[layer].row(y);
        for start in (b..w - b).step_by(SCAN_BLOCK) {
            let block = start..(start + SCAN_BLOCK).min(w - b);
            let mut candidates = if block.len() == SCAN_BLOCK {
                block_candidates(layers, w, start, y, threshold, avx2)
            } else {
                (1 << block.len()) - 1
            };
            while candidates != 0 {
                let x = start + candidates.trailing_zeros() as usize;
                candidates &= candidates - 1;
                let value = row[x];
                let beats = |layer: usize, own: bool| beats_block(&dogs[layer].data, w, x, y, value, own);
                // An infinite sample is refused as `neighbourhood` would; a NaN one fails `beats`.
                if value.abs() <= threshold
                    || value.is_infinite()
                    || !beats(layer, true)
                    || !beats(layer - 1, false)
                    || !beats(layer + 1, false)
                {
                    continue;
                }
                found.extend(refine(dogs, x, y, layer, params));
            }
        }
    }
    found
}

/// Samples of a row that [`extrema`] tests at once.
const SCAN_BLOCK: usize = 8;

/// Bit i set where sample `start` + i of row `y` of the middle of three `DoG` `layers` (each
/// `w` samples a row) is above `threshold` and strictly above its 26 neighbours in the three
/// layers, or below −`threshold` and strictly below them: a necessary condition for
/// [`extrema`]'s exact test (a NaN neighbour may be passed over here, which the exact test
/// refuses after; a NaN sample fails both), made for [`SCAN_BLOCK`] samples at once. Blocks
/// whose samples are all within the threshold, then blocks where none beats its own layer's 8
/// neighbours, stop early (most of them). With `avx2` (a proof the CPU has it) in
/// AVX2 vectors, with the same result: LLVM's own vectors of the portable code spent most of
/// their instructions moving lanes about (callgrind, omni 250² image). Testing the samples
/// above the threshold one by one, then 8 at once against their own layer alone, was a third
/// of SIFT's time on that image.
///
/// # Panics
/// If the block and its neighbours do not lie inside the layers ([`block_corner`]).
#[inline(always)]
fn block_candidates(layers: [&[f32]; 3], w: usize, start: usize, y: usize, threshold: f32, avx2: Option<Avx2>) -> u32 {
    let corner = block_corner(layers, w, start, y);
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = avx2 {
        // SAFETY: `avx2` proves the CPU has AVX2, and `block_corner` checked every read.
        return unsafe { block_candidates_avx2(avx2, layers, w, corner, threshold) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = avx2;
    let at = |layer: &[f32], (dy, dx): (usize, usize)| -> Lanes {
        layer[corner + dy * w + dx..][..SCAN_BLOCK]
            .try_into()
            .expect("a whole block")
    };
    let centre = at(layers[1], (1, 1));
    if centre.iter().all(|v| v.abs() <= threshold) {
        return 0;
    }
    // The largest and smallest neighbour (`if v > largest { v }`, AVX2's max): a NaN
    // neighbour may be passed over here, but the exact test refuses it after.
    let (mut largest, mut smallest) = ([f32::NEG_INFINITY; SCAN_BLOCK], [f32::INFINITY; SCAN_BLOCK]);
    let widen = |largest: &mut Lanes, smallest: &mut Lanes, lanes: Lanes| {
        for ((largest, smallest), v) in largest.iter_mut().zip(smallest.iter_mut()).zip(lanes) {
            *largest = if v > *largest { v } else { *largest };
            *smallest = if v < *smallest { v } else { *smallest };
        }
    };
    for offset in OWN_LAYER {
        widen(&mut largest, &mut smallest, at(layers[1], offset));
    }
    let beaten = |largest: &Lanes, smallest: &Lanes| {
        (0..SCAN_BLOCK).fold(0, |bits, i| {
            let above = centre[i] > threshold && centre[i] > largest[i];
            let below = centre[i] < -threshold && centre[i] < smallest[i];
            bits | (u32::from(above | below) << i)
        })
    };
    if beaten(&largest, &smallest) == 0 {
        return 0;
    }
    for layer in [layers[0], layers[2]] {
        for offset in OTHER_LAYER {
            widen(&mut largest, &mut smallest, at(layer, offset));
        }
    }
    beaten(&largest, &smallest)
}

/// [`block_candidates`] in AVX2 vectors, from the block's top-left neighbour `corner`.
///
/// # Safety
/// `corner` must be [`block_corner`]'s for these layers (the `Avx2` proof holds the rest).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn block_candidates_avx2(_: Avx2, layers: [&[f32]; 3], w: usize, corner: usize, threshold: f32) -> u32 {
    use std::arch::x86_64::{
        _CMP_GT_OQ, _CMP_LT_OQ, _mm256_and_ps, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps,
        _mm256_movemask_ps, _mm256_or_ps, _mm256_set1_ps,
    };
    // SAFETY: the caller's `corner` is `block_corner`'s, which checked these reads.
    let at =
        |layer: &[f32], (dy, dx): (usize, usize)| unsafe { _mm256_loadu_ps(layer.as_ptr().add(corner + dy * w + dx)) };
    let centre = at(layers[1], (1, 1));
    let above_threshold = _mm256_cmp_ps::<_CMP_GT_OQ>(centre, _mm256_set1_ps(threshold));
    let below_threshold = _mm256_cmp_ps::<_CMP_LT_OQ>(centre, _mm256_set1_ps(-threshold));
    if _mm256_movemask_ps(_mm256_or_ps(above_threshold, below_threshold)) == 0 {
        return 0;
    }
    // `_mm256_max_ps(v, largest)` is `if v > largest { v } else { largest }`, as in the
    // portable code.
    let (mut largest, mut smallest) = (_mm256_set1_ps(f32::NEG_INFINITY), _mm256_set1_ps(f32::INFINITY));
    for offset in OWN_LAYER {
        let v = at(layers[1], offset);
        (largest, smallest) = (_mm256_max_ps(v, largest), _mm256_min_ps(v, smallest));
    }
    let beaten = |largest, smallest| {
        let above = _mm256_and_ps(above_threshold, _mm256_cmp_ps::<_CMP_GT_OQ>(centre, largest));
        let below = _mm256_and_ps(below_threshold, _mm256_cmp_ps::<_CMP_LT_OQ>(centre, smallest));
        _mm256_movemask_ps(_mm256_or_ps(above, below)) as u32
    };
    if beaten(largest, smallest) == 0 {
        return 0;
    }
    for layer in [layers[0], layers[2]] {
        for offset in OTHER_LAYER {
            let v = at(layer, offset);
            (largest, smallest) = (_mm256_max_ps(v, largest), _mm256_min_ps(v, smallest));
        }
    }
    beaten(largest, smallest)
}

/// The index of the top-left neighbour of the [`SCAN_BLOCK`] samples from column `start` of
/// row `y`, in layers of `w` samples a row: [`block_candidates`] reads the block from there
/// plus 0 to 2 rows and columns.
///
/// # Panics
/// If those reads do not lie inside each layer: row `y` must have a row above and below it,
/// and columns `start` − 1 to `start` + [`SCAN_BLOCK`] must exist.
fn block_corner(layers: [&[f32]; 3], w: usize, start: usize, y: usize) -> usize {
    assert!(
        start >= 1 && y >= 1 && start + SCAN_BLOCK < w && layers.iter().all(|l| l.len() >= (y + 2) * w),
        "a block's neighbours lie inside its layers"
    );
    (y - 1) * w + start - 1
}

/// [`SCAN_BLOCK`] samples of a row, one per vector lane.
type Lanes = [f32; SCAN_BLOCK];

/// The (row, column) offsets of a sample's 8 neighbours in its own layer and its 9 in the
/// layers above and below, from its top-left neighbour.
const OWN_LAYER: [(usize, usize); 8] = [(0, 0), (0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1), (2, 2)];
const OTHER_LAYER: [(usize, usize); 9] = [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (2, 0), (2, 1), (2, 2)];

/// Whether `value`, the sample at (x, y) of the middle layer, is strictly above (if positive)
/// or below each value of the 3 × 3 block of `layer` around (x, y), its own sample left out
/// when `own` (`layer` is the sample's layer). A value that is not finite fails, as in
/// [`neighbourhood`]. The exact test of the few samples [`block_candidates`] keeps.
fn beats_block(layer: &[f32], w: usize, x: usize, y: usize, value: f32, own: bool) -> bool {
    let maximum = value > 0.0;
    (y - 1..=y + 1).all(|yy| {
        layer[yy * w + x - 1..][..3].iter().enumerate().all(|(dx, &v)| {
            (own && yy == y && dx == 1) || (v.is_finite() && if maximum { value > v } else { value < v })
        })
    })
}

/// Lowe 2004 §4: moves the sample to the fitted extremum (at most 5 times), then applies the
/// contrast and edge tests.
fn refine(dogs: &[Raster], mut x: usize, mut y: usize, mut layer: usize, params: &SiftParams) -> Option<Extremum> {
    let s = params.scales_per_octave;
    let (w, h) = (dogs[0].width, dogs[0].height);
    let b = params.border;
    for _ in 0..5 {
        let layers = [
            &dogs[layer - 1].data[..],
            &dogs[layer].data[..],
            &dogs[layer + 1].data[..],
        ];
        let n = neighbourhood(layers, w, x, y)?;
        let fit = QuadraticFit::new(&n);
        let offset = fit.offset()?;
        if offset.iter().all(|c| c.abs() < 0.5) {
            let contrast = n[1][1][1] + fit.gain(&offset);
            if contrast.abs() * (s as f32) < params.contrast_threshold {
                return None;
            }
            let (dxx, dyy, dxy) = (fit.hessian[(0, 0)], fit.hessian[(1, 1)], fit.hessian[(0, 1)]);
            let (trace, det) = (dxx + dyy, dxx * dyy - dxy * dxy);
            let r = params.edge_ratio;
            if det <= 0.0 || trace * trace * r >= (r + 1.0).powi(2) * det {
                return None;
            }
            return Some(Extremum {
                x: x as f32 + offset.x,
                y: y as f32 + offset.y,
                scale: layer as f32 + offset.z,
                layer,
                contrast,
            });
        }
        if offset.iter().any(|c| c.abs() > 1e6) {
            return None;
        }
        let step = |v: usize, d: f32| (v as f32 + d.round()) as i64;
        let (nx, ny, nl) = (step(x, offset.x), step(y, offset.y), step(layer, offset.z));
        if nl < 1 || nl > s as i64 || nx < b as i64 || nx >= (w - b) as i64 || ny < b as i64 || ny >= (h - b) as i64 {
            return None;
        }
        (x, y, layer) = (nx as usize, ny as usize, nl as usize);
    }
    None
}

/// e^(scale·t²) for t = −radius..=radius, into `factors`: one axis's factor of a 2-D Gaussian
/// window.
fn gaussian_factors(radius: i64, scale: f32, factors: &mut Vec<f32>) {
    factors.clear();
    factors.extend((-radius..=radius).map(|t| (scale * (t * t) as f32).exp()));
}

/// Buffers a thread reuses from one keypoint to the next (allocated per keypoint before).
#[derive(Default)]
struct Scratch {
    /// One axis's factors of the Gaussian window.
    weights: Vec<f32>,
    /// Orientation: the histogram, smoothed, a row's bins and votes, and the peaks' angles.
    raw: Vec<f32>,
    smoothed: Vec<f32>,
    bins: Vec<usize>,
    votes: Vec<f32>,
    angles: Vec<f32>,
    /// Descriptor: the histogram with its margins, the window's samples, their weighted
    /// magnitudes and orientation bins.
    hist: Vec<f32>,
    samples: Samples,
    magnitudes: Vec<f32>,
    orientation_bins: Vec<f32>,
}

/// Lowe 2004 §5: the angles (degrees, +x towards +y) of the orientation histogram's peaks,
/// into `scratch.angles`.
fn orientations(image: &Raster, x: f32, y: f32, octave_sigma: f32, params: &SiftParams, scratch: &mut Scratch) {
    let n = params.orientation_bins;
    let window = 1.5 * octave_sigma;
    let radius = (3.0 * window).round() as i64;
    let (px, py) = (x.round() as i64, y.round() as i64);
    let Scratch {
        weights,
        raw,
        smoothed,
        bins,
        votes,
        angles,
        ..
    } = scratch;
    raw.clear();
    raw.resize(n, 0.0);
    // The Gaussian window e^(−(i² + j²)/2w²) as the product of its row and column factors.
    gaussian_factors(radius, -1.0 / (2.0 * window * window), weights);
    // Slices from here on: through `&mut Vec` every store into the values reloaded the Vec.
    let (raw, weights) = (&mut raw[..], &weights[..]);
    // The columns inside the image's interior, where a central difference exists.
    let first = (px - radius).max(1);
    let last = (px + radius).min(image.width as i64 - 2);
    let columns = (first - (px - radius)) as usize..(last - (px - radius) + 1).max(0) as usize;
    // Every row overwrites them whole.
    bins.resize(columns.len(), 0);
    votes.resize(columns.len(), 0.0);
    let (bins, votes) = (&mut bins[..], &mut votes[..]);
    for (i, &row_weight) in (-radius..=radius).zip(weights) {
        let yy = py + i;
        if yy <= 0 || yy >= image.height as i64 - 1 || columns.is_empty() {
            continue;
        }
        let (above, here, below) = (
            image.row(yy as usize - 1),
            image.row(yy as usize),
            image.row(yy as usize + 1),
        );
        // Each row's bins and votes in a loop without branches (which the compiler
        // vectorises), then added in the same order as one sample at a time.
        let xs = first as usize..=last as usize;
        let gradients = xs
            .clone()
            .map(|xx| (here[xx + 1] - here[xx - 1], below[xx] - above[xx]));
        for (((bin, vote), (dx, dy)), &column_weight) in bins
            .iter_mut()
            .zip(votes.iter_mut())
            .zip(gradients)
            .zip(&weights[columns.clone()])
        {
            // Rounds to the nearest bin (angle ≥ 0); bin n is bin 0.
            let nearest = (atan2_degrees(dy, dx) * n as f32 / 360.0 + 0.5) as usize;
            *bin = if nearest >= n { nearest - n } else { nearest };
            *vote = row_weight * column_weight * (dx * dx + dy * dy).sqrt();
        }
        for (&bin, &vote) in bins.iter().zip(votes.iter()) {
            raw[bin] += vote;
        }
    }
    let at = |h: &[f32], i: i64| h[i.rem_euclid(n as i64) as usize];
    smoothed.clear();
    smoothed.extend((0..n as i64).map(|i| {
        (at(raw, i - 2) + at(raw, i + 2)) / 16.0
            + (at(raw, i - 1) + at(raw, i + 1)) * 4.0 / 16.0
            + at(raw, i) * 6.0 / 16.0
    }));
    let highest = smoothed.iter().copied().fold(0.0f32, f32::max);
    angles.clear();
    angles.extend((0..n as i64).filter_map(|i| {
        let (left, centre, right) = (at(smoothed, i - 1), at(smoothed, i), at(smoothed, i + 1));
        if centre > left && centre > right && centre >= params.peak_ratio * highest {
            let bin = i as f32 + 0.5 * (left - right) / (left - 2.0 * centre + right);
            Some((bin * 360.0 / n as f32).rem_euclid(360.0))
        } else {
            None
        }
    }));
}

/// The samples of one descriptor's window: place in cells, gradient, window weight.
#[derive(Default)]
struct Samples {
    rbin: Vec<f32>,
    cbin: Vec<f32>,
    dx: Vec<f32>,
    dy: Vec<f32>,
    weight: Vec<f32>,
}

impl Samples {
    /// Empty, with room for `n` samples, so that the window's loop never grows the vectors.
    fn clear_for(&mut self, n: usize) {
        for values in [
            &mut self.rbin,
            &mut self.cbin,
            &mut self.dx,
            &mut self.dy,
            &mut self.weight,
        ] {
            values.clear();
            values.reserve(n);
        }
    }

    fn push(&mut self, rbin: f32, cbin: f32, dx: f32, dy: f32, weight: f32) {
        self.rbin.push(rbin);
        self.cbin.push(cbin);
        self.dx.push(dx);
        self.dy.push(dy);
        self.weight.push(weight);
    }

    /// Weighted gradient magnitudes, and orientation bins 0..=n (n only by rounding) counted
    /// clockwise on screen from the keypoint's `angle` (counter-clockwise with y up, as in
    /// `OpenCV`, so that the descriptors are comparable with `OpenCV`'s), into `magnitudes`
    /// and `bins`.
    fn magnitudes_and_bins(&self, angle: f32, n: usize, magnitudes: &mut Vec<f32>, bins: &mut Vec<f32>) {
        // Overwritten whole below.
        magnitudes.resize(self.dx.len(), 0.0);
        bins.resize(self.dx.len(), 0.0);
        let gradients = self.dx.iter().zip(&self.dy).zip(&self.weight);
        for ((magnitude, obin), ((&dx, &dy), &weight)) in magnitudes.iter_mut().zip(bins.iter_mut()).zip(gradients) {
            let turned = angle - atan2_degrees(dy, dx);
            *obin = if turned < 0.0 { turned + 360.0 } else { turned } * n as f32 / 360.0;
            *magnitude = (dx * dx + dy * dy).sqrt() * weight;
        }
    }
}

/// Lowe 2004 §6 (`OpenCV`'s `calcSIFTDescriptor`): the descriptor of the keypoint at (x, y) of
/// `image` (octave pixels), turned by `angle` degrees, of scale `octave_sigma`, into `out`
/// (its [`descriptor_length`] values). Inlined, so that [`with_avx2`] compiles it for AVX2
/// (its loops without branches eight lanes wide).
#[inline(always)]
fn descriptor(
    image: &Raster,
    (x, y): (f32, f32),
    angle: f32,
    octave_sigma: f32,
    params: &SiftParams,
    scratch: &mut Scratch,
    out: &mut [f32],
) {
    let d = params.descriptor_width;
    let n = params.descriptor_bins;
    let (px, py) = (x.round() as i64, y.round() as i64);
    let (sin, cos) = angle.to_radians().sin_cos();
    let cell = 3.0 * octave_sigma;
    // The turn and the scale to cells in one multiply per term (as OpenCV).
    let (sin_cell, cos_cell) = (sin / cell, cos / cell);
    let radius = (cell * std::f32::consts::SQRT_2 * (d as f32 + 1.0) * 0.5).round() as i64;
    let radius = radius.min(((image.width.pow(2) + image.height.pow(2)) as f32).sqrt() as i64);
    let window = -1.0 / (d as f32 * d as f32 * 0.5);
    // Cells with a margin of one on each side and two extra orientation bins, folded back below.
    let stride = n + 2;
    let Scratch {
        weights,
        hist,
        samples,
        magnitudes,
        orientation_bins,
        ..
    } = scratch;
    hist.clear();
    hist.resize((d + 2) * (d + 2) * stride, 0.0);
    // The window e^((c_rot² + r_rot²)·window) with c_rot² + r_rot² = (i² + j²)/cell², as the
    // product of its row and column factors.
    gaussian_factors(radius, window / (cell * cell), weights);
    // Slices from here on: through `&mut Vec` every store into the values reloaded the Vec.
    let (hist, weights) = (&mut hist[..], &weights[..]);
    // Three passes, as OpenCV's: the samples inside the turned window, then their magnitudes
    // and orientations in one loop without branches (which the compiler vectorises), then the
    // votes.
    let side = 2 * radius as usize + 1;
    samples.clear_for(side * side);
    // Only the window's rows and columns inside the image's interior, where a central
    // difference exists: the square clipped once, not each sample tested against the image.
    let (w, h) = (image.width as i64, image.height as i64);
    let (first, last) = ((1 - px).max(-radius), (w - 2 - px).min(radius));
    let column_weights = if first <= last {
        &weights[(first + radius) as usize..=(last + radius) as usize]
    } else {
        &[]
    };
    for (i, &row_weight) in (-radius..=radius).zip(weights) {
        let r = py + i;
        if r <= 0 || r >= h - 1 {
            continue;
        }
        let (above, here, below) = (
            image.row(r as usize - 1),
            image.row(r as usize),
            image.row(r as usize + 1),
        );
        for (j, &column_weight) in (first..=last).zip(column_weights) {
            // The sample's place in the keypoint's frame, in cells.
            let c_rot = j as f32 * cos_cell + i as f32 * sin_cell;
            let r_rot = -j as f32 * sin_cell + i as f32 * cos_cell;
            let rbin = r_rot + d as f32 / 2.0 - 0.5;
            let cbin = c_rot + d as f32 / 2.0 - 0.5;
            if rbin <= -1.0 || rbin >= d as f32 || cbin <= -1.0 || cbin >= d as f32 {
                continue;
            }
            // The gradient by central differences, y pointing down the image.
            let c = (px + j) as usize;
            let (dx, dy) = (here[c + 1] - here[c - 1], below[c] - above[c]);
            samples.push(rbin, cbin, dx, dy, row_weight * column_weight);
        }
    }
    samples.magnitudes_and_bins(angle, n, magnitudes, orientation_bins);
    for ((&rbin, &cbin), (&magnitude, &obin)) in samples
        .rbin
        .iter()
        .zip(&samples.cbin)
        .zip(magnitudes.iter().zip(orientation_bins.iter()))
    {
        // Floors without libm's call: rbin and cbin are above −1, obin is 0 or more.
        let floor = |v: f32| if v >= 0.0 { v as i64 } else { -1 };
        let (r0, c0, o0) = (floor(rbin), floor(cbin), obin as usize);
        let (fr, fc, fo) = (rbin - r0 as f32, cbin - c0 as f32, obin - o0 as f32);
        // obin reaches n only by rounding up from just below 360°: bin 0.
        let o0 = if o0 >= n { o0 - n } else { o0 };
        let base = ((r0 + 1) as usize * (d + 2) + (c0 + 1) as usize) * stride + o0;
        // Each of the two cell rows as one slice from the sample's first bin: the four votes
        // into it at 0, 1, stride and stride + 1 then need no bounds check each (8 a sample
        // were a sixth of the votes' instructions). Each vote is magnitude·wr·wc·wo, as before.
        for (dr, wr) in [(0, 1.0 - fr), (1, fr)] {
            let row = &mut hist[base + dr * (d + 2) * stride..][..stride + 2];
            let weighted = magnitude * wr;
            let (left, right) = (weighted * (1.0 - fc), weighted * fc);
            row[0] += left * (1.0 - fo);
            row[1] += left * fo;
            row[stride] += right * (1.0 - fo);
            row[stride + 1] += right * fo;
        }
    }
    for (k, values) in out.chunks_exact_mut(n).enumerate() {
        let (i, j) = (k / d, k % d);
        let cell = &mut hist[((i + 1) * (d + 2) + j + 1) * stride..][..stride];
        cell[0] += cell[n];
        cell[1] += cell[n + 1];
        values.copy_from_slice(&cell[..n]);
    }
    normalise(out);
    out.iter_mut().for_each(|v| *v = v.min(params.magnitude_clamp));
    normalise(out);
}

/// The image doubled by bilinear interpolation, pixel u of the result at (u + ½)/2 − ½
/// (`OpenCV`'s `resize` with `INTER_LINEAR`): each output pixel is ¾·¼ of its two nearest
/// input pixels on each axis, borders repeated. Equal bit for bit to [`Raster::sample`] with
/// [`crate::Interpolation::Bilinear`] (the weights' products are exact; the same sum in the same
/// order), which spent most of this in its general tap setup.
fn upsample(image: &Raster) -> Raster {
    let (w, h) = (image.width * 2, image.height * 2);
    // Output column or row u reads input u/2 − ¼: pixels ⌊u/2⌋ − 1 and ⌊u/2⌋ weighted ¼, ¾
    // for even u, ⌊u/2⌋ and ⌊u/2⌋ + 1 weighted ¾, ¼ for odd u, clamped to the image.
    let taps = |u: usize, n: usize| -> ([usize; 2], [f64; 2]) {
        let i = (u / 2) as i64;
        let clamp = |v: i64| v.clamp(0, n as i64 - 1) as usize;
        if u.is_multiple_of(2) {
            ([clamp(i - 1), clamp(i)], [0.25, 0.75])
        } else {
            ([clamp(i), clamp(i + 1)], [0.75, 0.25])
        }
    };
    let mut out = Raster::from_vec(w, h, 1, buffers::take(w * h)).expect("sized");
    out.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let ([ya, yb], [wya, wyb]) = taps(y, image.height);
        let (above, below) = (image.row(ya), image.row(yb));
        // The four weights of a column, above then below: fixed for each row and parity.
        let weights = |[wxa, wxb]: [f64; 2]| [wxa * wya, wxb * wya, wxa * wyb, wxb * wyb].map(|v| v as f32);
        let sum = |[ca, cb, cc, cd]: [f32; 4], [xa, xb]: [usize; 2]| {
            let mut value = 0.0f32;
            value += ca * above[xa];
            value += cb * above[xb];
            value += cc * below[xa];
            value += cd * below[xb];
            value
        };
        // Odd column 2i + 1 and even column 2i + 2 both read input columns i and i + 1; the
        // first and last columns are clamped.
        let (odd, even) = (weights([0.75, 0.25]), weights([0.25, 0.75]));
        for (i, pair) in row[1..w - 1].chunks_exact_mut(2).enumerate() {
            pair[0] = sum(odd, [i, i + 1]);
            pair[1] = sum(even, [i, i + 1]);
        }
        for x in [0, w - 1] {
            let (columns, column_weights) = taps(x, image.width);
            row[x] = sum(weights(column_weights), columns);
        }
    });
    out
}

/// Every second pixel of every second row.
fn decimate(image: &Raster) -> Raster {
    let (w, h) = (image.width / 2, image.height / 2);
    let mut data = buffers::take(w * h);
    for (y, row) in data.chunks_mut(w.max(1)).enumerate() {
        for (x, value) in row.iter_mut().enumerate() {
            *value = image.at(2 * x, 2 * y);
        }
    }
    Raster::from_vec(w, h, 1, data).expect("sized")
}

fn difference(a: &Raster, b: &Raster) -> Raster {
    let mut data = buffers::take(a.data.len());
    for ((d, x), y) in data.iter_mut().zip(&a.data).zip(&b.data) {
        *d = x - y;
    }
    Raster::from_vec(a.width, a.height, 1, data).expect("sized")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Images with no pixels, or too few for one octave, give no features, not a panic.
    #[test]
    fn empty_and_tiny_images_give_no_features() {
        for (width, height) in [(0, 3), (3, 0), (0, 0), (1, 1), (4, 9)] {
            for upsample in [true, false] {
                let image = Raster::from_vec(width, height, 1, vec![0.5; width * height]).unwrap();
                let params = SiftParams {
                    upsample,
                    ..SiftParams::default()
                };
                let features = sift(&image, &params).unwrap();
                assert!(
                    features.keypoints.is_empty() && features.descriptors.is_empty(),
                    "{width}×{height}"
                );
                assert_eq!(features.length, descriptor_length(&params));
            }
        }
    }

    /// A Gaussian blob of σ₀ on a flat ground: the scale-normalised Laplacian of the scale
    /// space peaks at σ = σ₀ at its centre (Lindeberg 1998), so SIFT's strongest keypoint is
    /// there, within 0.1 px and 15 % of σ₀ (the `DoG` approximates the Laplacian between σ and
    /// kσ). Descriptors have unit length and no negative value.
    #[test]
    fn a_blob_is_one_keypoint_at_its_centre_and_scale() {
        let (size, cx, cy, sigma0) = (96usize, 47.3f32, 44.6f32, 4.0f32);
        let data = (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f32, (i / size) as f32);
                0.2 + 0.6 * (-((x - cx).powi(2) + (y - cy).powi(2)) / (2.0 * sigma0 * sigma0)).exp()
            })
            .collect();
        let image = Raster::from_vec(size, size, 1, data).unwrap();
        let features = sift(&image, &SiftParams::default()).unwrap();
        let near: Vec<&Keypoint> = features
            .keypoints
            .iter()
            .filter(|k| (k.x - cx).hypot(k.y - cy) < 2.0)
            .collect();
        assert!(!near.is_empty(), "{:?}", features.keypoints);
        let best = near.iter().max_by(|a, b| a.response.total_cmp(&b.response)).unwrap();
        assert!((best.x - cx).hypot(best.y - cy) < 0.1, "{best:?}");
        assert!((best.sigma / sigma0 - 1.0).abs() < 0.15, "{best:?}");
        assert_eq!(features.descriptors.len(), features.keypoints.len() * 128);
        for i in 0..features.keypoints.len() {
            let norm: f32 = features.descriptor(i).iter().map(|v| v * v).sum::<f32>().sqrt();
            assert!((norm - 1.0).abs() < 1e-4);
            assert!(features.descriptor(i).iter().all(|&v| v >= 0.0));
        }
    }

    /// The doubling equals the general bilinear sampler at (u + ½)/2 − ½ bit for bit, borders
    /// included, on odd and even sides.
    #[test]
    fn upsample_equals_bilinear_sampling() {
        for (w, h) in [(7, 4), (1, 3), (2, 1)] {
            let data = (0..w * h).map(|i| ((i * 37 % 11) as f32).sin()).collect();
            let image = Raster::from_vec(w, h, 1, data).unwrap();
            let doubled = upsample(&image);
            let mut value = [0.0];
            for y in 0..2 * h {
                for x in 0..2 * w {
                    let (u, v) = ((x as f64 + 0.5) / 2.0 - 0.5, (y as f64 + 0.5) / 2.0 - 0.5);
                    image.sample(u, v, crate::Interpolation::Bilinear, &mut value);
                    assert_eq!(doubled.at(x, y).to_bits(), value[0].to_bits(), "{w}×{h} at ({x}, {y})");
                }
            }
        }
    }

    /// The block pre-test of 8 samples against their 26 neighbours equals the per-sample
    /// threshold and exact test on finite layers, and never drops a sample that test keeps
    /// where NaNs and infinities are sprinkled in.
    #[test]
    fn block_candidates_keep_every_sample_the_exact_test_keeps() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(18);
        let (w, h, threshold) = (40, 6, 0.3f32);
        let mut kept_samples = 0;
        for trial in 0..300 {
            // Every fourth trial draws from nine values, so neighbours tie often: a pre-test that
            // kept or dropped ties unlike the exact (strict) test would show. Every third has
            // the middle layer scaled up, so that many samples beat their own layer and the
            // other two layers decide.
            let scale = if trial % 3 == 0 { 3.0 } else { 1.0 };
            let mut layers: Vec<Vec<f32>> = (0..3)
                .map(|l| {
                    (0..w * h)
                        .map(|_| {
                            let v = match trial % 4 {
                                2 => rng.random_range(-4..=4) as f32 * 0.1,
                                _ => rng.random_range(-1.0..1.0),
                            };
                            if l == 1 { v * scale } else { v }
                        })
                        .collect()
                })
                .collect();
            if trial % 2 == 1 {
                for _ in 0..36 {
                    let at = rng.random_range(0..w * h);
                    layers[rng.random_range(0..3)][at] =
                        [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][rng.random_range(0..3)];
                }
            }
            let slices = [&layers[0][..], &layers[1][..], &layers[2][..]];
            for y in 1..h - 1 {
                for start in (1..w - SCAN_BLOCK).step_by(3) {
                    let bits = block_candidates(slices, w, start, y, threshold, None);
                    assert_eq!(bits, block_candidates(slices, w, start, y, threshold, Avx2::detected()));
                    for i in 0..SCAN_BLOCK {
                        let x = start + i;
                        let value = layers[1][y * w + x];
                        let exact = value.abs() > threshold
                            && beats_block(slices[1], w, x, y, value, true)
                            && beats_block(slices[0], w, x, y, value, false)
                            && beats_block(slices[2], w, x, y, value, false);
                        let kept = bits & (1 << i) != 0;
                        kept_samples += usize::from(exact);
                        if trial % 2 == 0 {
                            assert_eq!(kept, exact, "trial {trial}, ({x}, {y})");
                        } else {
                            assert!(kept || !exact, "trial {trial}, ({x}, {y})");
                        }
                    }
                }
            }
        }
        assert!(kept_samples > 1000, "{kept_samples}");
    }

    /// A block whose neighbours would lie outside its layers is refused before any read: the
    /// test reads them without bounds checks.
    #[test]
    #[should_panic(expected = "a block's neighbours lie inside its layers")]
    fn a_block_at_the_layer_edge_is_refused() {
        let layer = [0.5f32; 9 * 3];
        block_candidates([&layer[..], &layer[..], &layer[..]], 9, 1, 1, 0.1, Avx2::detected());
    }

    /// The AVX2 build of the extremum scan finds the same extrema as the portable one, bit for
    /// bit, on the `DoG` layers of a seeded noise image. (On a CPU without AVX2 both sides are
    /// the portable build: the test then checks only that the scan finds extrema.)
    #[test]
    fn the_wide_extremum_scan_equals_the_portable_one() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(27);
        let (w, h) = (90, 61);
        let noise = (0..w * h).map(|_| rng.random_range(0.0..1.0)).collect();
        let image = Raster::from_vec(w, h, 1, noise).unwrap();
        let gaussians: Vec<Raster> = [1.0f32, 1.3, 1.7, 2.2, 2.8, 3.6]
            .iter()
            .map(|&sigma| gaussian_blur(&image, sigma))
            .collect();
        let dogs: Vec<Raster> = gaussians
            .windows(2)
            .map(|pair| difference(&pair[1], &pair[0]))
            .collect();
        let params = SiftParams::default();
        let key = |found: Vec<Extremum>| -> Vec<[u32; 5]> {
            found
                .iter()
                .map(|e| [e.x, e.y, e.scale, e.contrast].map(f32::to_bits))
                .zip(found.iter().map(|e| e.layer as u32))
                .map(|([x, y, scale, contrast], layer)| [x, y, scale, contrast, layer])
                .collect()
        };
        let mut total = 0;
        for layer in 1..=params.scales_per_octave {
            let portable = key(extrema(&dogs, layer, &params, None));
            total += portable.len();
            assert_eq!(
                portable,
                key(extrema(&dogs, layer, &params, Avx2::detected())),
                "layer {layer}"
            );
        }
        assert!(total >= 10, "{total} extrema");
    }

    /// The descriptor compiled for AVX2 equals the portable build's bit for bit, for keypoints
    /// whose windows lie inside the image and ones clipped by each of its edges. (On a CPU
    /// without AVX2 both sides are the portable build.)
    #[test]
    fn the_wide_descriptor_equals_the_portable_one() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
        let (w, h) = (70, 53);
        let noise = (0..w * h).map(|_| rng.random_range(0.0..1.0)).collect();
        let image = gaussian_blur(&Raster::from_vec(w, h, 1, noise).unwrap(), 1.2);
        let params = SiftParams::default();
        let length = descriptor_length(&params);
        let keypoints = [
            (34.6, 25.2, 0.0, 2.0),
            (30.1, 20.9, 137.5, 3.3),
            (2.4, 26.0, 301.0, 2.6),
            (66.8, 3.1, 45.0, 1.9),
            (10.0, 51.5, 200.0, 4.4),
        ];
        for (x, y, angle, sigma) in keypoints {
            let (mut portable, mut wide) = (vec![0.0; length], vec![0.0; length]);
            let mut scratch = Scratch::default();
            with_avx2(None, || {
                descriptor(&image, (x, y), angle, sigma, &params, &mut scratch, &mut portable);
            });
            with_avx2(
                Avx2::detected(),
                #[inline(always)]
                || descriptor(&image, (x, y), angle, sigma, &params, &mut scratch, &mut wide),
            );
            assert!(portable.iter().any(|&v| v > 0.0), "({x}, {y})");
            let bits = |values: &[f32]| values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&portable), bits(&wide), "({x}, {y})");
        }
    }

    #[test]
    fn bad_parameters_are_refused() {
        let image = Raster::new(64, 64, 1);
        let bad = SiftParams {
            scales_per_octave: 0,
            ..SiftParams::default()
        };
        assert!(matches!(
            sift(&image, &bad),
            Err(VisionError::Parameter {
                name: "scales_per_octave",
                ..
            })
        ));
        assert!(
            sift(
                &Raster::new(8, 8, 1),
                &SiftParams {
                    upsample: false,
                    ..SiftParams::default()
                }
            )
            .unwrap()
            .keypoints
            .is_empty()
        );
    }
}
