//! `LMgist`: the gist descriptor exactly as Oliva & Torralba's reference MATLAB code computes it
//! (`LMgist.m` of Torralba's `LabelMe` toolbox and its `prefilt`, `gistGabor`, `downN`,
//! `createGabor`, and `imresizecrop`), for comparison with published results; [`crate::gist`]
//! is omnisim's variant for panoramas (no prefilter, no resize, circular in x).
//!
//! Steps, with `LMgist`'s defaults (`param.imageSize = [256 256]`, `orientationsPerScale =
//! [8 8 8 8]`, `numberBlocks = 4`, `fc_prefilt = 4`, `boundaryExtension = 32`):
//! 1. grey = mean of the colour channels (`mean(img, 3)`);
//! 2. `imresizecrop`: scale by max(S/h, S/w) with MATLAB's bilinear `imresize` (antialiased when
//!    shrinking), sizes rounded, then the centred S × S crop;
//! 3. grey levels stretched to 0..255 (`img − min`, `255·img/max`);
//! 4. `prefilt` ([`prefilter`]): log(1 + I), 5 mirrored pixels on each side, mirrored on to an
//!    even square n × n; whitening I − IDFT(DFT(I)·G) and local contrast normalisation
//!    I / (0.2 + √|IDFT(DFT(I²)·G)|), G(f) = exp(−|f|²/s₁²), f in cycles per n pixels,
//!    s₁ = fc/√(ln 2); cropped back to S × S;
//! 5. `gistGabor`: 32 mirrored pixels on each side (S + 64 square), the Gabor bank of
//!    `createGabor` (the transfer function of [`crate::gist`], frequencies in cycles per pixel of
//!    the padded square), |IDFT(DFT(I)·G)| cropped to S × S;
//! 6. `downN`: block means over `fix(linspace(0, S, N + 1))` boundaries ([`block_bounds`]).
//!
//! The values come in `LMgist`'s order: filter by filter (scale-major), and within a filter the
//! N × N blocks column by column (MATLAB's column-major `reshape`), so the flat vector equals
//! `LMgist`'s. Computed in f64 (MATLAB's code runs in single precision).

use rustfft::FftDirection;

use crate::fft::{self, C64};
use crate::gist::{bank, check_bank, symmetric_index};
use crate::{Descriptor, Raster, VisionError, require};

/// `LMgist`'s settings; the default is its published one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmGistParams {
    /// Side S of the square the image is resized and cropped to (`param.imageSize`), even.
    pub image_size: usize,
    /// Gabor scales (`length(orientationsPerScale)`).
    pub scales: usize,
    /// Orientations per scale (the same at every scale).
    pub orientations: usize,
    /// Blocks per side (`numberBlocks`).
    pub blocks: usize,
    /// Prefilter cut-off, cycles per image (`fc_prefilt`).
    pub prefilter_cycles: f64,
}

impl Default for LmGistParams {
    fn default() -> Self {
        Self {
            image_size: 256,
            scales: 4,
            orientations: 8,
            blocks: 4,
            prefilter_cycles: 4.0,
        }
    }
}

/// Pixels mirrored around the resized image before the Gabor filters (`boundaryExtension`).
pub const BOUNDARY: usize = 32;
/// Pixels mirrored around the image in the prefilter (`prefilt`'s `w`).
const PREFILTER_PADDING: usize = 5;

impl LmGistParams {
    /// Checks the settings: an even image side 16–4096 (`createGabor`'s frequency grid
    /// `-n/2:n/2-1` is whole bins only for even sides), 1–16 scales, 1–64 orientations, 1 to
    /// S blocks, a finite positive prefilter cut-off.
    pub fn validate(&self) -> Result<(), VisionError> {
        require(
            (16..=4096).contains(&self.image_size) && self.image_size.is_multiple_of(2),
            "image size",
            || format!("needs an even side from 16 to 4096 pixels, got {}", self.image_size),
        )?;
        check_bank(self.scales, self.orientations)?;
        require((1..=self.image_size).contains(&self.blocks), "blocks", || {
            format!("needs 1 to {} blocks per side, got {}", self.image_size, self.blocks)
        })?;
        require(
            self.prefilter_cycles.is_finite() && self.prefilter_cycles > 0.0,
            "prefilter",
            || format!("the cut-off must be finite and positive, got {}", self.prefilter_cycles),
        )
    }
}

/// `LMgist` with its filter bank made once (`param.G`), for many images.
#[derive(Debug, Clone)]
pub struct LmGist {
    params: LmGistParams,
    /// Transfer functions on the padded square, one per (scale, orientation), scale-major.
    bank: crate::gist::Bank,
}

