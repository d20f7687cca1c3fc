//! Textures as shading reads them: a mip pyramid of 8-bit sRGB colours, decoded once at load.
//!
//! Each mip level is the box filter (2×2 mean, in linear light) of the one above it, encoded
//! back to 8-bit sRGB; its texels are held as those bytes' linear values in 16 bits a channel
//! (8 bytes a texel, [`MipLevel::texels`]): half of linear f32 RGBA, so 50 MB of JPEG textures
//! fit in memory on both backends, and the CPU filter (`shade/filter.rs`) reads linear light with
//! no decoding (its three table look-ups a texel, gathered, were about a fifth of the textured
//! shading in one process: docs/benchmarks.md, 2026-11-27 evening (tex)). The 8-bit sRGB bytes
//! follow from them exactly ([`srgb_byte`]): the GPU is given those, as it was.

use std::path::Path;

use rayon::prelude::*;

use crate::scene::lighting::{linear_to_srgb, linear_to_srgb3, srgb_decoding, srgb_to_linear};

/// Largest texture side, texels: a 16k texture is 2 GiB of texels before its mips.
pub const MAX_TEXTURE_SIDE: u32 = 16_384;

/// Most texels of one texture's finest level (256 Mi texels, 2 GiB).
pub const MAX_TEXTURE_TEXELS: u64 = 1 << 28;

/// Most texels of a scene's textures together (finest levels; 512 Mi texels: 4 GiB, and a
/// third more for the mips, at 8 bytes a texel). An image over it is refused from its header,
/// before it is decoded.
pub const MAX_SCENE_TEXELS: u64 = 1 << 29;

/// Bytes a texel of a finest level takes in memory with its share of the mips below it (8
/// bytes a texel, the mips a third more): what [`Texture::bytes`] comes to, for a size read
/// from a header.
pub const BYTES_PER_TEXEL_WITH_MIPS: f64 = 8.0 * 4.0 / 3.0;

/// Largest image file read as a texture.
pub const TEXTURE_FILE_LIMIT: u64 = 512 << 20;

/// How texture coordinates outside [0, 1) map onto the image.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Deserialize, serde::Serialize)]
pub enum Wrap {
    /// The image tiles the plane (the default).
    #[default]
    Repeat,
    /// Coordinates are clamped: the border texels stretch outwards.
    Clamp,
    /// The image tiles the plane, every other copy mirrored.
    Mirror,
}

impl Wrap {
    /// The number the GPU knows this mode by (`WRAP_*` in `shaders/texture.wgsl`).
    #[cfg(feature = "gpu")]
    pub(crate) fn gpu_code(self) -> u32 {
        match self {
            Wrap::Repeat => 0,
            Wrap::Clamp => 1,
            Wrap::Mirror => 2,
        }
    }
}

/// One level of a mip pyramid.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MipLevel {
    /// Width, texels.
    pub width: u32,
    /// Height, texels.
    pub height: u32,
    /// Row-major texels, row 0 at the top (v = 0): each channel's 8-bit sRGB byte b held as
    /// round(65535 · its linear value), packed `r | g << 16 | b << 32` (bits 48–63 are read
    /// as zero). Build levels with [`MipLevel::from_srgb`]: other 16-bit values are filtered
    /// as they are on the CPU but reach the GPU as their nearest sRGB byte.
    pub texels: Vec<u64>,
}

impl MipLevel {
    /// The level of `width` × `height` row-major 8-bit sRGB texels, each packed
    /// `r | g << 8 | b << 16`.
    pub fn from_srgb(width: u32, height: u32, packed: &[u32]) -> MipLevel {
        MipLevel {
            width,
            height,
            texels: {
                let linear = &*LINEAR16;
                packed
                    .par_iter()
                    .map(|&texel| linear_texel(linear, unpack(texel)))
                    .collect()
            },
        }
    }

    /// The sRGB colour of texel (x, y).
    pub fn texel(&self, x: u32, y: u32) -> [u8; 3] {
        srgb_texel(self.texels[y as usize * self.width as usize + x as usize])
    }

