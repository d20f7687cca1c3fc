//! The distances between global descriptors that Payá et al. 2014 (Sensors 14(2), §4) and
//! Amorós et al. 2021 (Sensors 21(10), §3) compare: Minkowski (L1, L2), cosine and correlation
//! distances, computed in f64.

/// A distance between two descriptors of one length.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Distance {
    /// Σ|a − b| (city block).
    L1,
    /// √Σ(a − b)² (Euclidean).
    L2,
    /// 1 − a·b/(‖a‖‖b‖); 1 when either is zero.
    Cosine,
    /// 1 − r, r the Pearson correlation of the values; 1 when either is constant.
    Correlation,
}

impl Distance {
    /// Every distance, in report order.
    pub const ALL: [Distance; 4] = [Distance::L1, Distance::L2, Distance::Cosine, Distance::Correlation];

    /// The name in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Distance::L1 => "l1",
            Distance::L2 => "l2",
            Distance::Cosine => "cosine",
            Distance::Correlation => "correlation",
        }
    }

    /// The distance named `name` (l1, l2, cosine, correlation).
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.name() == name)
    }

    /// The distance between `a` and `b` (the shorter length is compared).
    pub fn between(self, a: &[f32], b: &[f32]) -> f64 {
        let pairs = a.iter().zip(b).map(|(&x, &y)| (f64::from(x), f64::from(y)));
        match self {
            Distance::L1 => pairs.map(|(x, y)| (x - y).abs()).sum(),
            Distance::L2 => pairs.map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt(),
            Distance::Cosine => one_minus_cosine(pairs),
            Distance::Correlation => {
                let n = a.len().min(b.len()).max(1) as f64;
                let mean_a = a.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
                let mean_b = b.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
                one_minus_cosine(pairs.map(|(x, y)| (x - mean_a, y - mean_b)))
            }
        }
    }
}

/// 1 − cos of the angle between the vectors of the pairs; 1 when either is zero.
fn one_minus_cosine(pairs: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (dot, aa, bb) = pairs.fold((0.0, 0.0, 0.0), |(d, a, b), (x, y)| (d + x * y, a + x * x, b + y * y));
    if aa > 0.0 && bb > 0.0 {
        1.0 - dot / (aa.sqrt() * bb.sqrt())
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms on (1, 2, 3) and (2, 4, 7).
    #[test]
    fn closed_forms() {
        let (a, b) = ([1.0f32, 2.0, 3.0], [2.0f32, 4.0, 7.0]);
        assert_eq!(Distance::L1.between(&a, &b), 1.0 + 2.0 + 4.0);
        assert!((Distance::L2.between(&a, &b) - 21f64.sqrt()).abs() < 1e-12);
        let cosine = 1.0 - 31.0 / (14f64.sqrt() * 69f64.sqrt());
        assert!((Distance::Cosine.between(&a, &b) - cosine).abs() < 1e-12);
        // Centred: (−1, 0, 1) and (−7/3, −1/3, 8/3): r = (7/3 + 8/3)/(√2·√(114/9)).
        let r = 5.0 / (2f64.sqrt() * (114.0f64 / 9.0).sqrt());
        assert!((Distance::Correlation.between(&a, &b) - (1.0 - r)).abs() < 1e-12);
        // Scale does not change cosine or correlation; offset does not change correlation.
        let scaled: Vec<f32> = b.iter().map(|v| 3.0 * v + 1.0).collect();
        assert!((Distance::Correlation.between(&a, &scaled) - (1.0 - r)).abs() < 1e-6);
        for d in Distance::ALL {
            assert!(d.between(&a, &a).abs() < 1e-12, "{d:?}");
            assert_eq!(Distance::parse(d.name()), Some(d));
        }
        assert_eq!(Distance::Cosine.between(&[0.0, 0.0], &a), 1.0);
    }
}
