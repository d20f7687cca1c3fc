//! Principal components analysis of a map set of images or descriptors (Payá et al. 2010,
//! Sensors 10(12): PCA of the map's panoramas; Payá et al. 2014, Sensors 14(2)).
//!
//! X is the N × D matrix of centred samples. With N samples of dimension D ≥ N (images), the
//! principal axes come from the N × N Gram matrix (Turk & Pentland 1991, as those papers do):
//! if X·Xᵀ·v = λ·v then Xᵀ·v/√λ is a unit principal axis with variance λ/(N − 1). With
//! D < N (short descriptors of a large map) the D × D scatter matrix is smaller: Xᵀ·X·a = λ·a
//! gives the unit axis a directly, with the same λ. Both have the same non-zero eigenvalues, so
//! both give the same axes (up to sign) and variances. At most min(N − 1, D) axes exist.
//! Eigen-decomposition: nalgebra's `SymmetricEigen`.
//!
//! A test set is projected with the map's basis: fit once, [`Pca::save`], [`Pca::load`].

use std::path::Path;

use nalgebra::{DMatrix, SymmetricEigen};

use crate::{VisionError, npy, require};

/// The JSON sidecar [`Pca::save`] writes beside the arrays.
const SIDECAR: &str = "pca.json";
/// Largest sidecar read (it lists one variance ratio per component).
const SIDECAR_LIMIT: u64 = 64 << 20;

/// Mean, principal axes and their variances.
#[derive(Debug, Clone, PartialEq)]
pub struct Pca {
    /// Mean sample, D values.
    pub mean: Vec<f32>,
    /// Unit principal axes, row-major [components, D], largest variance first.
    pub axes: Vec<f32>,
    /// Variance of the map set along each axis.
    pub variances: Vec<f64>,
    /// Total variance of the map set (the sum over all N − 1 axes), for the explained ratios.
    pub total_variance: f64,
}

impl Pca {
    /// Fits `components` axes (at most N − 1, fewer if the samples span fewer dimensions) to
    /// `samples`, each of the same length: through the smaller of the N × N Gram and the D × D
    /// scatter matrix.
    pub fn fit(samples: &[Vec<f32>], components: usize) -> Result<Pca, VisionError> {
        let gram = samples.first().is_none_or(|s| s.len() >= samples.len());
        Self::fit_by(samples, components, gram)
    }

    /// [`Pca::fit`] through the Gram matrix (`gram`) or the scatter matrix.
    fn fit_by(samples: &[Vec<f32>], components: usize, gram: bool) -> Result<Pca, VisionError> {
        let n = samples.len();
        require(n >= 2, "samples", || format!("PCA needs at least 2 samples, got {n}"))?;
        let dim = samples[0].len();
        require(samples.iter().all(|s| s.len() == dim) && dim > 0, "samples", || {
            "every sample must have the same, non-zero length".to_string()
        })?;
        // Sums sample by sample, in the samples' order (a column-by-column pass strides through
        // every sample for each value: most of a 400-image map's fit).
        let mut mean = vec![0.0f64; dim];
        for sample in samples {
            for (m, &v) in mean.iter_mut().zip(sample) {
                *m += f64::from(v);
            }
        }
        mean.iter_mut().for_each(|m| *m /= n as f64);
        // One centred sample per column: Xᵀ of the module docs (`dim × n`; column-major, so it
        // fills sample by sample).
        let centred = DMatrix::from_fn(dim, n, |j, i| f64::from(samples[i][j]) - mean[j]);
        let eigen = if gram {
            SymmetricEigen::new(centred.transpose() * &centred)
        } else {
            SymmetricEigen::new(&centred * centred.transpose())
        };
        let mut order: Vec<usize> = (0..eigen.eigenvalues.len()).collect();
        order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
        let total: f64 = eigen.eigenvalues.iter().map(|l| l.max(0.0)).sum();
        // Eigenvalues at rounding level belong to the null space, not to axes.
        let floor = total * 1e-10;
        let kept: Vec<usize> = order
            .into_iter()
            .filter(|&i| eigen.eigenvalues[i] > floor)
            .take(components)
            .collect();
        let mut axes = Vec::with_capacity(kept.len() * dim);
        for &i in &kept {
            if gram {
                let axis = &centred * eigen.eigenvectors.column(i) / eigen.eigenvalues[i].sqrt();
                axes.extend(axis.iter().map(|&v| v as f32));
            } else {
                axes.extend(eigen.eigenvectors.column(i).iter().map(|&v| v as f32));
            }
        }
        let variance = |lambda: f64| lambda / (n - 1) as f64;
        Ok(Pca {
            mean: mean.iter().map(|&m| m as f32).collect(),
            axes,
            variances: kept.iter().map(|&i| variance(eigen.eigenvalues[i])).collect(),
            total_variance: variance(total),
        })
    }

