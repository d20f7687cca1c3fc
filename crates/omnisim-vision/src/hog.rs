//! Histograms of oriented gradients.
//!
//! - [`block_hog`]: the block layout of Dalal & Triggs 2005 (CVPR): cells of c × c pixels,
//!   blocks of b × b cells moved by a stride, each block's histograms L2-Hys normalised. Not
//!   their full descriptor: each pixel votes into its own cell only (no trilinear spatial
//!   interpolation between neighbouring cells) and blocks have no Gaussian window
//!   (σ = half the block width); scikit-image's `hog` leaves out the same two.
//! - [`panoramic_hog`]: the rotation-invariant variant of Payá et al. 2014 (Sensors 14(2))
//!   and Amorós et al. 2021 (Sensors 21(10), §2.2): the
//!   panorama is cut into k horizontal cells that span its full width; a turn of the camera
//!   shifts the panorama's columns and leaves each cell's pixels, so the histograms, unchanged.
//!
//! Gradients are the centred differences [−1, 0, 1] of Dalal & Triggs; each pixel votes its
//! magnitude into the two orientation bins nearest its angle, linearly (Dalal & Triggs'
//! orientation interpolation; bin b spans [b, b + 1)·range/bins and is centred at
//! (b + ½)·range/bins, range π unsigned or 2π signed, the bins of scikit-image's `hog`, which
//! votes into one bin only). No spatial (trilinear) interpolation nor Gaussian block window
//! (scikit-image has neither).
//!
//! Written here: imageproc's HOG is the block variant only and imageproc would bring
//! nalgebra 0.35 (beside the workspace's 0.34).

use crate::angle::atan2_degrees;
use crate::{Descriptor, Raster, Rotation, VisionError, require};

/// Orientation binning shared by both variants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orientations {
    /// Histogram bins.
    pub bins: usize,
    /// Angles over 2π (gradient direction) rather than π (edge orientation).
    pub signed: bool,
}

/// Dalal & Triggs' defaults: 9 unsigned bins, 8 × 8-pixel cells, 2 × 2-cell blocks, stride
/// 1 cell, L2-Hys clipping at 0.2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockHogParams {
    /// Orientation binning.
    pub orientations: Orientations,
    /// Cell side, pixels.
    pub cell: usize,
    /// Block side, cells.
    pub block: usize,
    /// Block step, cells.
    pub stride: usize,
    /// L2-Hys clipping of each normalised block value.
    pub clip: f32,
}

impl Default for BlockHogParams {
    fn default() -> Self {
        Self {
            orientations: Orientations { bins: 9, signed: false },
            cell: 8,
            block: 2,
            stride: 1,
            clip: 0.2,
        }
    }
}

/// k horizontal cells of b bins; by default 16 cells of 8 unsigned bins, each cell's histogram
/// L2-normalised (values within the ranges Payá et al. 2014 test).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanoramicHogParams {
    /// Orientation binning.
    pub orientations: Orientations,
    /// Horizontal cells k.
    pub cells: usize,
    /// L2-normalise each cell's histogram.
    pub normalise: bool,
}

impl Default for PanoramicHogParams {
    fn default() -> Self {
        Self {
            orientations: Orientations { bins: 8, signed: false },
            cells: 16,
            normalise: true,
        }
    }
}

/// Gradient magnitude and direction (degrees, 0..360, from +x towards +y) of every pixel;
/// with `wrap` the columns are circular (a 360° panorama), otherwise and for rows the border
/// pixel is repeated. Directions come from [`atan2_degrees`] (within 0.005°): libm's `atan2f`
/// was most of HOG's time.
fn gradients(image: &Raster, wrap: bool) -> Vec<(f32, f32)> {
    let (w, h) = (image.width, image.height);
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let (above, row, below) = (
            image.row(y.saturating_sub(1)),
            image.row(y),
            image.row((y + 1).min(h - 1)),
        );
        for x in 0..w {
            let left = match (x, wrap) {
                (0, true) => w - 1,
                (0, false) => 0,
                _ => x - 1,
            };
            let right = match (x + 1 == w, wrap) {
                (true, true) => 0,
                (true, false) => w - 1,
                _ => x + 1,
            };
            let (gx, gy) = (row[right] - row[left], below[x] - above[x]);
            out.push(((gx * gx + gy * gy).sqrt(), atan2_degrees(gy, gx)));
        }
    }
    out
}

