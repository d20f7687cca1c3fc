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

use crate::scene::lighting::{linear_to_srgb, srgb_to_linear};

/// Largest texture side, texels: a 16k texture is 2 GiB of texels before its mips.
pub const MAX_TEXTURE_SIDE: u32 = 16_384;

/// Most texels of one texture's finest level (256 Mi texels, 2 GiB).
pub const MAX_TEXTURE_TEXELS: u64 = 1 << 28;

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
            texels: packed.par_iter().map(|&texel| linear_texel(unpack(texel))).collect(),
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

/// The linear value of sRGB byte `byte` in 16 bits: round(65535 · its linear value), exactly
/// as [`srgb_to_linear`] gives it. Consecutive bytes lie at least 19 apart (the dark end's step,
/// 65535 / (255 · 12.92)), so [`srgb_byte`] gives the byte back.
pub(crate) fn linear16(byte: u8) -> u16 {
    LINEAR16[usize::from(byte)]
}

/// [`linear16`] of every byte.
static LINEAR16: std::sync::LazyLock<[u16; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|b| (srgb_to_linear(b as u8) * 65535.0).round() as u16));

/// The sRGB byte whose [`linear16`] is `linear` (the nearest sRGB encoding of its value): one
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

/// A texel of [`MipLevel::texels`] from its sRGB colour.
fn linear_texel(rgb: [u8; 3]) -> u64 {
    u64::from(linear16(rgb[0])) | (u64::from(linear16(rgb[1])) << 16) | (u64::from(linear16(rgb[2])) << 32)
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
        Self::from_packed(width, height, pixels.iter().map(|&p| pack(p)).collect())
    }

    /// The texture of `width` × `height` row-major 8-bit sRGB texels packed as [`pack`] packs.
    /// The mips are made from the packed bytes, then each level is held in linear light
    /// ([`MipLevel::from_srgb`]).
    fn from_packed(width: u32, height: u32, texels: Vec<u32>) -> Texture {
        assert_eq!(texels.len(), width as usize * height as usize, "texel count");
        // Each level is held in linear light as soon as the next is made from its bytes, so
        // the load's peak is one packed level beside the finished ones, not the whole packed
        // pyramid as well.
        let mut levels = Vec::new();
        let mut level = Packed { width, height, texels };
        loop {
            let next = (level.width > 1 || level.height > 1).then(|| half(&level));
            levels.push(MipLevel::from_srgb(level.width, level.height, &level.texels));
            match next {
                Some(next) => level = next,
                None => break,
            }
        }
        Texture { levels }
    }

    /// Size of the finest level.
    pub fn size(&self) -> (u32, u32) {
        (self.levels[0].width, self.levels[0].height)
    }

    /// Bytes the texels of every level take.
    pub fn bytes(&self) -> usize {
        self.levels.iter().map(|l| l.texels.len() * 8).sum()
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

/// A mip level of 8-bit sRGB texels packed as [`pack`] packs, as the mips are made.
struct Packed {
    width: u32,
    height: u32,
    texels: Vec<u32>,
}

/// The next mip level: each texel the mean, in linear light, of the 2×2 texels above it (the
/// last row or column of an odd size joins the one before it: a box of 2×1, 1×2 or 3×… never
/// leaves a texel out).
fn half(above: &Packed) -> Packed {
    let (width, height) = ((above.width / 2).max(1), (above.height / 2).max(1));
    // Source columns of destination column x: 2x, 2x+1, and 2x+2 too for the last one of an
    // odd width.
    let span = |x: u32, size: u32, half: u32| {
        let start = 2 * x;
        let end = if x + 1 == half { size } else { (2 * x + 2).min(size) };
        start..end
    };
    // Rows on all threads: a 4096² level takes 0.1 s on one.
    let texels = (0..height)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..width).map(move |x| {
                let mut sum = [0.0f64; 3];
                let mut count = 0.0;
                for sy in span(y, above.height, height) {
                    for sx in span(x, above.width, width) {
                        let c = unpack(above.texels[sy as usize * above.width as usize + sx as usize]);
                        for k in 0..3 {
                            sum[k] += srgb_to_linear(c[k]);
                        }
                        count += 1.0;
                    }
                }
                pack(sum.map(|s| linear_to_srgb(s / count)))
            })
        })
        .collect();
    Packed { width, height, texels }
}

