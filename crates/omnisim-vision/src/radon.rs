//! Radon transform of an omnidirectional image and the rotation between two images by
//! phase-only correlation (Berenguer et al. 2015, Sensors 15(10); compared with the other
//! descriptors in Amorós et al. 2021, Sensors 21(10), §2.6 and §3.6.2 "Radon–POC method").
//!
//! R(φ, p) = ∫∫ f(x, y)·δ(x·cos φ + y·sin φ − p) dx dy (Radon 1917), with x = u − cx,
//! y = v − cy about the image centre (the mirror axis), φ from +u towards +v over a full turn
//! [0, 2π), so that turning the image about its centre by θ shifts R circularly along φ by θ:
//! R_b(φ, p) = R_a(φ − θ, p).
//!
//! Written here: no maintained Rust crate computes a Radon transform (imageproc has none), and
//! the line integral is a few lines over the bilinear sampler of [`crate::raster`].

use rayon::prelude::*;
use rustfft::FftDirection;

use crate::fft::{self, C64};
use crate::{Interpolation, Raster, Rotation, VisionError, require};

/// Sampling of the transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadonParams {
    /// Angles over the full turn, step 2π/angles. Default 360 (1°), as Berenguer et al.
    pub angles: usize,
    /// Radial samples p_j = (j − (n−1)/2)·radial_step, j = 0..n; `None`: as many as reach
    /// the shorter image side's half, 2·⌊(min(W, H) − 1)/(2·step)⌋ + 1.
    pub radial_samples: Option<usize>,
    /// Pixels between radial samples. Default 1.
    pub radial_step: f64,
    /// Step along each line, pixels.
    pub line_step: f64,
}

impl Default for RadonParams {
    fn default() -> Self {
        Self {
            angles: 360,
            radial_samples: None,
            radial_step: 1.0,
            line_step: 0.5,
        }
    }
}

/// The transform: row i is angle φ_i = 2π·i/angles, column j is [`Radon::p`]`(j)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Radon {
    /// One channel: rows are angles, columns radial samples.
    pub values: Raster,
    /// Pixels between radial samples.
    pub radial_step: f64,
}

impl Radon {
    /// Transform of a one-channel image about its centre ((W−1)/2, (H−1)/2): the mirror axis
    /// of omnisim's catadioptric images.
    pub fn new(image: &Raster, params: RadonParams) -> Result<Self, VisionError> {
        require(image.channels == 1, "channels", || {
            format!("the Radon transform reads one channel, got {}", image.channels)
        })?;
        require(params.angles >= 2, "angles", || {
            format!("needs at least 2, got {}", params.angles)
        })?;
        require(params.line_step > 0.0, "line step", || {
            format!("must be positive, got {}", params.line_step)
        })?;
        require(params.radial_step > 0.0, "radial step", || {
            format!("must be positive, got {}", params.radial_step)
        })?;
        let reach = (image.width.min(image.height) as f64 - 1.0) / 2.0;
        let radial = params
            .radial_samples
            .unwrap_or(2 * (reach / params.radial_step).floor() as usize + 1);
        require(radial >= 2, "radial samples", || {
            format!("needs at least 2, got {radial}")
        })?;
        // Bounded so that a mistyped step cannot ask for days of work (the default is 6.3e7
        // samples for a 250² image).
        let samples = params.angles as f64 * radial as f64 * image.width.max(image.height) as f64 / params.line_step;
        require(samples <= 1e10, "sampling", || {
            format!("{samples:.1e} line samples asked (angles × radial samples × line length / line step); at most 1e10")
        })?;
        let p = |j: usize| radial_position(j, radial, params.radial_step);
        let (cx, cy) = ((image.width as f64 - 1.0) / 2.0, (image.height as f64 - 1.0) / 2.0);
        let (max_x, max_y) = ((image.width - 1) as f64, (image.height - 1) as f64);
        // Half the image diagonal: every line leaves the image within ±this of its foot.
        let half_length = cx.hypot(cy) + 1.0;
        let steps = (half_length / params.line_step).ceil() as i64;
        let mut values = Raster::new(radial, params.angles, 1);
        values.data.par_chunks_mut(radial).enumerate().for_each(|(i, row)| {
            let (sin, cos) = (std::f64::consts::TAU * i as f64 / params.angles as f64).sin_cos();
            let mut sample = [0.0f32];
            for (j, value) in row.iter_mut().enumerate() {
                let p = p(j);
                let mut sum = 0.0f64;
                for k in -steps..=steps {
                    let t = k as f64 * params.line_step;
                    let (x, y) = (cx + p * cos - t * sin, cy + p * sin + t * cos);
                    if (0.0..=max_x).contains(&x) && (0.0..=max_y).contains(&y) {
                        image.sample(x, y, Interpolation::Bilinear, &mut sample);
                        sum += sample[0] as f64;
                    }
                }
                *value = (sum * params.line_step) as f32;
            }
        });
        Ok(Self {
            values,
            radial_step: params.radial_step,
        })
    }