impl Orientations {
    fn check(&self) -> Result<(), VisionError> {
        require((2..=360).contains(&self.bins), "bins", || {
            format!("needs 2 to 360, got {}", self.bins)
        })
    }

    /// Adds `magnitude` at `degrees` (0..360) to `histogram`, split linearly between the two
    /// bins whose centres (b + ½)·range/bins are nearest (circularly).
    fn vote(&self, degrees: f32, magnitude: f32, histogram: &mut [f32]) {
        let range = if self.signed { 360.0 } else { 180.0 };
        let folded = if degrees >= range { degrees - range } else { degrees };
        // In bins from bin 0's centre: −½ … bins − ½; below 0 it is between the last bin and
        // the first (floors without libm's call).
        let position = folded / range * self.bins as f32 - 0.5;
        let (lower, fraction) = if position >= 0.0 {
            (position as usize % self.bins, position - (position as usize) as f32)
        } else {
            (self.bins - 1, position + 1.0)
        };
        histogram[lower] += magnitude * (1.0 - fraction);
        histogram[(lower + 1) % self.bins] += magnitude * fraction;
    }
}

impl BlockHogParams {
    /// Checks the settings that do not depend on the image: bins 2–360, cell, block and
    /// stride at least 1, `clip` finite and positive.
    pub fn validate(&self) -> Result<(), VisionError> {
        self.orientations.check()?;
        require(self.cell >= 1 && self.block >= 1 && self.stride >= 1, "cells", || {
            "cell, block and stride must be at least 1".to_string()
        })?;
        require(self.clip.is_finite() && self.clip > 0.0, "clip", || {
            format!("must be finite and positive, got {}", self.clip)
        })
    }

    /// Checks everything, for a `width × height` image: also that one block fits.
    pub fn fits(&self, width: usize, height: usize) -> Result<(), VisionError> {
        self.validate()?;
        let (cells_x, cells_y) = (width / self.cell, height / self.cell);
        require(cells_x >= self.block && cells_y >= self.block, "block", || {
            format!(
                "a {cells_x}×{cells_y}-cell image holds no {0}×{0}-cell block",
                self.block
            )
        })
    }
}

impl PanoramicHogParams {
    /// Checks the settings that do not depend on the image: bins 2–360, at least 1 cell.
    pub fn validate(&self) -> Result<(), VisionError> {
        self.orientations.check()?;
        require(self.cells >= 1, "cells", || "needs at least 1 cell".to_string())
    }

    /// Checks everything, for a `width × height` panorama: also cells ≤ height.
    pub fn fits(&self, _width: usize, height: usize) -> Result<(), VisionError> {
        self.validate()?;
        require(self.cells <= height, "cells", || {
            format!("needs 1 ≤ cells ≤ height = {height}, got {}", self.cells)
        })
    }
}

impl VerticalHogParams {
    /// Checks the settings that do not depend on the image: bins 2–360, cell width and
    /// column step at least 1.
    pub fn validate(&self) -> Result<(), VisionError> {
        self.orientations.check()?;
        require(self.width >= 1 && self.step >= 1, "cells", || {
            "cell width and column step must be at least 1".to_string()
        })
    }

    /// Checks everything, for a `width × height` panorama: also that the step divides the
    /// width and a cell fits in it.
    pub fn fits(&self, width: usize, _height: usize) -> Result<(), VisionError> {
        self.validate()?;
        require(width.is_multiple_of(self.step), "step", || {
            format!("must divide the panorama's width {width}, got {}", self.step)
        })?;
        require(self.width <= width, "width", || {
            format!("needs 1 ≤ width ≤ {width} columns, got {}", self.width)
        })
    }
}

fn l2_normalise(values: &mut [f32]) {
    let norm = values.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm > 0.0 {
        values.iter_mut().for_each(|v| *v /= norm);
    }
}

