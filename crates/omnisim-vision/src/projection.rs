//! Views resampled from a central catadioptric image: panoramic (cylindrical), equirectangular
//! (unit sphere), perspective in any direction, and an orthographic bird's-eye view of a
//! horizontal plane.
//!
//! Each output pixel is turned into a body-frame point or direction by the view's own model
//! (omnisim's `Cylindrical`, `Equirectangular` and `Pinhole` cameras, so a resampled view can
//! be compared pixel for pixel with the same view traced exactly), and that point is projected
//! into the omnidirectional image by the mirror's closed-form projection
//! ([`Catadioptric::project`], Mei's unified model). The table of source coordinates
//! ([`Remap`]) is made once per (camera, view) and applied to any number of images, as
//! `OpenCV`'s `remap`.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::{DMat3, DVec2, DVec3, dvec2, dvec3};
use omnisim::camera::{Camera, Catadioptric, Cylindrical, Equirectangular, Pinhole};
use rayon::prelude::*;

use crate::{Interpolation, Raster, VisionError, require};

/// Most pixels in a view: 16 Mi (4096 × 4096) resample an omnidirectional image of a few
/// megapixels finely already and take seconds per image; the table holds 24 bytes a pixel, so
/// the 100 megapixels of omnisim's cameras took gigabytes and minutes without a word.
pub const VIEW_PIXELS_MAX: u64 = 1 << 24;

/// Shortest and longest lengths a view takes (ground sampling distance, plane height), metres:
/// omnisim's bounds on mirror sizes and rims (`Camera::validate`).
const LENGTH_MIN: f64 = 1e-6;
const LENGTH_MAX: f64 = 1000.0;

/// Orthographic view of the horizontal plane z = `plane_z` of the body frame (metres below the
/// viewpoint are negative: the floor seen from a camera 0.7 m above it is `plane_z = -0.7`).
/// Image up is body +x (forward), image right is body −y, as a map seen from above.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneView {
    /// Output width.
    pub width: u32,
    /// Output height.
    pub height: u32,
    /// Ground sampling distance.
    pub metres_per_pixel: f64,
    /// Height of the plane in the body frame, metres.
    pub plane_z: f64,
    /// Body (x, y) at the image centre ((W−1)/2, (H−1)/2).
    pub centre: DVec2,
}

impl PlaneView {
    fn image_centre(&self) -> DVec2 {
        dvec2(f64::from(self.width) - 1.0, f64::from(self.height) - 1.0) / 2.0
    }

    fn point(&self, pixel: DVec2) -> DVec3 {
        let offset = (self.image_centre() - pixel) * self.metres_per_pixel;
        (self.centre + dvec2(offset.y, offset.x)).extend(self.plane_z)
    }

    fn project(&self, point: DVec3) -> DVec2 {
        let offset = point.truncate() - self.centre;
        self.image_centre() - dvec2(offset.y, offset.x) / self.metres_per_pixel
    }
}

/// What an output image shows, from the omnidirectional camera's viewpoint.
#[derive(Debug, Clone, PartialEq)]
pub enum View {
    /// A central camera of omnisim (cylindrical, equirectangular, pinhole) at the viewpoint,
    /// turned by `body_from_view` (its body frame into the omni camera's body frame).
    Camera {
        /// The view's camera model.
        camera: Camera,
        /// Its body frame in the omni camera's body frame.
        body_from_view: DMat3,
    },
    /// Orthographic bird's-eye view of a horizontal plane.
    Plane(PlaneView),
}

impl View {
    /// 360° cylindrical panorama whose rows span the elevations `lowest..highest` (radians,
    /// rows uniform in tan(elevation), as omnisim's `Cylindrical` camera; top row = highest).
    pub fn panorama(width: u32, height: u32, lowest: f64, highest: f64) -> Result<View, VisionError> {
        let limit = 89f64.to_radians();
        require(
            -limit <= lowest && lowest < highest && highest <= limit,
            "elevation band",
            || {
                format!(
                    "needs −89° ≤ lowest < highest ≤ 89°, got {}° .. {}°",
                    degrees(lowest),
                    degrees(highest)
                )
            },
        )?;
        // Row v sees tan(elevation) = (cy − v)/fy; the top edge (v = −½) sees `highest` and the
        // bottom edge (v = H − ½) `lowest`.
        let fy = f64::from(height) / (highest.tan() - lowest.tan());
        let camera = Cylindrical {
            width,
            height,
            fy,
            cy: fy * highest.tan() - 0.5,
        };
        Ok(View::Camera {
            camera: Camera::Cylindrical(camera),
            body_from_view: DMat3::IDENTITY,
        })
    }

