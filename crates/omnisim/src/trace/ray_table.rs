//! Camera rays computed once per camera for the CPU backend.
//!
//! A pixel's body-frame ray depends on the camera alone, not on the pose, and for a
//! catadioptric camera it costs more than tracing it (the f64 mirror intersection: two thirds
//! of an omni pixel, measured with callgrind, docs/benchmarks.md). A run of many poses through
//! one camera (a data set, a trajectory, a benchmark) therefore reads them from a table.

use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

use crate::accel::SceneBvh;
use crate::camera::{Camera, CameraRay, Cone};
use crate::frame::Frame;
use crate::pose::Pose;
use crate::trace::CpuTracer;

/// Cameras whose rays are kept: two, so a stereo rig's left and right views alternate
/// without recomputing.
const CAMERAS: usize = 2;

/// Largest image whose rays are kept (64 bytes a pixel, 80 with the cones: 80 MB); larger ones are computed
/// per frame.
const MAX_PIXELS: usize = 1 << 20;

/// Largest image whose ray cones are kept where its rays are not (16 bytes a pixel: 64 MB): a
/// textured pixel then computes its own camera ray only, not its neighbours' too (equirect
/// 2048×1024: docs/benchmarks.md, "Ray cones").
const MAX_CONE_PIXELS: usize = 1 << 22;

/// Every pixel centre's body-frame ray of one camera, row by row, and, once a textured face
/// is shaded through it, every pixel's ray cone (the texture footprint, `shade/footprint.rs`).
pub(crate) struct RayTable {
    camera: Camera,
    pub(crate) rays: Vec<Option<CameraRay>>,
    cones: OnceLock<Vec<Cone>>,
}

impl RayTable {
    /// Every pixel's ray cone, made on first use from the table's rays.
    pub(crate) fn cones(&self) -> &[Cone] {
        self.cones
            .get_or_init(|| Cone::of_image(&self.camera, |index| self.rays[index]))
    }
}

/// Every pixel's ray cone of one camera whose rays are not kept (its image is larger than
/// `MAX_PIXELS`).
pub(crate) struct ConeTable {
    camera: Camera,
    pub(crate) cones: Vec<Cone>,
}

/// The ray tables (and cone tables) of the last cameras a renderer traced on the CPU.
#[derive(Default)]
pub(crate) struct RayCache {
    tables: Mutex<Vec<Arc<RayTable>>>,
    cone_tables: Mutex<Vec<Arc<ConeTable>>>,
}

/// The entry of `list` made for `camera`, or `make()` added (the oldest dropped beyond
/// `CAMERAS`).
fn cached<T>(
    list: &Mutex<Vec<Arc<T>>>,
    camera: &Camera,
    of: impl Fn(&T) -> &Camera,
    make: impl FnOnce() -> T,
) -> Arc<T> {
    // A poisoned lock only means another thread panicked while holding it: the tables are
    // complete or absent, never half made, so they stay usable.
    let mut list = list.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(entry) = list.iter().find(|entry| of(entry) == camera) {
        return Arc::clone(entry);
    }
    let entry = Arc::new(make());
    if list.len() == CAMERAS {
        list.remove(0);
    }
    list.push(Arc::clone(&entry));
    entry
}

/// Traces one frame with `tracer`, reading `camera`'s rays from `table` (its
/// [`RayCache::table`]) where there is one.
pub(crate) fn trace_frame(
    tracer: CpuTracer,
    bvh: &SceneBvh,
    camera: &Camera,
    pose: &Pose,
    table: Option<&RayTable>,
) -> Frame {
    match table {
        Some(table) => tracer.trace_rays(bvh, camera.size(), pose, |index| table.rays[index]),
        None => tracer.trace(bvh, camera, pose),
    }
}

impl RayCache {
    /// `camera`'s ray table, made on first use, where the image is small enough to keep one.
    pub(crate) fn table(&self, camera: &Camera) -> Option<Arc<RayTable>> {
        let (width, height) = camera.size();
        let pixels = width as usize * height as usize;
        if pixels > MAX_PIXELS {
            return None;
        }
        Some(cached(
            &self.tables,
            camera,
            |table| &table.camera,
            || RayTable {
                camera: camera.clone(),
                rays: (0..pixels)
                    .into_par_iter()
                    .map(|index| camera.pixel_ray(index))
                    .collect(),
                cones: OnceLock::new(),
            },
        ))
    }

    /// `camera`'s ray cones alone, made on first use, where its image is too large for a ray
    /// table ([`RayCache::table`]) but small enough to keep its cones.
    pub(crate) fn cone_table(&self, camera: &Camera) -> Option<Arc<ConeTable>> {
        let (width, height) = camera.size();
        let pixels = width as usize * height as usize;
        if pixels <= MAX_PIXELS || pixels > MAX_CONE_PIXELS {
            return None;
        }
        Some(cached(
            &self.cone_tables,
            camera,
            |table| &table.camera,
            || ConeTable {
                camera: camera.clone(),
                cones: Cone::of_image(camera, |index| camera.pixel_ray(index)),
            },
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Equirectangular, Pinhole};
    use glam::dvec3;

    #[test]
    fn frames_from_ray_tables_equal_frames_from_the_camera_and_tables_follow_the_camera() {
        let (_, bvh) = crate::trace::test_scene("env1");
        let cache = RayCache::default();
        let cameras = [
            Camera::Pinhole(Pinhole::with_horizontal_fov(40, 30, 1.2)),
            Camera::Equirectangular(Equirectangular { width: 48, height: 24 }),
            Camera::Pinhole(Pinhole::with_horizontal_fov(40, 30, 0.6)),
        ];
        for round in 0..2 {
            for (index, camera) in cameras.iter().enumerate() {
                let pose = Pose::new(
                    dvec3(1.0, 0.5 + 0.1 * f64::from(round), 0.4),
                    dvec3(0.0, 0.1, index as f64),
                );
                let direct = CpuTracer::Fast.trace(&bvh, camera, &pose);
                let cached = trace_frame(CpuTracer::Fast, &bvh, camera, &pose, cache.table(camera).as_deref());
                assert_eq!(direct.pixels(), cached.pixels(), "camera {index}, round {round}");
            }
        }
        let tables = cache.tables.lock().unwrap();
        assert_eq!(tables.len(), CAMERAS);
        assert!(
            tables.iter().all(|table| table.camera != cameras[0]),
            "the oldest table is dropped"
        );
    }
}
