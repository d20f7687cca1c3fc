//! f32 arrays as `NumPy` `.npy` files (npyz), readable with `numpy.load`.

use std::io::BufReader;
use std::path::Path;

use npyz::WriterBuilder;

use crate::VisionError;

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> VisionError + '_ {
    move |source| VisionError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `values` (row-major, C order) with `shape` as little-endian f32 (`<f4`).
pub fn write(path: &Path, shape: &[usize], values: &[f32]) -> Result<(), VisionError> {
    let expected: usize = shape.iter().product();
    if expected != values.len() {
        return Err(VisionError::Parameter {
            name: "shape",
            reason: format!("{shape:?} holds {expected} values, got {}", values.len()),
        });
    }
    let shape: Vec<u64> = shape.iter().map(|&n| n as u64).collect();
    // Atomically: never half a file, never through a link planted at `path`.
    omnisim::atomic_file::write_atomically(path, |out| {
        let mut writer = npyz::WriteOptions::new()
            .default_dtype()
            .shape(&shape)
            .writer(out)
            .begin_nd()?;
        writer.extend(values.iter().copied())?;
        writer.finish()
    })
    .map_err(io_error(path))
}

/// Largest `.npy` file read (a PCA basis of 1000 axes of 500,000 values).
pub const READ_LIMIT: u64 = 2 << 30;

/// Reads an f32 `.npy` file: (shape, row-major values). Only a regular file is opened.
pub fn read(path: &Path) -> Result<(Vec<usize>, Vec<f32>), VisionError> {
    let file = omnisim::input::open_regular(path, READ_LIMIT)?;
    let npy = npyz::NpyFile::new(BufReader::new(file)).map_err(io_error(path))?;
    if npy.order() != npyz::Order::C {
        return Err(VisionError::Format {
            path: path.to_path_buf(),
            reason: "Fortran-ordered arrays are not read".to_string(),
        });
    }
    let shape = npy.shape().iter().map(|&n| n as usize).collect();
    let values = npy.into_vec::<f32>().map_err(io_error(path))?;
    Ok((shape, values))
}