impl LmGist {
    /// The bank of `params` (`createGabor(orientationsPerScale, S + 2·32)`).
    pub fn new(params: LmGistParams) -> Result<Self, VisionError> {
        params.validate()?;
        let n = params.image_size + 2 * BOUNDARY;
        let bank = bank(n, n, params.scales, params.orientations);
        Ok(Self { params, bank })
    }

    /// The settings.
    pub fn params(&self) -> LmGistParams {
        self.params
    }

    /// The descriptor of an image of one channel, or of three (averaged, as `mean(img, 3)`):
    /// shape [scales, orientations, blocks (column), blocks (row)], `LMgist`'s order.
    pub fn describe(&self, image: &Raster) -> Result<Descriptor, VisionError> {
        require(image.channels == 1 || image.channels == 3, "channels", || {
            format!("LMgist reads one or three channels, got {}", image.channels)
        })?;
        require(image.width >= 1 && image.height >= 1, "image", || {
            "the image is empty".to_string()
        })?;
        let p = self.params;
        let size = p.image_size;
        let grey: Vec<f64> = image
            .data
            .chunks(image.channels)
            .map(|c| c.iter().map(|&v| f64::from(v)).sum::<f64>() / c.len() as f64)
            .collect();
        let mut square = resize_crop(&grey, image.width, image.height, size);
        let min = square.iter().copied().fold(f64::INFINITY, f64::min);
        square.iter_mut().for_each(|v| *v -= min);
        let max = square.iter().copied().fold(0.0, f64::max);
        // MATLAB divides 0 by 0 for a flat image (NaN everywhere); a flat image stays 0 here.
        if max > 0.0 {
            square.iter_mut().for_each(|v| *v *= 255.0 / max);
        }
        let filtered = prefilter(&square, size, size, p.prefilter_cycles);
        let n = size + 2 * BOUNDARY;
        let padded: Vec<C64> = (0..n * n)
            .map(|i| {
                let (x, y) = (i % n, i / n);
                let source = symmetric_index(y as isize - BOUNDARY as isize, size) * size
                    + symmetric_index(x as isize - BOUNDARY as isize, size);
                C64::new(filtered[source], 0.0)
            })
            .collect();
        let mut spectrum = padded;
        fft::fft2(&mut spectrum, n, n, FftDirection::Forward);
        let bounds = block_bounds(size, p.blocks);
        let mut values = Vec::with_capacity(self.bank.len() * p.blocks * p.blocks);
        let mut work = vec![C64::default(); n * n];
        for filter in self.bank.iter() {
            for ((out, &s), &g) in work.iter_mut().zip(&spectrum).zip(filter) {
                *out = s * g;
            }
            fft::fft2(&mut work, n, n, FftDirection::Inverse);
            let amplitude = |x: usize, y: usize| work[(y + BOUNDARY) * n + x + BOUNDARY].norm();
            // downN, column blocks outer, row blocks inner (column-major reshape).
            for columns in bounds.windows(2) {
                for rows in bounds.windows(2) {
                    let mut sum = 0.0;
                    for y in rows[0]..rows[1] {
                        for x in columns[0]..columns[1] {
                            sum += amplitude(x, y);
                        }
                    }
                    let count = (rows[1] - rows[0]) * (columns[1] - columns[0]);
                    values.push((sum / count as f64) as f32);
                }
            }
        }
        Ok(Descriptor {
            shape: vec![p.scales, p.orientations, p.blocks, p.blocks],
            values,
        })
    }
}

/// `fix(linspace(0, n, blocks + 1))`: block i spans samples bounds[i]..bounds[i + 1]. MATLAB's
/// `linspace` computes i·n/blocks as (i·n)/blocks, exact for whole numbers, so `fix` is the
/// integer quotient (250 in 4 blocks: 0, 62, 125, 187, 250; ⌊y·4/250⌋ would start block 1 at
/// 63).
pub fn block_bounds(n: usize, blocks: usize) -> Vec<usize> {
    (0..=blocks).map(|i| i * n / blocks).collect()
}