/// The block HOG of a one-channel image (Dalal & Triggs' layout without their spatial
/// interpolation and block window; module docs): shape [`blocks_y`, `blocks_x`, block, block,
/// bins], each block's vector L2-Hys normalised (L2, clipped at `clip`, L2 again).
pub fn block_hog(image: &Raster, params: BlockHogParams) -> Result<Descriptor, VisionError> {
    require(image.channels == 1, "channels", || {
        format!("HOG reads one channel, got {}", image.channels)
    })?;
    params.fits(image.width, image.height)?;
    let bins = params.orientations.bins;
    let (cells_x, cells_y) = (image.width / params.cell, image.height / params.cell);
    let mut cells = vec![0.0f32; cells_x * cells_y * bins];
    // Pixels past the last whole cell (right and bottom) vote nowhere.
    for (y, row) in gradients(image, false)
        .chunks(image.width)
        .take(cells_y * params.cell)
        .enumerate()
    {
        let cell_row = &mut cells[y / params.cell * cells_x * bins..][..cells_x * bins];
        for (x, &(magnitude, angle)) in row[..cells_x * params.cell].iter().enumerate() {
            let start = x / params.cell * bins;
            params
                .orientations
                .vote(angle, magnitude, &mut cell_row[start..start + bins]);
        }
    }
    let blocks_x = (cells_x - params.block) / params.stride + 1;
    let blocks_y = (cells_y - params.block) / params.stride + 1;
    let block_len = params.block * params.block * bins;
    let mut values = Vec::with_capacity(blocks_x * blocks_y * block_len);
    for by in 0..blocks_y {
        for bx in 0..blocks_x {
            let start = values.len();
            for cy in by * params.stride..by * params.stride + params.block {
                for cx in bx * params.stride..bx * params.stride + params.block {
                    let cell = (cy * cells_x + cx) * bins;
                    values.extend_from_slice(&cells[cell..cell + bins]);
                }
            }
            let block = &mut values[start..];
            l2_normalise(block);
            block.iter_mut().for_each(|v| *v = v.min(params.clip));
            l2_normalise(block);
        }
    }
    Ok(Descriptor {
        shape: vec![blocks_y, blocks_x, params.block, params.block, bins],
        values,
    })
}

/// The rotation-invariant HOG of a one-channel 360° panorama: shape [cells, bins], cell i
/// holding rows ⌊i·H/k⌋ .. ⌊(i+1)·H/k⌋ over the full width, gradients circular in x.
pub fn panoramic_hog(panorama: &Raster, params: PanoramicHogParams) -> Result<Descriptor, VisionError> {
    require(panorama.channels == 1, "channels", || {
        format!("HOG reads one channel, got {}", panorama.channels)
    })?;
    params.fits(panorama.width, panorama.height)?;
    let bins = params.orientations.bins;
    let mut values = vec![0.0f32; params.cells * bins];
    for (y, row) in gradients(panorama, true).chunks(panorama.width).enumerate() {
        let cell = y * params.cells / panorama.height;
        let histogram = &mut values[cell * bins..(cell + 1) * bins];
        for &(magnitude, angle) in row {
            params.orientations.vote(angle, magnitude, histogram);
        }
    }
    if params.normalise {
        values.chunks_mut(bins).for_each(l2_normalise);
    }
    Ok(Descriptor {
        shape: vec![params.cells, bins],
        values,
    })
}

/// Overlapping vertical cells of a panorama for orientation (Payá et al. 2014; Amorós et al.
/// 2021 §2.2): cell i spans the full height and columns i·step .. i·step + width (circular),
/// each histogram L2-normalised. A turn of the camera by a multiple of `step` columns shifts
/// the cells circularly, so comparing shifted cells recovers the turn (resolution
/// 2π·step/W). Defaults: 8 unsigned bins, cells 32 columns wide every column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerticalHogParams {
    /// Orientation binning.
    pub orientations: Orientations,
    /// Columns per cell.
    pub width: usize,
    /// Columns between the starts of consecutive cells.
    pub step: usize,
}

impl Default for VerticalHogParams {
    fn default() -> Self {
        Self {
            orientations: Orientations { bins: 8, signed: false },
            width: 32,
            step: 1,
        }
    }
}

