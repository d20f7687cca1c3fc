//! Frames of textured scenes: pixels on textured faces are filtered [`LANES`] at a time
//! (`filter::trilinear_lanes`: coordinates, wraps, weights and mixing in vector lanes), the
//! rest shaded one by one as `mod.rs` shades untextured scenes. The same colours as shading
//! each pixel alone (`shade`): per pixel the same look-up, lanes that give the one-lane
//! sample's bits (tested in `filter.rs`), the same lighting and encoding; only the footprint's
//! angle is taken in the camera body's frame (the face's normal turned once per face), so its
//! f32 rounding may differ, and with it, rarely, a pixel's level of detail: a linear colour's
//! last bits, or now and then an 8-bit byte.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::filter::{LANES, Lookups, Wraps, trilinear_lanes};
use super::{
    Appearance, Footprint, View, lit, shade_on, texture_coordinates, texture_of, untextured_albedo, write_pixel,
};
use crate::frame::{BACKGROUND, Frame, Pixel, Plane, Planes};
use crate::scene::lighting::linear_to_srgb3_lanes;
use crate::scene::surface::{Surface, UvMap};
use crate::scene::texture::Texture;

/// Pixels one task shades: enough to fill the lanes many times over, few enough to spread a
/// 250×250 image over every thread.
const CHUNK: usize = 512;

/// Shades every pixel of `frame` (traced through `view`) of a scene with textures, as
/// `shade_frame` does, lit by `lux` (by pixel index; empty for an unlit scene), filling the
/// planes `planes` asks for.
pub(super) fn shade_planes(appearance: &Appearance, lux: &[DVec3], view: View<'_>, frame: &mut Frame, planes: Planes) {
    let footprint_of = view.footprints();
    let pixels = frame.pixels();
    let shader = Shader {
        appearance,
        lux,
        view: &view,
        footprint_of: &footprint_of,
    };
    let mut colour = vec![BACKGROUND; pixels.len()];
    let mut linear = Vec::new();
    let chunks = pixels.par_chunks(CHUNK).zip(colour.par_chunks_mut(CHUNK)).enumerate();
    if planes.contains(Plane::LinearColour) {
        linear = vec![[0.0; 3]; pixels.len()];
        chunks
            .zip(linear.par_chunks_mut(CHUNK))
            .for_each(|((chunk, (hits, colour)), linear)| shader.chunk(chunk * CHUNK, hits, colour, Some(linear)));
    } else {
        chunks.for_each(|(chunk, (hits, colour))| shader.chunk(chunk * CHUNK, hits, colour, None));
    }
    frame.set_shading(planes, linear, colour);
}

/// What shading a chunk reads.
struct Shader<'a, F> {
    appearance: &'a Appearance,
    /// The illuminance of each lit pixel by its index in the frame (empty unlit).
    lux: &'a [DVec3],
    /// The camera and pose the frame was traced with.
    view: &'a View<'a>,
    /// The footprint of a pixel by its index in the frame, in the camera body's frame.
    footprint_of: &'a F,
}

/// A textured face, and what shading its pixels reads besides their hits.
#[derive(Clone, Copy)]
struct Face<'a> {
    id: u32,
    surface: &'a Surface,
    map: &'a UvMap,
    texture: &'a Texture,
    /// Its map's wrap, as the lanes read it.
    wraps: Wraps,
    /// Its texture's squared texels per metre (`texture_of`).
    texels_per_metre_squared: f32,
    /// Its albedo before the texture where that is the same all over (no vertex colours).
    base: Option<DVec3>,
    /// Its normal in the camera body's frame, where the footprints lie (either side: the
    /// footprint takes its angle's |cos|).
    normal: Vec3,
}

impl<'a> Face<'a> {
    /// The face `hit` (seen through `view`) lies on, whose surface is `surface`, if that has a
    /// texture.
    fn of(appearance: &'a Appearance, view: &View<'_>, hit: &Pixel, surface: &'a Surface) -> Option<Self> {
        let map = surface.uv.as_ref()?;
        let (texture, texels_per_metre_squared) = texture_of(appearance, map);
        Some(Face {
            id: hit.face,
            surface,
            map,
            texture,
            wraps: Wraps::of(map.wrap),
            texels_per_metre_squared,
            base: surface
                .colours
                .is_none()
                .then(|| untextured_albedo(appearance, hit, surface)),
            normal: view.body_normal(hit.normal),
        })
    }
}

