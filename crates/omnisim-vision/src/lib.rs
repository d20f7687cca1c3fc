//! omnisim-vision: what the users of omnidirectional data sets do with the images.
//!
//! - [`projection`]: panoramic (cylindrical), equirectangular, perspective and bird's-eye
//!   views resampled from a central catadioptric image through its exact camera model.
//! - Global-appearance descriptors of the papers the reference paper cites (see
//!   `docs/vision.md` for each paper and equation): [`fourier`] signature, [`radon`] transform
//!   with phase-only correlation, [`hog`], [`gist`] (omnisim's variant for panoramas) and
//!   [`lmgist`] (Oliva & Torralba's reference code exactly), and [`pca`].
//! - [`localize`]: map against test images by global appearance, scored, reported, charted.
//! - [`accuracy`] of resampled views against exact renders, and [`chart`]s of it.
//! - Local features: [`sift`] (Lowe 2004) and [`surf`] (Bay et al. 2006), their
//!   [`keypoints`] and ratio-test matching.
//!
//! It depends on omnisim's cameras, not on its renderer: any image with a calibration works,
//! rendered or real.
//!
//! A descriptor computed on a rendered image: the Fourier signature of the panorama resampled
//! from the reference paper's omnidirectional camera.
//!
//! ```
//! use omnisim::camera::Catadioptric;
//! use omnisim::glam::dvec3;
//! use omnisim::{BackendChoice, Camera, Planes, Pose, Renderer, Scene};
//! use omnisim_vision::fourier::{FourierParams, FourierSignature};
//! use omnisim_vision::{Interpolation, Raster, Remap, View};
//!
//! let scene = Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/env1.ron"))?;
//! let renderer = Renderer::new(BackendChoice::Cpu)?;
//! let omni = Catadioptric::hyperbolic(250, 250, 0.04, 0.16, Some(20f64.to_radians()));
//! let pose = Pose::from_degrees(dvec3(1.5, 0.0, 0.4), dvec3(0.0, 0.0, 60.0));
//! let frame = renderer.render(&renderer.prepare(&scene)?, &Camera::Catadioptric(omni.clone()), &pose, Planes::COLOUR)?;
//! let (width, height) = (frame.width as usize, frame.height as usize);
//! let image = Raster::from_rgb8(width, height, frame.colour().unwrap())?.to_grey();
//! // A 256 × 64 cylindrical panorama from 45° below to 15° above the horizon.
//! let view = View::panorama(256, 64, (-45f64).to_radians(), 15f64.to_radians())?;
//! let panorama = Remap::new(&omni, &view)?.apply(&image, Interpolation::Bicubic)?;
//! let signature = FourierSignature::new(&panorama, FourierParams { coefficients: 16 })?;
//! assert_eq!(signature.magnitudes().len(), 64 * 16);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod accuracy;
mod angle;
mod buffers;
pub mod chart;
pub mod fft;
pub mod fourier;
mod gaussian;
pub mod gist;
pub mod hog;
pub mod keypoints;
pub mod lmgist;
pub mod localize;
pub mod npy;
pub mod pca;
pub mod projection;
pub mod radon;
pub mod raster;
pub mod sift;
pub mod surf;

pub use projection::{PlaneView, Remap, RemapTaps, View};
pub use raster::{Interpolation, Raster};

/// A descriptor and its shape (row-major, last axis fastest).
#[derive(Debug, Clone, PartialEq)]
pub struct Descriptor {
    /// Size of each axis.
    pub shape: Vec<usize>,
    /// The values, row-major.
    pub values: Vec<f32>,
}

/// A circular shift between two descriptors of a rotation-periodic signal: `steps` samples
/// out of `period` (0..period), and the angle 2π·steps/period it stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rotation {
    /// Samples of the shift, 0..period.
    pub steps: usize,
    /// 2π·steps/period.
    pub radians: f64,
}

impl Rotation {
    pub(crate) fn from_steps(steps: usize, period: usize) -> Self {
        Self {
            steps,
            radians: std::f64::consts::TAU * steps as f64 / period as f64,
        }
    }
}

/// Why a projection or descriptor cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum VisionError {
    #[error(
        "the camera is not central (spherical or elliptic mirror, or misaligned): it has no closed-form projection to resample through"
    )]
    /// A camera without a closed-form projection.
    NonCentral,
    #[error("the image is {}×{} pixels, but the camera's image is {}×{}", got.0, got.1, expected.0, expected.1)]
    /// An image of the wrong size.
    SizeMismatch {
        /// Its size.
        got: (usize, usize),
        /// The size needed.
        expected: (usize, usize),
    },
    #[error("{name}: {reason}")]
    /// A setting out of its range.
    Parameter {
        /// The setting.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    #[error("{path}: {source}")]
    /// A file that cannot be read or written.
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    #[error(transparent)]
    /// An input that is not a regular file (a FIFO would block), or too large.
    Input(#[from] omnisim::input::InputError),
    #[error("{path}: {reason}")]
    /// A file that is not what was expected.
    Format {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong with it.
        reason: String,
    },
}

/// `Err(Parameter)` unless `ok`: the check every descriptor makes of its settings.
pub(crate) fn require(ok: bool, name: &'static str, reason: impl FnOnce() -> String) -> Result<(), VisionError> {
    if ok {
        Ok(())
    } else {
        Err(VisionError::Parameter { name, reason: reason() })
    }
}