    /// The texels' 8-bit sRGB colours packed `r | g << 8 | b << 16` (as the GPU reads them),
    /// row by row.
    pub fn srgb_texels(&self) -> impl Iterator<Item = u32> + '_ {
        self.texels.iter().map(|&texel| pack(srgb_texel(texel)))
    }
}

/// The linear value of each sRGB byte in 16 bits: round(65535 · its linear value), exactly as
/// [`srgb_to_linear`] gives it. Consecutive bytes lie at least 19 apart (the dark end's step,
/// 65535 / (255 · 12.92)), so [`srgb_byte`] gives the byte back.
static LINEAR16: std::sync::LazyLock<[u16; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|b| (srgb_to_linear(b as u8) * 65535.0).round() as u16));

/// [`LINEAR16`] of `byte`.
#[cfg(test)]
pub(crate) fn linear16(byte: u8) -> u16 {
    LINEAR16[usize::from(byte)]
}

/// The sRGB byte whose [`LINEAR16`] value is `linear` (the nearest sRGB encoding of its value): one
/// look-up, as the GPU's upload reads back every texel's three.
fn srgb_byte(linear: u16) -> u8 {
    SRGB_BYTES[usize::from(linear)]
}

/// [`srgb_byte`] of every 16-bit value (64 KiB).
static SRGB_BYTES: std::sync::LazyLock<Box<[u8; 65536]>> = std::sync::LazyLock::new(|| {
    let mut bytes = Box::new([0; 65536]);
    for (linear, byte) in bytes.iter_mut().enumerate() {
        *byte = linear_to_srgb(linear as f64 / 65535.0);
    }
    bytes
});

/// A texel of [`MipLevel::texels`] from its sRGB colour, `linear` the table [`LINEAR16`]
/// (found once by the caller: a look-up of the lazy table per channel was a fifth of the mip
/// building).
fn linear_texel(linear: &[u16; 256], rgb: [u8; 3]) -> u64 {
    let channel = |k: usize| u64::from(linear[usize::from(rgb[k])]);
    channel(0) | (channel(1) << 16) | (channel(2) << 32)
}

/// The sRGB colour of a texel of [`MipLevel::texels`].
fn srgb_texel(texel: u64) -> [u8; 3] {
    [0, 16, 32].map(|shift| srgb_byte((texel >> shift) as u16))
}

/// A mip-mapped texture: level 0 is the image, each next level half as wide and high (at least
/// one texel), down to 1×1.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Texture {
    /// Finest first.
    pub levels: Vec<MipLevel>,
}

/// Packs 8-bit sRGB as the GPU reads it.
pub(crate) fn pack(rgb: [u8; 3]) -> u32 {
    u32::from(rgb[0]) | (u32::from(rgb[1]) << 8) | (u32::from(rgb[2]) << 16)
}

/// The inverse of [`pack`].
pub(crate) fn unpack(packed: u32) -> [u8; 3] {
    [packed as u8, (packed >> 8) as u8, (packed >> 16) as u8]
}

impl Texture {
    /// A texture from row-major 8-bit sRGB pixels (`width × height` of them), with its mips.
    pub fn from_rgb(width: u32, height: u32, pixels: &[[u8; 3]]) -> Texture {
        Self::from_srgb_bytes(width, height, pixels.as_flattened())
    }

    /// The texture of `width` × `height` row-major 8-bit sRGB texels, three bytes each (as
    /// decoders give them). Each next level is made from the bytes of the one above, and held
    /// in linear light in the same pass ([`half`]); only the bytes of the level last made are
    /// kept beside the finished levels.
    fn from_srgb_bytes(width: u32, height: u32, bytes: &[u8]) -> Texture {
        assert_eq!(bytes.len(), width as usize * height as usize * 3, "texel count");
        let linear = &*LINEAR16;
        let mut texels = vec![0; width as usize * height as usize];
        // Rows on all threads, a row at a time (a collect texel by texel cost 36 instructions a
        // texel); an empty image has none (its chunks are 1 wide: chunks of 0 panic).
        texels
            .par_chunks_mut(width.max(1) as usize)
            .zip(bytes.par_chunks(width.max(1) as usize * 3))
            .for_each(|(texels, bytes)| {
                for (texel, rgb) in texels.iter_mut().zip(bytes.chunks_exact(3)) {
                    *texel = linear_texel(linear, [rgb[0], rgb[1], rgb[2]]);
                }
            });
        let mut levels = vec![MipLevel { width, height, texels }];
        let (mut width, mut height) = (width, height);
        let mut above: Option<Vec<[u8; 3]>> = None;
        while width > 1 || height > 1 {
            let (next_bytes, next) = half(above.as_deref().map_or(bytes, <[[u8; 3]]>::as_flattened), width, height);
            (width, height) = (next.width, next.height);
            levels.push(next);
            above = Some(next_bytes);
        }
        Texture { levels }
    }
    /// Size of the finest level.
    pub fn size(&self) -> (u32, u32) {
        (self.levels[0].width, self.levels[0].height)
    }

