//! The shading stage: hits, materials and lights in, colour out. This is the one f64
//! implementation; `shaders/shade.wgsl` is its WGSL twin. Nothing else maps a hit to a colour.
//!
//! Model (README, `scene/lighting.rs`): linear = albedo · (ambient + Σ visible `E_light`) / white,
//! `E_light` = I·cosθ/d² (point) or E⊥·cosθ (directional), sRGB encoding last. A scene without
//! lighting is drawn in flat face colours (linear = albedo), exactly as the files say.

pub(crate) mod antialias;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::accel::SceneBvh;
use crate::frame::{BACKGROUND, Frame, Pixel, Plane, Planes};
use crate::scene::Scene;
use crate::scene::lighting::{LightKind, Lighting, linear_rgb, linear_to_srgb};
use crate::trace::CpuTracer;

/// Shadow rays start this far (relative to the point's distance from the scene centre, plus
/// one) off the face, on the lit side: far above f64 rounding, far below any real gap. The
/// face itself is skipped too, so a planar face never shadows itself.
pub(crate) const SHADOW_OFFSET: f64 = 1e-9;

/// What shading reads besides the hits: face colours and lights. Changing it between frames
/// never rebuilds the BVH or the GPU pipelines.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Appearance {
    /// sRGB colour of each scene face.
    pub face_colours: Vec<[u8; 3]>,
    /// Lights and exposure, or `None` for flat colours.
    pub lighting: Option<Lighting>,
}

impl Appearance {
    /// The face colours and lighting a scene file gives.
    pub fn of(scene: &Scene) -> Self {
        Self {
            face_colours: scene.faces.iter().map(|f| f.colour).collect(),
            lighting: scene.lighting.clone(),
        }
    }
}

/// Linear colour of one hit (1.0 = full scale); black where nothing is hit. `tracer` traces
/// the shadow rays (both tracers give the same answer).
pub fn shade(tracer: CpuTracer, geometry: &SceneBvh, appearance: &Appearance, hit: &Pixel) -> DVec3 {
    if !hit.is_hit() {
        return DVec3::ZERO;
    }
    let albedo = linear_rgb(appearance.face_colours[hit.face as usize]);
    match &appearance.lighting {
        None => albedo,
        Some(lighting) => albedo * illuminance(tracer, geometry, lighting, hit) / lighting.white,
    }
}

/// Illuminance (lux, per colour channel) reaching a hit from the side its ray came from.
fn illuminance(tracer: CpuTracer, geometry: &SceneBvh, lighting: &Lighting, hit: &Pixel) -> DVec3 {
    let face_normal = geometry.face_normals[hit.face as usize];
    // The exact f64 normal, turned to the side the camera sees (the hit's normal says which).
    let normal = if face_normal.dot(hit.normal.as_dvec3()) < 0.0 {
        -face_normal
    } else {
        face_normal
    };
    let local = hit.point - geometry.offset;
    let origin = local + normal * (SHADOW_OFFSET * (1.0 + local.abs().max_element()));
    let mut total = DVec3::splat(lighting.ambient);
    for light in lighting.lights_on() {
        let (towards, distance, strength) = match light.kind {
            LightKind::Point { position, intensity } => {
                let offset = position - geometry.offset - local;
                let squared = offset.length_squared();
                let distance = squared.sqrt();
                (offset / distance, distance, intensity / squared)
            }
            LightKind::Directional { direction, illuminance } => (-direction, f64::INFINITY, illuminance),
        };
        let cosine = normal.dot(towards);
        if cosine.is_nan() || cosine <= 0.0 || tracer.occluded(geometry, origin, towards, distance, hit.face) {
            continue;
        }
        total += light.colour * (strength * cosine);
    }
    total
}

/// Shades every pixel of `frame` on all CPU threads, filling the planes `planes` asks for.
/// Without lighting a pixel's 8-bit colour is its
/// face's colour, which is what encoding the decoded colour gives (`scene/lighting.rs` tests every
/// byte), without the cost of encoding.
pub(crate) fn shade_frame(
    tracer: CpuTracer,
    geometry: &SceneBvh,
    appearance: &Appearance,
    frame: &mut Frame,
    planes: Planes,
) {
    if !planes.contains(Plane::LinearColour) {
        // Without the linear plane, nothing of it is stored (nor computed for unlit scenes):
        // env2's omni images, colour, 811–826 → 959–987 images/s (docs/benchmarks.md).
        let colour = frame
            .pixels()
            .par_iter()
            .map(|hit| match hit.is_hit() {
                false => BACKGROUND,
                true => eight_bit(appearance, hit, || shade(tracer, geometry, appearance, hit)),
            })
            .collect();
        frame.set_shading(planes, Vec::new(), colour);
        return;
    }
    let (linear, colour) = frame
        .pixels()
        .par_iter()
        .map(|hit| {
            if !hit.is_hit() {
                return ([0.0; 3], BACKGROUND);
            }
            let linear = shade(tracer, geometry, appearance, hit);
            (linear.as_vec3().to_array(), eight_bit(appearance, hit, || linear))
        })
        .unzip();
    frame.set_shading(planes, linear, colour);
}

/// The 8-bit colour of hit pixel `hit` whose linear colour `linear` gives: its face's colour
/// without lighting (`linear` is then not called), else `linear()` encoded.
#[inline(always)]
fn eight_bit(appearance: &Appearance, hit: &Pixel, linear: impl FnOnce() -> DVec3) -> [u8; 3] {
    match appearance.lighting {
        None => appearance.face_colours[hit.face as usize],
        Some(_) => encode(linear()),
    }
}

/// 8-bit sRGB of a linear colour.
pub fn encode(linear: DVec3) -> [u8; 3] {
    linear.to_array().map(linear_to_srgb)
}