    /// Axes kept.
    pub fn components(&self) -> usize {
        self.variances.len()
    }

    /// Fraction of the map set's variance along each axis.
    pub fn explained_variance_ratio(&self) -> Vec<f64> {
        self.variances.iter().map(|v| v / self.total_variance).collect()
    }

    /// Coordinates of `sample` on the first `components` axes.
    pub fn project(&self, sample: &[f32], components: usize) -> Result<Vec<f32>, VisionError> {
        require(sample.len() == self.mean.len(), "sample", || {
            format!("{} values, the basis has {}", sample.len(), self.mean.len())
        })?;
        Ok(self
            .axes
            .chunks(self.mean.len())
            .take(components)
            .map(|axis| {
                axis.iter()
                    .zip(sample.iter().zip(&self.mean))
                    .map(|(a, (x, m))| f64::from(*a) * (f64::from(*x) - f64::from(*m)))
                    .sum::<f64>() as f32
            })
            .collect())
    }

    /// The sample that `coordinates` (on the first axes) stand for.
    pub fn reconstruct(&self, coordinates: &[f32]) -> Vec<f32> {
        let mut sample: Vec<f64> = self.mean.iter().map(|&m| f64::from(m)).collect();
        for (axis, &c) in self.axes.chunks(self.mean.len()).zip(coordinates) {
            for (s, a) in sample.iter_mut().zip(axis) {
                *s += f64::from(c) * f64::from(*a);
            }
        }
        sample.iter().map(|&s| s as f32).collect()
    }

    /// Writes `mean.npy` [D], `axes.npy` [components, D], `variances.npy` [components] and
    /// `pca.json` (the total variance, which the explained ratios divide by, and the shapes)
    /// into `folder`, which must exist.
    pub fn save(&self, folder: &Path) -> Result<(), VisionError> {
        npy::write(&folder.join("mean.npy"), &[self.mean.len()], &self.mean)?;
        npy::write(
            &folder.join("axes.npy"),
            &[self.components(), self.mean.len()],
            &self.axes,
        )?;
        let variances: Vec<f32> = self.variances.iter().map(|&v| v as f32).collect();
        npy::write(&folder.join("variances.npy"), &[variances.len()], &variances)?;
        let sidecar = serde_json::json!({
            "total_variance": self.total_variance,
            "components": self.components(),
            "dimension": self.mean.len(),
            "explained_variance_ratio": self.explained_variance_ratio(),
            "files": { "mean": "mean.npy", "axes": "axes.npy", "variances": "variances.npy" },
        });
        let path = folder.join(SIDECAR);
        let text = serde_json::to_string_pretty(&sidecar).expect("a JSON value serialises") + "\n";
        omnisim::atomic_file::write_atomically(&path, |out| std::io::Write::write_all(out, text.as_bytes()))
            .map_err(|source| VisionError::Io { path, source })
    }