    /// Full-sphere equirectangular (unit-sphere) view; what the mirror does not see is empty.
    pub fn equirectangular(width: u32, height: u32) -> View {
        View::Camera {
            camera: Camera::Equirectangular(Equirectangular { width, height }),
            body_from_view: DMat3::IDENTITY,
        }
    }

    /// Perspective view `hfov` radians wide looking at azimuth `yaw` (from body +x towards +y)
    /// and elevation `pitch` (up positive), image rows level.
    pub fn perspective(width: u32, height: u32, hfov: f64, yaw: f64, pitch: f64) -> Result<View, VisionError> {
        require(hfov > 0.0 && hfov < 179f64.to_radians(), "hfov", || {
            format!("needs 0 < hfov < 179°, got {}°", degrees(hfov))
        })?;
        // A turn or more of yaw names no new direction, and beyond ±90° pitch looks back over
        // the top: such values are mistakes (or radians where degrees were meant).
        require(yaw.abs() <= 2.0 * PI && pitch.abs() <= FRAC_PI_2, "direction", || {
            format!(
                "needs −360° ≤ yaw ≤ 360° and −90° ≤ pitch ≤ 90°, got {}° and {}°",
                degrees(yaw),
                degrees(pitch)
            )
        })?;
        Ok(View::Camera {
            camera: Camera::Pinhole(Pinhole::with_horizontal_fov(width, height, hfov)),
            // The pinhole looks along its body +x; pitch turns +x towards +z (a negative turn
            // about y), then yaw about z.
            body_from_view: DMat3::from_rotation_z(yaw) * DMat3::from_rotation_y(-pitch),
        })
    }

    /// Orthographic view of the plane z = `plane_z` (body frame), centred under the viewpoint.
    pub fn birds_eye(width: u32, height: u32, metres_per_pixel: f64, plane_z: f64) -> Result<View, VisionError> {
        require(
            (LENGTH_MIN..=LENGTH_MAX).contains(&metres_per_pixel),
            "metres per pixel",
            || format!("needs {LENGTH_MIN:e} to {LENGTH_MAX} m, got {metres_per_pixel:?}"),
        )?;
        require(plane_z != 0.0, "plane height", || {
            "a plane through the viewpoint is seen edge-on".to_string()
        })?;
        require(
            (LENGTH_MIN..=LENGTH_MAX).contains(&plane_z.abs()),
            "plane height",
            || format!("needs {LENGTH_MIN:e} to {LENGTH_MAX} m above or below the viewpoint, got {plane_z:?}"),
        )?;
        Ok(View::Plane(PlaneView {
            width,
            height,
            metres_per_pixel,
            plane_z,
            centre: DVec2::ZERO,
        }))
    }

    /// Output size in pixels (width, height).
    pub fn size(&self) -> (u32, u32) {
        match self {
            View::Camera { camera, .. } => camera.size(),
            View::Plane(plane) => (plane.width, plane.height),
        }
    }

    /// A body-frame point (or, for central camera views, a direction) that output pixel
    /// `pixel` sees.
    pub fn point(&self, pixel: DVec2) -> Option<DVec3> {
        match self {
            View::Camera { camera, body_from_view } => camera.ray(pixel).map(|ray| *body_from_view * ray.direction),
            View::Plane(plane) => Some(plane.point(pixel)),
        }
    }

    /// Where a body-frame point appears in this view (the view's own model).
    pub fn project(&self, point: DVec3) -> Option<DVec2> {
        match self {
            View::Camera { camera, body_from_view } => camera.project(body_from_view.transpose() * point),
            View::Plane(plane) => {
                // Only the plane's own points are in an orthographic view of it.
                ((point.z - plane.plane_z).abs() <= 1e-9 * plane.plane_z.abs()).then(|| plane.project(point))
            }
        }
    }
}