/// `prefilt(img, fc)` of a `width × height` image (values 0..255): log, mirrored padding,
/// whitening and local contrast normalisation (module docs, step 4); same size out.
pub fn prefilter(image: &[f64], width: usize, height: usize, cycles: f64) -> Vec<f64> {
    let pad = PREFILTER_PADDING;
    let (sn, sm) = (height + 2 * pad, width + 2 * pad);
    let n = sn.max(sm);
    let n = n + n % 2;
    // Row r of the n × n square: first `padarray([w w], 'symmetric')`, then 'post' to n.
    let source = |r: usize, len: usize, padded: usize| {
        symmetric_index(symmetric_index(r as isize, padded) as isize - pad as isize, len)
    };
    let mut values: Vec<C64> = (0..n * n)
        .map(|i| {
            let (x, y) = (source(i % n, width, sm), source(i / n, height, sn));
            C64::new((image[y * width + x] + 1.0).ln(), 0.0)
        })
        .collect();
    let s1 = cycles / std::f64::consts::LN_2.sqrt();
    let bin = |k: usize| if 2 * k >= n { k as f64 - n as f64 } else { k as f64 };
    let gaussian: Vec<f64> = (0..n * n)
        .map(|i| (-(bin(i % n).powi(2) + bin(i / n).powi(2)) / (s1 * s1)).exp())
        .collect();
    let low_pass = |data: &mut Vec<C64>| {
        fft::fft2(data, n, n, FftDirection::Forward);
        data.iter_mut().zip(&gaussian).for_each(|(v, g)| *v *= g);
        fft::fft2(data, n, n, FftDirection::Inverse);
    };
    let mut smooth = values.clone();
    low_pass(&mut smooth);
    // Whitening: the real part of the low-passed image taken away.
    values
        .iter_mut()
        .zip(&smooth)
        .for_each(|(v, s)| *v = C64::new(v.re - s.re, 0.0));
    let mut energy: Vec<C64> = values.iter().map(|v| C64::new(v.re * v.re, 0.0)).collect();
    low_pass(&mut energy);
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width + pad, i / width + pad);
            values[y * n + x].re / (0.2 + energy[y * n + x].norm().sqrt())
        })
        .collect()
}

/// `imresizecrop(img, [S S], 'bilinear')`: resized by max(S/h, S/w) (sizes rounded), then the
/// centred S × S crop, floor((size − S)/2) from the top left.
fn resize_crop(image: &[f64], width: usize, height: usize, size: usize) -> Vec<f64> {
    let scaling = (size as f64 / height as f64).max(size as f64 / width as f64);
    let (new_w, new_h) = (
        ((width as f64 * scaling).round() as usize).max(size),
        ((height as f64 * scaling).round() as usize).max(size),
    );
    let resized = resize(image, width, height, new_w, new_h);
    let (top, left) = ((new_h - size) / 2, (new_w - size) / 2);
    (0..size * size)
        .map(|i| resized[(top + i / size) * new_w + left + i % size])
        .collect()
}

/// MATLAB's `imresize(img, [new_h new_w], 'bilinear')`: separable triangle kernel, stretched
/// by 1/scale when shrinking (antialiasing), output sample x (1-based) centred at
/// u = x/scale + ½(1 − 1/scale) of the input, weights normalised to sum 1, input indices past
/// the ends mirrored (`[1:n, n:-1:1]`); the axis with the smaller scale first, as MATLAB.
pub(crate) fn resize(image: &[f64], width: usize, height: usize, new_w: usize, new_h: usize) -> Vec<f64> {
    let (scale_x, scale_y) = (new_w as f64 / width as f64, new_h as f64 / height as f64);
    let along_x = |data: &[f64], h: usize| -> Vec<f64> {
        let weights = contributions(width, new_w);
        (0..new_w * h)
            .map(|i| {
                let row = &data[i / new_w * width..][..width];
                weights[i % new_w].iter().map(|&(j, w)| w * row[j]).sum()
            })
            .collect()
    };
    let along_y = |data: &[f64], w: usize| -> Vec<f64> {
        let weights = contributions(height, new_h);
        (0..w * new_h)
            .map(|i| weights[i / w].iter().map(|&(j, wt)| wt * data[j * w + i % w]).sum())
            .collect()
    };
    if scale_y <= scale_x {
        along_x(&along_y(image, width), new_h)
    } else {
        along_y(&along_x(image, height), new_w)
    }
}