    /// Reads what [`Pca::save`] wrote.
    pub fn load(folder: &Path) -> Result<Pca, VisionError> {
        let (_, mean) = npy::read(&folder.join("mean.npy"))?;
        let (axes_shape, axes) = npy::read(&folder.join("axes.npy"))?;
        let (_, variances) = npy::read(&folder.join("variances.npy"))?;
        let path = folder.join(SIDECAR);
        let text = omnisim::input::read_text(&path, SIDECAR_LIMIT)?;
        let total_variance = serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v["total_variance"].as_f64())
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| VisionError::Format {
                path,
                reason: "no total_variance (a finite number ≥ 0)".to_string(),
            })?;
        if axes_shape != [variances.len(), mean.len()] {
            return Err(VisionError::Format {
                path: folder.join("axes.npy"),
                reason: format!(
                    "shape {axes_shape:?} does not match {} axes of {} values",
                    variances.len(),
                    mean.len()
                ),
            });
        }
        Ok(Pca {
            mean,
            axes,
            variances: variances.iter().map(|&v| f64::from(v)).collect(),
            total_variance,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 12 samples of 60 values spanning 11 dimensions (a seeded pseudo-random mix).
    fn samples() -> Vec<Vec<f32>> {
        (0..12)
            .map(|i| {
                (0..60)
                    .map(|j| {
                        let x = ((i * 7919 + j * 104_729) % 1000) as f32 / 1000.0;
                        x + 0.3 * ((i as f32 * 0.7).sin() * (j as f32 * 0.3).cos())
                    })
                    .collect()
            })
            .collect()
    }

    fn squared_error(a: &[f32], b: &[f32]) -> f64 {
        a.iter().zip(b).map(|(x, y)| f64::from(x - y).powi(2)).sum()
    }

    /// The map set's reconstruction error falls with every added axis and is ~0 with all
    /// N − 1 = 11; the explained ratios fall and add up to 1.
    #[test]
    fn reconstruction_error_falls_to_zero_at_full_rank() {
        let samples = samples();
        let pca = Pca::fit(&samples, 100).unwrap();
        assert_eq!(pca.components(), 11);
        let error = |k: usize| -> f64 {
            samples
                .iter()
                .map(|s| squared_error(s, &pca.reconstruct(&pca.project(s, k).unwrap())))
                .sum()
        };
        let errors: Vec<f64> = (0..=11).map(error).collect();
        for k in 1..=11 {
            assert!(errors[k] < errors[k - 1], "{errors:?}");
        }
        assert!(errors[11] < 1e-8 * errors[0], "{errors:?}");
        // The error left by k axes is (N − 1) × the variance of the axes not kept.
        for k in 0..11 {
            let left: f64 = pca.variances[k..].iter().sum::<f64>() * 11.0;
            assert!(
                (errors[k] - left).abs() < 1e-4 * errors[0],
                "k {k}: {} vs {left}",
                errors[k]
            );
        }
        let ratios = pca.explained_variance_ratio();
        assert!(ratios.windows(2).all(|w| w[0] >= w[1]));
        assert!((ratios.iter().sum::<f64>() - 1.0).abs() < 1e-9);
    }

    /// A saved basis projects a test sample as the fitted one does.
    #[test]
    fn basis_saves_and_loads() {
        let samples = samples();
        let pca = Pca::fit(&samples[..10], 5).unwrap();
        let folder = tempfile::tempdir().unwrap();
        pca.save(folder.path()).unwrap();
        let loaded = Pca::load(folder.path()).unwrap();
        assert_eq!(loaded.components(), 5);
        // variances.npy holds the axes' variances only; the total is in pca.json.
        assert_eq!(npy::read(&folder.path().join("variances.npy")).unwrap().0, vec![5]);
        std::fs::remove_file(folder.path().join(SIDECAR)).unwrap();
        assert!(Pca::load(folder.path()).is_err());
        pca.save(folder.path()).unwrap();
        assert_eq!(loaded.mean, pca.mean);
        assert_eq!(loaded.axes, pca.axes);
        let test = &samples[11];
        assert_eq!(loaded.project(test, 5).unwrap(), pca.project(test, 5).unwrap());
        assert!((loaded.total_variance - pca.total_variance).abs() < 1e-6 * pca.total_variance);
    }

    /// Short samples (D = 5 < N = 12) go through the 5 × 5 scatter matrix; the 12 × 12 Gram
    /// matrix gives the same variances, the same axes up to sign and the same reconstructions.
    #[test]
    fn gram_and_scatter_matrices_agree() {
        let samples: Vec<Vec<f32>> = samples().iter().map(|s| s[..5].to_vec()).collect();
        let scatter = Pca::fit(&samples, 10).unwrap();
        let gram = Pca::fit_by(&samples, 10, true).unwrap();
        assert_eq!(scatter, Pca::fit_by(&samples, 10, false).unwrap());
        assert_eq!((scatter.components(), gram.components()), (5, 5));
        assert!((scatter.total_variance - gram.total_variance).abs() < 1e-9 * gram.total_variance);
        for (a, b) in scatter.variances.iter().zip(&gram.variances) {
            assert!((a - b).abs() < 1e-9 * gram.total_variance, "variances {a} vs {b}");
        }
        for (a, b) in scatter.axes.chunks(5).zip(gram.axes.chunks(5)) {
            let dot: f32 = a.iter().zip(b).map(|(x, y)| x * y).sum();
            assert!((dot.abs() - 1.0).abs() < 1e-5, "axes differ: |cos| {}", dot.abs());
        }
        for (k, sample) in (1..=5).zip(&samples) {
            let (a, b) = (
                scatter.reconstruct(&scatter.project(sample, k).unwrap()),
                gram.reconstruct(&gram.project(sample, k).unwrap()),
            );
            assert!(squared_error(&a, &b) < 1e-10, "{k} axes: {a:?} vs {b:?}");
        }
    }
}