/// For every pixel of a view, where it comes from in the omnidirectional image.
#[derive(Debug, Clone, PartialEq)]
pub struct Remap {
    /// Output width.
    pub width: usize,
    /// Output height.
    pub height: usize,
    /// Size of the omnidirectional image the table reads.
    pub source_size: (usize, usize),
    /// Source pixel coordinates per output pixel (row-major); `None` where the mirror does not
    /// see the view's ray (beyond the rim, behind the camera body, outside the image).
    pub source: Vec<Option<DVec2>>,
}

impl Remap {
    /// The table for `view` of the central catadioptric camera `omni`.
    pub fn new(omni: &Catadioptric, view: &View) -> Result<Remap, VisionError> {
        if !omni.is_central() {
            return Err(VisionError::NonCentral);
        }
        let (width, height) = view.size();
        require(
            width >= 1 && height >= 1 && u64::from(width) * u64::from(height) <= VIEW_PIXELS_MAX,
            "view size",
            || format!("{width}×{height} pixels: a view has 1 to {VIEW_PIXELS_MAX} pixels (4096×4096)"),
        )?;
        let (source_w, source_h) = (f64::from(omni.width), f64::from(omni.height));
        let inside = |p: &DVec2| p.x >= -0.5 && p.y >= -0.5 && p.x <= source_w - 0.5 && p.y <= source_h - 0.5;
        let source = (0..width as usize * height as usize)
            .into_par_iter()
            .map(|i| {
                let pixel = dvec2((i % width as usize) as f64, (i / width as usize) as f64);
                view.point(pixel).and_then(|point| omni.project(point)).filter(inside)
            })
            .collect();
        Ok(Remap {
            width: width as usize,
            height: height as usize,
            source_size: (omni.width as usize, omni.height as usize),
            source,
        })
    }

    /// Whether each output pixel has a source (row-major).
    pub fn valid(&self) -> impl Iterator<Item = bool> + '_ {
        self.source.iter().map(Option::is_some)
    }

    /// The view of `image` (the omnidirectional image, any channel count); pixels without a
    /// source are 0.
    pub fn apply(&self, image: &Raster, interpolation: Interpolation) -> Result<Raster, VisionError> {
        same_size(image, self.source_size)?;
        let mut out = Raster::new(self.width, self.height, image.channels);
        // A row of the view at a time: one pixel per task cost more than its sampling.
        out.data
            .par_chunks_mut((self.width * image.channels).max(1))
            .zip(self.source.par_chunks(self.width.max(1)))
            .for_each(|(row, sources)| {
                for (pixel, source) in row.chunks_mut(image.channels).zip(sources) {
                    if let Some(p) = source {
                        image.sample(p.x, p.y, interpolation, pixel);
                    }
                }
            });
        Ok(out)
    }
}

/// Refuses an image of another size than the table's `source_size`.
fn same_size(image: &Raster, source_size: (usize, usize)) -> Result<(), VisionError> {
    if (image.width, image.height) == source_size {
        Ok(())
    } else {
        Err(VisionError::SizeMismatch {
            got: (image.width, image.height),
            expected: source_size,
        })
    }
}

/// A [`Remap`] for one-channel images with each view pixel's kernel worked out once: the first
/// source pixel of its block and its taps² weights, so that resampling an image is gathers and
/// multiply-adds (describe resamples every image of a set through one table; working the taps
/// out per image was most of a panorama's time). The sums are [`Raster::sample`]'s, bit for
/// bit. It holds 4 + 4·taps² bytes a view pixel (68 bicubic): made for views of up to
/// [`RemapTaps::PIXELS_MAX`] pixels, which [`RemapTaps::new`] refuses beyond.
#[derive(Debug, Clone)]
pub struct RemapTaps {
    width: usize,
    height: usize,
    source_size: (usize, usize),
    interpolation: Interpolation,
    /// Per view pixel, the source index of its block's top-left tap where the whole block lies
    /// inside the source image; [`RemapTaps::ELSEWHERE`] where the pixel has no source or its
    /// block crosses the image's border.
    first: Vec<u32>,
    /// Per view pixel, taps² weights, the block's rows in turn (zeros where `first` is
    /// [`RemapTaps::ELSEWHERE`]).
    weights: Vec<f32>,
    /// View pixels whose block crosses the image's border, with their source points: sampled
    /// with the border repeated, as [`Remap::apply`] does.
    border: Vec<(usize, DVec2)>,
}

