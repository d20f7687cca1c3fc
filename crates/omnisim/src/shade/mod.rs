//! The shading stage: hits, materials and lights in, colour out. This is the one f64
//! implementation; `shaders/shade.wgsl` is its WGSL twin. Nothing else maps a hit to a colour.
//!
//! Model (README, `scene/lighting.rs`): linear = albedo · (ambient + Σ visible `E_light`) / white,
//! `E_light` = I·cosθ/d² (point) or E⊥·cosθ (directional), sRGB encoding last. A scene without
//! lighting is drawn in flat face colours (linear = albedo), exactly as the files say. The
//! albedo is the face's colour, times its texture (filtered to the pixel's footprint,
//! `footprint.rs`, `filter.rs`) and its vertex colours where it has them (`scene/surface.rs`).

pub(crate) mod antialias;
pub(crate) mod coverage;
pub(crate) mod filter;
pub(crate) mod footprint;
mod textured;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use std::sync::Arc;

use glam::{DMat3, DVec2, Vec3};

use crate::accel::SceneBvh;
use crate::camera::Camera;
use crate::frame::{BACKGROUND, Frame, Pixel, Plane, Planes};
use crate::pose::Pose;
use crate::scene::Scene;
use crate::scene::lighting::{Light, LightKind, Lighting, linear_rgb, linear_to_srgb3};
use crate::scene::surface::{OneColourFaces, Surface, Surfaces, UvMap};
use crate::scene::texture::Texture;
use crate::trace::ray_table::{RayCache, RayTable};
use crate::trace::{CpuTracer, PACKET, ShadowRays};
pub use footprint::Footprint;

/// Shadow rays start this far (relative to the point's distance from the scene centre, plus
/// one) off the face, on the lit side: far above f64 rounding, far below any real gap. The
/// face itself is skipped too, so a planar face never shadows itself.
pub(crate) const SHADOW_OFFSET: f64 = 1e-9;

/// What shading reads besides the hits: face colours, textures and lights. Changing it between
/// frames never rebuilds the BVH or the GPU pipelines.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Appearance {
    /// sRGB colour of each scene face (the tint of a textured face).
    pub face_colours: Vec<[u8; 3]>,
    /// Lights and exposure, or `None` for flat colours.
    pub lighting: Option<Lighting>,
    /// Textures and vertex colours by face (shared with the scene).
    #[serde(skip)]
    pub surfaces: Arc<Surfaces>,
}

impl Appearance {
    /// The face colours, surfaces and lighting a scene file gives.
    pub fn of(scene: &Scene) -> Self {
        Self {
            face_colours: scene.faces.iter().map(|f| f.colour).collect(),
            lighting: scene.lighting.clone(),
            surfaces: Arc::clone(&scene.surfaces),
        }
    }

    /// Whether shading face `face` needs the pixel's footprint (it has a texture).
    pub fn needs_footprint(&self, face: u32) -> bool {
        self.surfaces.of(face).is_some_and(|s| s.uv.is_some())
    }
}

/// Linear albedo of a hit on a face with `surface`: the face colour (or its vertex colours
/// where it has them), times its texture filtered to the pixel's footprint where it has one
/// (`footprint` is asked only then).
#[inline(always)]
fn albedo(
    appearance: &Appearance,
    hit: &Pixel,
    surface: Option<&Surface>,
    footprint: impl FnOnce() -> Footprint,
) -> DVec3 {
    let Some(surface) = surface else {
        return linear_rgb(appearance.face_colours[hit.face as usize]);
    };
    let base = untextured_albedo(appearance, hit, surface);
    match &surface.uv {
        None => base,
        Some(map) => {
            let (texture, scale) = texture_of(appearance, map);
            let (uv, length) = texture_point(hit, surface.anchor, map, hit.normal, footprint);
            let lod = filter::level_of_detail(scale, length);
            base * filter::trilinear(texture, map.wrap, uv, lod).as_dvec3()
        }
    }
}

/// The albedo of a hit on a face with `surface` before its texture: its vertex colours where
/// it has them, else the face's colour.
#[inline(always)]
fn untextured_albedo(appearance: &Appearance, hit: &Pixel, surface: &Surface) -> DVec3 {
    match &surface.colours {
        Some(colours) => Surface::colour_at(colours, surface.anchor, hit.point).clamp(DVec3::ZERO, DVec3::ONE),
        None => linear_rgb(appearance.face_colours[hit.face as usize]),
    }
}

/// The texture a face textured by `map` samples, and its squared texels per metre
/// ([`UvMap::texels_per_metre_squared`]), worked out from the texture as it is (a `Surfaces`
/// may be built or edited through its public fields), as the GPU reads it from the texture's
/// header.
#[inline(always)]
fn texture_of<'a>(appearance: &'a Appearance, map: &UvMap) -> (&'a Texture, f32) {
    let texture = &appearance.surfaces.textures[map.texture as usize];
    (texture, map.texels_per_metre_squared(texture.size()) as f32)
}

