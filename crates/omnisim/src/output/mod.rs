//! Writers for rendered frames: PNG colour, EXR range, PLY coloured point cloud, and (in
//! `planes.rs`) segmentation, normals and linear colour. Each writes
//! atomically (see `crate::atomic_file`) and names its units and conventions inside the file.
//!
//! EXRs are scan lines stored in increasing order, ZIP-compressed unless the caller picks
//! another lossless [`ExrCompression`]: the same values give the same bytes. Single-value images (range, depth, disparity) hold one channel
//! named `Y`, the luminance channel every reader opens (`OpenCV` reads no other single channel);
//! three-value images (normals, ray origins and directions, linear colour) hold `R G B`, the only
//! other layout `OpenCV` and imageio open (`OpenCV` returns them as B, G, R). What the values are
//! is in the header: the string attribute `quantity` and `comments`.

pub mod folder;
mod planes;
mod rle;
mod set;
pub mod store;

pub use planes::{
    LINEAR_CONVENTION, MAX_SEGMENT_ID, NORMAL_CONVENTION, SegmentObject, SegmentationLegend, face_ids, write_id_png,
    write_linear_exr, write_normal_exr,
};
pub use set::{Destination, FrameTarget, OutputSet, PlainFolder};

use serde::{Deserialize, Serialize};

use std::path::{Path, PathBuf};

use image::ImageEncoder;

use glam::DVec2;

use crate::camera::Camera;
use crate::frame::{Frame, Pixel};
use store::FileStore;

/// The channel of single-value EXRs (range, depth, disparity).
pub const VALUE_CHANNEL: &str = "Y";

/// The EXR header attribute naming what an EXR holds: `range`, `z`, `disparity`, `normal`,
/// `linear colour`, `ray origin` or `ray direction`.
pub const QUANTITY_ATTRIBUTE: &str = "quantity";

/// What range means for `camera`, stored in the EXR header and the metadata.
pub fn range_convention(camera: &Camera) -> &'static str {
    if camera.is_central() {
        "range: Euclidean distance in metres (f32) from the viewpoint (the optical centre, or a central mirror's \
         effective viewpoint F') to the first surface hit; +inf where nothing is hit"
    } else {
        "range: Euclidean distance in metres (f32) from each pixel's own ray origin (the mirror point, or the \
         camera's optical centre in the body frame; see raymap-origin.exr) to the first surface hit; +inf where nothing is hit"
    }
}

/// A file that could not be written, and why; nothing is left at `path`.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {problem}", path.display())]
pub struct OutputError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    #[source]
    pub problem: OutputProblem,
}

/// Why a file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputProblem {
    /// The system refused, or an encoder failed. Said as the system says it, and kept as the
    /// error's source (not `transparent`, which would hide it from a search of the causes: the
    /// CLI names the process limit behind an EFBIG or EMFILE that way).
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// The run's folder refused the name (another run's file, a link).
    #[error(transparent)]
    Folder(#[from] folder::FolderError),
    /// The frame lacks the plane the file is made from.
    #[error("the frame has no {plane} plane (render it with {request})")]
    MissingPlane {
        /// The plane, as the user knows it.
        plane: &'static str,
        /// What to ask the renderer for.
        request: &'static str,
    },
    /// An object or face id beyond what a 16-bit segmentation image holds.
    #[error(
        "id {id} does not fit a 16-bit segmentation image (at most {})",
        planes::MAX_SEGMENT_ID
    )]
    IdTooLarge {
        /// The id.
        id: u32,
    },
}

impl OutputError {
    /// `problem` at `path`.
    pub(crate) fn at(path: &Path, problem: impl Into<OutputProblem>) -> Self {
        Self {
            path: path.to_path_buf(),
            problem: problem.into(),
        }
    }
}

pub(crate) fn failed(path: &Path) -> impl Fn(std::io::Error) -> OutputError + '_ {
    move |e| OutputError::at(path, e)
}

