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
        let n = a.len().min(b.len());
        let (a, b) = (&a[..n], &b[..n]);
        match self {
            Distance::L1 => lanes(a, b, |x, y| (x - y).abs()),
            Distance::L2 => lanes(a, b, |x, y| (x - y) * (x - y)).sqrt(),
            Distance::Cosine => one_minus_cosine(
                lanes(a, b, |x, y| x * y),
                lanes(a, a, |x, _| x * x),
                lanes(b, b, |y, _| y * y),
            ),
            Distance::Correlation => {
                let count = n.max(1) as f64;
                let mean_a = lanes(a, a, |x, _| x) / count;
                let mean_b = lanes(b, b, |y, _| y) / count;
                let (ca, cb) = (|x: f64| x - mean_a, |y: f64| y - mean_b);
                one_minus_cosine(
                    lanes(a, b, |x, y| ca(x) * cb(y)),
                    lanes(a, a, |x, _| ca(x) * ca(x)),
                    lanes(b, b, |y, _| cb(y) * cb(y)),
                )
            }
        }
    }
}

/// Σ `term(a_i, b_i)` in f64 over four running sums: independent additions that the compiler
/// pipelines and vectorizes (one sum in order waits on each addition; the distance matrix of a
/// localization run is most of its matching time).
fn lanes(a: &[f32], b: &[f32], term: impl Fn(f64, f64) -> f64) -> f64 {
    const LANES: usize = 4;
    let mut sums = [0.0f64; LANES];
    let (a_chunks, b_chunks) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f64 = a_chunks
        .remainder()
        .iter()
        .zip(b_chunks.remainder())
        .map(|(&x, &y)| term(f64::from(x), f64::from(y)))
        .sum();
    for (x, y) in a_chunks.zip(b_chunks) {
        for ((s, &x), &y) in sums.iter_mut().zip(x).zip(y) {
            *s += term(f64::from(x), f64::from(y));
        }
    }
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + tail
}

/// 1 − dot/(√aa·√bb), the cosine of the angle between two vectors from their dot product and
/// squared norms; 1 when either is zero.
fn one_minus_cosine(dot: f64, aa: f64, bb: f64) -> f64 {
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