/// Where a hit on a face whose surface is anchored at `anchor` and textured by `map` lies on
/// the texture, and the longer axis of the pixel's footprint (asked of `footprint`) laid on
/// the face's `normal` (in the footprint's frame), which [`filter::level_of_detail`] takes: the
/// first stage of texturing a pixel (`textured.rs` works out the same in lanes).
#[inline(always)]
fn texture_point(
    hit: &Pixel,
    anchor: DVec3,
    map: &UvMap,
    normal: Vec3,
    footprint: impl FnOnce() -> Footprint,
) -> (DVec2, f32) {
    let uv = Surface::uv_at(map, anchor, hit.point);
    (uv, footprint().longer_axis(hit.range, normal))
}

/// Linear colour of one hit (1.0 = full scale); black where nothing is hit. `tracer` traces
/// the shadow rays (both tracers give the same answer); `footprint` is the pixel's, for
/// textured faces ([`Footprint::POINT`] samples textures at their finest level). Textures with a
/// side above `MAX_TEXTURE_SIDE` (only hand-built ones can have it) filter wrong here; the
/// renderer refuses them (`RenderError::Texture`).
pub fn shade(
    tracer: CpuTracer,
    geometry: &SceneBvh,
    appearance: &Appearance,
    hit: &Pixel,
    footprint: &Footprint,
) -> DVec3 {
    let surface = appearance.surfaces.of(hit.face);
    shade_on(
        appearance,
        hit,
        surface,
        || *footprint,
        |lighting| illuminance(tracer, geometry, lighting, hit),
    )
}

/// [`shade`] for a hit whose face's surface is `surface` (looked up once per pixel), with the
/// footprint computed only where a texture needs it, and the illuminance (lux) from
/// `lux_of` where the scene is lit. Kept out of line: inlined into the per-pixel
/// closure, it cost the flat path of untextured unlit images, which never calls it, about 16
/// instructions a pixel in register saves (docs/benchmarks.md, "Ray cones").
#[inline(never)]
fn shade_on(
    appearance: &Appearance,
    hit: &Pixel,
    surface: Option<&Surface>,
    footprint: impl FnOnce() -> Footprint,
    lux_of: impl FnOnce(&Lighting) -> DVec3,
) -> DVec3 {
    if !hit.is_hit() {
        return DVec3::ZERO;
    }
    let albedo = albedo(appearance, hit, surface, footprint);
    lit(appearance, surface, albedo, lux_of)
}

/// The linear colour of a hit of albedo `albedo` on a face with `surface`: lit by the scene's
/// lights where it has them and the surface is not unlit, with the illuminance (lux) that
/// `lux_of` gives.
#[inline(always)]
fn lit(
    appearance: &Appearance,
    surface: Option<&Surface>,
    albedo: DVec3,
    lux_of: impl FnOnce(&Lighting) -> DVec3,
) -> DVec3 {
    match &appearance.lighting {
        Some(lighting) if lit_by_lights(surface) => albedo * lux_of(lighting) / lighting.white,
        _ => albedo,
    }
}

/// Whether the lights shine on a face with `surface`: all but unlit ones.
fn lit_by_lights(surface: Option<&Surface>) -> bool {
    !surface.is_some_and(|s| s.unlit)
}

/// Illuminance (lux, per colour channel) reaching a hit from the side its ray came from.
fn illuminance(tracer: CpuTracer, geometry: &SceneBvh, lighting: &Lighting, hit: &Pixel) -> DVec3 {
    let (local, normal, origin) = shadow_start(geometry, hit);
    let mut total = DVec3::splat(lighting.ambient);
    for light in lighting.lights_on() {
        let Some((towards, distance, lux)) = towards_light(geometry, light, local, normal) else {
            continue;
        };
        if !tracer.occluded(geometry, origin, towards, distance, hit.face) {
            total += lux;
        }
    }
    total
}

/// A hit's scene-local point, its face's exact f64 normal turned to the side the camera sees
/// (the hit's normal says which), and where its shadow rays start.
fn shadow_start(geometry: &SceneBvh, hit: &Pixel) -> (DVec3, DVec3, DVec3) {
    let face_normal = geometry.face_normals[hit.face as usize];
    let normal = if face_normal.dot(hit.normal.as_dvec3()) < 0.0 {
        -face_normal
    } else {
        face_normal
    };
    let local = hit.point - geometry.offset;
    let origin = local + normal * (SHADOW_OFFSET * (1.0 + local.abs().max_element()));
    (local, normal, origin)
}