/// The input samples and weights of each output sample of one axis (MATLAB's `contributions`).
fn contributions(input: usize, output: usize) -> Vec<Vec<(usize, f64)>> {
    let scale = output as f64 / input as f64;
    // Antialiasing when shrinking: h(x) = scale·triangle(scale·x), twice as wide per halving.
    let (stretch, width) = if scale < 1.0 { (scale, 2.0 / scale) } else { (1.0, 2.0) };
    let taps = width.ceil() as i64 + 2;
    let triangle = |x: f64| (1.0 - x.abs()).max(0.0);
    (1..=output)
        .map(|x| {
            let u = x as f64 / scale + 0.5 * (1.0 - 1.0 / scale);
            let left = (u - width / 2.0).floor() as i64;
            let mut weights: Vec<(usize, f64)> = (left..left + taps)
                .map(|i| {
                    (
                        symmetric_index((i - 1) as isize, input),
                        stretch * triangle(stretch * (u - i as f64)),
                    )
                })
                .collect();
            let sum: f64 = weights.iter().map(|w| w.1).sum();
            weights.iter_mut().for_each(|w| w.1 /= sum);
            weights
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// MATLAB's `imresize(1:4, [1 8], 'bilinear')` = 1, 1.25, 1.75, …, 3.75, 4 and
    /// `imresize(1:8, [1 4], 'bilinear')` (antialiased) = 1.625, 3.5, 5.5, 7.375: the values
    /// of `contributions` worked by hand from its formula.
    #[test]
    fn resize_is_matlabs_bilinear() {
        let up = resize(&[1.0, 2.0, 3.0, 4.0], 4, 1, 8, 1);
        let expected = [1.0, 1.25, 1.75, 2.25, 2.75, 3.25, 3.75, 4.0];
        assert!(up.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-12), "{up:?}");
        let ramp: Vec<f64> = (1..=8).map(f64::from).collect();
        let down = resize(&ramp, 8, 1, 4, 1);
        let expected = [1.625, 3.5, 5.5, 7.375];
        assert!(
            down.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-12),
            "{down:?}"
        );
        // The same along y.
        let column = resize(&ramp, 1, 8, 1, 4);
        assert!(
            column.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-12),
            "{column:?}"
        );
    }

    /// `downN`'s boundaries: `fix(linspace(0, 250, 5))` = 0 62 125 187 250 (row 62 is in block 1,
    /// where omnisim's grid gist put it in block 0), and whole divisions for 256.
    #[test]
    fn blocks_are_downns() {
        assert_eq!(block_bounds(250, 4), [0, 62, 125, 187, 250]);
        assert_eq!(block_bounds(256, 4), [0, 64, 128, 192, 256]);
        assert_eq!(block_bounds(10, 3), [0, 3, 6, 10]);
    }

    /// `prefilt` written out term by term with a direct (slow) DFT on a small odd-sized image:
    /// padding by 5 mirrored pixels, to an even square, G = exp(−(fx² + fy²)/s₁²) over the bins
    /// −n/2..n/2 − 1, whitening, local contrast. The FFT path agrees to 1e-10.
    #[test]
    fn prefilter_follows_lmgists_equations() {
        let (w, h) = (7usize, 4usize);
        let image: Vec<f64> = (0..w * h).map(|i| ((i * 37 % 11) as f64) * 20.0).collect();
        let fc = 4.0;
        // padarray([5 5], 'symmetric'): 14 × 17, then 'post' to 18 × 18.
        let (sn, sm) = (h + 10, w + 10);
        let n = 18;
        let mirror = |i: i64, len: i64| {
            let i = i.rem_euclid(2 * len);
            if i < len { i } else { 2 * len - 1 - i }
        };
        let at = |r: usize, c: usize| {
            let (r, c) = (mirror(r as i64, sn as i64), mirror(c as i64, sm as i64));
            let (r, c) = (mirror(r - 5, h as i64) as usize, mirror(c - 5, w as i64) as usize);
            (image[r * w + c] + 1.0).ln()
        };
        let s1 = fc / 2f64.ln().sqrt();
        // Direct DFT filter: out(y, x) = Σ_k G(k) Σ_j in(j) e^{−2πi k·j/n} e^{2πi k·(y,x)/n} / n².
        let filter = |input: &dyn Fn(usize, usize) -> f64| -> Vec<C64> {
            let mut spectrum = vec![C64::default(); n * n];
            for (k, s) in spectrum.iter_mut().enumerate() {
                let (kx, ky) = ((k % n) as f64, (k / n) as f64);
                for j in 0..n * n {
                    let phase = -std::f64::consts::TAU * (kx * (j % n) as f64 + ky * (j / n) as f64) / n as f64;
                    *s += C64::from_polar(input(j / n, j % n), phase);
                }
                let fx = if kx >= 9.0 { kx - 18.0 } else { kx };
                let fy = if ky >= 9.0 { ky - 18.0 } else { ky };
                *s *= (-(fx * fx + fy * fy) / (s1 * s1)).exp();
            }
            (0..n * n)
                .map(|j| {
                    spectrum.iter().enumerate().fold(C64::default(), |acc, (k, s)| {
                        let phase = std::f64::consts::TAU * (((k % n) * (j % n)) as f64 + ((k / n) * (j / n)) as f64)
                            / n as f64;
                        acc + s * C64::from_polar(1.0, phase)
                    }) / (n * n) as f64
                })
                .collect()
        };
        let low = filter(&|r, c| at(r, c));
        let white = |r: usize, c: usize| at(r, c) - low[r * n + c].re;
        let local = filter(&|r, c| white(r, c).powi(2));
        let ours = prefilter(&image, w, h, fc);
        for y in 0..h {
            for x in 0..w {
                let (r, c) = (y + 5, x + 5);
                let expected = white(r, c) / (0.2 + local[r * n + c].norm().sqrt());
                assert!(
                    (ours[y * w + x] - expected).abs() < 1e-10,
                    "({x}, {y}): {} vs {expected}",
                    ours[y * w + x]
                );
            }
        }
        // A flat image whitens to 0.
        assert!(prefilter(&[100.0; 64], 8, 8, fc).iter().all(|v| v.abs() < 1e-12));
    }

    /// The published configuration: 4 × 8 filters × 16 blocks = 512 values; a grating at
    /// scale 1's frequency and orientation 3's angle on a 256² image excites filter (1, 3)
    /// most; a colour image and its channel mean give the same descriptor.
    #[test]
    fn grating_excites_its_filter_in_lmgists_order() {
        let n = 256;
        let angle = -3.0 * std::f64::consts::PI / 8.0;
        let f = 0.3 / 1.85;
        let (kx, ky) = (
            (f * angle.cos() * n as f64).round(),
            (f * angle.sin() * n as f64).round(),
        );
        let data: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f64, (i / n) as f64);
                (0.5 + 0.4 * (std::f64::consts::TAU * (kx * x + ky * y) / n as f64).cos()) as f32
            })
            .collect();
        let lmgist = LmGist::new(LmGistParams::default()).unwrap();
        let grey = Raster::from_vec(n, n, 1, data.clone()).unwrap();
        let d = lmgist.describe(&grey).unwrap();
        assert_eq!(d.shape, vec![4, 8, 4, 4]);
        assert_eq!(d.values.len(), 512);
        let energy = |f: usize| d.values[f * 16..(f + 1) * 16].iter().sum::<f32>();
        let best = (0..32).max_by(|&a, &b| energy(a).total_cmp(&energy(b))).unwrap();
        assert_eq!((best / 8, best % 8), (1, 3));
        let colour: Vec<f32> = data.iter().flat_map(|&v| [v * 0.5, v, v * 1.5]).collect();
        let c = lmgist.describe(&Raster::from_vec(n, n, 3, colour).unwrap()).unwrap();
        for (a, b) in d.values.iter().zip(&c.values) {
            assert!((a - b).abs() <= 1e-5 * a.abs().max(1e-3), "{a} vs {b}");
        }
    }

    /// Column-major blocks: texture in the image's top-right block lands in block index
    /// column·4 + row with row 0 (12 = column 3, or 8 where a filter spills into column 2) for
    /// the finest scale, as `LMgist`'s reshape; not in index 3 (a row-major order).
    #[test]
    fn blocks_are_column_major() {
        let n = 64;
        let data: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = (i % n, i / n);
                if x >= 48 && y < 16 {
                    ((x * 7 + y * 3) % 5) as f32 / 4.0
                } else {
                    0.0
                }
            })
            .collect();
        let params = LmGistParams {
            image_size: 64,
            ..Default::default()
        };
        let d = LmGist::new(params)
            .unwrap()
            .describe(&Raster::from_vec(n, n, 1, data).unwrap())
            .unwrap();
        // The finest scale's 8 filters (the coarse ones spread over neighbouring blocks).
        for filter in d.values.chunks(16).take(8) {
            let best = (0..16).max_by(|&a, &b| filter[a].total_cmp(&filter[b])).unwrap();
            // Row 0 (index ≡ 0 mod 4), column 2 or 3 (the coarse filters spill one block left);
            // index 3, where a row-major order would put the top-right block, is near empty.
            assert!(best % 4 == 0 && best / 4 >= 2, "{best}: {filter:?}");
            assert!(filter[3] < 0.1 * filter[best], "{filter:?}");
        }
    }

    #[test]
    fn bad_settings_are_refused() {
        for p in [
            LmGistParams {
                image_size: 255,
                ..Default::default()
            },
            LmGistParams {
                image_size: 0,
                ..Default::default()
            },
            LmGistParams {
                blocks: 0,
                ..Default::default()
            },
            LmGistParams {
                prefilter_cycles: f64::NAN,
                ..Default::default()
            },
            LmGistParams {
                scales: 17,
                ..Default::default()
            },
        ] {
            assert!(matches!(LmGist::new(p), Err(VisionError::Parameter { .. })), "{p:?}");
        }
    }
}