    /// Texels of every level.
    pub(crate) fn texel_count(&self) -> usize {
        self.levels.iter().map(|l| l.texels.len()).sum()
    }

    /// Bytes the texels of every level take.
    pub fn bytes(&self) -> usize {
        self.texel_count() * size_of::<u64>()
    }

    /// The 32-bit words this texture takes in the GPU's texture array: a header a level (first
    /// texel, width, height), then every level's texels packed as sRGB
    /// ([`MipLevel::srgb_texels`], a word a texel). The GPU upload lays it out so, and memory
    /// checks count the host's copy of it by this.
    pub fn gpu_words(&self) -> usize {
        3 * self.levels.len() + self.texel_count()
    }

    /// Why the renderer cannot filter this texture, if it cannot: a level with a side above
    /// [`MAX_TEXTURE_SIDE`], which only a texture built by hand can have (the filter holds a
    /// reduced texel position in f32, within 2^-9 texel at a mirrored side of that limit: see
    /// `shade::filter`'s `reduced`).
    pub(crate) fn oversized(&self) -> Option<String> {
        let (at, level) = self
            .levels
            .iter()
            .enumerate()
            .find(|(_, level)| level.width.max(level.height) > MAX_TEXTURE_SIDE)?;
        Some(format!(
            "its mip level {at} is {}×{} texels, but omnisim filters textures of at most {MAX_TEXTURE_SIDE} \
             texels a side: scale the image down",
            level.width, level.height
        ))
    }
}

/// The level below the `width` × `height` level of sRGB bytes `above` (three a texel): each
/// texel the mean, in linear light, of the 2×2 texels above it (the last row or column of an
/// odd size joins the one before it: a box of 2×1, 1×2 or 3×… never leaves a texel out), as its
/// sRGB bytes (which make the level after it) and as the level's linear texels.
fn half(above: &[u8], width: u32, height: u32) -> (Vec<[u8; 3]>, MipLevel) {
    let (half_width, half_height) = ((width / 2).max(1), (height / 2).max(1));
    // Source columns of destination column x: 2x, 2x+1, and 2x+2 too for the last one of an
    // odd width.
    let span = |x: usize, size: u32, half: u32| {
        let start = 2 * x;
        let end = if x + 1 == half as usize {
            size as usize
        } else {
            (2 * x + 2).min(size as usize)
        };
        start..end
    };
    let (decoding, linear) = (srgb_decoding(), &*LINEAR16);
    let stride = width as usize * 3;
    let mut bytes = vec![[0; 3]; half_width as usize * half_height as usize];
    let mut texels = vec![0; half_width as usize * half_height as usize];
    // Rows on all threads. Channels are written out, not `array::map`ped: the map was an
    // out-of-line call per texel (callgrind: 400 M instructions of four 2048² textures).
    bytes
        .par_chunks_mut(half_width as usize)
        .zip(texels.par_chunks_mut(half_width as usize))
        .enumerate()
        .for_each(|(y, (row_bytes, row_texels))| {
            let rows = span(y, height, half_height);
            for (x, (rgb, texel)) in row_bytes.iter_mut().zip(row_texels).enumerate() {
                let columns = span(x, width, half_width);
                let mean = if rows.len() == 2 && columns.len() == 2 {
                    // The common 2×2 box: the same sums, in the same order, as the loops below.
                    let top = &above[rows.start * stride + columns.start * 3..][..6];
                    let bottom = &above[(rows.start + 1) * stride + columns.start * 3..][..6];
                    let tap = |texels: &[u8], at: usize| decoding[usize::from(texels[at])];
                    let channel =
                        |k: usize| (tap(top, k) + tap(top, k + 3) + tap(bottom, k) + tap(bottom, k + 3)) / 4.0;
                    [channel(0), channel(1), channel(2)]
                } else {
                    let mut sum = [0.0f64; 3];
                    let mut count = 0.0;
                    for sy in rows.clone() {
                        let line = &above[sy * stride..];
                        for sx in columns.clone() {
                            for k in 0..3 {
                                sum[k] += decoding[usize::from(line[sx * 3 + k])];
                            }
                            count += 1.0;
                        }
                    }
                    [sum[0] / count, sum[1] / count, sum[2] / count]
                };
                *rgb = linear_to_srgb3(mean);
                *texel = linear_texel(linear, *rgb);
            }
        });
    let level = MipLevel {
        width: half_width,
        height: half_height,
        texels,
    };
    (bytes, level)
}