/// The shadow ray towards `light` from scene-local `local` on a face turned to `normal`
/// (direction and length), and the illuminance the light gives there where nothing blocks
/// it; `None` where the light lies behind the face (no ray is cast).
fn towards_light(geometry: &SceneBvh, light: &Light, local: DVec3, normal: DVec3) -> Option<(DVec3, f64, DVec3)> {
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
    if cosine.is_nan() || cosine <= 0.0 {
        return None;
    }
    Some((towards, distance, light.colour * (strength * cosine)))
}

/// [`illuminance`] of every hit of `frame` that `is_lit` accepts (zero elsewhere), by index. The
/// shadow rays of each 8×8 tile towards one light start near one another and end at one
/// point (or run parallel): they are traced as one packet (`CpuTracer::occluded_rays`),
/// with the same answers and sums as ray by ray.
fn frame_illuminance(
    tracer: CpuTracer,
    geometry: &SceneBvh,
    lighting: &Lighting,
    frame: &Frame,
    is_lit: impl Fn(&Pixel) -> bool + Sync,
) -> Vec<DVec3> {
    let row_length = frame.width.max(1) as usize;
    // Each pixel's sum is made in the tile's own array and written once, with no fill of the
    // frame's before: a fill and a sum kept in the frame's array cost a lit equirect 1024²
    // frame about 11 instructions a pixel (docs/benchmarks.md, "2026-11-26 afternoon (pixel)").
    let pixels = frame.pixels().len();
    // The writes below cover whole rows only: a frame whose public size fields no longer
    // match its pixels would leave entries unwritten (once a frame, free).
    assert_eq!(
        pixels,
        frame.width as usize * frame.height as usize,
        "frame size {}x{} against {pixels} pixels",
        frame.width,
        frame.height
    );
    let mut lux = Vec::with_capacity(pixels);
    lux.spare_capacity_mut()[..pixels]
        .par_chunks_mut(row_length * 8)
        .zip(frame.pixels().par_chunks(row_length * 8))
        .for_each(|(lux, hits)| {
            let rows = hits.len() / row_length;
            let mut shadows = ShadowRays {
                rays: [(DVec3::ZERO, DVec3::X, 0.0); PACKET],
                t_max: [0.0; PACKET],
                skip_face: [0; PACKET],
            };
            // Per ray of the tile: scene-local point and turned normal, its light's lux, and
            // its illuminance so far.
            let mut starts = [(DVec3::ZERO, DVec3::ZERO); PACKET];
            let mut light_lux = [DVec3::ZERO; PACKET];
            let mut tile_lux = [DVec3::ZERO; PACKET];
            for column in (0..row_length).step_by(8) {
                let tile = crate::trace::tile(row_length, rows, column);
                let mut active = 0u64;
                for (r, offset) in tile.clone().enumerate() {
                    let hit = &hits[offset];
                    tile_lux[r] = DVec3::ZERO;
                    if hit.is_hit() && is_lit(hit) {
                        let (local, normal, origin) = shadow_start(geometry, hit);
                        starts[r] = (local, normal);
                        shadows.rays[r].0 = origin;
                        shadows.skip_face[r] = hit.face;
                        tile_lux[r] = DVec3::splat(lighting.ambient);
                        active |= 1 << r;
                    }
                }
                for light in lighting.lights_on() {
                    let mut cast = 0u64;
                    for (r, &(local, normal)) in starts.iter().enumerate() {
                        if active & (1 << r) == 0 {
                            continue;
                        }
                        if let Some((towards, distance, e)) = towards_light(geometry, light, local, normal) {
                            shadows.rays[r].1 = towards;
                            shadows.t_max[r] = distance;
                            light_lux[r] = e;
                            cast |= 1 << r;
                        }
                    }
                    if cast == 0 {
                        continue;
                    }
                    let mut reached = cast & !tracer.occluded_rays(geometry, &shadows, cast);
                    while reached != 0 {
                        let r = reached.trailing_zeros() as usize;
                        reached &= reached - 1;
                        tile_lux[r] += light_lux[r];
                    }
                }
                for (r, offset) in tile.enumerate() {
                    lux[offset].write(tile_lux[r]);
                }
            }
        });
    // SAFETY: the loop above wrote each of the first `pixels` entries: the bands cover the
    // frame, and a band's tiles cover every pixel of it, since `pixels` is width·height
    // (asserted at the top) and so every band is whole rows (a partial last row
    // would leave entries unwritten). A panic there unwinds past this line, leaving the length 0.
    unsafe { lux.set_len(pixels) };
    lux
}

/// The camera and pose a frame was traced with: where shading finds each pixel's footprint.
#[derive(Clone, Copy)]
pub(crate) struct View<'a> {
    camera: &'a Camera,
    world_from_body: DMat3,
    /// The camera's rays (and cones) of every pixel, where the renderer keeps them.
    table: Option<&'a RayTable>,
    /// Where the cones of an image too large for a ray table are kept.
    cache: Option<&'a RayCache>,
}