/// Pretty-printed JSON of `value`, written through `store`.
pub(crate) fn write_json(store: &mut impl FileStore, path: &Path, value: &impl Serialize) -> Result<(), OutputError> {
    store
        .store(path, |out| {
            serde_json::to_writer_pretty(&mut *out, value).map_err(std::io::Error::other)
        })
        .map_err(failed(path))
}

/// The PNG encoder of every per-frame image: fast deflate (fdeflate) with the Sub filter on
/// every row. Per-frame encoding competes with the tracer for the same cores in data sets, so
/// speed wins over size: fast deflate took a 250×250 omni frame about 30× less time than
/// default deflate for 1.5× the bytes (first measured when it was chosen), and Sub instead of
/// trying all five filters a row (adaptive) now takes 0.05–0.15 ms instead of 0.12–0.23 for
/// 9–25 % more bytes (docs/benchmarks.md, "2026-11-26 afternoon (data)").
pub(crate) fn png_encoder<W: std::io::Write>(out: W) -> image::codecs::png::PngEncoder<W> {
    image::codecs::png::PngEncoder::new_with_quality(
        out,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Sub,
    )
}

/// 8-bit sRGB PNG of the frame's colour plane; background black.
pub fn write_png(to: &mut impl FileStore, path: &Path, frame: &Frame) -> Result<(), OutputError> {
    let colour = frame.colour().ok_or_else(|| {
        OutputError::at(
            path,
            OutputProblem::MissingPlane {
                plane: "colour",
                request: "Planes::COLOUR",
            },
        )
    })?;
    to.store(path, |out| {
        png_encoder(out)
            .write_image(
                colour.as_flattened(),
                frame.width,
                frame.height,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(std::io::Error::other)
    })
    .map_err(failed(path))
}

/// Single-channel f32 EXR of range (`quantity` = `range`), metres, +inf where nothing is hit;
/// `camera` made `frame` and decides what range is measured from (`range_convention`).
pub fn write_range_exr(
    to: &mut impl FileStore,
    path: &Path,
    frame: &Frame,
    camera: &Camera,
    compression: ExrCompression,
) -> Result<(), OutputError> {
    let ranges: Vec<f32> = frame.pixels().iter().map(|p| p.range).collect();
    write_ranges_exr(to, path, (frame.width, frame.height), &ranges, camera, compression)
}

/// [`write_range_exr`] of ranges already read from a frame's pixels (or perturbed from them).
pub fn write_ranges_exr(
    to: &mut impl FileStore,
    path: &Path,
    size: (u32, u32),
    ranges: &[f32],
    camera: &Camera,
    compression: ExrCompression,
) -> Result<(), OutputError> {
    write_channel_exr(to, path, size, "range", range_convention(camera), ranges, compression)
}

/// What the range EXR and the point cloud take from a frame's 48-byte pixels, read in one pass:
/// each pass over a frame whose pixels are no longer cached costs about as much as an
/// encoder's own work (docs/benchmarks.md, "2026-11-27 evening (data)").
pub(crate) struct PixelPass {
    /// Every pixel's range.
    pub(crate) ranges: Vec<f32>,
    /// How many pixels are hits ([`Frame::hit_count`]).
    pub(crate) hits: usize,
    /// Where asked for, the point cloud's points as its PLY stores them, hit by hit.
    pub(crate) points: Option<Vec<u8>>,
}

impl PixelPass {
    /// Reads `frame`'s ranges and counts its hits, and encodes its points where `points`.
    pub(crate) fn read(frame: &Frame, points: bool) -> Self {
        let pixels = frame.pixels();
        let colours = frame.colour().unwrap_or_default();
        debug_assert!(colours.is_empty() || colours.len() == pixels.len());
        let mut encoded = points.then(|| Vec::with_capacity(pixels.len() * PLY_POINT));
        let mut hits = 0;
        // One allocation of the pixels' length, no capacity check per range (`TrustedLen`).
        let ranges = (pixels.iter().enumerate())
            .map(|(index, p)| {
                if p.is_hit() {
                    hits += 1;
                    if let Some(encoded) = encoded.as_mut() {
                        encoded.extend_from_slice(&ply_point(p, point_colour(colours, index)));
                    }
                }
                p.range
            })
            .collect();
        Self {
            ranges,
            hits,
            points: encoded,
        }
    }
}

/// Single-channel f32 EXR of disparity (`quantity` = `disparity`; pixels, `u_left` − `u_right`),
/// NaN where no hit.
pub fn write_disparity_exr(
    to: &mut impl FileStore,
    path: &Path,
    size: (u32, u32),
    disparity: &[f32],
    compression: ExrCompression,
) -> Result<(), OutputError> {
    let convention = "disparity of the left image in pixels: u_left - u_right = fx*baseline/z, z = depth along \
                      the optical axis; NaN where nothing is hit";
    write_channel_exr(to, path, size, "disparity", convention, disparity, compression)
}

/// Single-channel f32 EXR of depth along the optical axis (`quantity` = `z`), metres, +inf
/// where no hit.
pub fn write_axial_depth_exr(
    to: &mut impl FileStore,
    path: &Path,
    size: (u32, u32),
    depth: &[f32],
    compression: ExrCompression,
) -> Result<(), OutputError> {
    write_channel_exr(to, path, size, "z", AXIAL_DEPTH_CONVENTION, depth, compression)
}

/// Text stored with axial depth.
pub const AXIAL_DEPTH_CONVENTION: &str =
    "z: depth along the camera's optical axis in metres (f32); +inf where nothing is hit";

/// Scale of TUM RGB-D depth PNGs: stored value = metres × 5000.
pub const TUM_DEPTH_SCALE: f64 = 5000.0;

/// 16-bit grey PNG of axial depth in the TUM RGB-D convention: value = z × 5000 rounded,
/// 0 where nothing is hit or where z is beyond 13.1 m (65535 / 5000), which 16 bits cannot hold.
pub fn write_tum_depth_png(
    to: &mut impl FileStore,
    path: &Path,
    size: (u32, u32),
    depth: &[f32],
) -> Result<(), OutputError> {
    let mut bytes = Vec::with_capacity(2 * depth.len());
    for &z in depth {
        let scaled = (f64::from(z) * TUM_DEPTH_SCALE).round();
        let value = if scaled.is_finite() && (1.0..=65535.0).contains(&scaled) {
            scaled as u16
        } else {
            0
        };
        bytes.extend_from_slice(&value.to_ne_bytes());
    }
    to.store(path, |out| {
        png_encoder(out)
            .write_image(&bytes, size.0, size.1, image::ExtendedColorType::L16)
            .map_err(std::io::Error::other)
    })
    .map_err(failed(path))
}

/// One f32 channel named `Y` holding `quantity`, with its convention in `comments`.
fn write_channel_exr(
    to: &mut impl FileStore,
    path: &Path,
    size: (u32, u32),
    quantity: &str,
    convention: &str,
    values: &[f32],
    compression: ExrCompression,
) -> Result<(), OutputError> {
    write_exr(
        to,
        path,
        size,
        quantity,
        convention,
        &[(VALUE_CHANNEL, values)],
        compression,
    )
}

/// Lossless EXR compressions. Encoding a 250 × 250 f32 image (docs/benchmarks.md, "Data
/// sets"): ZIP 3.5 ms to 197 kB, RLE 0.3 ms to 229 kB, none 0.05 ms to 254 kB; on a 1024 × 512
/// range image ZIP stores 674 kB where the others need about 2.1 MB.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ExrCompression {
    /// zlib over blocks of 16 scan lines: the smallest files, the slowest to write.
    #[default]
    Zip,
    /// Run-length encoding: ten times faster than ZIP, small gains except on constant areas.
    Rle,
    /// Stored as is.
    None,
}