/// An image whose header has been read (its size is known and within the limits) and whose
/// texels have not: the scene's texel cap is checked between the two
/// (`TextureBank::add_images`), and the decoding can run on any thread.
pub(crate) struct PendingImage<'a> {
    reader: ImageSource<'a>,
    format: image::ImageFormat,
    width: u32,
    height: u32,
    /// How errors name the image: "texture PATH" or a glTF's "image N".
    name: String,
}

/// Where a [`PendingImage`]'s bytes come from.
enum ImageSource<'a> {
    /// A file, opened again to be decoded: a mesh's images wait with no file open (a thousand
    /// of them would pass `ulimit -n`).
    File(std::path::PathBuf),
    /// Bytes in memory (a GLB's embedded image, a data URI).
    Bytes(std::io::Cursor<std::borrow::Cow<'a, [u8]>>),
}

/// Reads the header of a PNG, JPEG, TGA, BMP or WebP file (`path` a regular file of at most
/// [`TEXTURE_FILE_LIMIT`] bytes). Its size is checked against [`MAX_TEXTURE_SIDE`] and
/// [`MAX_TEXTURE_TEXELS`] before any pixel is decoded, so a file that claims 100k × 100k texels
/// allocates nothing. Errors name the file, never its bytes.
pub(crate) fn open_image(path: &Path) -> Result<PendingImage<'static>, String> {
    let name = format!("texture {}", path.display());
    let format = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => image::ImageFormat::Png,
        Some("jpg" | "jpeg") => image::ImageFormat::Jpeg,
        // TGA and BMP, as OBJ and PLY scans ship them; WebP, as glTF's EXT_texture_webp does.
        Some("tga") => image::ImageFormat::Tga,
        Some("bmp") => image::ImageFormat::Bmp,
        Some("webp") => image::ImageFormat::WebP,
        _ => {
            return Err(format!(
                "{name}: unknown image format; use a .png, .jpg, .jpeg, .tga, .bmp or .webp file"
            ));
        }
    };
    PendingImage::new(ImageSource::File(path.to_path_buf()), Some(format), name)
}

/// `path` opened as a texture file: a regular file of at most [`TEXTURE_FILE_LIMIT`] bytes.
fn open_texture_file(path: &Path) -> Result<std::io::BufReader<std::io::Take<std::fs::File>>, String> {
    let file = crate::input::open_regular(path, TEXTURE_FILE_LIMIT).map_err(|e| match e {
        crate::input::InputError::Io { error, .. } if error.kind() == std::io::ErrorKind::NotFound => format!(
            "texture {}: file not found; texture paths are relative to the file that names them",
            path.display()
        ),
        other => format!("texture: {other}"),
    })?;
    Ok(std::io::BufReader::new(file))
}

/// Reads the header of an image held in memory (a GLB's embedded texture, a data URI; `what`
/// names it) like [`open_image`].
pub(crate) fn open_bytes<'a>(
    bytes: impl Into<std::borrow::Cow<'a, [u8]>>,
    what: &str,
) -> Result<PendingImage<'a>, String> {
    PendingImage::new(
        ImageSource::Bytes(std::io::Cursor::new(bytes.into())),
        None,
        what.to_string(),
    )
}