impl<'a> View<'a> {
    /// The view of `camera` at `pose`, reading rays and cones from `table` (the camera's ray
    /// table) where given, else cones from `cache` where it keeps them for this camera.
    pub(crate) fn new(
        camera: &'a Camera,
        pose: &Pose,
        table: Option<&'a RayTable>,
        cache: Option<&'a RayCache>,
    ) -> Self {
        Self {
            camera,
            world_from_body: pose.world_from_body_rotation(),
            table,
            cache,
        }
    }

    /// The footprint at any pixel position (sub-pixel samples), from the camera's own rays.
    pub(crate) fn footprint_at(&self, pixel: DVec2) -> Footprint {
        Footprint::around(pixel, self.world_from_body, self.camera)
    }

    /// World vector `normal` (a face's) in the camera body's frame, where [`View::footprints`]
    /// lays footprints.
    fn body_normal(&self, normal: Vec3) -> Vec3 {
        (self.world_from_body.transpose() * normal.as_dvec3()).as_vec3()
    }

    /// Where the footprints of the frame's pixels lie, in the camera body's frame
    /// ([`Footprint::in_body`], laid on [`View::body_normal`]s): the ray table's rays and
    /// cones where there is one (the cones made on first use), else a cone table and each
    /// pixel's own ray from the camera's ray source, else the camera's rays alone (three a
    /// pixel).
    fn footprints(&self) -> footprint::Footprints<'_> {
        if let Some(table) = self.table {
            return footprint::Footprints::Table(table.cones());
        }
        match self.cache.and_then(|cache| cache.cone_table(self.camera)) {
            Some(table) => footprint::Footprints::Cones {
                table,
                rays: self.camera.ray_source(),
            },
            None => footprint::Footprints::Camera {
                camera: self.camera,
                width: self.camera.size().0,
            },
        }
    }
}

/// Shades every pixel of `frame` (traced through `view`) on all CPU threads, filling the
/// planes `planes` asks for. Without lighting a pixel's 8-bit colour is its
/// face's colour, which is what encoding the decoded colour gives (`scene/lighting.rs` tests every
/// byte), without the cost of encoding. A scene in which no face has a surface (texture or
/// vertex colours) is decided once per frame and shaded as before surfaces existed: no
/// footprints, no surface look-ups per pixel (they cost env1's untextured images about 12
/// instructions a pixel, docs/benchmarks.md). In a scene without lighting or textures whose
/// faces have surfaces, the 8-bit colour alone takes the faces of one colour from the
/// surfaces' own table ([`Surfaces::one_colour_faces`], made on first use).
pub(crate) fn shade_frame(
    tracer: CpuTracer,
    geometry: &SceneBvh,
    appearance: &Appearance,
    view: View<'_>,
    frame: &mut Frame,
    planes: Planes,
) {
    // The illuminance of every lit hit, its shadow rays traced tile by tile; none unlit.
    let lux = appearance.lighting.as_ref().map_or_else(Vec::new, |lighting| {
        frame_illuminance(tracer, geometry, lighting, frame, |hit| {
            appearance.surfaces.is_empty() || lit_by_lights(appearance.surfaces.of(hit.face))
        })
    });
    if appearance.surfaces.is_empty() {
        shade_planes::<false>(appearance, &lux, frame, planes);
    } else if appearance.surfaces.textures.is_empty() {
        if appearance.lighting.is_none() && !planes.contains(Plane::LinearColour) {
            let faces = appearance.surfaces.one_colour_faces();
            if !faces.every_face_varies {
                return shade_one_colour_faces(appearance, faces, frame, planes);
            }
        }
        shade_planes::<true>(appearance, &lux, frame, planes);
    } else {
        textured::shade_planes(appearance, &lux, view, frame, planes);
    }
}

/// [`shade_frame`]'s 8-bit colour (without the linear plane) of a scene without lighting or
/// textures where some face has a surface: each face's byte from `faces` where it has one, the
/// rest shaded pixel by pixel.
fn shade_one_colour_faces(appearance: &Appearance, faces: &OneColourFaces, frame: &mut Frame, planes: Planes) {
    let colours = &appearance.face_colours;
    eight_bit_frame(frame, planes, |_, hit| {
        match faces.of_face.get(hit.face as usize) {
            // A miss (`NO_FACE` is past every face), a face without a surface, or one whose
            // surface leaves the face's colour.
            None | Some(&OneColourFaces::FACE_COLOUR) => colours.get(hit.face as usize).copied().unwrap_or(BACKGROUND),
            Some(&OneColourFaces::VARYING) => {
                let surface = appearance.surfaces.of(hit.face);
                encode(shade_on(appearance, hit, surface, || Footprint::POINT, |_| DVec3::ZERO))
            }
            Some(&colour) => {
                let [_, r, g, b] = colour.to_be_bytes();
                [r, g, b]
            }
        }
    });
}

