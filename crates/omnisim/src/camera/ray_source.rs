//! Every pixel centre's ray of one camera, with what its rays share worked out once: the one
//! place ray tables, frames too large for a table, cone tables and `omnisim bench`'s counting
//! pass get a camera's rays from, bit for bit as [`Camera::ray`] gives them.
//!
//! Per pixel, libm's sine and cosine cost an equirect 1024² image ~247 M instructions, about
//! half a frame of env1; a mirror's shared values (the tilt's sines and cosines, `hypot`s, the
//! quadric) ~450 of its ~830 instructions a ray (docs/benchmarks.md, "2026-11-26 afternoon
//! (pixel)").

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::catadioptric::RayConstants;
use super::{Camera, CameraRay, Catadioptric, Cylindrical, Equirectangular};

/// A camera's pixel rays ([`Camera::ray_source`]).
pub(crate) struct RaySource<'a> {
    size: (u32, u32),
    rays: Rays<'a>,
    /// What [`Self::shared_origin`] gives.
    shared_origin: Option<DVec3>,
}

/// How a [`RaySource`] makes a pixel's ray.
enum Rays<'a> {
    /// An equirect panorama: each column's azimuth and each row's elevation as (cosine, sine).
    Equirect(Grid<(f64, f64), (f64, f64)>),
    /// A cylindrical panorama: each column's azimuth as (cosine, sine), each row's rise.
    Cylindrical(Grid<(f64, f64), f64>),
    /// A mirror, with the values every ray shares (boxed: they are five times the size of the
    /// other variants).
    Mirror(&'a Catadioptric, Box<RayConstants>),
    /// Any other camera, pixel by pixel.
    EachPixel(&'a Camera),
}

/// Values worked out once per column and once per row of an image.
struct Grid<C, R> {
    columns: Vec<C>,
    rows: Vec<R>,
}

impl<C: Copy, R: Copy> Grid<C, R> {
    /// `column(u)` for every column and `row(v)` for every row of a `width`×`height` image.
    fn new((width, height): (u32, u32), column: impl Fn(f64) -> C, row: impl Fn(f64) -> R) -> Self {
        Self {
            columns: (0..width).map(|u| column(f64::from(u))).collect(),
            rows: (0..height).map(|v| row(f64::from(v))).collect(),
        }
    }

    /// The values of `column` and of `row`.
    #[inline(always)]
    fn at(&self, column: u32, row: u32) -> (C, R) {
        (self.columns[column as usize], self.rows[row as usize])
    }
}

impl<'a> RaySource<'a> {
    /// `camera`'s rays, with what they share worked out now.
    pub(crate) fn new(camera: &'a Camera) -> Self {
        let size = camera.size();
        let (rays, shared_origin) = match camera {
            Camera::Equirectangular(c) => {
                let grid = Grid::new(size, |u| super::panorama_azimuth(u, c.width), |v| c.elevation(v));
                (Rays::Equirect(grid), Some(DVec3::ZERO))
            }
            Camera::Cylindrical(c) => {
                let grid = Grid::new(size, |u| super::panorama_azimuth(u, c.width), |v| c.rise(v));
                (Rays::Cylindrical(grid), Some(DVec3::ZERO))
            }
            Camera::Catadioptric(c) => {
                let constants = Box::new(c.ray_constants());
                let origin = c.shared_origin(&constants);
                (Rays::Mirror(c, constants), origin)
            }
            Camera::Pinhole(c) => (Rays::EachPixel(camera), Some(c.position)),
            Camera::Lens(c) => (Rays::EachPixel(camera), Some(c.intrinsics.position)),
        };
        Self {
            size,
            rays,
            shared_origin,
        }
    }

    /// The ray through the centre of pixel `index` (below width·height), counted row by row
    /// from the top left.
    #[inline(always)]
    pub(crate) fn ray(&self, index: usize) -> Option<CameraRay> {
        let row_length = self.size.0.max(1) as usize;
        // Both fit in u32: the column is below the width, the row below the height.
        self.ray_at((index % row_length) as u32, (index / row_length) as u32)
    }

    /// The ray through the centre of the pixel in `column` and `row`.
    #[inline(always)]
    pub(crate) fn ray_at(&self, column: u32, row: u32) -> Option<CameraRay> {
        // From u32 to f64 is one instruction (from usize about a dozen), the same values.
        let pixel = || DVec2::new(f64::from(column), f64::from(row));
        match &self.rays {
            Rays::Equirect(grid) => {
                let (azimuth, elevation) = grid.at(column, row);
                Some(Equirectangular::ray_between(azimuth, elevation))
            }
            Rays::Cylindrical(grid) => {
                let (azimuth, rise) = grid.at(column, row);
                Some(Cylindrical::ray_between(azimuth, rise))
            }
            Rays::Mirror(c, constants) => c.ray_with(constants, pixel()),
            Rays::EachPixel(camera) => camera.ray(pixel()),
        }
    }

    /// Every ray's origin, bit for bit, where the camera's rays all start at one point it
    /// knows without computing them: the panoramas' and a central mirror's body origin, a
    /// pinhole's or lens camera's position. `None` for non-central mirrors.
    pub(crate) fn shared_origin(&self) -> Option<DVec3> {
        self.shared_origin
    }

    /// Every pixel's ray, row by row, on all threads.
    pub(crate) fn all(&self) -> Vec<Option<CameraRay>> {
        (0..self.size.0 as usize * self.size.1 as usize)
            .into_par_iter()
            .map(|index| self.ray(index))
            .collect()
    }
}
