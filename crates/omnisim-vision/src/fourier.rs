//! Fourier signature of a panoramic image (Menegatti et al. 2004, as used by Payá et al. 2010,
//! Sensors 10(12), and 2014, Sensors 14(2); Amorós et al. 2021, Sensors 21(10), §2.1 and
//! §3.1): the 1-D DFT of every row, of which the first k coefficients are kept.
//!
//! Turning the camera about the vertical axis shifts a 360° panorama by q columns, and by the
//! DFT shift theorem multiplies coefficient k of every row by e^{−j2πqk/W}: the magnitudes are
//! unchanged (a rotation-invariant position descriptor) and the phases carry the rotation.

use rustfft::FftDirection;

use crate::fft::{self, C64};
use crate::{Raster, Rotation, VisionError, require};

/// How many coefficients per row to keep. The default, 16, is within the range those papers
/// find a good compromise (they test k = 4 … 64 on 128 × 512 panoramas).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FourierParams {
    /// Coefficients k kept per row (0..k).
    pub coefficients: usize,
}

impl Default for FourierParams {
    fn default() -> Self {
        Self { coefficients: 16 }
    }
}

impl FourierParams {
    /// Checks the setting that does not depend on the panorama: k at least 1.
    pub fn validate(&self) -> Result<(), VisionError> {
        require(self.coefficients >= 1, "coefficients", || {
            "needs k ≥ 1, got 0".to_string()
        })
    }

    /// Checks everything, for a `width × height` panorama: also k ≤ width/2 + 1.
    pub fn fits(&self, width: usize, _height: usize) -> Result<(), VisionError> {
        self.validate()?;
        require(width >= 1, "width", || {
            "needs a panorama at least 1 column wide, got 0".to_string()
        })?;
        let k = self.coefficients;
        require(k <= width / 2 + 1, "coefficients", || {
            format!("needs 1 ≤ k ≤ width/2 + 1 = {}, got {k}", width / 2 + 1)
        })
    }
}

/// The first k DFT coefficients of every row of a one-channel panorama.
#[derive(Debug, Clone, PartialEq)]
pub struct FourierSignature {
    /// Rows of the panorama.
    pub rows: usize,
    /// Coefficients kept per row.
    pub coefficients: usize,
    /// Width of the panorama (the DFT length), which sets the angular resolution 2π/width.
    pub width: usize,
    /// Row-major, `rows × coefficients`: A[n][k] = `Σ_m` a[n][m]·e^{−j2πmk/W}.
    pub values: Vec<C64>,
}

impl FourierSignature {
    /// The signature of a one-channel panorama.
    pub fn new(panorama: &Raster, params: FourierParams) -> Result<Self, VisionError> {
        require(panorama.channels == 1, "channels", || {
            format!("the Fourier signature reads one channel, got {}", panorama.channels)
        })?;
        params.fits(panorama.width, panorama.height)?;
        let k = params.coefficients;
        let values = fft::real_rows(&panorama.data, panorama.width, k);
        Ok(Self {
            rows: panorama.height,
            coefficients: k,
            width: panorama.width,
            values,
        })
    }

    /// |A[n][k]|, row-major: invariant to rotations about the vertical axis.
    pub fn magnitudes(&self) -> Vec<f32> {
        self.values.iter().map(|v| v.norm() as f32).collect()
    }

    /// arg A[n][k] in (−π, π], row-major, whatever the signs of a coefficient's zeros (the
    /// real transform leaves −0 where a complex one left +0): a real negative coefficient has
    /// phase +π (`atan2(−0, x < 0)` is −π), and one that is exactly zero has +0.
    pub fn phases(&self) -> Vec<f32> {
        // Adding +0 turns −0 into +0 and leaves every other value as it is.
        (self.values.iter())
            .map(|v| (v.im + 0.0).atan2(v.re + 0.0) as f32)
            .collect()
    }