/// [`shade_frame`] for an untextured scene where some face has a surface (vertex colours:
/// `SURFACES`) or none does, lit by `lux` (by pixel index; empty for an unlit scene).
fn shade_planes<const SURFACES: bool>(appearance: &Appearance, lux: &[DVec3], frame: &mut Frame, planes: Planes) {
    let surface_of = |hit: &Pixel| match SURFACES {
        true => appearance.surfaces.of(hit.face),
        false => None,
    };
    // No texture: the footprint is never asked for.
    let linear = |index: usize, hit: &Pixel, surface: Option<&Surface>| {
        shade_on(appearance, hit, surface, || Footprint::POINT, |_| lux[index])
    };
    let flat = |surface: Option<&Surface>| is_flat(appearance, surface);
    if !planes.contains(Plane::LinearColour) {
        // Without the linear plane, nothing of it is stored (nor computed for unlit scenes):
        // env2's omni images, colour, 811–826 → 959–987 images/s (docs/benchmarks.md).
        if !SURFACES && appearance.lighting.is_none() {
            // Every hit flat: its face's byte, looked up with the miss folded into the bounds
            // check (`NO_FACE` is past every face), and no lighting asked per pixel (env1 omni
            // 250², the colour pass with its chunk loop: ~22 → ~18 instructions a pixel;
            // docs/benchmarks.md, "2026-11-27 morning (walk)").
            let colours = &appearance.face_colours;
            eight_bit_frame(frame, planes, |_, hit| {
                colours.get(hit.face as usize).copied().unwrap_or(BACKGROUND)
            });
        } else {
            eight_bit_frame(frame, planes, |index, hit| {
                if hit.is_hit() {
                    let surface = surface_of(hit);
                    eight_bit(appearance, hit, flat(surface), || linear(index, hit, surface))
                } else {
                    BACKGROUND
                }
            });
        }
        return;
    }
    let (linear, colour) = frame
        .pixels()
        .par_iter()
        .enumerate()
        .map(|(index, hit)| {
            if !hit.is_hit() {
                return ([0.0; 3], BACKGROUND);
            }
            let surface = surface_of(hit);
            let shaded = linear(index, hit, surface);
            (
                shaded.as_vec3().to_array(),
                eight_bit(appearance, hit, flat(surface), || shaded),
            )
        })
        .unzip();
    frame.set_shading(planes, linear, colour);
}

/// Sets `frame`'s 8-bit colour plane alone (`planes` has no linear colour), pixel `index`'s
/// colour `colour_of(index, pixel)`, on all CPU threads. In chunks whose loop inlines the
/// pixel's work: as a rayon `map` each pixel was a call (perf, env1 omni colour: 7 % of a
/// frame). Every pixel is written once, misses too, with no fill before: a fill cost 5
/// instructions a pixel (docs/benchmarks.md, "2026-11-26 afternoon (pixel)").
#[inline(always)]
fn eight_bit_frame(frame: &mut Frame, planes: Planes, colour_of: impl Fn(usize, &Pixel) -> [u8; 3] + Sync) {
    const CHUNK: usize = 4096;
    let pixels = frame.pixels().len();
    let mut colour = Vec::with_capacity(pixels);
    colour.spare_capacity_mut()[..pixels]
        .par_chunks_mut(CHUNK)
        .zip(frame.pixels().par_chunks(CHUNK))
        .enumerate()
        .for_each(|(chunk, (colour, hits))| {
            for (offset, (colour, hit)) in colour.iter_mut().zip(hits).enumerate() {
                colour.write(colour_of(chunk * CHUNK + offset, hit));
            }
        });
    // SAFETY: the loop above wrote each of the first `pixels` entries: the colour chunks are
    // zipped with the frame's pixel chunks of the same size and count (both hold `pixels`
    // entries), and each chunk's loop writes every pixel of it. A panic there unwinds past
    // this line, leaving the length 0.
    unsafe { colour.set_len(pixels) };
    frame.set_shading(planes, Vec::new(), colour);
}

/// Whether a hit on a face with `surface` is flat: unlit and without a surface, so its 8-bit
/// colour is its face's byte directly ([`eight_bit`]).
#[inline(always)]
fn is_flat(appearance: &Appearance, surface: Option<&Surface>) -> bool {
    appearance.lighting.is_none() && surface.is_none()
}