impl ExrCompression {
    fn encoding(self) -> exr::prelude::Encoding {
        use exr::prelude::{Compression, Encoding};
        let compression = match self {
            Self::Zip => Compression::ZIP16,
            Self::Rle => Compression::RLE,
            Self::None => Compression::Uncompressed,
        };
        Encoding {
            compression,
            ..Encoding::SMALL_LOSSLESS
        }
    }
}

/// f32 channels of one image, each (name, values): `quantity` in the header attribute of that
/// name, the convention in `comments`.
fn write_exr(
    to: &mut impl FileStore,
    path: &Path,
    size: (u32, u32),
    quantity: &str,
    convention: &str,
    channels: &[(&str, &[f32])],
    compression: ExrCompression,
) -> Result<(), OutputError> {
    use exr::prelude::*;
    // The headers need the channels' names alone, so the image holds no samples and the values
    // are read from `channels` where they lie (owned samples cost the ray maps a copy of their
    // six planes).
    let names = channels.iter().map(|&(name, _)| (name, Vec::new())).collect();
    let image = exr_image(size, quantity, convention, names, compression);
    let headers = (&image).write().infer_meta_data();
    // The channels in the file's order (by name), as each scan line holds them.
    let channels: Vec<&[f32]> = (image.layer_data.channel_data.list.iter())
        .map(|channel| {
            let named = channels.iter().find(|(name, _)| channel.name == **name);
            named.expect("the image's channels are those given").1
        })
        .collect();
    to.store(path, |out| {
        exr::block::write(out, headers, true, |meta, chunks| {
            write_exr_blocks(&meta, chunks, &channels, size.0 as usize, compression)
        })
        .map_err(std::io::Error::other)
    })
    .map_err(failed(path))
}