    /// The signed distance p (pixels) of column j's lines from the centre.
    pub fn p(&self, j: usize) -> f64 {
        radial_position(j, self.values.width, self.radial_step)
    }

    /// Phase-only correlation with `other` (Kuglin & Hines 1975): the inverse 2-D DFT of the
    /// cross-power spectrum normalised to unit magnitude, conj(F_a)·F_b/|conj(F_a)·F_b|,
    /// whose peak sits at the shift from `self` to `other`. Returns the rotation
    /// (`steps` = angle samples by which `other` is `self` shifted, `radians` = the image's
    /// turn from +u towards +v; for omnisim's mount-up mirrors the body's yaw from a to b is
    /// −radians) and the peak height (1 for identical transforms, near 0 for unrelated ones).
    pub fn rotation_to(&self, other: &Radon) -> Result<(Rotation, f64), VisionError> {
        let (w, h) = (self.values.width, self.values.height);
        require(
            (w, h) == (other.values.width, other.values.height),
            "transforms",
            || "phase-only correlation needs two transforms of the same sampling".to_string(),
        )?;
        let mut a = fft::complex(&self.values.data);
        let mut b = fft::complex(&other.values.data);
        fft::fft2(&mut a, w, h, FftDirection::Forward);
        fft::fft2(&mut b, w, h, FftDirection::Forward);
        let mut cross: Vec<C64> = a
            .iter()
            .zip(&b)
            .map(|(a, b)| {
                let c = a.conj() * b;
                let norm = c.norm();
                if norm > 1e-12 { c / norm } else { C64::default() }
            })
            .collect();
        fft::fft2(&mut cross, w, h, FftDirection::Inverse);
        let (peak_index, peak) = cross
            .iter()
            .enumerate()
            .max_by(|(_, x), (_, y)| x.re.total_cmp(&y.re))
            .expect("non-empty");
        Ok((Rotation::from_steps(peak_index / w, h), peak.re))
    }
}