impl RemapTaps {
    /// Most view pixels a table is made for: 1 Mi (68 MB bicubic, 20 MB bilinear, besides the
    /// `Remap`'s 24 MB); larger views are resampled by [`Remap::apply`] (the same bits).
    pub const PIXELS_MAX: usize = 1 << 20;

    /// `first` of a pixel that is not read through the table.
    const ELSEWHERE: u32 = u32::MAX;

    /// The taps of every pixel of `remap` with `interpolation`'s kernel, a row of the view at a
    /// time in parallel, written in place into tables made once at their full size; `None` for a
    /// view of more than [`RemapTaps::PIXELS_MAX`] pixels or a `remap` whose `source` is not
    /// `width × height` long.
    pub fn new(remap: &Remap, interpolation: Interpolation) -> Option<RemapTaps> {
        let pixels = remap.source.len();
        if pixels > Self::PIXELS_MAX || pixels != remap.width * remap.height {
            return None;
        }
        let (source_w, source_h) = remap.source_size;
        let taps = interpolation.width();
        let inside = |start: i64, len: usize| start >= 0 && start as usize + taps <= len;
        let row_len = remap.width.max(1);
        let mut first = vec![Self::ELSEWHERE; pixels];
        let mut weights = vec![0.0; pixels * taps * taps];
        let border = first
            .par_chunks_mut(row_len)
            .zip(weights.par_chunks_mut(row_len * taps * taps))
            .zip(remap.source.par_chunks(row_len))
            .enumerate()
            .flat_map_iter(|(row, ((first, weights), sources))| {
                let mut border = Vec::new();
                let pixels = first.iter_mut().zip(weights.chunks_exact_mut(taps * taps)).zip(sources);
                for (column, ((first, weights), source)) in pixels.enumerate() {
                    let Some(p) = source else { continue };
                    let ((x0, wx), (y0, wy)) = (interpolation.taps(p.x), interpolation.taps(p.y));
                    let start = (inside(x0, source_w) && inside(y0, source_h))
                        .then(|| y0 as usize * source_w + x0 as usize)
                        .and_then(|start| u32::try_from(start).ok().filter(|&s| s != Self::ELSEWHERE));
                    match start {
                        Some(start) => {
                            *first = start;
                            for (row_weights, &wyj) in weights.chunks_exact_mut(taps).zip(&wy[..taps]) {
                                for (weight, &wxi) in row_weights.iter_mut().zip(&wx[..taps]) {
                                    *weight = (wxi * wyj) as f32;
                                }
                            }
                        }
                        None => border.push((row * remap.width + column, *p)),
                    }
                }
                border
            })
            .collect();
        Some(RemapTaps {
            width: remap.width,
            height: remap.height,
            source_size: remap.source_size,
            interpolation,
            first,
            weights,
            border,
        })
    }

    /// Width and height of the view.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The view of the one-channel `image`; pixels without a source are 0.
    pub fn apply(&self, image: &Raster) -> Result<Raster, VisionError> {
        if image.channels != 1 {
            return Err(VisionError::Parameter {
                name: "channels",
                reason: format!("a table of taps resamples one-channel images, got {}", image.channels),
            });
        }
        same_size(image, self.source_size)?;
        let mut out = Raster::new(self.width, self.height, 1);
        match self.interpolation {
            Interpolation::Bilinear => self.apply_inside::<2>(image, &mut out.data),
            Interpolation::Bicubic => self.apply_inside::<4>(image, &mut out.data),
        }
        for &(pixel, p) in &self.border {
            image.sample(p.x, p.y, self.interpolation, &mut out.data[pixel..=pixel]);
        }
        Ok(out)
    }