/// The `exr` image of f32 `channels` with omnisim's attributes; its headers (which the samples
/// do not change) are what [`write_exr`] writes.
fn exr_image(
    size: (u32, u32),
    quantity: &str,
    convention: &str,
    channels: Vec<(&str, Vec<f32>)>,
    compression: ExrCompression,
) -> exr::prelude::Image<exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>> {
    use exr::prelude::*;
    let mut attributes = LayerAttributes {
        comments: Some(Text::from(convention)),
        software_name: Some(Text::from(concat!("omnisim ", env!("CARGO_PKG_VERSION")))),
        ..Default::default()
    };
    // exr keeps custom attributes in a HashMap, written in its random order: one custom
    // attribute only, so the bytes stay reproducible.
    attributes.other.insert(
        Text::from(QUANTITY_ATTRIBUTE),
        AttributeValue::Text(Text::from(quantity)),
    );
    let list = channels
        .into_iter()
        .map(|(name, values)| AnyChannel::new(name, FlatSamples::F32(values)))
        .collect();
    Image::from_layer(Layer::new(
        (size.0 as usize, size.1 as usize),
        attributes,
        compression.encoding(),
        AnyChannels::sort(list),
    ))
}

/// Each block of scan lines of `channels` (f32 planes `width` wide, in the file's channel
/// order), compressed and written in increasing order: RLE by [`rle::RleEncoder`], the others by
/// `exr`'s own encoders; the bytes are those `exr`'s image writer makes.
fn write_exr_blocks(
    meta: &exr::meta::MetaData,
    chunks: &mut impl exr::block::writer::ChunksWriter,
    channels: &[&[f32]],
    width: usize,
    compression: ExrCompression,
) -> exr::error::UnitResult {
    use exr::block::UncompressedBlock;
    use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
    let mut rle = rle::RleEncoder::default();
    // Every channel is f32 (`exr_image` makes no other), so a block holds 4 bytes a sample;
    // anything else goes through exr's own compressor, which checks the block's size.
    let all_f32 = meta
        .headers
        .iter()
        .all(|header| header.channels.list.len() == channels.len());
    let own_rle = compression == ExrCompression::Rle && cfg!(target_endian = "little") && all_f32;
    for (index_in_header, index) in meta.enumerate_ordered_header_block_indices() {
        let rows = index.pixel_position.y()..index.pixel_position.y() + index.pixel_size.y();
        let mut data = Vec::with_capacity(rows.len() * channels.len() * width * 4);
        for row in rows {
            for values in channels {
                let start = data.len();
                data.resize(start + width * 4, 0);
                let line = &values[row * width..(row + 1) * width];
                for (bytes, value) in data[start..].chunks_exact_mut(4).zip(line) {
                    bytes.copy_from_slice(&value.to_ne_bytes());
                }
            }
        }
        let chunk = if own_rle {
            let packed = rle.compress(&data);
            let header = &meta.headers[index.layer];
            Chunk {
                layer_index: index.layer,
                compressed_block: CompressedBlock::ScanLine(CompressedScanLineBlock {
                    y_coordinate: i32::try_from(index.pixel_position.y())
                        .map_err(|_| exr::error::Error::Invalid("scan line beyond i32".into()))?
                        + header.own_attributes.layer_position.y(),
                    // Stored as is where compression does not make the block smaller.
                    compressed_pixels_le: if packed.len() < data.len() { packed } else { data },
                }),
            }
        } else {
            UncompressedBlock { index, data }.compress_to_chunk(&meta.headers)?
        };
        chunks.write_chunk(index_in_header, chunk)?;
    }
    Ok(())
}