    /// The rotation that best takes this panorama to `other` (`steps` = columns by which
    /// `other` is this panorama shifted right; `radians` = the body's turn about +z,
    /// counter-clockwise from above, for omnisim's panoramas), by the phases: the shift q that
    /// maximises the correlation `Σ_n` `Σ_k` `w_k·Re(conj(A`[n][k])·B[n][k]·e^{j2πqk/W}) of the kept
    /// coefficients (`w_0` = 1, `w_k` = 2 for the conjugate bins a real row also has). For a pure
    /// shift B = A·e^{−j2πqk/W} every term peaks at the true q; resolution 2π/W.
    pub fn rotation_to(&self, other: &FourierSignature) -> Result<Rotation, VisionError> {
        require(
            (self.rows, self.coefficients, self.width) == (other.rows, other.coefficients, other.width),
            "signatures",
            || "rotation needs two signatures of the same shape".to_string(),
        )?;
        // Per-coefficient cross spectrum summed over rows, laid into a length-W spectrum whose
        // inverse DFT is the correlation over every shift at once.
        let mut spectrum = vec![C64::default(); self.width];
        for (a, b) in self
            .values
            .chunks(self.coefficients)
            .zip(other.values.chunks(other.coefficients))
        {
            for (k, (a, b)) in a.iter().zip(b).enumerate() {
                let weight = if k == 0 || 2 * k == self.width { 1.0 } else { 2.0 };
                spectrum[k] += a.conj() * b * weight;
            }
        }
        fft::rows(&mut spectrum, self.width, FftDirection::Inverse);
        let columns = (0..self.width)
            .max_by(|&i, &j| spectrum[i].re.total_cmp(&spectrum[j].re))
            .expect("width ≥ 1");
        Ok(Rotation::from_steps(columns, self.width))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(width: usize, height: usize) -> Raster {
        let data = (0..width * height)
            .map(|i| {
                let (x, y) = ((i % width) as f32, (i / width) as f32);
                (0.5 + 0.3 * (0.21 * x + 0.7 * y).sin() + 0.2 * (0.05 * x * y).cos()).fract()
            })
            .collect();
        Raster::from_vec(width, height, 1, data).unwrap()
    }

    /// A real negative coefficient has phase +π whatever its imaginary zero's sign: −π lies
    /// outside (−π, π]. Built by hand: the real transform left +0 in the one case tried (the
    /// Nyquist bin of a row alternating 0, 1), which gave +π before the fix too.
    #[test]
    fn phases_of_negative_real_coefficients_are_plus_pi() {
        let pi = std::f32::consts::PI;
        let signature = FourierSignature {
            rows: 1,
            coefficients: 4,
            width: 6,
            values: vec![
                C64::new(-2.0, -0.0),
                C64::new(-2.0, 0.0),
                C64::new(-0.0, -0.0),
                C64::new(0.0, -1.0),
            ],
        };
        let phases = signature.phases();
        assert_eq!(phases[..2], [pi, pi]);
        assert_eq!(phases[2].to_bits(), 0.0f32.to_bits());
        assert_eq!(phases[3], -pi / 2.0, "a nonzero imaginary part keeps its sign");
    }

    /// Whole-column shifts keep the magnitudes and are recovered exactly from the phases.
    #[test]
    fn shift_keeps_magnitudes_and_phases_give_it_back() {
        let panorama = texture(128, 16);
        let params = FourierParams::default();
        let reference = FourierSignature::new(&panorama, params).unwrap();
        for shift in [1, 5, 64, 127] {
            let shifted = FourierSignature::new(&panorama.shift_columns(shift), params).unwrap();
            for (a, b) in reference.magnitudes().iter().zip(shifted.magnitudes()) {
                assert!((a - b).abs() <= 1e-4 * a.max(1.0), "shift {shift}: {a} vs {b}");
            }
            let rotation = reference.rotation_to(&shifted).unwrap();
            assert_eq!(rotation.steps as i64, shift);
            assert!((rotation.radians - std::f64::consts::TAU * shift as f64 / 128.0).abs() < 1e-12);
        }
    }

    /// k = 1 keeps only the row means: no information on rotation, and k past W/2 + 1 is refused.
    #[test]
    fn coefficient_count_is_checked() {
        let panorama = texture(32, 4);
        let too_many = FourierParams { coefficients: 18 };
        assert!(FourierSignature::new(&panorama, too_many).is_err());
        let dc = FourierSignature::new(&panorama, FourierParams { coefficients: 1 }).unwrap();
        for (n, value) in dc.values.iter().enumerate() {
            let sum: f32 = panorama.row(n).iter().sum();
            assert!((value.re - f64::from(sum)).abs() < 1e-4 && value.im.abs() < 1e-9);
        }
    }

    /// A black row has only zero coefficients, up to the Nyquist bin k = W/2 + 1: every phase
    /// is +0.0 (the bits a complex transform gave), not the −0.0 of `atan2(−0, +0)`.
    #[test]
    fn phases_of_zero_coefficients_are_positive_zero() {
        let (width, height) = (16, 3);
        let mut panorama = texture(width, height);
        panorama.data[width..2 * width].fill(0.0);
        let params = FourierParams {
            coefficients: width / 2 + 1,
        };
        let signature = FourierSignature::new(&panorama, params).unwrap();
        let phases = signature.phases();
        let black = &phases[params.coefficients..2 * params.coefficients];
        assert!(black.iter().all(|p| p.to_bits() == 0.0f32.to_bits()), "{black:?}");
        assert!(phases[..params.coefficients].iter().any(|p| *p != 0.0));
    }

    /// A panorama without columns is refused by name, not a panic in the transform.
    #[test]
    fn zero_width_is_refused() {
        let empty = Raster::from_vec(0, 3, 1, vec![]).unwrap();
        let error = FourierSignature::new(&empty, FourierParams { coefficients: 1 }).unwrap_err();
        assert!(error.to_string().contains("width"), "{error}");
    }
}