fn radial_position(j: usize, samples: usize, step: f64) -> f64 {
    (j as f64 - (samples - 1) as f64 / 2.0) * step
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An n × n image whose pixel values are the area fraction of each pixel inside
    /// `inside` (16 × 16 samples per pixel).
    fn coverage(n: usize, inside: impl Fn(f64, f64) -> bool) -> Raster {
        let c = (n as f64 - 1.0) / 2.0;
        let data = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f64 - c, (i / n) as f64 - c);
                let hits = (0..256)
                    .filter(|s| {
                        inside(
                            x + ((s % 16) as f64 + 0.5) / 16.0 - 0.5,
                            y + ((s / 16) as f64 + 0.5) / 16.0 - 0.5,
                        )
                    })
                    .count();
                hits as f32 / 256.0
            })
            .collect();
        Raster::from_vec(n, n, 1, data).unwrap()
    }

    /// A centred disc of radius R: every angle gives the chord 2√(R² − p²), within 0.4 px
    /// (the pixels' area coverage blurs the rim, where the chord is steepest) up to 5 px from
    /// the rim; a centre off by half a pixel would be 1.8 px off there.
    #[test]
    fn disc_gives_chord_lengths() {
        let radius = 40.0;
        let image = coverage(101, |x, y| x * x + y * y <= radius * radius);
        let params = RadonParams {
            angles: 36,
            ..Default::default()
        };
        let radon = Radon::new(&image, params).unwrap();
        let mut worst: f64 = 0.0;
        for i in 0..36 {
            for j in 0..radon.values.width {
                let p = radon.p(j);
                let chord = 2.0 * (radius * radius - p * p).max(0.0).sqrt();
                let value = radon.values.at(j, i) as f64;
                if p.abs() <= radius - 5.0 {
                    worst = worst.max((value - chord).abs());
                    assert!((value - chord).abs() < 0.4, "φ {i}0°, p {p}: {value} vs chord {chord}");
                }
                if p.abs() >= radius + 2.0 {
                    assert!(value.abs() < 1e-6);
                }
            }
        }
        assert!(worst > 0.0);
    }

    /// A horizontal segment at v − cy = 20 from u − cx = −30 to +30: its whole length at
    /// φ = 90° (normal +v), p = 20, and at φ = 270°, p = −20; at φ = 0 its thickness over
    /// |p| < 30; and every angle integrates to its mass.
    #[test]
    fn line_peaks_at_its_normal() {
        let image = coverage(101, |x, y| (19.5..20.5).contains(&y) && (-30.5..30.5).contains(&x));
        let radon = Radon::new(&image, RadonParams::default()).unwrap();
        let centre = (radon.values.width - 1) as f64 / 2.0;
        let at = |angle: usize, p: f64| radon.values.at((p + centre) as usize, angle) as f64;
        assert!((at(90, 20.0) - 61.0).abs() < 0.1, "{}", at(90, 20.0));
        assert!((at(270, -20.0) - 61.0).abs() < 0.1, "{}", at(270, -20.0));
        let peak = radon.values.data.iter().copied().fold(f32::MIN, f32::max) as f64;
        assert!((peak - at(90, 20.0)).abs() < 1e-3);
        for p in -28..=28 {
            assert!((at(0, p as f64) - 1.0).abs() < 0.01, "φ 0, p {p}: {}", at(0, p as f64));
        }
        for angle in (0..360).step_by(7) {
            let mass: f64 = (0..radon.values.width).map(|j| radon.values.at(j, angle) as f64).sum();
            assert!((mass - 61.0).abs() < 0.5, "φ {angle}°: mass {mass}");
        }
    }

    /// An image turned by 90° about its centre (an exact pixel permutation) shifts the
    /// transform by 90 of 360 angles; phase-only correlation finds it with a high peak (0.88:
    /// whitening lifts the f32 rounding of near-empty frequencies).
    #[test]
    fn quarter_turn_is_found_by_phase_only_correlation() {
        let n = 61;
        let image = coverage(n, |x, y| {
            (x - 7.0).powi(2) + (y + 11.0).powi(2) < 60.0 || (x + y > 20.0 && x < 25.0)
        });
        // (x, y) → (−y, x): a turn by +90° from +u towards +v.
        let mut turned = Raster::new(n, n, 1);
        for y in 0..n {
            for x in 0..n {
                turned.data[x * n + (n - 1 - y)] = image.at(x, y);
            }
        }
        let params = RadonParams::default();
        let a = Radon::new(&image, params).unwrap();
        let b = Radon::new(&turned, params).unwrap();
        let (rotation, peak) = a.rotation_to(&b).unwrap();
        assert_eq!(rotation.steps, 90);
        assert!(peak > 0.8, "peak {peak}");
        let (back, _) = b.rotation_to(&a).unwrap();
        assert_eq!(back.steps, 270);
    }
}
