//! Summaries of localization errors: mean, median, 95th percentile, recall at a radius.

/// Mean, median, 95th percentile and largest of a list of errors.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Summary {
    /// How many errors.
    pub count: usize,
    /// Their mean.
    pub mean: f64,
    /// Their median.
    pub median: f64,
    /// Their 95th percentile.
    pub p95: f64,
    /// The largest.
    pub max: f64,
}

/// The summary of `values` (`None` for none), percentiles interpolated linearly between
/// order statistics (numpy's default: rank q·(n − 1)).
pub fn summarise(values: &[f64]) -> Option<Summary> {
    if values.is_empty() {
        return None;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let percentile = |q: f64| {
        let rank = q * (sorted.len() - 1) as f64;
        let (lo, hi) = (rank.floor() as usize, rank.ceil() as usize);
        sorted[lo] + (sorted[hi] - sorted[lo]) * (rank - lo as f64)
    };
    Some(Summary {
        count: values.len(),
        mean: values.iter().sum::<f64>() / values.len() as f64,
        median: percentile(0.5),
        p95: percentile(0.95),
        max: sorted[sorted.len() - 1],
    })
}

/// The fraction of `errors` at most `radius`.
pub fn recall(errors: &[f64], radius: f64) -> f64 {
    if errors.is_empty() {
        return 0.0;
    }
    errors.iter().filter(|&&e| e <= radius).count() as f64 / errors.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// numpy: percentile([3, 1, 4, 1, 5], 50) = 3, 95 → 4.8; recall counts the boundary.
    #[test]
    fn numpy_percentiles() {
        let s = summarise(&[3.0, 1.0, 4.0, 1.0, 5.0]).unwrap();
        assert_eq!((s.count, s.mean, s.median, s.max), (5, 2.8, 3.0, 5.0));
        assert!((s.p95 - 4.8).abs() < 1e-12);
        assert_eq!(recall(&[0.1, 0.25, 0.3], 0.25), 2.0 / 3.0);
        assert!(summarise(&[]).is_none());
    }
}
