//! f32 arrays as `NumPy` `.npy` files (npyz), readable with `numpy.load`.

use std::io::{BufRead, BufReader};
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
    let bytes = file.get_ref().metadata().map_err(io_error(path))?.len();
    let mut file = BufReader::new(file);
    let header = file.fill_buf().map_err(io_error(path))?;
    check_shape(header, bytes).map_err(|reason| VisionError::Format {
        path: path.to_path_buf(),
        reason,
    })?;
    let npy = npyz::NpyFile::new(file).map_err(io_error(path))?;
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

/// Refuses a header whose shape holds more values than the file has bytes, before npyz reads
/// it: npyz multiplies the shape's numbers unchecked (an overflow panic in debug builds, a
/// wrapped count in release), and such a header can only be a damaged or crafted file.
/// `start` is the file's first bytes (a `BufReader`'s buffer: 8 KiB, more than any header
/// numpy writes for an array of numbers), `bytes` its length.
fn check_shape(start: &[u8], bytes: u64) -> Result<(), String> {
    let Some(&major) = start.strip_prefix(b"\x93NUMPY").and_then(|rest| rest.first()) else {
        return Ok(()); // not an .npy file: npyz says so
    };
    // The header's length: two bytes after the version in version 1, four in 2 and 3.
    let (length_bytes, text_start) = if major == 1 { (2, 10) } else { (4, 12) };
    let Some(length) = start.get(8..8 + length_bytes) else {
        return Ok(()); // truncated: npyz says so
    };
    let length = length.iter().rev().fold(0_u64, |n, &b| n << 8 | u64::from(b));
    let text_end = text_start as u64 + length;
    if text_end > bytes {
        return Ok(()); // truncated: npyz says so
    }
    let Some(text) = usize::try_from(text_end)
        .ok()
        .and_then(|end| start.get(text_start..end))
    else {
        return Err(format!(
            "its header is {length} bytes, more than the {} an array of numbers needs: a damaged or crafted file",
            start.len()
        ));
    };
    let text = String::from_utf8_lossy(text);
    let Some(at) = text.find("'shape'").or_else(|| text.find("\"shape\"")) else {
        return Ok(()); // no shape: npyz refuses the header
    };
    let tuple = &text[at..];
    let Some(numbers) = tuple
        .find('(')
        .zip(tuple.find(')'))
        .and_then(|(open, close)| tuple.get(open + 1..close))
    else {
        return Err("its header's shape is not a tuple of counts".to_string());
    };
    // Overflowing at any step is refused even where a later 0 would make the product 0: npyz
    // multiplies in the same order.
    let mut values = Some(1_u64);
    for number in numbers
        .split(',')
        .map(|n| n.trim().trim_end_matches('L'))
        .filter(|n| !n.is_empty())
    {
        let n: u64 = number
            .parse()
            .map_err(|_| format!("the header's shape ({numbers}) holds '{number}', not a count"))?;
        values = values.and_then(|v| v.checked_mul(n));
    }
    match values {
        Some(values) if values <= bytes => Ok(()),
        _ => Err(format!(
            "the header's shape ({numbers}) holds more values than the file's {bytes} bytes: the file is damaged; \
             write it again"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A header whose shape overflows (or merely exceeds the file) is a located format error;
    /// npyz alone multiplied it unchecked (a panic in debug builds). The file as written reads.
    #[test]
    fn a_shape_larger_than_the_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hog.npy");
        write(&path, &[3, 2], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        assert_eq!(read(&path).unwrap(), (vec![3, 2], vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
        let written = std::fs::read(&path).unwrap();
        // The shape's tuple as npyz wrote it, whatever its spacing.
        let open = written.iter().position(|&b| b == b'(').unwrap();
        let close = open + written[open..].iter().position(|&b| b == b')').unwrap();
        // numpy's spelling, with its trailing comma, reads; so does a large count beside a 0.
        let numpy = b"{'descr': '<f4', 'fortran_order': False, 'shape': (3, 2), }";
        let header_start = written.iter().position(|&b| b == b'{').unwrap();
        let header_end = written.iter().position(|&b| b == b'\n').unwrap();
        let padding = (header_end - header_start).checked_sub(numpy.len()).unwrap();
        let spelled = [
            &written[..header_start],
            numpy,
            &vec![b' '; padding],
            &written[header_end..],
        ]
        .concat();
        std::fs::write(&path, spelled).unwrap();
        assert_eq!(read(&path).unwrap().0, vec![3, 2]);
        let empty = [&written[..open], b"(1000000, 0)", &written[close + 1..]].concat();
        assert!(check_shape(&empty, empty.len() as u64).is_ok());
        // A header longer than the buffer, its shape past the first 8 KiB: refused, not
        // handed to npyz unchecked.
        let mut long = written[..8].to_vec();
        let text = format!(
            "{{'descr': '<f4', {}'shape': (4611686018427387904, 4611686018427387904), }}\n",
            " ".repeat(9000)
        );
        long.extend_from_slice(&u16::try_from(text.len()).unwrap().to_le_bytes());
        long.extend_from_slice(text.as_bytes());
        long.extend_from_slice(&[0; 24]);
        std::fs::write(&path, long).unwrap();
        let error = read(&path).expect_err("a long header").to_string();
        assert!(error.contains("more than the 8192"), "{error}");
        for (shape, said) in [
            ("(4611686018427387904, 4611686018427387904, 8)", "more values than"),
            ("(100000, 2)", "more values than"),
            ("(3, x)", "not a count"),
        ] {
            let patched = [&written[..open], shape.as_bytes(), &written[close + 1..]].concat();
            std::fs::write(&path, patched).unwrap();
            let error = read(&path).expect_err(shape).to_string();
            assert!(error.contains("hog.npy") && error.contains(said), "{shape}: {error}");
        }
    }
}