/// A hit pixel's 8-bit colour: `flat` where it is a flat face's byte (as [`eight_bit`] takes
/// it), else the linear colour `shaded` gives, encoded; and that linear colour written into
/// `linear` where asked. `shaded` is called only where one of them needs it.
#[inline(always)]
fn pixel_colour(flat: Option<[u8; 3]>, shaded: impl FnOnce() -> DVec3, linear: Option<&mut [f32; 3]>) -> [u8; 3] {
    match linear {
        Some(linear) => {
            let shaded = shaded();
            *linear = shaded.as_vec3().to_array();
            flat.unwrap_or_else(|| encode(shaded))
        }
        None => flat.unwrap_or_else(|| encode(shaded())),
    }
}

/// The 8-bit colour of hit pixel `hit` whose linear colour `linear` gives: its face's colour
/// where it is `flat` (unlit, no surface; `linear` is then not called), else `linear()` encoded.
#[inline(always)]
fn eight_bit(appearance: &Appearance, hit: &Pixel, flat: bool, linear: impl FnOnce() -> DVec3) -> [u8; 3] {
    match flat {
        true => appearance.face_colours[hit.face as usize],
        false => encode(linear()),
    }
}

/// 8-bit sRGB of a linear colour.
pub fn encode(linear: DVec3) -> [u8; 3] {
    linear_to_srgb3(linear.to_array())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Equirectangular;
    use crate::frame::NO_FACE;
    use crate::renderer::{BackendChoice, Renderer};
    use crate::scene::surface::ColourMap;

    /// The last faces of [`surfaces_of_every_kind`], past its list.
    const PAST_THE_LIST: usize = 7;

    /// env1's faces given surfaces by hand, by face id modulo 4: vertex colours equal at every
    /// corner (`one_colour` of the face: a zero gradient), vertex colours that vary, a surface
    /// without colours, and none (and the last [`PAST_THE_LIST`] faces past the list).
    fn surfaces_of_every_kind(faces: usize, one_colour: impl Fn(usize) -> [u8; 3]) -> Arc<Surfaces> {
        let mut surfaces = Surfaces::default();
        for face in 0..faces - PAST_THE_LIST {
            let colours = match face % 4 {
                0 => Some(ColourMap {
                    at_anchor: DVec3::from_array(one_colour(face).map(crate::scene::lighting::srgb_to_linear)),
                    gradient: [DVec3::ZERO; 3],
                }),
                1 => Some(ColourMap {
                    at_anchor: DVec3::new(0.3, 0.5, 0.7),
                    gradient: [
                        DVec3::new(0.2, 0.0, 0.1),
                        DVec3::new(0.0, -0.3, 0.0),
                        DVec3::new(0.1, 0.1, 0.4),
                    ],
                }),
                2 => None,
                _ => continue,
            };
            let anchor = DVec3::new(0.5, -0.25, 1.0);
            let unlit = false;
            surfaces.push(
                face,
                Surface {
                    anchor,
                    uv: None,
                    colours,
                    unlit,
                },
            );
        }
        Arc::new(surfaces)
    }

    /// Each face's surface: vertex colours that vary, or of one colour with a non-finite
    /// anchor (hand-built; left to the pixel's own shading).
    fn surfaces_all_shaded_per_pixel(faces: usize) -> Arc<Surfaces> {
        let mut surfaces = Surfaces::default();
        for face in 0..faces {
            let gradient = match face % 2 {
                0 => [DVec3::ZERO; 3],
                _ => [DVec3::new(0.2, 0.0, 0.1), DVec3::Y, DVec3::NEG_Z],
            };
            let colours = Some(ColourMap {
                at_anchor: DVec3::new(0.3, 0.5, 0.7),
                gradient,
            });
            let (anchor, uv, unlit) = (DVec3::NAN, None, false);
            surfaces.push(
                face,
                Surface {
                    anchor,
                    uv,
                    colours,
                    unlit,
                },
            );
        }
        Arc::new(surfaces)
    }

    /// Faces whose surfaces give one colour are drawn by a byte looked up
    /// ([`OneColourFaces`]), the rest shaded pixel by pixel: each pixel's 8-bit colour must
    /// still be what shading its hit alone gives, encoded, for every kind of face, black among
    /// the colours (`+0` plus a `-0` product), misses (from outside the room), and a scene whose
    /// every face is shaded per pixel (no table read).
    #[test]
    fn one_colour_faces_looked_up_are_each_hit_shaded_alone() {
        let camera = Camera::Equirectangular(Equirectangular {
            width: 203,
            height: 101,
        });
        let (scene, bvh) = crate::trace::test_scene("env1");
        let faces = scene.faces.len();
        let mut every_kind = Appearance::of(&scene);
        every_kind.surfaces = surfaces_of_every_kind(faces, |face| match face % 8 {
            0 => [0, 0, 0],
            _ => [(face * 37 % 256) as u8, 255 - face as u8, 3],
        });
        let kinds = OneColourFaces::of(&every_kind.surfaces);
        for kind in [OneColourFaces::FACE_COLOUR, OneColourFaces::VARYING, 0, 0x00_94_FB_03] {
            assert!(kinds.of_face.contains(&kind), "{kind:#x} among {:x?}", kinds.of_face);
        }
        assert!(!kinds.every_face_varies);
        let per_pixel = Appearance {
            surfaces: surfaces_all_shaded_per_pixel(faces),
            ..every_kind.clone()
        };
        assert!(OneColourFaces::of(&per_pixel.surfaces).every_face_varies);
        let mut drawn = [0; 4];
        for appearance in [&every_kind, &per_pixel] {
            for position in [DVec3::new(0.3, -0.2, 0.4), DVec3::new(9.0, 4.0, 1.0)] {
                let pose = Pose::new(position, DVec3::new(0.1, -0.2, 0.7));
                let mut frame = CpuTracer::Fast.trace(&bvh, &camera, &pose);
                let view = View::new(&camera, &pose, None, None);
                shade_frame(CpuTracer::Fast, &bvh, appearance, view, &mut frame, Planes::COLOUR);
                assert!(
                    appearance.surfaces.one_colour_faces.made().is_some(),
                    "made on first use"
                );
                for (hit, colour) in frame.pixels().iter().zip(frame.colour().unwrap()) {
                    let alone = match hit.face {
                        NO_FACE => BACKGROUND,
                        face => {
                            drawn[face as usize % 4] += 1;
                            encode(shade(CpuTracer::Fast, &bvh, appearance, hit, &Footprint::POINT))
                        }
                    };
                    assert_eq!(*colour, alone, "{hit:?} from {position}");
                }
            }
        }
        assert!(drawn.iter().all(|&n| n > 100), "{drawn:?} hits of each kind");
    }

    /// The one-colour table is for the 8-bit colour of unlit scenes only ([`shade_frame`]'s
    /// guards): lit, a face of one vertex colour is shaded (no longer its flat byte), and a
    /// frame asking for the linear plane gets each hit's interpolated linear colour. Both are
    /// what shading each hit alone gives.
    #[test]
    fn one_colour_faces_are_looked_up_neither_when_lit_nor_for_the_linear_plane() {
        let camera = Camera::Equirectangular(Equirectangular {
            width: 203,
            height: 101,
        });
        let pose = Pose::new(DVec3::new(0.3, -0.2, 0.4), DVec3::new(0.1, -0.2, 0.7));
        let one_colour = [200, 120, 40];
        for (name, planes) in [
            ("env1-lit", Planes::COLOUR),
            ("env1", Planes::COLOUR.with(Plane::LinearColour)),
        ] {
            let (scene, bvh) = crate::trace::test_scene(name);
            let mut appearance = Appearance::of(&scene);
            appearance.surfaces = surfaces_of_every_kind(scene.faces.len(), |_| one_colour);
            let mut frame = CpuTracer::Fast.trace(&bvh, &camera, &pose);
            let view = View::new(&camera, &pose, None, None);
            shade_frame(CpuTracer::Fast, &bvh, &appearance, view, &mut frame, planes);
            let colour = frame.colour().unwrap();
            let linear = frame.linear_colour().unwrap_or_default();
            if planes.contains(Plane::LinearColour) {
                assert_eq!(linear.len(), colour.len(), "{name}: the linear plane");
            }
            let mut unflat = 0;
            for (index, hit) in frame.pixels().iter().enumerate() {
                assert!(hit.is_hit(), "inside the room");
                let alone = shade(CpuTracer::Fast, &bvh, &appearance, hit, &Footprint::POINT);
                assert_eq!(colour[index], encode(alone), "{name}: {hit:?}");
                if let Some(linear) = linear.get(index) {
                    assert_eq!(*linear, alone.as_vec3().to_array(), "{name}: {hit:?}");
                }
                let of_one_colour = hit.face % 4 == 0 && (hit.face as usize) < scene.faces.len() - PAST_THE_LIST;
                unflat += usize::from(of_one_colour && colour[index] != one_colour);
            }
            if appearance.lighting.is_some() {
                assert!(unflat > 1000, "{name}: {unflat} lit hits of one-colour faces shaded");
            }
        }
    }

    /// The `same_rays` case end to end: env1 exported by `scene export` as a PLY (each face's
    /// colour on its three corners) and loaded as one mesh has vertex colours, every face of
    /// one colour, and the renderer's colour plane of it is each hit shaded alone.
    #[test]
    fn an_exported_scene_is_drawn_by_its_faces_bytes() {
        let folder = tempfile::tempdir().unwrap();
        let source = crate::trace::test_scene("env1").0;
        source
            .export(&folder.path().join("env1.ply"), crate::scene::ExportFormat::Ply)
            .unwrap();
        let ron = r#"Scene(name: "env1", objects: [Mesh(name: "env1", path: "env1.ply", colour: (200, 200, 200))])"#;
        let scene = Scene::from_ron(ron, &folder.path().join("env1.ron")).unwrap();
        let faces = OneColourFaces::of(&scene.surfaces);
        assert!(!faces.of_face.is_empty() && !faces.of_face.contains(&OneColourFaces::VARYING));
        let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
        let prepared = renderer.prepare(&scene).unwrap();
        let camera = Camera::Equirectangular(Equirectangular { width: 96, height: 48 });
        let pose = Pose::new(DVec3::new(1.5, 0.0, 0.4), DVec3::new(0.0, 0.0, 60f64.to_radians()));
        let frame = renderer.render(&prepared, &camera, &pose, Planes::COLOUR).unwrap();
        let appearance = Appearance::of(&scene);
        for (hit, colour) in frame.pixels().iter().zip(frame.colour().unwrap()) {
            assert!(hit.is_hit(), "inside the room");
            let alone = encode(shade(
                CpuTracer::Fast,
                prepared.geometry(),
                &appearance,
                hit,
                &Footprint::POINT,
            ));
            assert_eq!(*colour, alone, "{hit:?}");
        }
    }

    /// A prepared scene's one-colour faces are made for a new appearance's surfaces: a frame
    /// after `set_appearance` takes the new colours.
    #[test]
    fn one_colour_faces_follow_the_appearances_surfaces() {
        let (scene, _) = crate::trace::test_scene("env1");
        let renderer = Renderer::new(BackendChoice::Cpu).unwrap();
        let mut prepared = renderer.prepare(&scene).unwrap();
        let camera = Camera::Equirectangular(Equirectangular { width: 64, height: 32 });
        let pose = Pose::new(DVec3::new(0.3, -0.2, 0.4), DVec3::ZERO);
        let mut appearance = Appearance::of(&scene);
        for colour in [[200, 10, 10], [10, 10, 200]] {
            appearance.surfaces = surfaces_of_every_kind(scene.faces.len(), |_| colour);
            for _ in 0..2 {
                renderer.set_appearance(&mut prepared, appearance.clone()).unwrap();
                let frame = renderer.render(&prepared, &camera, &pose, Planes::COLOUR).unwrap();
                let drawn = frame
                    .pixels()
                    .iter()
                    .zip(frame.colour().unwrap())
                    .filter(|(hit, _)| hit.is_hit() && hit.face % 4 == 0)
                    .filter(|(hit, _)| (hit.face as usize) < scene.faces.len() - PAST_THE_LIST);
                let (mut hits, mut ok) = (0, 0);
                for (_, c) in drawn {
                    hits += 1;
                    ok += usize::from(*c == colour);
                }
                assert!(hits > 0 && ok == hits, "{ok} of {hits} hits {colour:?}");
            }
        }
    }

    /// The colour plane shaded without the linear plane (written once a pixel, misses too, with
    /// no fill before) equals, byte for byte, the one shaded beside it: lit and unlit, from
    /// inside the room (every pixel a hit) and from outside it (misses among the hits).
    #[test]
    fn colour_alone_equals_colour_beside_the_linear_plane() {
        let camera = Camera::Equirectangular(Equirectangular {
            width: 203,
            height: 101,
        });
        for name in ["env1", "env1-lit"] {
            let (scene, bvh) = crate::trace::test_scene(name);
            let appearance = Appearance::of(&scene);
            for position in [DVec3::new(0.3, -0.2, 0.4), DVec3::new(9.0, 4.0, 1.0)] {
                let pose = Pose::new(position, DVec3::new(0.1, -0.2, 0.7));
                let traced = CpuTracer::Fast.trace(&bvh, &camera, &pose);
                let shaded = |planes| {
                    let mut frame = traced.clone();
                    let view = View::new(&camera, &pose, None, None);
                    shade_frame(CpuTracer::Fast, &bvh, &appearance, view, &mut frame, planes);
                    frame.colour().expect("colour was asked for").to_vec()
                };
                let alone = shaded(Planes::COLOUR);
                assert_eq!(alone, shaded(Planes::ALL), "{name} from {position}");
                let misses = traced.pixels().iter().filter(|hit| hit.face == NO_FACE).count();
                assert_eq!(misses > 0, position.x > 3.0, "{name} from {position}: {misses} misses");
                let flat = traced
                    .pixels()
                    .iter()
                    .zip(&alone)
                    .filter(|(hit, colour)| hit.is_hit() && **colour == appearance.face_colours[hit.face as usize])
                    .count();
                let hits = traced.pixels().len() - misses;
                // Unlit, every hit is its face's colour; lit, almost none is.
                match appearance.lighting {
                    None => assert_eq!(flat, hits, "{name}"),
                    Some(_) => assert!(flat < hits / 10, "{name}: {flat} of {hits} hits flat"),
                }
            }
        }
    }
}
