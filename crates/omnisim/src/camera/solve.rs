//! The one scalar root finder the lens models share: the inverse of an increasing function on
//! an interval, by Newton steps kept inside a shrinking bracket (bisection when a step would
//! leave it), with a convergence test. Hand-written because the models need the bracket
//! (a Newton step past a lens's valid range would land on a wrapped ray), and the crates that
//! offer bracketed Newton (`roots`, `argmin`) bring far more than these twenty lines.

/// Most iterations: bisection alone halves the bracket 64 times, enough for f64.
const ITERATIONS: usize = 200;

/// The x in `[low, high]` with `f(x) = target`, for `f` increasing there with derivative
/// `slope`; `None` when `target` lies outside `[f(low), f(high)]` or the iteration does not
/// converge (the caller treats the pixel or point as outside the lens's field of view).
pub(crate) fn increasing_inverse(
    f: impl Fn(f64) -> f64,
    slope: impl Fn(f64) -> f64,
    target: f64,
    (mut low, mut high): (f64, f64),
) -> Option<f64> {
    let tolerance = 4.0 * f64::EPSILON * target.abs().max(1.0);
    let (f_low, f_high) = (f(low), f(high));
    if !(target >= f_low - tolerance && target <= f_high + tolerance) {
        return None;
    }
    // The linear guess between the ends; exact for a linear f.
    let mut x = if f_high > f_low {
        (low + (target - f_low) / (f_high - f_low) * (high - low)).clamp(low, high)
    } else {
        low
    };
    for _ in 0..ITERATIONS {
        let residual = f(x) - target;
        if residual.abs() <= tolerance {
            return Some(x);
        }
        if residual > 0.0 {
            high = x;
        } else {
            low = x;
        }
        let step = x - residual / slope(x);
        x = if step > low && step < high && step.is_finite() {
            step
        } else {
            0.5 * (low + high)
        };
        if high - low <= 2.0 * f64::EPSILON * high.abs().max(1.0) {
            return ((f(x) - target).abs() <= 16.0 * tolerance).then_some(x);
        }
    }
    None
}

/// The first x in `(0, end]` where `slope` stops being positive, found on `samples` steps and
/// refined by bisection; `end` when it stays positive. The edge of a lens's valid field of
/// view, where its mapping stops increasing.
pub(crate) fn first_non_increase(slope: impl Fn(f64) -> f64, end: f64, samples: usize) -> f64 {
    let mut previous = 0.0;
    for step in 1..=samples {
        let x = end * step as f64 / samples as f64;
        if slope(x) > 0.0 {
            previous = x;
            continue;
        }
        let (mut low, mut high) = (previous, x);
        for _ in 0..80 {
            let middle = 0.5 * (low + high);
            if slope(middle) > 0.0 {
                low = middle;
            } else {
                high = middle;
            }
        }
        return low;
    }
    end
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverts_an_increasing_cubic_and_refuses_targets_outside_its_range() {
        let f = |x: f64| x + x * x * x;
        let slope = |x: f64| 1.0 + 3.0 * x * x;
        for target in [0.0, 0.3, 1.0, 9.9] {
            let x = increasing_inverse(f, slope, target, (0.0, 2.0)).expect("inside");
            assert!((f(x) - target).abs() < 1e-14, "{target}");
        }
        assert_eq!(increasing_inverse(f, slope, 10.5, (0.0, 2.0)), None);
        assert_eq!(increasing_inverse(f, slope, -0.1, (0.0, 2.0)), None);
    }

    #[test]
    fn finds_where_a_slope_turns() {
        // sin'(x) = cos(x) turns at π/2.
        let turn = first_non_increase(f64::cos, 3.0, 100);
        assert!((turn - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(first_non_increase(|_| 1.0, 3.0, 10), 3.0);
    }
}