impl<'a> PendingImage<'a> {
    /// Reads the header of `reader` (of `format`, or guessed from its first bytes), leaving the
    /// reader at its start.
    fn new(mut reader: ImageSource<'a>, format: Option<image::ImageFormat>, name: String) -> Result<Self, String> {
        let header = match &mut reader {
            ImageSource::File(path) => read_header(&mut open_texture_file(path)?, format),
            ImageSource::Bytes(bytes) => read_header(bytes, format),
        };
        let (format, width, height) = header.map_err(|e| format!("{name}: {e}"))?;
        Ok(PendingImage {
            reader,
            format,
            width,
            height,
            name,
        })
    }

    /// Width and height, texels, as the header gives them.
    pub(crate) fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// How errors name the image.
    pub(crate) fn name(&self) -> &str {
        &self.name
    }

    /// Decodes the image and builds its mips.
    pub(crate) fn decode(self) -> Result<Texture, String> {
        let decoded = match self.reader {
            ImageSource::File(path) => decode(open_texture_file(&path)?, self.format),
            ImageSource::Bytes(bytes) => decode(bytes, self.format),
        };
        let name = &self.name;
        let image = decoded.map_err(|e| format!("{name}: {e}"))?.into_rgb8();
        if image.dimensions() != (self.width, self.height) {
            return Err(format!("{name}: the file changed while it was read"));
        }
        Ok(Texture::from_srgb_bytes(self.width, self.height, image.as_raw()))
    }
}

/// The size limits of a texture, for the decoder: it checks the header's size against them
/// before it allocates anything.
fn limits() -> image::Limits {
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    limits.max_alloc = Some(MAX_TEXTURE_TEXELS * 8);
    limits
}

/// The format and size of the image `reader` holds (of `format`, or guessed), under the size
/// limits; the reader is left at its start.
fn read_header<R: std::io::BufRead + std::io::Seek>(
    reader: &mut R,
    format: Option<image::ImageFormat>,
) -> Result<(image::ImageFormat, u32, u32), String> {
    let mut header = image::ImageReader::new(&mut *reader);
    match format {
        Some(format) => header.set_format(format),
        None => header = header.with_guessed_format().map_err(|e| e.to_string())?,
    }
    let format = header
        .format()
        .ok_or("unsupported image: The image format could not be determined")?;
    header.limits(limits());
    let (width, height) = match header.into_dimensions() {
        Ok(size) => size,
        // image's BMP reader refuses a side over 65535 as corrupt before any limit sees it.
        Err(_) if format == image::ImageFormat::Bmp && bmp_side_past_cap(reader) => return Err(too_large()),
        Err(e) => return Err(image_error(e, format)),
    };
    reader.rewind().map_err(|e| e.to_string())?;
    if width == 0 || height == 0 {
        return Err("the image has no pixels".into());
    }
    if u64::from(width) * u64::from(height) > MAX_TEXTURE_TEXELS {
        return Err(format!(
            "the image is {width}×{height}; omnisim reads at most {MAX_TEXTURE_TEXELS} texels per texture"
        ));
    }
    Ok((format, width, height))
}

/// Whether the BMP that `reader` holds claims a side over [`MAX_TEXTURE_SIDE`] in its header:
/// width and height at byte 18, 16 bits each in the old 12-byte core header, else 32 (a negative
/// height runs top-down).
fn bmp_side_past_cap<R: std::io::Read + std::io::Seek>(reader: &mut R) -> bool {
    let mut header = [0u8; 26];
    if reader.rewind().is_err() || reader.read_exact(&mut header).is_err() || &header[..2] != b"BM" {
        return false;
    }
    let field = |at: usize, bytes: usize| {
        header[at..at + bytes]
            .iter()
            .rev()
            .fold(0u32, |v, &b| v << 8 | u32::from(b))
    };
    let (width, height) = if field(14, 4) == 12 {
        (field(18, 2), field(20, 2))
    } else {
        (
            (field(18, 4) as i32).unsigned_abs(),
            (field(22, 4) as i32).unsigned_abs(),
        )
    };
    width.max(height) > MAX_TEXTURE_SIDE
}