/// What the two ray-map files of a view hold, in their headers and in `render.json`.
pub const RAY_MAP_CONVENTION: &str = "per-pixel camera rays in the body frame (x forward, y left, z up; metres): \
     raymap-origin.exr (quantity 'ray origin') and raymap-direction.exr (quantity 'ray direction', unit vectors), \
     channels R, G, B = x, y, z, and both in raymap-all.exr (channels origin.X, origin.Y, origin.Z, direction.X, \
     direction.Y, direction.Z); a hit at range r is origin + r*direction; NaN where the pixel has no ray";

/// The files holding every pixel's ray of a view whose files end in `suffix` (`""`, or a
/// stereo view's `-left`, `-right`): origin, direction, then both in one file.
pub fn ray_map_names(suffix: &str) -> [String; 3] {
    [
        format!("raymap{suffix}-origin.exr"),
        format!("raymap{suffix}-direction.exr"),
        format!("raymap{suffix}-all.exr"),
    ]
}

/// Every pixel's ray in the body frame, as two three-channel f32 EXRs (`R G B` = x y z) that
/// every EXR reader opens — the origins at `origin_path`, the unit directions at
/// `direction_path` — and both in one six-channel EXR at `all_path`; NaN where the pixel sees
/// nothing. Non-central cameras need them to rebuild points from range.
///
/// The six-channel file is the one ray map of omnisim before `OpenCV`'s readers were asked for
/// (`OpenCV` and imageio refuse its channel names); it stays for the OpenEXR-based tools that
/// read it, among them `../shared/bench/same_rays.py`, which takes the first `raymap*` file by
/// name — so its name sorts first.
pub fn write_ray_map_exrs(
    store: &mut impl FileStore,
    [origin_path, direction_path, all_path]: [&Path; 3],
    camera: &Camera,
) -> Result<(), OutputError> {
    let (width, height) = camera.size();
    let pixels = width as usize * height as usize;
    let mut origin: [Vec<f32>; 3] = std::array::from_fn(|_| Vec::with_capacity(pixels));
    let mut direction: [Vec<f32>; 3] = std::array::from_fn(|_| Vec::with_capacity(pixels));
    for v in 0..height {
        for u in 0..width {
            let (o, d) = match camera.ray(DVec2::new(f64::from(u), f64::from(v))) {
                Some(ray) => (ray.origin.to_array(), ray.direction.to_array()),
                None => ([f64::NAN; 3], [f64::NAN; 3]),
            };
            for k in 0..3 {
                origin[k].push(o[k] as f32);
                direction[k].push(d[k] as f32);
            }
        }
    }
    let size = (width, height);
    let ([ox, oy, oz], [dx, dy, dz]) = (&origin, &direction);
    write_exr(
        store,
        all_path,
        size,
        "ray origin and direction",
        RAY_MAP_CONVENTION,
        &[
            ("origin.X", ox),
            ("origin.Y", oy),
            ("origin.Z", oz),
            ("direction.X", dx),
            ("direction.Y", dy),
            ("direction.Z", dz),
        ],
        ExrCompression::Zip,
    )?;
    write_xyz_exr(
        store,
        origin_path,
        size,
        "ray origin",
        RAY_MAP_CONVENTION,
        &origin,
        ExrCompression::Zip,
    )?;
    write_xyz_exr(
        store,
        direction_path,
        size,
        "ray direction",
        RAY_MAP_CONVENTION,
        &direction,
        ExrCompression::Zip,
    )
}

