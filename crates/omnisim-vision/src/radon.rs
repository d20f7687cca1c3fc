//! Radon transform of an omnidirectional image and the rotation between two images by
//! phase-only correlation (Berenguer et al. 2015, Sensors 15(10); compared with the other
//! descriptors in Amorós et al. 2021, Sensors 21(10), §2.6 and §3.6.2 "Radon–POC method").
//!
//! R(φ, p) = ∫∫ f(x, y)·δ(x·cos φ + y·sin φ − p) dx dy (Radon 1917), with x = u − cx,
//! y = v − cy about the image centre (the mirror axis), φ from +u towards +v over a full turn
//! [0, 2π), so that turning the image about its centre by θ shifts R circularly along φ by θ:
//! `R_b(φ`, p) = `R_a(φ` − θ, p).
//!
//! Support: the integral runs over the disc of radius `reach` (the distance from the centre to
//! the nearest image edge), and the radial samples stop short of it (|p| < reach). Every angle
//! then sees the same support, a chord of length 2√(reach² − p²). Integrating over the whole
//! square made a pattern fixed to the pixel grid: when the centre falls on a whole pixel (odd
//! sizes, 251²), the sample p = ±reach is the edge row or column, counted for half its length
//! or, at exactly 0°/90°/180°/270°, all of it, and phase-only correlation locked onto that
//! pattern at 0° (3 of 20 yaws of a 251² image came back as 0°).
//!
//! Written here: no maintained Rust crate computes a Radon transform (imageproc has none), and
//! the line integral is a few lines over the bilinear sampler of [`crate::raster`].

use rayon::prelude::*;
use rustfft::FftDirection;

use crate::fft::{self, C64};
use crate::{Raster, Rotation, VisionError, require};

/// Sampling of the transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadonParams {
    /// Angles over the full turn, step 2π/angles. Default 360 (1°), as Berenguer et al.
    pub angles: usize,
    /// Radial samples `p_j` = (j − (`n−1)/2)·radial_step`, j = 0..n; `None`: every p strictly
    /// inside the disc that reaches the image edge nearest the centre, 2·(⌈reach/step⌉ − 1) + 1
    /// (reach = (min(W, H) − 1)/2 for the image centre: 249 samples for 250² and 251²).
    /// Samples at or beyond the reach integrate nothing.
    pub radial_samples: Option<usize>,
    /// Pixels between radial samples. Default 1.
    pub radial_step: f64,
    /// Step along each line, pixels.
    pub line_step: f64,
    /// The point (u, v) the lines' distances p are measured from, pixels: the mirror axis,
    /// i.e. the calibration's principal point (cx, cy). `None`: the image centre
    /// ((W−1)/2, (H−1)/2).
    pub centre: Option<(f64, f64)>,
}

impl Default for RadonParams {
    fn default() -> Self {
        Self {
            angles: 360,
            radial_samples: None,
            radial_step: 1.0,
            line_step: 0.5,
            centre: None,
        }
    }
}

/// Most radial samples and angles (each), and most values in a transform: a mistyped step
/// cannot ask for more memory than a machine has.
const MAX_SAMPLES: f64 = 1e6;
const MAX_VALUES: f64 = 1e8;

impl RadonParams {
    /// Checks the settings that do not depend on the image: 2 to 10⁶ angles, finite positive
    /// steps, 2 to 10⁶ radial samples if given, a finite centre if given.
    pub fn validate(&self) -> Result<(), VisionError> {
        require(self.angles >= 2 && self.angles as f64 <= MAX_SAMPLES, "angles", || {
            format!("needs 2 to {MAX_SAMPLES:.0e}, got {}", self.angles)
        })?;
        require(self.line_step.is_finite() && self.line_step > 0.0, "line step", || {
            format!("must be finite and positive, got {}", self.line_step)
        })?;
        require(
            self.radial_step.is_finite() && self.radial_step > 0.0,
            "radial step",
            || format!("must be finite and positive, got {}", self.radial_step),
        )?;
        if let Some(n) = self.radial_samples {
            require(n >= 2 && n as f64 <= MAX_SAMPLES, "radial samples", || {
                format!("needs 2 to {MAX_SAMPLES:.0e}, got {n}")
            })?;
        }
        require(
            self.centre.is_none_or(|(x, y)| x.is_finite() && y.is_finite()),
            "centre",
            || format!("must be finite, got {:?}", self.centre),
        )
    }
}

