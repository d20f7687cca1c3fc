//! glTF accessors read as lists: every component type and the `normalized` flag (core glTF,
//! and `KHR_mesh_quantization`'s integer positions and texture coordinates), byteStride,
//! sparse substitution, and accessors without a buffer view (zeros, as the spec says).
//!
//! Written here rather than with gltf's `accessor::Iter` and `mesh::util` readers: those take
//! every position as f32 (a debug assertion, garbage in release), reach `unreachable!` on
//! component types a quantized file uses (i8 texture coordinates, f32 indices), and add
//! offsets unchecked. Every range here is checked against its view and buffer first.

use gltf::accessor::DataType;
use gltf::accessor::sparse::IndexType;

use crate::scene::mesh_data::MAX_MESH_TRIANGLES;

/// Most elements one accessor may hold: as many corners as a mesh may have triangles'.
const MAX_ELEMENTS: usize = 3 * MAX_MESH_TRIANGLES;

/// Fewest elements an accessor without a buffer view may hold whatever the file's size.
/// Beyond it, such an accessor (zeros, and its sparse substitutes) may hold no more elements
/// than the file's buffers hold bytes: its count is backed by no bytes of its own, and a
/// 400-byte file asking for 100 M zeros took 2.7 GB and 4.5 s before the bound. This bounds
/// one accessor; `within_read_budget` (gltf/mod.rs) bounds all that a file's primitives read.
const VIEW_LESS_FLOOR: usize = 4096;

/// One component type as stored: its size and its value (normalized as the spec says:
/// signed types clamped at −1, unsigned ones divided by their largest value; the spec has no
/// normalized u32 or f32, read leniently all the same).
trait Component {
    const SIZE: usize;
    fn value(bytes: &[u8], normalized: bool) -> f64;
}

macro_rules! component {
    ($type:ty, $size:expr, $normalize:expr) => {
        impl Component for $type {
            const SIZE: usize = $size;
            fn value(bytes: &[u8], normalized: bool) -> f64 {
                let v = f64::from(<$type>::from_le_bytes(
                    bytes[..$size].try_into().expect("SIZE bytes"),
                ));
                if normalized { $normalize(v) } else { v }
            }
        }
    };
}

component!(i8, 1, |v: f64| (v / 127.0).max(-1.0));
component!(u8, 1, |v: f64| v / 255.0);
component!(i16, 2, |v: f64| (v / 32767.0).max(-1.0));
component!(u16, 2, |v: f64| v / 65535.0);
component!(u32, 4, |v: f64| v / 4_294_967_295.0);
component!(f32, 4, |v: f64| v);

/// The bytes of `count` elements of `size` bytes, `stride` apart, from `offset` in `view`:
/// `None` where they reach beyond the view or the view beyond its buffer.
fn elements<'a>(
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    size: usize,
    stride: usize,
    buffers: &'a [Vec<u8>],
) -> Option<&'a [u8]> {
    let buffer = buffers.get(view.buffer().index())?;
    let view_bytes = buffer.get(view.offset()..view.offset().checked_add(view.length())?)?;
    let end = count
        .checked_sub(1)?
        .checked_mul(stride)?
        .checked_add(size)?
        .checked_add(offset)?;
    view_bytes.get(offset..end)
}

/// Reads `accessor` of `N`-component elements, each made into a `T` by `make`, as
/// `what` (`POSITION`, `TEXCOORD_1`, …: named in errors with the accessor's index, and formatted
/// only for them).
pub(super) fn read<T: Copy, const N: usize>(
    accessor: &gltf::Accessor,
    buffers: &[Vec<u8>],
    what: impl std::fmt::Display + Copy,
    make: impl Fn([f64; N]) -> T,
) -> Result<Vec<T>, String> {
    let normalized = accessor.normalized();
    match accessor.data_type() {
        DataType::I8 => read_as::<i8, T, N>(accessor, normalized, buffers, what, make),
        DataType::U8 => read_as::<u8, T, N>(accessor, normalized, buffers, what, make),
        DataType::I16 => read_as::<i16, T, N>(accessor, normalized, buffers, what, make),
        DataType::U16 => read_as::<u16, T, N>(accessor, normalized, buffers, what, make),
        DataType::U32 => read_as::<u32, T, N>(accessor, normalized, buffers, what, make),
        DataType::F32 => read_as::<f32, T, N>(accessor, normalized, buffers, what, make),
    }
}

