//! `OCamCalib`'s `calib_results.txt` (Scaramuzza's toolbox; read by its `get_ocam_model` in
//! `ocam_functions.c`): the direct polynomial (`ss`, used by `cam2world`), the inverse
//! polynomial (`invpol`, used by `world2cam`), the centre as row and column, the affine
//! c d e, and the image size as height and width. The inverse polynomial is a fit; the file
//! states its largest error.

use std::f64::consts::FRAC_PI_2;
use std::fmt::Write;

use nalgebra::{DMatrix, DVector};

use crate::camera::{LensCamera, Scaramuzza};

/// Angles the inverse polynomial is fitted and checked on.
const FIT_SAMPLES: usize = 2000;
/// The fit stops growing its degree once no sample is off by more than this, pixels.
const FIT_TOLERANCE_PX: f64 = 1e-4;
/// Highest degree tried (`OCamCalib`'s C reader holds 64 coefficients).
const MAX_DEGREE: usize = 30;

/// `OCamCalib`'s inverse polynomial: ρ as a polynomial in θ = atan(z/‖(x, y)‖) of its frame
/// (z = −optical z, so θ runs from −π/2 on the axis), fitted by least squares with the
/// lowest degree that meets [`FIT_TOLERANCE_PX`]. Returns (coefficients, largest error px).
fn inverse_polynomial(model: &Scaramuzza, max_angle: f64) -> (Vec<f64>, f64) {
    let samples: Vec<(f64, f64)> = (0..FIT_SAMPLES)
        .filter_map(|i| {
            let off_axis = max_angle * i as f64 / (FIT_SAMPLES - 1) as f64;
            model.rho_at_angle(off_axis).map(|rho| (off_axis - FRAC_PI_2, rho))
        })
        .collect();
    let mut best = (Vec::new(), f64::INFINITY);
    for degree in 2..=MAX_DEGREE {
        let columns = degree + 1;
        let design = DMatrix::from_fn(samples.len(), columns, |row, column| {
            samples[row].0.powi(i32::try_from(column).unwrap_or(i32::MAX))
        });
        let target = DVector::from_iterator(samples.len(), samples.iter().map(|&(_, rho)| rho));
        let Ok(solution) = design.svd(true, true).solve(&target, 1e-300) else {
            continue;
        };
        let coefficients: Vec<f64> = solution.iter().copied().collect();
        let error = samples
            .iter()
            .map(|&(theta, rho)| (evaluate(&coefficients, theta) - rho).abs())
            .fold(0.0, f64::max);
        if error < best.1 {
            best = (coefficients, error);
        }
        if best.1 <= FIT_TOLERANCE_PX {
            break;
        }
    }
    best
}

fn evaluate(coefficients: &[f64], x: f64) -> f64 {
    coefficients.iter().rev().fold(0.0, |sum, &a| sum * x + a)
}

fn numbers(values: &[f64]) -> String {
    values.iter().fold(String::new(), |mut out, v| {
        let _ = write!(out, " {v:e}");
        out
    })
}

/// The text of `calib_results.txt` for a Scaramuzza lens camera.
pub(super) fn calib_results(camera: &LensCamera, model: &Scaramuzza) -> String {
    let (invpol, error) = inverse_polynomial(model, camera.model.max_angle());
    let (c, d, e) = model.affine();
    let mut out = String::from(
        "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). These are used by cam2world\n\n",
    );
    let _ = writeln!(out, "{}{}\n", model.polynomial().len(), numbers(model.polynomial()));
    out += "#polynomial coefficients for the inverse mapping function (ocam_model.invpol in MATLAB). These are used by world2cam\n\n";
    let _ = writeln!(out, "{}{}\n", invpol.len(), numbers(&invpol));
    out += "#center: \"row\" and \"column\", starting from 0 (C convention)\n\n";
    // OCamCalib's centre is (row, column): omnisim's (cy, cx).
    let _ = writeln!(out, "{:e} {:e}\n", camera.intrinsics.cy, camera.intrinsics.cx);
    out += "#affine parameters \"c\", \"d\", \"e\"\n\n";
    let _ = writeln!(out, "{c:e} {d:e} {e:e}\n");
    out += "#image size: \"height\" and \"width\"\n\n";
    let _ = writeln!(out, "{} {}\n", camera.intrinsics.height, camera.intrinsics.width);
    let _ = writeln!(
        out,
        "#omnisim: the direct polynomial is the lens itself (exact); the inverse polynomial is a least-squares fit\n\
         #of degree {}, off by at most {error:.2e} px over the valid field of view ({:.3} degrees off axis). OCamCalib's\n\
         #frame: x along rows, y along columns, z = ss(rho) < 0 towards the scene; omnisim's optical frame is\n\
         #(y, x, -z) of it (x right, y down, z forward), mounted looking along body +x.",
        invpol.len().saturating_sub(1),
        camera.model.max_angle().to_degrees()
    );
    out
}