/// The transform: row i is angle `φ_i` = 2π·i/angles, column j is [`Radon::p`]`(j)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Radon {
    /// One channel: rows are angles, columns radial samples.
    pub values: Raster,
    /// Pixels between radial samples.
    pub radial_step: f64,
}

/// Where a transform of a given image size samples: its centre, the radius of the disc it
/// integrates over, and its radial sample count.
struct Layout {
    centre: (f64, f64),
    reach: f64,
    radial: usize,
}

impl RadonParams {
    /// Checks everything, for a `width × height` image: also the centre inside it and the
    /// sample counts it implies within their bounds.
    pub fn fits(&self, width: usize, height: usize) -> Result<(), VisionError> {
        self.layout(width, height).map(|_| ())
    }

    fn layout(&self, width: usize, height: usize) -> Result<Layout, VisionError> {
        self.validate()?;
        require(width >= 1 && height >= 1, "image", || "the image is empty".to_string())?;
        let (cx, cy) = self
            .centre
            .unwrap_or(((width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0));
        let (max_x, max_y) = ((width - 1) as f64, (height - 1) as f64);
        require(
            (0.0..=max_x).contains(&cx) && (0.0..=max_y).contains(&cy),
            "centre",
            || format!("({cx}, {cy}) is outside the {width}×{height} image"),
        )?;
        // From the centre to the nearest image edge ((min(W, H) − 1)/2 for the image centre).
        let reach = cx.min(max_x - cx).min(cy).min(max_y - cy);
        // In f64 first: a tiny step would overflow the count as an integer. Only |p| < reach:
        // the line at p = reach touches the disc in one point (module docs).
        let radial = match self.radial_samples {
            Some(n) => n as f64,
            None => 2.0 * ((reach / self.radial_step).ceil() - 1.0).max(0.0) + 1.0,
        };
        require((2.0..=MAX_SAMPLES).contains(&radial), "radial samples", || {
            format!(
                "{radial:.0} (the odd count of samples strictly within {reach} px of the centre); needs 2 to {MAX_SAMPLES:.0e}"
            )
        })?;
        let values = radial * self.angles as f64;
        require(values <= MAX_VALUES, "sampling", || {
            format!("{values:.1e} values asked (angles × radial samples); at most {MAX_VALUES:.0e}")
        })?;
        // Bounded so that a mistyped step cannot ask for days of work (the default is 6.3e7
        // samples for a 250² image).
        let samples = values * width.max(height) as f64 / self.line_step;
        require(samples <= 1e10, "sampling", || {
            format!(
                "{samples:.1e} line samples asked (angles × radial samples × line length / line step); at most 1e10"
            )
        })?;
        Ok(Layout {
            centre: (cx, cy),
            reach,
            radial: radial as usize,
        })
    }
}

impl Radon {
    /// Transform of a one-channel image about [`RadonParams::centre`] (the mirror axis; by
    /// default the image centre ((W−1)/2, (H−1)/2)), over the disc that reaches the nearest
    /// image edge.
    pub fn new(image: &Raster, params: RadonParams) -> Result<Self, VisionError> {
        require(image.channels == 1, "channels", || {
            format!("the Radon transform reads one channel, got {}", image.channels)
        })?;
        let Layout {
            centre: (cx, cy),
            reach,
            radial,
        } = params.layout(image.width, image.height)?;
        let p = |j: usize| radial_position(j, radial, params.radial_step);
        let mut values = Raster::new(radial, params.angles, 1);
        // R(φ + π, p) = R(φ, −p): the same line, walked the other way, and the radial samples
        // are symmetric about 0 (p of column n − 1 − j is −p of column j). With an even angle
        // count the second half-turn is the first one's rows reversed, and only half the lines
        // are integrated (equal to integrating them up to the rounding of sin and cos).
        let sampled_rows = if params.angles.is_multiple_of(2) {
            params.angles / 2
        } else {
            params.angles
        };
        let (sampled, mirrored) = values.data.split_at_mut(sampled_rows * radial);
        sampled.par_chunks_mut(radial).enumerate().for_each(|(i, row)| {
            let (sin, cos) = (std::f64::consts::TAU * i as f64 / params.angles as f64).sin_cos();
            for (j, value) in row.iter_mut().enumerate() {
                let p = p(j);
                // The chord of the disc at distance p: t² ≤ reach² − p², the same at every angle,
                // sampled symmetrically about the line's foot.
                let half_chord = (reach * reach - p * p).max(0.0).sqrt();
                let steps = (half_chord / params.line_step).floor() as i64;
                let mut sum = 0.0f64;
                if p.abs() < reach {
                    for k in -steps..=steps {
                        let t = k as f64 * params.line_step;
                        sum += f64::from(image.bilinear_one(cx + p * cos - t * sin, cy + p * sin + t * cos));
                    }
                }
                *value = (sum * params.line_step) as f32;
            }
        });
        for (mirror, row) in mirrored.chunks_mut(radial).zip(sampled.chunks(radial)) {
            for (m, &v) in mirror.iter_mut().zip(row.iter().rev()) {
                *m = v;
            }
        }
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
    /// cross-power spectrum normalised to unit magnitude, `conj(F_a)·F_b/|conj(F_a)·F_b`|,
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

impl Radon {
    /// A descriptor of the transform that a turn of the image leaves unchanged: for each
    /// radial sample p, the magnitudes of the first k coefficients of the DFT of R(·, p) along
    /// φ (a turn is a circular shift along φ, which changes only their phases). Radial-major,
    /// `width × k` values; k is at most angles/2 + 1.
    pub fn signature(&self, k: usize) -> Result<Vec<f32>, VisionError> {
        let (radial, angles) = (self.values.width, self.values.height);
        require((1..=angles / 2 + 1).contains(&k), "coefficients", || {
            format!("needs 1 ≤ k ≤ angles/2 + 1 = {}, got {k}", angles / 2 + 1)
        })?;
        let mut columns: Vec<C64> = (0..radial * angles)
            .map(|i| C64::new(f64::from(self.values.at(i / angles, i % angles)), 0.0))
            .collect();
        fft::rows(&mut columns, angles, FftDirection::Forward);
        Ok(columns
            .chunks(angles)
            .flat_map(|c| c[..k].iter().map(|v| v.norm() as f32))
            .collect())
    }
}

fn radial_position(j: usize, samples: usize, step: f64) -> f64 {
    (j as f64 - (samples - 1) as f64 / 2.0) * step
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Interpolation;

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
                            x + (f64::from(s % 16) + 0.5) / 16.0 - 0.5,
                            y + (f64::from(s / 16) + 0.5) / 16.0 - 0.5,
                        )
                    })
                    .count();
                hits as f32 / 256.0
            })
            .collect();
        Raster::from_vec(n, n, 1, data).unwrap()
    }

    /// The second half-turn, copied from the first with p reversed, equals the lines integrated
    /// at those angles (a seeded, lopsided image, off-centre; 1e-5 of the largest value).
    #[test]
    fn second_half_turn_equals_its_lines() {
        let (w, h) = (41, 37);
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                (0.3 * x).sin() + 0.02 * x * y / 10.0 + if x > 25.0 && y < 12.0 { 1.0 } else { 0.0 }
            })
            .collect();
        let image = Raster::from_vec(w, h, 1, data).unwrap();
        let params = RadonParams {
            angles: 24,
            centre: Some((19.0, 17.5)),
            ..Default::default()
        };
        let radon = Radon::new(&image, params).unwrap();
        let Layout { reach, radial, .. } = params.layout(w, h).unwrap();
        let largest = radon.values.data.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let mut sample = [0.0f32];
        for i in 12..24 {
            let (sin, cos) = (std::f64::consts::TAU * i as f64 / 24.0).sin_cos();
            for j in 0..radial {
                let p = radon.p(j);
                let steps = ((reach * reach - p * p).max(0.0).sqrt() / params.line_step).floor() as i64;
                let direct: f64 = (-steps..=steps)
                    .map(|k| {
                        let t = k as f64 * params.line_step;
                        image.sample(
                            19.0 + p * cos - t * sin,
                            17.5 + p * sin + t * cos,
                            Interpolation::Bilinear,
                            &mut sample,
                        );
                        f64::from(sample[0])
                    })
                    .sum::<f64>()
                    * params.line_step;
                let copied = f64::from(radon.values.at(j, i));
                assert!(
                    (copied - direct).abs() <= 1e-5 * f64::from(largest),
                    "row {i}, column {j}: {copied} vs {direct}"
                );
            }
        }
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
                let value = f64::from(radon.values.at(j, i));
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
        let at = |angle: usize, p: f64| f64::from(radon.values.at((p + centre) as usize, angle));
        assert!((at(90, 20.0) - 61.0).abs() < 0.1, "{}", at(90, 20.0));
        assert!((at(270, -20.0) - 61.0).abs() < 0.1, "{}", at(270, -20.0));
        let peak = f64::from(radon.values.data.iter().copied().fold(f32::MIN, f32::max));
        assert!((peak - at(90, 20.0)).abs() < 1e-3);
        for p in -28..=28 {
            assert!(
                (at(0, f64::from(p)) - 1.0).abs() < 0.01,
                "φ 0, p {p}: {}",
                at(0, f64::from(p))
            );
        }
        for angle in (0..360).step_by(7) {
            let mass: f64 = (0..radon.values.width)
                .map(|j| f64::from(radon.values.at(j, angle)))
                .sum();
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

    /// The signature is unchanged by a turn (a circular shift along φ) and is the DFT of each
    /// radial column: its first coefficient is the column's sum.
    #[test]
    fn signature_ignores_turns() {
        let image = coverage(41, |x, y| {
            (x - 5.0).powi(2) + (y + 3.0).powi(2) < 40.0 || (x > 4.0 && y > 8.0 && x < 12.0)
        });
        let radon = Radon::new(
            &image,
            RadonParams {
                angles: 72,
                ..Default::default()
            },
        )
        .unwrap();
        let mut turned = radon.clone();
        for i in 0..72 {
            for j in 0..radon.values.width {
                turned.values.data[((i + 17) % 72) * radon.values.width + j] = radon.values.at(j, i);
            }
        }
        let (a, b) = (radon.signature(8).unwrap(), turned.signature(8).unwrap());
        assert_eq!(a.len(), radon.values.width * 8);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-4 * x.abs().max(1.0), "{x} vs {y}");
        }
        let column_sum: f32 = (0..72).map(|i| radon.values.at(20, i)).sum();
        assert!((a[20 * 8] - column_sum).abs() <= 1e-3 * column_sum.max(1.0));
        assert!(radon.signature(0).is_err() && radon.signature(38).is_err());
    }

    /// A disc off the image centre, transformed about its own centre (`centre`), gives the
    /// chords of a centred disc; about the image centre it does not.
    #[test]
    fn centre_is_a_parameter() {
        let (radius, (dx, dy)) = (25.0, (12.0, -9.0));
        let image = coverage(101, |x, y| (x - dx).powi(2) + (y - dy).powi(2) <= radius * radius);
        let params = RadonParams {
            angles: 36,
            centre: Some((50.0 + dx, 50.0 + dy)),
            ..Default::default()
        };
        let radon = Radon::new(&image, params).unwrap();
        // The nearest edge is 50 − 12 = 38 px away: |p| ≤ 37, 2·37 + 1 samples.
        assert_eq!(radon.values.width, 75);
        let chord_error = |radon: &Radon| {
            let mut worst: f64 = 0.0;
            for i in 0..36 {
                for j in 0..radon.values.width {
                    let p = radon.p(j);
                    if p.abs() <= radius - 5.0 {
                        let chord = 2.0 * (radius * radius - p * p).sqrt();
                        worst = worst.max((f64::from(radon.values.at(j, i)) - chord).abs());
                    }
                }
            }
            worst
        };
        assert!(chord_error(&radon) < 0.4, "{}", chord_error(&radon));
        let about_image_centre = Radon::new(&image, RadonParams { centre: None, ..params }).unwrap();
        assert!(chord_error(&about_image_centre) > 10.0);
    }

    /// Settings a user can type are refused with an error, never a panic: a step so small
    /// that the sample count overflows, non-finite steps, a centre outside the image.
    #[test]
    fn bad_settings_are_refused() {
        let image = Raster::new(20, 20, 1);
        for params in [
            RadonParams {
                radial_step: 1e-20,
                ..Default::default()
            },
            RadonParams {
                radial_step: f64::NAN,
                ..Default::default()
            },
            RadonParams {
                line_step: f64::INFINITY,
                ..Default::default()
            },
            RadonParams {
                radial_samples: Some(usize::MAX),
                ..Default::default()
            },
            RadonParams {
                angles: usize::MAX,
                ..Default::default()
            },
            RadonParams {
                centre: Some((25.0, 3.0)),
                ..Default::default()
            },
            RadonParams {
                centre: Some((f64::NAN, 3.0)),
                ..Default::default()
            },
        ] {
            assert!(
                matches!(Radon::new(&image, params), Err(VisionError::Parameter { .. })),
                "{params:?}"
            );
        }
    }
}