/// A three-value image (a vector's x y z, or a colour's R G B) as the f32 channels `R G B`:
/// the one multi-channel layout `OpenCV`'s and imageio's EXR readers open (they refuse other
/// channel names); `quantity` in the header says what the values are.
pub(crate) fn write_xyz_exr(
    to: &mut impl FileStore,
    path: &Path,
    size: (u32, u32),
    quantity: &str,
    convention: &str,
    [x, y, z]: &[Vec<f32>; 3],
    compression: ExrCompression,
) -> Result<(), OutputError> {
    write_exr(
        to,
        path,
        size,
        quantity,
        convention,
        &[("R", x), ("G", y), ("B", z)],
        compression,
    )
}

/// Binary little-endian PLY of every hit pixel: float x y z (world metres), uchar red green
/// blue (the colour plane, or grey 128 where the frame has none). Readable by `Open3D`,
/// `CloudCompare`, `MeshLab` and PCL. Streams the points from the frame a block at a time: a
/// list of the hits would cost 16 bytes a pixel (more while it grows), the largest copy any
/// writer made (a data set's store, which holds each file whole anyway, encodes them with the
/// ranges instead: `PixelPass`).
pub fn write_point_cloud_ply(
    to: &mut impl FileStore,
    path: &Path,
    frame: &Frame,
    comment: &str,
) -> Result<(), OutputError> {
    let hits = frame.hit_count();
    write_point_cloud_points(to, path, PlyPoints::Streamed { frame, hits }, comment)
}

