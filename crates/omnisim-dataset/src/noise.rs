//! Sensor noise on copies of the ground truth: colour in linear light before quantization,
//! depth with a distance-dependent σ, stereo disparity with sub-pixel quantization. The
//! noise-free planes are never touched; noisy files are written beside them as `*-noisy.*`.

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use super::spec::{ColourNoise, DepthNoise, DisparityNoise};
use omnisim::scene::lighting::linear_to_srgb;

/// One pixel's linear colour after every model of `models`, in order (unclamped).
pub fn colour_pixel(linear: [f32; 3], models: &[ColourNoise], rng: &mut impl Rng) -> [f64; 3] {
    let mut y = linear.map(f64::from);
    for model in models {
        match *model {
            ColourNoise::Gaussian { sigma } => {
                for c in &mut y {
                    *c += sigma * normal(rng);
                }
            }
            ColourNoise::PoissonGaussian { a, b } => {
                for c in &mut y {
                    *c += (a * c.max(0.0) + b).sqrt() * normal(rng);
                }
            }
            ColourNoise::SaltPepper { probability } => {
                if rng.random_bool(probability) {
                    y = [if rng.random_bool(0.5) { 1.0 } else { 0.0 }; 3];
                }
            }
        }
    }
    y
}

/// The noisy 8-bit sRGB image of a linear colour plane.
pub fn colour(linear: &[[f32; 3]], models: &[ColourNoise], rng: &mut impl Rng) -> Vec<[u8; 3]> {
    linear
        .iter()
        .map(|&pixel| colour_pixel(pixel, models, rng).map(linear_to_srgb))
        .collect()
}

/// σ(z) of a depth noise model, metres.
pub fn depth_sigma(model: &DepthNoise, z: f64) -> f64 {
    model.c0 + model.c1 * z + model.c2 * z * z
}

/// Depths (or ranges) with Gaussian noise of σ(z); pixels without a hit (+inf) stay so, and
/// noise never makes a depth negative (it is clamped at 0).
pub fn depth(values: &[f32], model: &DepthNoise, rng: &mut impl Rng) -> Vec<f32> {
    values
        .iter()
        .map(|&z| {
            if z.is_finite() {
                let z = f64::from(z);
                (z + depth_sigma(model, z) * normal(rng)).max(0.0) as f32
            } else {
                z
            }
        })
        .collect()
}

/// Disparities with Gaussian noise, rounded to 1/`subpixel` pixel; NaN (no hit) stays NaN.
pub fn disparity(values: &[f32], model: &DisparityNoise, rng: &mut impl Rng) -> Vec<f32> {
    values
        .iter()
        .map(|&d| {
            if d.is_nan() {
                return d;
            }
            let noisy = f64::from(d) + model.sigma * normal(rng);
            let q = f64::from(model.subpixel);
            (if q > 0.0 { (noisy * q).round() / q } else { noisy }) as f32
        })
        .collect()
}

fn normal(rng: &mut impl Rng) -> f64 {
    StandardNormal.sample(rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};

    const N: usize = 100_000;

    /// Mean and variance of `samples`.
    fn moments(samples: &[f64]) -> (f64, f64) {
        let n = samples.len() as f64;
        let mean = samples.iter().sum::<f64>() / n;
        (
            mean,
            samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (n - 1.0),
        )
    }

    /// Asserts mean and variance of Gaussian samples within 5 standard errors of (μ, σ²):
    /// se(mean) = σ/√n, se(variance) = σ²·√(2/(n−1)).
    fn assert_gaussian(samples: &[f64], mu: f64, sigma: f64) {
        let (mean, variance) = moments(samples);
        let n = samples.len() as f64;
        assert!((mean - mu).abs() < 5.0 * sigma / n.sqrt(), "mean {mean}, expected {mu}");
        let se = sigma * sigma * (2.0 / (n - 1.0)).sqrt();
        assert!(
            (variance - sigma * sigma).abs() < 5.0 * se,
            "variance {variance}, expected {}",
            sigma * sigma
        );
    }

    #[test]
    fn poisson_gaussian_variance_is_a_y_plus_b() {
        let mut rng = stream(1, "t", Some(0), Purpose::Noise);
        let (a, b) = (0.01, 0.0004);
        for y in [0.05f32, 0.5, 0.9] {
            let models = [ColourNoise::PoissonGaussian { a, b }];
            let samples: Vec<f64> = (0..N).map(|_| colour_pixel([y; 3], &models, &mut rng)[1]).collect();
            assert_gaussian(&samples, f64::from(y), (a * f64::from(y) + b).sqrt());
        }
        let gaussian = [ColourNoise::Gaussian { sigma: 0.02 }];
        let samples: Vec<f64> = (0..N).map(|_| colour_pixel([0.3; 3], &gaussian, &mut rng)[0]).collect();
        assert_gaussian(&samples, f64::from(0.3f32), 0.02);
    }

    #[test]
    fn salt_and_pepper_hits_the_stated_fraction_half_white() {
        let mut rng = stream(2, "t", Some(0), Purpose::Noise);
        let p = 0.05;
        let pixels = colour(
            &vec![[0.2; 3]; N],
            &[ColourNoise::SaltPepper { probability: p }],
            &mut rng,
        );
        let white = pixels.iter().filter(|c| **c == [255; 3]).count() as f64;
        let black = pixels.iter().filter(|c| **c == [0; 3]).count() as f64;
        let hit = (white + black) / N as f64;
        // Binomial: se = √(p(1−p)/n).
        assert!((hit - p).abs() < 5.0 * (p * (1.0 - p) / N as f64).sqrt(), "{hit}");
        let half = white / (white + black);
        assert!((half - 0.5).abs() < 5.0 * (0.25 / (white + black)).sqrt(), "{half}");
        // Untouched pixels keep the exact ground truth.
        let grey = linear_to_srgb(f64::from(0.2f32));
        assert!(pixels.iter().all(|c| *c == [grey; 3] || *c == [0; 3] || *c == [255; 3]));
    }

    #[test]
    fn depth_noise_grows_as_its_model_and_keeps_misses() {
        let mut rng = stream(3, "t", Some(0), Purpose::Noise);
        let model = DepthNoise {
            c0: 0.001,
            c1: 0.0,
            c2: 0.0025,
        };
        for z in [0.5f32, 4.0] {
            let noisy: Vec<f64> = depth(&vec![z; N], &model, &mut rng)
                .into_iter()
                .map(f64::from)
                .collect();
            assert_gaussian(&noisy, f64::from(z), depth_sigma(&model, f64::from(z)));
        }
        assert_eq!(depth(&[f32::INFINITY], &model, &mut rng), [f32::INFINITY]);
    }

    #[test]
    fn disparity_noise_is_quantized_to_the_subpixel_step() {
        let mut rng = stream(4, "t", Some(0), Purpose::Noise);
        let model = DisparityNoise {
            sigma: 0.5,
            subpixel: 16,
        };
        let noisy = disparity(&vec![20.0; N], &model, &mut rng);
        assert!(noisy.iter().all(|d| (d * 16.0).fract() == 0.0));
        let samples: Vec<f64> = noisy.iter().map(|&d| f64::from(d)).collect();
        // Rounding to 1/16 px adds a uniform error of variance (1/16)²/12.
        assert_gaussian(&samples, 20.0, (0.25f64 + (1.0 / 16.0f64).powi(2) / 12.0).sqrt());
        assert!(disparity(&[f32::NAN], &model, &mut rng)[0].is_nan());
    }
}