/// Decodes a PNG or JPEG file (`path` a regular file of at most [`TEXTURE_FILE_LIMIT`] bytes)
/// into a texture. The size is read from the header and checked against
/// [`MAX_TEXTURE_SIDE`] and [`MAX_TEXTURE_TEXELS`] before any pixel is decoded, so a file that
/// claims 100k × 100k texels allocates nothing. Errors name the file, never its bytes.
pub fn load_image(path: &Path) -> Result<Texture, String> {
    let file = crate::input::open_regular(path, TEXTURE_FILE_LIMIT).map_err(|e| match e {
        crate::input::InputError::Io { error, .. } if error.kind() == std::io::ErrorKind::NotFound => format!(
            "texture {}: file not found; texture paths are relative to the file that names them",
            path.display()
        ),
        other => format!("texture: {other}"),
    })?;
    let bad = |what: String| format!("texture {}: {what}", path.display());
    let format = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => image::ImageFormat::Png,
        Some("jpg" | "jpeg") => image::ImageFormat::Jpeg,
        _ => return Err(bad("unknown image format; use a .png, .jpg or .jpeg file".into())),
    };
    decode(image::ImageReader::with_format(std::io::BufReader::new(file), format)).map_err(bad)
}

/// Decodes an image held in memory (a GLB's embedded texture) like [`load_image`].
pub fn decode_bytes(bytes: &[u8], what: &str) -> Result<Texture, String> {
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("{what}: {e}"))?;
    decode(reader).map_err(|e| format!("{what}: {e}"))
}

/// Decodes under the size limits: the decoder checks the header's size against them before it
/// allocates anything.
fn decode<R: std::io::BufRead + std::io::Seek>(mut reader: image::ImageReader<R>) -> Result<Texture, String> {
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    limits.max_alloc = Some(MAX_TEXTURE_TEXELS * 8);
    reader.limits(limits);
    let image = reader.decode().map_err(|e| match e {
        image::ImageError::Limits(_) => format!(
            "the image is larger than omnisim reads as a texture (at most {MAX_TEXTURE_SIDE} texels a side and \
             {MAX_TEXTURE_TEXELS} texels); scale it down"
        ),
        image::ImageError::Unsupported(u) => format!("unsupported image: {u}"),
        image::ImageError::Decoding(_) | image::ImageError::IoError(_) => {
            "not a readable PNG or JPEG image (truncated or corrupt)".to_string()
        }
        other => format!("cannot decode the image: {other}"),
    })?;
    let (width, height) = (image.width(), image.height());
    if width == 0 || height == 0 {
        return Err("the image has no pixels".into());
    }
    if u64::from(width) * u64::from(height) > MAX_TEXTURE_TEXELS {
        return Err(format!(
            "the image is {width}×{height}; omnisim reads at most {MAX_TEXTURE_TEXELS} texels per texture"
        ));
    }
    // Packed straight from the decoded image, which is dropped before the levels are made:
    // no third copy of a large texture.
    let packed = image.into_rgb8().pixels().map(|p| pack(p.0)).collect();
    Ok(Texture::from_packed(width, height, packed))
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
        assert_eq!(srgb_texel(linear_texel(texel)), texel);
        assert_eq!(MipLevel::from_srgb(1, 1, &[pack(texel)]).texel(0, 0), texel);
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
        let error = load_image(&path).unwrap_err();
        assert!(error.contains("huge.png") && error.contains("larger than"), "{error}");
        let error = decode_bytes(&png, "image 0").unwrap_err();
        assert!(error.contains("larger than"), "{error}");
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