/// Textured pixels of a chunk waiting for their lanes: where each goes, its surface,
/// its albedo before the texture, and its look-up.
struct Batch<'a> {
    len: usize,
    slot: [usize; LANES],
    surface: [&'a Surface; LANES],
    base: [DVec3; LANES],
    lookups: Lookups<'a, LANES>,
}

impl<'a, F: Fn(usize) -> Footprint + Sync> Shader<'a, F> {
    /// Shades the hits `hits` of the pixels from index `start` on into `colour` (and `linear`
    /// where given); pixels that hit nothing stay as they are (black).
    fn chunk(&self, start: usize, hits: &'a [Pixel], colour: &mut [[u8; 3]], mut linear: Option<&mut [[f32; 3]]>) {
        let appearance = self.appearance;
        let mut batch: Option<Batch<'a>> = None;
        // The last textured face seen, and what shading it needs besides the hit: neighbouring
        // pixels mostly see the same face.
        let mut last: Option<Face<'a>> = None;
        for (slot, hit) in hits.iter().enumerate() {
            if !hit.is_hit() {
                continue;
            }
            let face = match last {
                Some(face) if face.id == hit.face => face,
                _ => {
                    let surface = appearance.surfaces.of(hit.face);
                    let Some(face) = surface.and_then(|surface| Face::of(appearance, self.view, hit, surface)) else {
                        // As `mod.rs` shades it: no texture, so no footprint.
                        let flat = (appearance.lighting.is_none() && surface.is_none())
                            .then(|| appearance.face_colours[hit.face as usize]);
                        let shaded = || {
                            shade_on(
                                appearance,
                                hit,
                                surface,
                                || Footprint::POINT,
                                |_| self.lux[start + slot],
                            )
                        };
                        let linear = linear.as_deref_mut().map(|linear| &mut linear[slot]);
                        write_pixel(flat, shaded, &mut colour[slot], linear);
                        continue;
                    };
                    *last.insert(face)
                }
            };
            let (surface, map, texture) = (face.surface, face.map, face.texture);
            let scale = face.texels_per_metre_squared;
            let (uv, lod) = texture_coordinates(hit, surface.anchor, map, scale, face.normal, || {
                (self.footprint_of)(start + slot)
            });
            let base = face.base.unwrap_or_else(|| untextured_albedo(appearance, hit, surface));
            let batch = match &mut batch {
                Some(batch) => batch,
                // Every lane starts as this pixel's.
                None => batch.insert(Batch {
                    len: 0,
                    slot: [slot; LANES],
                    surface: [surface; LANES],
                    base: [base; LANES],
                    lookups: Lookups::filled(texture, face.wraps, uv, lod),
                }),
            };
            if batch.len == LANES {
                self.finish(start, batch, colour, linear.as_deref_mut());
                batch.len = 0;
            }
            let lane = batch.len;
            batch.slot[lane] = slot;
            batch.surface[lane] = surface;
            batch.base[lane] = base;
            batch.lookups.set(lane, texture, face.wraps, uv, lod);
            batch.len += 1;
        }
        // Lanes past the last batch's length hold earlier pixels' look-ups (or copies of its
        // first): filtered, and not written.
        if let Some(batch) = &batch {
            self.finish(start, batch, colour, linear);
        }
    }

    /// Filters a batch's textures and writes the colours of its pixels (of a chunk from pixel
    /// index `start` on), encoding the batch's eight colours at once.
    fn finish(&self, start: usize, batch: &Batch<'_>, colour: &mut [[u8; 3]], mut linear: Option<&mut [[f32; 3]]>) {
        let samples = trilinear_lanes(&batch.lookups);
        // Lanes past the batch's length stay black: encoded, and not written.
        let mut shaded = [[0.0; 3]; LANES];
        for (lane, &slot) in batch.slot.iter().enumerate().take(batch.len) {
            let sample = DVec3::from_array([0, 1, 2].map(|channel| f64::from(samples[channel][lane])));
            let albedo = batch.base[lane] * sample;
            let surface = Some(batch.surface[lane]);
            let lit_colour = lit(self.appearance, surface, albedo, |_| self.lux[start + slot]);
            if let Some(linear) = linear.as_deref_mut() {
                linear[slot] = lit_colour.as_vec3().to_array();
            }
            shaded[lane] = lit_colour.to_array();
        }
        // A textured pixel is never flat: its colour is always encoded.
        let encoded = linear_to_srgb3_lanes(&shaded);
        for (&slot, &encoded) in batch.slot.iter().zip(&encoded).take(batch.len) {
            colour[slot] = encoded;
        }
    }
}