/// Decodes the image of `format` that `reader` holds, under the size limits.
fn decode<R: std::io::BufRead + std::io::Seek>(
    reader: R,
    format: image::ImageFormat,
) -> Result<image::DynamicImage, String> {
    let mut reader = image::ImageReader::with_format(reader, format);
    reader.limits(limits());
    reader.decode().map_err(|e| image_error(e, format))
}

/// Why an image past the caps is refused, and the mend.
fn too_large() -> String {
    format!(
        "the image is larger than omnisim reads as a texture (at most {MAX_TEXTURE_SIDE} texels a side and \
         {MAX_TEXTURE_TEXELS} texels); scale it down"
    )
}

/// What went wrong reading an image of `format`, in words.
fn image_error(error: image::ImageError, format: image::ImageFormat) -> String {
    match error {
        image::ImageError::Limits(_) => too_large(),
        image::ImageError::Unsupported(u) => format!("unsupported image: {u}"),
        image::ImageError::Decoding(_) | image::ImageError::IoError(_) => {
            let name = format.extensions_str().first().map_or("", |e| e).to_ascii_uppercase();
            format!("not a readable {name} image (truncated or corrupt)")
        }
        other => format!("cannot decode the image: {other}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mips_halve_down_to_one_texel_and_average_in_linear_light() {
        // Black and white columns: every level below averages to linear 0.5 = sRGB 188.
        let pixels: Vec<[u8; 3]> = (0..8 * 4).map(|i| if i % 2 == 0 { [0; 3] } else { [255; 3] }).collect();
        let texture = Texture::from_rgb(8, 4, &pixels);
        let sizes: Vec<(u32, u32)> = texture.levels.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(8, 4), (4, 2), (2, 1), (1, 1)]);
        for level in &texture.levels[1..] {
            assert!(level.srgb_texels().all(|t| unpack(t) == [188; 3]));
        }
    }

    /// Every sRGB byte's 16-bit linear value encodes back to the byte, and increases with it.
    #[test]
    fn sixteen_bit_linear_values_give_their_bytes_back() {
        for byte in 0..=255u8 {
            assert_eq!(srgb_byte(linear16(byte)), byte);
            let exact = srgb_to_linear(byte) * 65535.0;
            assert!((f64::from(linear16(byte)) - exact).abs() <= 0.5, "{byte}");
            if byte > 0 {
                assert!(linear16(byte) >= linear16(byte - 1) + 19, "{byte}");
            }
        }
        let texel = [3, 128, 255];
        assert_eq!(srgb_texel(linear_texel(&LINEAR16, texel)), texel);
        assert_eq!(MipLevel::from_srgb(1, 1, &[pack(texel)]).texel(0, 0), texel);
    }

    /// Every level equals the definition, texel for texel: the mean in linear light of the
    /// box above it (2×2; 3 wide or high at an odd last column or row), summed row by row,
    /// encoded to sRGB; the level's linear texels are those bytes' [`LINEAR16`] values.
    #[test]
    fn every_level_is_the_box_mean_of_the_one_above() {
        let mut seed = 12345u32;
        for (width, height) in [(8, 6), (7, 5), (1, 9), (16, 1), (33, 17)] {
            let pixels: Vec<[u8; 3]> = (0..width * height)
                .map(|_| {
                    [0; 3].map(|_| {
                        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                        (seed >> 24) as u8
                    })
                })
                .collect();
            let texture = Texture::from_rgb(width, height, &pixels);
            let finest: Vec<u64> = pixels.iter().map(|&rgb| linear_texel(&LINEAR16, rgb)).collect();
            assert_eq!(texture.levels[0].texels, finest);
            let mut above = pixels;
            let (mut w, mut h) = (width as usize, height as usize);
            for level in &texture.levels[1..] {
                let (half_w, half_h) = ((w / 2).max(1), (h / 2).max(1));
                let span = |i: usize, size: usize, half: usize| 2 * i..if i + 1 == half { size } else { 2 * i + 2 };
                let mut below = Vec::new();
                for y in 0..half_h {
                    for x in 0..half_w {
                        let mut sum = [0.0; 3];
                        let mut count = 0.0;
                        for sy in span(y, h, half_h) {
                            for sx in span(x, w, half_w) {
                                for k in 0..3 {
                                    sum[k] += srgb_to_linear(above[sy * w + sx][k]);
                                }
                                count += 1.0;
                            }
                        }
                        below.push(sum.map(|s| linear_to_srgb(s / count)));
                    }
                }
                assert_eq!((level.width as usize, level.height as usize), (half_w, half_h));
                let expected: Vec<u64> = below.iter().map(|&rgb| linear_texel(&LINEAR16, rgb)).collect();
                assert_eq!(level.texels, expected, "{width}×{height}, level {half_w}×{half_h}");
                (above, w, h) = (below, half_w, half_h);
            }
            assert_eq!((w, h), (1, 1));
        }
    }

    #[test]
    fn odd_sizes_keep_every_texel() {
        // 3×1: the single texel of level 1 averages all three (two black, one white).
        let texture = Texture::from_rgb(3, 1, &[[0; 3], [0; 3], [255; 3]]);
        assert_eq!(texture.levels.len(), 2);
        assert_eq!(texture.levels[1].texel(0, 0), [linear_to_srgb(1.0 / 3.0); 3]);
    }

    #[test]
    fn a_header_claiming_100k_by_100k_texels_is_refused_before_decoding() {
        // A PNG header (signature and IHDR) claiming 100000 × 100000 RGB texels, and no data.
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        let mut ihdr = b"IHDR".to_vec();
        ihdr.extend(100_000u32.to_be_bytes());
        ihdr.extend(100_000u32.to_be_bytes());
        ihdr.extend([8, 2, 0, 0, 0]);
        png.extend(13u32.to_be_bytes());
        png.extend(&ihdr);
        png.extend(crc32(&ihdr).to_be_bytes());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.png");
        std::fs::write(&path, &png).unwrap();
        let error = open_image(&path).err().unwrap();
        assert!(error.contains("huge.png") && error.contains("larger than"), "{error}");
        let error = open_bytes(&png[..], "image 0").err().unwrap();
        assert!(
            error.starts_with("image 0: ") && error.contains("larger than"),
            "{error}"
        );
    }

    /// A TGA and a BMP whose headers claim 60000² and 30000² texels, and a BMP 70000 wide (a
    /// side image's BMP reader refuses as corrupt): refused as the PNG's is, naming the file,
    /// before any texel is read (they have none).
    #[test]
    fn tga_and_bmp_headers_past_the_caps_are_refused_before_decoding() {
        // TGA: no id, no colour map, true colour; origin, size, 24 bits, top-left first.
        let mut tga = vec![0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        tga.extend(60_000u16.to_le_bytes());
        tga.extend(60_000u16.to_le_bytes());
        tga.extend([24, 0x20]);
        // BMP: file header, then a BITMAPINFOHEADER of 24 bits, uncompressed.
        let bmp = |width: i32, height: i32| {
            let mut bmp = b"BM".to_vec();
            for field in [0u32, 0, 54, 40] {
                bmp.extend(field.to_le_bytes());
            }
            bmp.extend(width.to_le_bytes());
            bmp.extend(height.to_le_bytes());
            bmp.extend(1u16.to_le_bytes());
            bmp.extend(24u16.to_le_bytes());
            bmp.extend([0; 24]);
            bmp
        };
        let dir = tempfile::tempdir().unwrap();
        for (name, bytes) in [
            ("huge.tga", tga),
            ("huge.bmp", bmp(30_000, 30_000)),
            ("wide.bmp", bmp(70_000, 1)),
            ("tall.bmp", bmp(1, -70_000)),
        ] {
            let path = dir.path().join(name);
            std::fs::write(&path, &bytes).unwrap();
            let error = open_image(&path).err().unwrap();
            assert!(error.contains(name) && error.contains("larger than"), "{error}");
        }
    }

    /// CRC-32 (PNG's chunk checksum), bit by bit: only the test's one header needs it.
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }
}