/// The vertical-cell HOG of a one-channel 360° panorama: shape [W / step, bins] (the width
/// must be a multiple of the step). Each column's histogram is made once and the cells sum
/// `width` of them.
pub fn vertical_hog(panorama: &Raster, params: VerticalHogParams) -> Result<Descriptor, VisionError> {
    require(panorama.channels == 1, "channels", || {
        format!("HOG reads one channel, got {}", panorama.channels)
    })?;
    params.fits(panorama.width, panorama.height)?;
    let w = panorama.width;
    let bins = params.orientations.bins;
    let mut columns = vec![0.0f32; w * bins];
    for row in gradients(panorama, true).chunks(w) {
        for (histogram, &(magnitude, angle)) in columns.chunks_mut(bins).zip(row) {
            params.orientations.vote(angle, magnitude, histogram);
        }
    }
    let cells = w / params.step;
    let mut values = vec![0.0f32; cells * bins];
    for (cell, histogram) in values.chunks_mut(bins).enumerate() {
        for offset in 0..params.width {
            let x = (cell * params.step + offset) % w;
            histogram
                .iter_mut()
                .zip(&columns[x * bins..(x + 1) * bins])
                .for_each(|(h, c)| *h += c);
        }
        l2_normalise(histogram);
    }
    Ok(Descriptor {
        shape: vec![cells, bins],
        values,
    })
}