    /// The pixels whose blocks lie inside the image, a row of the view at a time; the products
    /// summed in [`Raster::sample`]'s order.
    fn apply_inside<const TAPS: usize>(&self, image: &Raster, out: &mut [f32]) {
        let stride = image.width;
        out.par_chunks_mut(self.width.max(1))
            .zip(self.first.par_chunks(self.width.max(1)))
            .zip(self.weights.par_chunks((self.width * TAPS * TAPS).max(1)))
            .for_each(|((row, first), weights)| {
                for ((value, &first), weights) in row.iter_mut().zip(first).zip(weights.chunks_exact(TAPS * TAPS)) {
                    if first == Self::ELSEWHERE {
                        continue;
                    }
                    let mut sum = 0.0f32;
                    for (j, weights) in weights.chunks_exact(TAPS).enumerate() {
                        let start = first as usize + j * stride;
                        for (&weight, &v) in weights.iter().zip(&image.data[start..start + TAPS]) {
                            sum += weight * v;
                        }
                    }
                    *value = sum;
                }
            });
    }
}

/// The unit vector at azimuth `azimuth` (from +x towards +y) and elevation `elevation`.
pub fn direction(azimuth: f64, elevation: f64) -> DVec3 {
    let (sin_e, cos_e) = elevation.sin_cos();
    dvec3(cos_e * azimuth.cos(), cos_e * azimuth.sin(), sin_e)
}

/// Radians as degrees for messages, rounded to 1e-9° so that a value typed in degrees reads back
/// as typed (45, not 45.00000000000001).
fn degrees(radians: f64) -> f64 {
    (radians.to_degrees() * 1e9).round() / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table of taps gives `Remap::apply`'s view bit for bit, with both kernels: blocks
    /// inside the image, blocks over each edge and corner (the border repeated), points beyond
    /// the image and pixels without a source; and it refuses another size or channel count.
    #[test]
    fn remap_taps_equal_remap_apply() {
        let (w, h) = (13, 11);
        let data = (0..w * h).map(|i| ((i * 29 % 17) as f32 * 0.37).cos()).collect();
        let image = Raster::from_vec(w, h, 1, data).unwrap();
        let (view_w, view_h) = (40, 30);
        let source = (0..view_w * view_h)
            .map(|i| {
                let (u, v) = ((i % view_w) as f64, (i / view_w) as f64);
                (i % 7 != 3).then(|| dvec2(-0.5 + u * 13.2 / 39.0, -0.5 + v * 11.1 / 29.0))
            })
            .collect();
        let remap = Remap {
            width: view_w,
            height: view_h,
            source_size: (w, h),
            source,
        };
        for interpolation in [Interpolation::Bilinear, Interpolation::Bicubic] {
            let taps = RemapTaps::new(&remap, interpolation).unwrap();
            assert!(!taps.border.is_empty() && taps.border.len() < view_w * view_h / 2);
            let expected = remap.apply(&image, interpolation).unwrap();
            let got = taps.apply(&image).unwrap();
            let bits = |r: &Raster| r.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&expected), "{interpolation:?}");
            assert!(taps.apply(&Raster::new(w, h + 1, 1)).is_err());
            assert!(taps.apply(&Raster::new(w, h, 3)).is_err());
        }
    }

    /// No table for a view beyond `PIXELS_MAX` pixels (its caller resamples through the
    /// `Remap`); one at the limit; none for a `Remap` whose source is not `width × height` long.
    #[test]
    fn remap_taps_refuse_large_views() {
        let remap = |width: usize| Remap {
            width,
            height: 1024,
            source_size: (8, 8),
            source: vec![None; width * 1024],
        };
        assert!(RemapTaps::new(&remap(1024), Interpolation::Bicubic).is_some());
        assert!(RemapTaps::new(&remap(1025), Interpolation::Bicubic).is_none());
        let mut uneven = remap(4);
        uneven.source.push(Some(DVec2::new(1.0, 1.0)));
        assert!(
            RemapTaps::new(&uneven, Interpolation::Bilinear).is_none(),
            "source longer than width × height"
        );
        uneven.width = 0;
        assert!(
            RemapTaps::new(&uneven, Interpolation::Bilinear).is_none(),
            "no width, some source"
        );
    }
}
