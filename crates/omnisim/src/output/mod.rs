//! Writers for rendered frames: PNG colour, EXR range, PLY coloured point cloud. Each writes
//! atomically (see `atomic.rs`) and names its units and conventions inside the file.

pub mod atomic;

use std::io::Write;
use std::path::{Path, PathBuf};

use image::ImageEncoder;

use crate::frame::Frame;
use atomic::write_atomically;

/// The EXR channel holding range.
pub const RANGE_CHANNEL: &str = "range";

/// Text stored in the EXR header and the PLY comments.
pub const RANGE_CONVENTION: &str = "range: Euclidean distance in metres (f32) from the camera ray origin (the viewpoint; for \
     catadioptric cameras the mirror's effective viewpoint F') to the first surface hit; +inf where nothing is hit";

#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {message}", path.display())]
pub struct OutputError {
    pub path: PathBuf,
    pub message: String,
}

fn failed(path: &Path) -> impl Fn(std::io::Error) -> OutputError + '_ {
    move |e| OutputError {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// 8-bit sRGB PNG of the face colours; background black.
pub fn write_png(path: &Path, frame: &Frame) -> Result<(), OutputError> {
    let bytes: Vec<u8> = frame.pixels().iter().flat_map(|p| p.colour).collect();
    write_atomically(path, |out| {
        image::codecs::png::PngEncoder::new(out)
            .write_image(&bytes, frame.width, frame.height, image::ExtendedColorType::Rgb8)
            .map_err(std::io::Error::other)
    })
    .map_err(failed(path))
}

/// Single-channel f32 EXR named `range`, metres, +inf where nothing is hit.
pub fn write_range_exr(path: &Path, frame: &Frame) -> Result<(), OutputError> {
    use exr::prelude::*;
    let ranges: Vec<f32> = frame.pixels().iter().map(|p| p.range).collect();
    let mut attributes = LayerAttributes::named("omnisim");
    attributes.comments = Some(Text::from(RANGE_CONVENTION));
    attributes.software_name = Some(Text::from(concat!("omnisim ", env!("CARGO_PKG_VERSION"))));
    let layer = Layer::new(
        (frame.width as usize, frame.height as usize),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new(RANGE_CHANNEL, FlatSamples::F32(ranges))])),
    );
    write_atomically(path, |out| {
        Image::from_layer(layer).write().to_buffered(out).map_err(std::io::Error::other)
    })
    .map_err(failed(path))
}

/// Binary little-endian PLY of every hit pixel: float x y z (world metres), uchar red green
/// blue. Readable by Open3D, CloudCompare, MeshLab and PCL.
pub fn write_point_cloud_ply(path: &Path, frame: &Frame, comment: &str) -> Result<(), OutputError> {
    let hits: Vec<_> = frame.pixels().iter().filter(|p| p.is_hit()).collect();
    write_atomically(path, |out| {
        write!(
            out,
            "ply\nformat binary_little_endian 1.0\ncomment omnisim point cloud, world frame, metres, z up\n\
             comment {}\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
             property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
            comment.replace('\n', " "),
            hits.len()
        )?;
        for p in hits {
            for v in [p.point.x, p.point.y, p.point.z] {
                out.write_all(&(v as f32).to_le_bytes())?;
            }
            out.write_all(&p.colour)?;
        }
        Ok(())
    })
    .map_err(failed(path))
}