/// The turn that takes panorama `a` to panorama `b` (`b` is `a` with its columns moved right
/// by `steps`), from their vertical-cell HOGs made with the same `params` on panoramas `width`
/// columns wide: the circular shift of the cells with the least sum of squared differences.
pub fn vertical_hog_rotation(
    a: &Descriptor,
    b: &Descriptor,
    params: VerticalHogParams,
    width: usize,
) -> Result<Rotation, VisionError> {
    require(
        a.shape == b.shape && a.shape.len() == 2 && a.shape[0] * params.step == width,
        "descriptors",
        || {
            format!(
                "shapes {:?} and {:?} are not both vertical-cell HOGs of {width} columns",
                a.shape, b.shape
            )
        },
    )?;
    let (cells, bins) = (a.shape[0], a.shape[1]);
    let distance = |shift: usize| -> f32 {
        (0..cells)
            .map(|i| {
                let (x, y) = (
                    &a.values[i * bins..(i + 1) * bins],
                    &b.values[(i + shift) % cells * bins..][..bins],
                );
                x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum::<f32>()
            })
            .sum()
    };
    let best = (0..cells)
        .min_by(|&p, &q| distance(p).total_cmp(&distance(q)))
        .unwrap_or(0);
    Ok(Rotation::from_steps(best * params.step, width))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: usize, height: usize, f: impl Fn(f32, f32) -> f32) -> Raster {
        let data = (0..width * height)
            .map(|i| f((i % width) as f32, (i / width) as f32))
            .collect();
        Raster::from_vec(width, height, 1, data).unwrap()
    }

    /// Dalal & Triggs' 64 × 128 window gives their 3780 values (7 × 15 blocks of 36), every
    /// block of unit norm after L2-Hys.
    #[test]
    fn block_hog_shape_and_normalisation() {
        let texture = image(64, 128, |x, y| {
            ((0.3 * x).sin() * (0.17 * y + 0.02 * x * y).cos()).abs()
        });
        let hog = block_hog(&texture, BlockHogParams::default()).unwrap();
        assert_eq!(hog.shape, vec![15, 7, 2, 2, 9]);
        assert_eq!(hog.values.len(), 3780);
        for block in hog.values.chunks(36) {
            let norm = block.iter().map(|v| v * v).sum::<f32>().sqrt();
            assert!((norm - 1.0).abs() < 1e-4, "block norm {norm}");
            assert!(block.iter().all(|&v| v >= 0.0));
        }
    }

    /// Brightness varying along x only: every gradient is horizontal (angle 0 or π, both
    /// orientation 0 unsigned), half-way between the centres of bins 0 (10°) and 8 (170°), so
    /// the mass splits evenly between them; along the 45° diagonal it splits 3 : 1 between
    /// bins 2 (centre 50°) and 1 (30°) in a block clear of the border.
    #[test]
    fn gradient_directions_land_in_their_bins() {
        let stripes = image(32, 32, |x, _| (0.5 * x).sin());
        let hog = block_hog(&stripes, BlockHogParams::default()).unwrap();
        for (i, v) in hog.values.iter().enumerate() {
            if i % 9 != 0 && i % 9 != 8 {
                assert!(v.abs() < 1e-6, "bin {} has {v}", i % 9);
            }
        }
        for cell in hog.values.chunks(9) {
            assert!(
                (cell[0] - cell[8]).abs() < 1e-6 && cell[0] > 0.1,
                "bins 0 and 8: {} {}",
                cell[0],
                cell[8]
            );
        }
        let diagonal = image(32, 32, |x, y| 0.05 * (x + y));
        let params = BlockHogParams {
            clip: 1.0,
            ..Default::default()
        };
        let hog = block_hog(&diagonal, params).unwrap();
        // Block (1, 1) of the 3 × 3, its first cell's bins 1 and 2.
        let (bin1, bin2) = (hog.values[4 * 36 + 1], hog.values[4 * 36 + 2]);
        assert!((bin2 / bin1 - 3.0).abs() < 1e-3, "{bin2} / {bin1}");
    }

    /// Whole-column shifts of a panorama leave the panoramic HOG unchanged; a different
    /// panorama does not.
    #[test]
    fn panoramic_hog_is_invariant_to_column_shifts() {
        let panorama = image(128, 32, |x, y| {
            (0.5 + 0.4 * (0.3 * x).sin() * (0.2 * y).cos() + 0.001 * x * y).fract()
        });
        let params = PanoramicHogParams::default();
        let reference = panoramic_hog(&panorama, params).unwrap();
        assert_eq!(reference.shape, vec![16, 8]);
        for cell in reference.values.chunks(8) {
            assert!((cell.iter().map(|v| v * v).sum::<f32>().sqrt() - 1.0).abs() < 1e-4);
        }
        for shift in [1, 17, 64, 127] {
            let shifted = panoramic_hog(&panorama.shift_columns(shift), params).unwrap();
            for (a, b) in reference.values.iter().zip(&shifted.values) {
                assert!((a - b).abs() < 1e-5, "shift {shift}: {a} vs {b}");
            }
        }
        let other = panoramic_hog(&image(128, 32, |x, y| (0.07 * x * y).sin()), params).unwrap();
        let difference: f32 = reference
            .values
            .iter()
            .zip(&other.values)
            .map(|(a, b)| (a - b).abs())
            .sum();
        assert!(difference > 1.0);
    }

    /// A panorama's columns moved right by 37 give the same cells shifted by 37 (exactly), and
    /// the search finds 37 columns; with step 4 a move of 36 is found as 36. The panoramic
    /// (horizontal-cell) variant is unchanged by the same move, so it cannot tell the turn.
    #[test]
    fn vertical_cells_recover_a_turn() {
        let pano = image(128, 32, |x, y| {
            ((x * 0.7).sin() * (y * 0.3).cos() + (x * 0.13 + y * 0.21).sin() * 0.5 + (x * x * 0.001).cos()) * 0.3 + 0.5
        });
        for (step, moved) in [(1usize, 37i64), (4, 36)] {
            let params = VerticalHogParams {
                step,
                ..VerticalHogParams::default()
            };
            let a = vertical_hog(&pano, params).unwrap();
            let b = vertical_hog(&pano.shift_columns(moved), params).unwrap();
            assert_eq!(a.shape, vec![128 / step, 8]);
            let rotation = vertical_hog_rotation(&a, &b, params, 128).unwrap();
            assert_eq!(rotation.steps as i64, moved, "step {step}");
            assert!((rotation.radians - std::f64::consts::TAU * moved as f64 / 128.0).abs() < 1e-12);
        }
        let bad = VerticalHogParams {
            step: 3,
            ..VerticalHogParams::default()
        };
        assert!(vertical_hog(&pano, bad).is_err());
    }

    /// L2-Hys needs a finite, positive clip: 0 would zero every block, NaN poison it.
    #[test]
    fn clip_is_validated() {
        let texture = image(32, 32, |x, y| (0.3 * x + 0.2 * y).sin());
        for clip in [0.0, -0.2, f32::NAN, f32::INFINITY] {
            let params = BlockHogParams {
                clip,
                ..Default::default()
            };
            assert!(
                matches!(
                    block_hog(&texture, params),
                    Err(VisionError::Parameter { name: "clip", .. })
                ),
                "{clip}"
            );
        }
    }
}