/// Where a point cloud's points come from.
#[derive(Clone, Copy)]
pub(crate) enum PlyPoints<'a> {
    /// Each hit of `frame`, of which there are `hits` ([`Frame::hit_count`]), encoded a block
    /// at a time as they are written.
    Streamed { frame: &'a Frame, hits: usize },
    /// Encoded already ([`PixelPass::points`]).
    Encoded(&'a [u8]),
}

/// Bytes of one point of a point cloud: three f32 and three u8.
const PLY_POINT: usize = 15;

/// A hit as its point cloud stores it: x y z as little-endian f32, then its colour.
fn ply_point(p: &Pixel, colour: &[u8; 3]) -> [u8; PLY_POINT] {
    let mut row = [0; PLY_POINT];
    row[0..4].copy_from_slice(&(p.point.x as f32).to_le_bytes());
    row[4..8].copy_from_slice(&(p.point.y as f32).to_le_bytes());
    row[8..12].copy_from_slice(&(p.point.z as f32).to_le_bytes());
    row[12..].copy_from_slice(colour);
    row
}

/// The colour of pixel `index` in a point cloud: the colour plane's, or grey where the frame
/// has none (`colours` empty).
fn point_colour(colours: &[[u8; 3]], index: usize) -> &[u8; 3] {
    colours.get(index).unwrap_or(&[128; 3])
}

/// [`write_point_cloud_ply`] of `points`: streamed from a frame whose hits are already counted,
/// or encoded already, without a pass to count them.
pub(crate) fn write_point_cloud_points(
    to: &mut impl FileStore,
    path: &Path,
    points: PlyPoints,
    comment: &str,
) -> Result<(), OutputError> {
    /// Points encoded before each write: 60 kB blocks.
    const BLOCK: usize = 4096;
    let hits = match points {
        PlyPoints::Streamed { hits, .. } => hits,
        PlyPoints::Encoded(encoded) => encoded.len() / PLY_POINT,
    };
    to.store(path, |out| {
        write!(
            out,
            "ply\nformat binary_little_endian 1.0\ncomment omnisim point cloud, world frame, metres, z up\n\
             comment {}\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
             property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
            ascii_line(comment),
            hits
        )?;
        let frame = match points {
            PlyPoints::Streamed { frame, .. } => frame,
            PlyPoints::Encoded(encoded) => return out.write_all(encoded),
        };
        let colours = frame.colour().unwrap_or_default();
        debug_assert!(colours.is_empty() || colours.len() == frame.pixels().len());
        let mut block = vec![0u8; BLOCK * PLY_POINT];
        let mut hit_pixels = frame.pixels().iter().enumerate().filter(|(_, p)| p.is_hit());
        loop {
            // Each row written in place. `zip` takes a row before a hit, so no hit is drawn and
            // dropped when the block is full.
            let mut filled = 0;
            for (row, (index, p)) in block.chunks_exact_mut(PLY_POINT).zip(hit_pixels.by_ref()) {
                row.copy_from_slice(&ply_point(p, point_colour(colours, index)));
                filled += PLY_POINT;
            }
            out.write_all(&block[..filled])?;
            if filled < block.len() {
                return Ok(());
            }
        }
    })
    .map_err(failed(path))
}

/// `text` as one printable-ASCII line: PLY headers are ASCII (python-plyfile refuses anything
/// else), so other characters are escaped as `\u{...}`.
fn ascii_line(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            ' '..='~' => c.to_string(),
            '\n' | '\r' | '\t' => " ".into(),
            _ => c.escape_unicode().to_string(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use exr::prelude::WritableImage;

    /// Keeps each file a writer stores, by path, instead of writing it, and tells writers
    /// `in_memory` ([`FileStore::encodes_in_memory`]).
    #[derive(Default)]
    pub(super) struct Kept {
        pub(super) in_memory: bool,
        pub(super) files: Vec<(std::path::PathBuf, Vec<u8>)>,
    }

    impl Kept {
        /// The bytes of the last file stored.
        fn last(&self) -> &[u8] {
            &self.files.last().expect("a file was stored").1
        }
    }

    impl FileStore for Kept {
        fn store(
            &mut self,
            path: &Path,
            fill: impl FnOnce(&mut dyn store::Sink) -> std::io::Result<()>,
        ) -> std::io::Result<()> {
            let mut out = std::io::Cursor::new(Vec::new());
            fill(&mut out)?;
            self.files.push((path.to_path_buf(), out.into_inner()));
            Ok(())
        }

        fn encodes_in_memory(&self) -> bool {
            self.in_memory
        }
    }

    /// Checks that `write_exr` writes `channels` as the bytes `exr`'s own image writer makes,
    /// and that `exr`'s reader gives the values back bit for bit.
    fn check_against_exr(size: (u32, u32), channels: Vec<(&str, Vec<f32>)>, compression: ExrCompression) {
        let mut expected = std::io::Cursor::new(Vec::new());
        exr_image(size, "range", "text", channels.clone(), compression)
            .write()
            .non_parallel()
            .to_buffered(&mut expected)
            .unwrap();
        let mut kept = Kept::default();
        let borrowed: Vec<(&str, &[f32])> = channels.iter().map(|(name, values)| (*name, &values[..])).collect();
        write_exr(
            &mut kept,
            Path::new("x.exr"),
            size,
            "range",
            "text",
            &borrowed,
            compression,
        )
        .unwrap();
        let (width, height) = size;
        assert!(
            kept.last() == &expected.get_ref()[..],
            "{width}x{height} {compression:?}: the bytes differ from exr's"
        );
        use exr::prelude::{ReadChannels, ReadLayers};
        let image = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(kept.last()))
            .unwrap();
        let read: Vec<(String, Vec<u32>)> = (image.layer_data.channel_data.list.iter())
            .map(|c| {
                (
                    c.name.to_string(),
                    c.sample_data.values_as_f32().map(f32::to_bits).collect(),
                )
            })
            .collect();
        let mut written: Vec<(String, Vec<u32>)> = (channels.into_iter())
            .map(|(name, values)| (name.to_string(), values.iter().map(|v| v.to_bits()).collect()))
            .collect();
        written.sort();
        assert!(
            read == written,
            "{width}x{height} {compression:?}: exr reads other values back"
        );
    }

    /// The chunks `write_exr` compresses itself (RLE) or hands to `exr`'s encoders give the
    /// bytes `exr`'s own image writer makes, for one and three channels, odd sizes, runs
    /// longer than a token, NaN and infinities, and blocks that do not compress.
    #[test]
    fn exr_files_are_byte_for_byte_those_of_exrs_writer() {
        let mut seed = 12345_u64;
        let mut random = move || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 33) as u32
        };
        for (width, height) in [(1, 1), (7, 3), (250, 250), (301, 17)] {
            let n = width * height;
            let plane = |random: &mut dyn FnMut() -> u32| -> Vec<f32> {
                (0..n)
                    .map(|i| match (i / 97) % 5 {
                        // Constant stretches: runs longer than one token.
                        0 => 2.5,
                        1 => f32::INFINITY,
                        2 => f32::NAN,
                        3 => f32::from_bits(random()),
                        _ => 1.0 + (i % 300) as f32 * 1e-3,
                    })
                    .collect()
            };
            let planes = [plane(&mut random), plane(&mut random), plane(&mut random)];
            let size = (width as u32, height as u32);
            for compression in [ExrCompression::Rle, ExrCompression::None, ExrCompression::Zip] {
                for channels in [
                    vec![("Y", planes[0].clone())],
                    vec![
                        ("R", planes[0].clone()),
                        ("G", planes[1].clone()),
                        ("B", planes[2].clone()),
                    ],
                ] {
                    check_against_exr(size, channels, compression);
                }
            }
        }
    }

    /// Constant planes, whose RLE runs end a block (a block is one scan line): after the
    /// predictor a plane of equal bytes (0.0, 0x41414141) is one literal byte and then one run
    /// to the line's end, which ends in a full token (32 wide: 127 bytes; 64: 128 + 127) or in
    /// a run of exactly three (33 wide: 128 + 3; three channels 43 wide: 4 × 128 + 3); +inf
    /// (a range image that hits nothing) runs through its even bytes and ends the block in a
    /// literal; 2.5 alternates and never runs. The bytes are `exr`'s and read back bit for bit.
    #[test]
    fn constant_planes_whose_runs_end_a_block_are_exrs_bytes() {
        for (width, height) in [(32, 2), (33, 3), (43, 2), (64, 1), (1, 4), (250, 250)] {
            let n = width * height;
            for value in [0.0, f32::from_bits(0x4141_4141), f32::INFINITY, 2.5, -0.0] {
                let plane = vec![value; n];
                let size = (width as u32, height as u32);
                for compression in [ExrCompression::Rle, ExrCompression::None, ExrCompression::Zip] {
                    check_against_exr(size, vec![("Y", plane.clone())], compression);
                    check_against_exr(
                        size,
                        vec![("R", plane.clone()), ("G", plane.clone()), ("B", plane.clone())],
                        compression,
                    );
                }
            }
        }
    }

    #[test]
    fn ply_comments_become_printable_ascii() {
        assert_eq!(super::ascii_line("θx=30\nnext"), "\\u{3b8}x=30 next");
    }
}
