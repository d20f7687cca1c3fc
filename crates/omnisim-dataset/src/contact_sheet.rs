//! A set's contact sheet: thumbnails of its colour frames in a grid, each with its frame
//! number, to check a set at a glance.
//!
//! The bytes depend on the frames alone (no system fonts, no time), so a resumed, sharded or
//! merged run writes the same sheet as an uninterrupted one. The numbers therefore come from
//! the small digit font below rather than from a font file on the machine.

use std::path::Path;

use image::imageops::{self, FilterType};
use image::{ImageEncoder, Rgb, RgbImage};

use super::DatasetError;

/// The sheet's file name in a set's folder.
pub(crate) const CONTACT_SHEET: &str = "contact-sheet.png";
/// Thumbnails at most: larger sets show every k-th frame, evenly spread, the last included.
const MAX_THUMBNAILS: usize = 100;
/// Thumbnails per row, at most.
const COLUMNS: usize = 10;
/// Largest side of a thumbnail, pixels.
const THUMBNAIL: u32 = 128;
/// Space around thumbnails, pixels.
const GAP: u32 = 6;
/// Height of the label strip under a thumbnail, pixels.
const LABEL: u32 = 16;
/// Digit glyphs, 3 columns × 5 rows, one bit per pixel, top row first (bit 2 = left column).
const DIGITS: [[u8; 5]; 10] = [
    [0b111, 0b101, 0b101, 0b101, 0b111],
    [0b010, 0b110, 0b010, 0b010, 0b111],
    [0b111, 0b001, 0b111, 0b100, 0b111],
    [0b111, 0b001, 0b111, 0b001, 0b111],
    [0b101, 0b101, 0b111, 0b001, 0b001],
    [0b111, 0b100, 0b111, 0b001, 0b111],
    [0b111, 0b100, 0b111, 0b101, 0b111],
    [0b111, 0b001, 0b010, 0b010, 0b010],
    [0b111, 0b101, 0b111, 0b101, 0b111],
    [0b111, 0b101, 0b111, 0b001, 0b111],
];
/// Pixels per glyph pixel.
const GLYPH_SCALE: u32 = 2;
const BACKGROUND: Rgb<u8> = Rgb([40, 40, 40]);
const TEXT: Rgb<u8> = Rgb([235, 235, 235]);

/// Which of `frames` frames the sheet shows: all, or `MAX_THUMBNAILS` evenly spread.
pub(crate) fn chosen(frames: usize) -> Vec<usize> {
    super::evenly_spread(frames, MAX_THUMBNAILS)
}

/// The PNG bytes of a sheet of `frames`: (frame number, colour PNG path), in order.
pub(crate) fn contact_sheet(frames: &[(usize, &Path)]) -> Result<Vec<u8>, DatasetError> {
    let mut thumbnails = Vec::with_capacity(frames.len());
    for &(number, path) in frames {
        let picture = image::open(path)
            .map_err(|e| DatasetError::Picture(format!("{}: {e}", path.display())))?
            .to_rgb8();
        let (w, h) = picture.dimensions();
        let shrink = f64::from(THUMBNAIL) / f64::from(w.max(h));
        let size = |v: u32| ((f64::from(v) * shrink).round() as u32).max(1);
        thumbnails.push((
            number,
            imageops::resize(&picture, size(w), size(h), FilterType::Triangle),
        ));
    }
    let columns = frames.len().clamp(1, COLUMNS) as u32;
    let rows = frames.len().div_ceil(COLUMNS).max(1) as u32;
    let cell = (THUMBNAIL + GAP, THUMBNAIL + LABEL + GAP);
    let mut sheet = RgbImage::from_pixel(GAP + columns * cell.0, GAP + rows * cell.1, BACKGROUND);
    for (k, (number, thumbnail)) in thumbnails.iter().enumerate() {
        let (x, y) = (GAP + (k as u32 % columns) * cell.0, GAP + (k as u32 / columns) * cell.1);
        let (w, h) = thumbnail.dimensions();
        imageops::replace(
            &mut sheet,
            thumbnail,
            i64::from(x + (THUMBNAIL - w) / 2),
            i64::from(y + (THUMBNAIL - h) / 2),
        );
        draw_number(&mut sheet, *number, x, y + THUMBNAIL + 3);
    }
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(
            sheet.as_raw(),
            sheet.width(),
            sheet.height(),
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| DatasetError::Picture(e.to_string()))?;
    Ok(bytes)
}

/// Writes `number` in the digit font with its top-left corner at (x, y).
fn draw_number(sheet: &mut RgbImage, number: usize, x: u32, y: u32) {
    for (position, digit) in number.to_string().bytes().enumerate() {
        let glyph = DIGITS[usize::from(digit - b'0')];
        let left = x + position as u32 * 4 * GLYPH_SCALE;
        for (row, bits) in glyph.iter().enumerate() {
            for column in 0..3 {
                if bits & (0b100 >> column) == 0 {
                    continue;
                }
                for dy in 0..GLYPH_SCALE {
                    for dx in 0..GLYPH_SCALE {
                        let (px, py) = (left + column * GLYPH_SCALE + dx, y + row as u32 * GLYPH_SCALE + dy);
                        if px < sheet.width() && py < sheet.height() {
                            sheet.put_pixel(px, py, TEXT);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The digit font draws what it says: the lit pixels of "10" are those of its glyphs.
    #[test]
    fn numbers_are_drawn_glyph_by_glyph() {
        let mut sheet = RgbImage::from_pixel(40, 20, BACKGROUND);
        draw_number(&mut sheet, 10, 1, 2);
        let lit = |x: u32, y: u32| sheet.get_pixel(x, y) == &TEXT;
        // "1": top row 010, so (1 + 2, 2) lit and (1, 2) dark; "0" starts 8 px later with 111.
        assert!(lit(3, 2) && !lit(1, 2));
        assert!(lit(9, 2) && lit(11, 2) && lit(13, 2));
        // "0" has a hole in the middle row: column 1 of row 2 dark.
        assert!(!lit(11, 2 + 2 * GLYPH_SCALE));
        let count = sheet.pixels().filter(|p| **p == TEXT).count() as u32;
        let glyph_bits = |d: usize| DIGITS[d].iter().map(|b| b.count_ones()).sum::<u32>();
        assert_eq!(count, (glyph_bits(1) + glyph_bits(0)) * GLYPH_SCALE * GLYPH_SCALE);
    }

    #[test]
    fn large_sets_show_frames_evenly_spread_from_first_to_last() {
        assert_eq!(chosen(3), [0, 1, 2]);
        let many = chosen(1000);
        assert_eq!((many.len(), many[0], many[99]), (100, 0, 999));
        assert!(many.windows(2).all(|w| (w[1] - w[0]).abs_diff(10) <= 1));
    }
}