/// The corner indices of `accessor` (unsigned integer scalars, as the spec requires), read as
/// integers even where the file sets `normalized`, which the spec forbids on indices: read
/// normalized, they would all be 0 or 1.
pub(super) fn read_indices(accessor: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<Vec<u32>, String> {
    // Exact in f64, and below 2³² by their type.
    let index = |[i]: [f64; 1]| i as u32;
    match accessor.data_type() {
        DataType::U8 => read_as::<u8, u32, 1>(accessor, false, buffers, "indices", index),
        DataType::U16 => read_as::<u16, u32, 1>(accessor, false, buffers, "indices", index),
        DataType::U32 => read_as::<u32, u32, 1>(accessor, false, buffers, "indices", index),
        other => Err(format!(
            "accessor {} (indices) holds {other:?} components; indices must be unsigned 8, 16 or 32-bit integers",
            accessor.index()
        )),
    }
}

fn read_as<C: Component, T: Copy, const N: usize>(
    accessor: &gltf::Accessor,
    normalized: bool,
    buffers: &[Vec<u8>],
    what: impl std::fmt::Display + Copy,
    make: impl Fn([f64; N]) -> T,
) -> Result<Vec<T>, String> {
    let name = || format!("accessor {} ({what})", accessor.index());
    let width = accessor.dimensions().multiplicity();
    if width != N {
        let expected = match N {
            1 => "SCALAR".to_string(),
            n => format!("VEC{n}"),
        };
        return Err(format!(
            "{} is {:?}; {what} must be {expected}",
            name(),
            accessor.dimensions()
        ));
    }
    let count = accessor.count();
    if count == 0 || count > MAX_ELEMENTS {
        return Err(format!(
            "{} has {count} elements; an accessor holds 1 to {MAX_ELEMENTS}",
            name()
        ));
    }
    let size = N * C::SIZE;
    let decode = |bytes: &[u8]| make(std::array::from_fn(|k| C::value(&bytes[k * C::SIZE..], normalized)));
    let truncated = || {
        format!(
            "{} ({count} elements) reaches beyond its buffer view or buffer: the file is truncated or corrupt",
            name()
        )
    };
    let mut list: Vec<T> = if let Some(view) = accessor.view() {
        let stride = view.stride().unwrap_or(size);
        let bytes = elements(&view, accessor.offset(), count, size, stride, buffers).ok_or_else(truncated)?;
        // The last element may end before a full stride does.
        (0..count)
            .map(|i| decode(&bytes[i * stride..i * stride + size]))
            .collect()
    } else {
        let backed = buffers.iter().map(Vec::len).sum::<usize>().max(VIEW_LESS_FLOOR);
        if count > backed {
            return Err(format!(
                "{} has no buffer view and {count} elements, more than the file's {backed} buffer bytes could \
                 describe",
                name()
            ));
        }
        vec![make([0.0; N]); count]
    };
    if let Some(sparse) = accessor.sparse() {
        let substitutes = sparse.count();
        if substitutes == 0 || substitutes > count {
            return Err(format!(
                "{} is sparse with {substitutes} substitutes for {count} elements",
                name()
            ));
        }
        let indices = sparse.indices();
        let index_size = match indices.index_type() {
            IndexType::U8 => 1,
            IndexType::U16 => 2,
            IndexType::U32 => 4,
        };
        let sparse_truncated = || {
            format!(
                "{}: its sparse indices or values reach beyond their buffer view",
                name()
            )
        };
        let index_bytes = elements(
            &indices.view(),
            indices.offset(),
            substitutes,
            index_size,
            index_size,
            buffers,
        )
        .ok_or_else(sparse_truncated)?;
        let values = sparse.values();
        let value_bytes =
            elements(&values.view(), values.offset(), substitutes, size, size, buffers).ok_or_else(sparse_truncated)?;
        for (k, index) in index_bytes.chunks_exact(index_size).enumerate() {
            let index = index.iter().rev().fold(0usize, |n, &b| n << 8 | usize::from(b));
            let slot = list.get_mut(index).ok_or_else(|| {
                format!(
                    "{}: sparse index {index} is out of range: there are {count} elements",
                    name()
                )
            })?;
            *slot = decode(&value_bytes[k * size..(k + 1) * size]);
        }
    }
    Ok(list)
}

#[cfg(test)]
mod tests {
    use super::{Component, read, read_indices};

    /// The spec's normalization (glTF 2.0, 3.11 "Animation" and the accessor tables): signed
    /// types clamp their lowest value at −1; unsigned ones reach exactly 1.
    #[test]
    fn normalized_components_follow_the_spec() {
        assert_eq!(i8::value(&[0x81], true), -1.0);
        assert_eq!(i8::value(&[0x80], true), -1.0);
        assert_eq!(i8::value(&[127], true), 1.0);
        assert_eq!(u8::value(&[255], true), 1.0);
        assert_eq!(i16::value(&(-32768i16).to_le_bytes(), true), -1.0);
        assert_eq!(u16::value(&[0xff, 0xff], true), 1.0);
        assert_eq!(u16::value(&1000u16.to_le_bytes(), false), 1000.0);
        assert_eq!(i16::value(&(-7i16).to_le_bytes(), false), -7.0);
    }

    /// A quantized (normalized i16, byteStride 8) VEC3 accessor with a sparse substitute, a
    /// view-less VEC2 accessor (zeros) with one, u8 indices (also flagged `normalized`), and the
    /// VEC3s read past their view.
    #[test]
    fn strided_quantized_sparse_and_view_less_accessors_read_their_closed_forms() {
        let mut bin = Vec::new();
        for element in [[32767i16, 0, -32768], [16384, -16384, 1], [0, 0, 0]] {
            bin.extend(element.iter().flat_map(|c| c.to_le_bytes()));
            bin.extend([0xee, 0xee]); // the stride's padding, never read
        }
        bin.extend([2u8, 0, 1, 0]); // indices 2, 0, 1 (and padding)
        bin.extend(1u16.to_le_bytes()); // sparse index 1 of the VEC2s
        bin.extend(2u16.to_le_bytes()); // sparse index 2 of the VEC3s
        bin.extend([0.25f32, -4.0].iter().flat_map(|v| v.to_le_bytes()));
        bin.extend([-32767i16, 32767, 0].iter().flat_map(|c| c.to_le_bytes()));
        bin.extend([2u8, 0, 255]); // indices 2, 0, 255, flagged normalized
        let json = serde_json::json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": bin.len()}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 24, "byteStride": 8},
                {"buffer": 0, "byteOffset": 24, "byteLength": 3},
                {"buffer": 0, "byteOffset": 28, "byteLength": 2},
                {"buffer": 0, "byteOffset": 30, "byteLength": 2},
                {"buffer": 0, "byteOffset": 32, "byteLength": 8},
                {"buffer": 0, "byteOffset": 40, "byteLength": 6},
                {"buffer": 0, "byteOffset": 0, "byteLength": 20, "byteStride": 8},
                {"buffer": 0, "byteOffset": 46, "byteLength": 3}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC3",
                 "sparse": {"count": 1, "indices": {"bufferView": 3, "componentType": 5123},
                            "values": {"bufferView": 5}}},
                {"componentType": 5126, "count": 3, "type": "VEC2",
                 "sparse": {"count": 1, "indices": {"bufferView": 2, "componentType": 5123},
                            "values": {"bufferView": 4}}},
                {"bufferView": 1, "componentType": 5121, "count": 3, "type": "SCALAR"},
                {"bufferView": 6, "componentType": 5122, "count": 3, "type": "VEC3"},
                {"bufferView": 7, "componentType": 5121, "normalized": true, "count": 3, "type": "SCALAR"}
            ]
        });
        let gltf = gltf::Gltf::from_slice(&serde_json::to_vec(&json).unwrap()).unwrap();
        let accessor = |i: usize| gltf.document.accessors().nth(i).unwrap();
        let buffers = [bin];
        let positions = read(&accessor(0), &buffers, "POSITION", |p: [f64; 3]| p).unwrap();
        assert_eq!(
            positions,
            [
                [1.0, 0.0, -1.0],
                [16384.0 / 32767.0, -16384.0 / 32767.0, 1.0 / 32767.0],
                [-1.0, 1.0, 0.0]
            ]
        );
        let uvs = read(&accessor(1), &buffers, "TEXCOORD_0", |uv: [f64; 2]| uv).unwrap();
        assert_eq!(uvs, [[0.0, 0.0], [0.25, -4.0], [0.0, 0.0]]);
        assert_eq!(read_indices(&accessor(2), &buffers).unwrap(), [2, 0, 1]);
        // The same bytes flagged `normalized` (which the spec forbids on indices): still integers.
        assert_eq!(read_indices(&accessor(4), &buffers).unwrap(), [2, 0, 255]);
        // The third element's six bytes end at 22, past the view's 20.
        let past = read(&accessor(3), &buffers, "POSITION", |p: [f64; 3]| p).unwrap_err();
        assert!(
            past.contains("accessor 3 (POSITION)") && past.contains("truncated"),
            "{past}"
        );
        let wrong_width = read(&accessor(1), &buffers, "COLOR_0", |c: [f64; 3]| c).unwrap_err();
        assert!(wrong_width.contains("must be VEC3"), "{wrong_width}");
    }
}
