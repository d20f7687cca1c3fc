//! What a face carries besides its flat colour: texture coordinates and vertex colours, as
//! affine functions of the hit point on the face's plane.
//!
//! Anything interpolated linearly across a triangle (UVs, colours) is an affine function of the
//! point on its plane, and so is a planar mapping of a whole polygon (library faces mapped in
//! metres). A surface therefore stores each such quantity as its value at an anchor point plus
//! a world-space gradient, computed once in f64 at load; shading evaluates
//! `value + gradient · (P − anchor)` at the hit point on CPU and GPU alike, so the hit planes
//! need no barycentrics. Faces without a surface are shaded exactly as before.

use std::sync::OnceLock;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::lighting::linear_to_srgb3;
use super::texture::{Texture, Wrap};

/// Index of a face without a surface in [`Surfaces::of_face`].
pub const NO_SURFACE: u32 = u32::MAX;

/// The scene's textures and face surfaces, kept apart from the geometry (the BVH never sees
/// them) and indexed by face id.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Surfaces {
    /// Every texture, mip-mapped; `UvMap::texture` indexes this list.
    pub textures: Vec<Texture>,
    /// Where each texture came from (an image file, a pattern, a glTF's image), in the order
    /// of `textures`: what `scene check` lists.
    pub sources: Vec<String>,
    /// Every surface, in face order ([`Surfaces::list`]). Read-only outside the crate, as is
    /// `of_face`: the one-colour table below is made from them once, and loading, the only
    /// writer, fills them before any frame.
    pub(crate) list: Vec<Surface>,
    /// Index into `list` of each face, [`NO_SURFACE`] for none ([`Surfaces::of_face`]).
    pub(crate) of_face: Vec<u32>,
    /// The faces whose surfaces give one colour, made from these surfaces on the first frame
    /// without lighting that needs them: another appearance's surfaces are another value, so
    /// its frames never meet this table, and these surfaces cannot change under it (their
    /// lists are the crate's to write). Not part of the value: a clone (`Arc::make_mut` of
    /// shared surfaces) starts without it, and equality ignores it.
    pub(crate) one_colour_faces: OneColourCache,
}

impl Surfaces {
    /// The surface of face `face`, if it has one.
    pub fn of(&self, face: u32) -> Option<&Surface> {
        match self.of_face.get(face as usize) {
            Some(&i) if i != NO_SURFACE => self.list.get(i as usize),
            _ => None,
        }
    }

    /// Every surface, in face order.
    pub fn list(&self) -> &[Surface] {
        &self.list
    }

    /// Index into [`Surfaces::list`] of each face, [`NO_SURFACE`] for none; shorter than the
    /// face list (empty for a scene without surfaces): faces past its end have none.
    pub fn of_face(&self) -> &[u32] {
        &self.of_face
    }

    /// Gives face `face` (the scene's last so far) `surface`.
    pub(crate) fn push(&mut self, face: usize, surface: Surface) {
        self.one_colour_faces = Default::default();
        self.of_face.resize(face, NO_SURFACE);
        self.of_face.push(self.list.len() as u32);
        self.list.push(surface);
    }

    /// Gives `faces` (ascending, after the scene's last so far with a surface) their
    /// `surfaces`, one each, written on all threads: as [`Surfaces::push`] of each in turn.
    pub(crate) fn extend(&mut self, faces: &[usize], surfaces: impl IndexedParallelIterator<Item = Surface>) {
        debug_assert_eq!(faces.len(), surfaces.len());
        self.one_colour_faces = Default::default();
        for (next, &face) in (self.list.len() as u32..).zip(faces) {
            self.of_face.resize(face, NO_SURFACE);
            self.of_face.push(next);
        }
        self.list.par_extend(surfaces);
    }

    /// Whether no face has a surface.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// The faces of these surfaces that give one colour, made on first use.
    pub(crate) fn one_colour_faces(&self) -> &OneColourFaces {
        self.one_colour_faces.of(self)
    }
}

/// For scenes without lighting (not faces with `Surface::unlit`), untextured: the 8-bit colour
/// of each face whose surface gives every hit one colour. Vertex colours equal at its three
/// corners (each face of what `omnisim scene export` writes, meshes coloured by face) are that
/// colour, and a surface without colours leaves the face's own. Worked out once for a scene's
/// surfaces (they keep it: [`OneColourCache`]), so that shading (`shade::shade_frame`) draws such
/// faces as flat ones, by a byte looked up, instead of a colour interpolated and encoded per
/// pixel; held here, beside the surfaces it is made from (env1 exported as a PLY,
/// omni 250²: ~185 instructions a hit; docs/benchmarks.md, "2026-11-27 night (small)").
#[derive(Debug)]
pub(crate) struct OneColourFaces {
    /// Per face, as long as `Surfaces::of_face`: the colour as `0x00RRGGBB`, or
    /// [`OneColourFaces::FACE_COLOUR`] or [`OneColourFaces::VARYING`].
    pub(crate) of_face: Vec<u32>,
    /// Whether every face has colours that vary (a scan's mesh): then nothing is looked up,
    /// and the frame is shaded as before the table.
    pub(crate) every_face_varies: bool,
}

impl OneColourFaces {
    /// The face's colour in the appearance (no surface, or one that leaves it).
    pub(crate) const FACE_COLOUR: u32 = u32::MAX;
    /// Colours that vary across the face: shaded per pixel.
    pub(crate) const VARYING: u32 = u32::MAX - 1;

    /// The faces of `surfaces`. A hit's vertex colour is `at_anchor + gradient · (P − anchor)`
    /// (`Surface::colour_at`): with every gradient zero and a finite anchor, each product is
    /// ±0 at a hit's finite point, so the sum equals `at_anchor` up to the sign of a zero,
    /// which clamps and encodes alike. A non-finite anchor (only a hand-built surface has one)
    /// is left to the pixel's own shading.
    pub(crate) fn of(surfaces: &Surfaces) -> Self {
        let of_face: Vec<u32> = surfaces
            .of_face
            .iter()
            .map(|&index| match surfaces.list.get(index as usize) {
                None => Self::FACE_COLOUR,
                Some(surface) => match (&surface.uv, &surface.colours) {
                    (None, None) => Self::FACE_COLOUR,
                    (None, Some(colours)) if colours.gradient == [DVec3::ZERO; 3] && surface.anchor.is_finite() => {
                        let [r, g, b] = linear_to_srgb3(colours.at_anchor.clamp(DVec3::ZERO, DVec3::ONE).to_array());
                        u32::from_be_bytes([0, r, g, b])
                    }
                    _ => Self::VARYING,
                },
            })
            .collect();
        Self {
            every_face_varies: !of_face.is_empty() && of_face.iter().all(|&entry| entry == Self::VARYING),
            of_face,
        }
    }
}

/// [`Surfaces`]' table of [`OneColourFaces`], made on first use: derived from the surfaces, so
/// a clone starts without it and it never makes two surfaces unequal.
#[derive(Debug, Default)]
pub(crate) struct OneColourCache(OnceLock<OneColourFaces>);

impl OneColourCache {
    /// The table of `surfaces` (whose cache this is), made on first use.
    pub(crate) fn of(&self, surfaces: &Surfaces) -> &OneColourFaces {
        self.0.get_or_init(|| OneColourFaces::of(surfaces))
    }

    /// The table, if a frame made it.
    #[cfg(test)]
    pub(crate) fn made(&self) -> Option<&OneColourFaces> {
        self.0.get()
    }
}

impl Clone for OneColourCache {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl PartialEq for OneColourCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// The texture of a face: which one, how coordinates wrap, and u, v as affine functions.
#[derive(Debug, Clone, PartialEq)]
pub struct UvMap {
    /// Index into `Scene::textures`.
    pub texture: u32,
    /// Wrap of u and of v.
    pub wrap: [Wrap; 2],
    /// (u, v) at the surface's anchor. u runs right along the image, v down (row 0 at v = 0).
    pub at_anchor: DVec2,
    /// World-space gradients of u and of v (per metre).
    pub gradient: [DVec3; 2],
}

impl UvMap {
    /// The squared number of texels per metre, along the direction where it is largest, on a
    /// texture of `size` texels: the larger eigenvalue of the Gram matrix of the gradients in
    /// texels (exact for library faces, whose mapping is a scaled rotation; the upper bound
    /// for a skewed mesh mapping). The level of detail scales a footprint's length by it.
    pub fn texels_per_metre_squared(&self, size: (u32, u32)) -> f64 {
        let (u, v) = (
            self.gradient[0] * f64::from(size.0),
            self.gradient[1] * f64::from(size.1),
        );
        let (uu, uv, vv) = (u.length_squared(), u.dot(v), v.length_squared());
        let half_difference = 0.5 * (uu - vv);
        0.5 * (uu + vv) + (half_difference * half_difference + uv * uv).sqrt()
    }
}

/// Vertex colours interpolated across a triangle, in linear light.
#[derive(Debug, Clone, PartialEq)]
pub struct ColourMap {
    /// Linear colour at the anchor.
    pub at_anchor: DVec3,
    /// World-space gradients of red, green and blue (per metre).
    pub gradient: [DVec3; 3],
}

/// A face's varying albedo: vertex colours (which replace the face's colour), a texture (which
/// multiplies the face's colour or the vertex colours: the face colour is then a tint, glTF's
/// `baseColorFactor`, MTL's `Kd`), or both.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Where the affine functions are anchored (a vertex of the face), world metres.
    pub anchor: DVec3,
    /// The texture, if any.
    pub uv: Option<UvMap>,
    /// Vertex colours, if any.
    pub colours: Option<ColourMap>,
    /// Drawn in its albedo whatever the lights (glTF's `KHR_materials_unlit`).
    pub unlit: bool,
}

impl Surface {
    /// (u, v) at world point `point`.
    pub fn uv_at(map: &UvMap, anchor: DVec3, point: DVec3) -> DVec2 {
        let d = point - anchor;
        map.at_anchor + DVec2::new(map.gradient[0].dot(d), map.gradient[1].dot(d))
    }

    /// Linear vertex colour at world point `point`.
    pub fn colour_at(map: &ColourMap, anchor: DVec3, point: DVec3) -> DVec3 {
        let d = point - anchor;
        map.at_anchor + DVec3::new(map.gradient[0].dot(d), map.gradient[1].dot(d), map.gradient[2].dot(d))
    }
}

/// The gradient of the affine function on triangle `corners` that takes `values` at them:
/// the vector g in the triangle's plane with g·(p1 − p0) = f1 − f0 and g·(p2 − p0) = f2 − f0.
/// `None` for a triangle without area.
pub(crate) fn gradient(corners: [DVec3; 3], values: [f64; 3]) -> Option<DVec3> {
    let (e1, e2) = (corners[1] - corners[0], corners[2] - corners[0]);
    let n = e1.cross(e2);
    let area2 = n.length_squared();
    if !(area2 > 0.0 && area2.is_finite()) {
        return None;
    }
    Some(((values[1] - values[0]) * e2.cross(n) + (values[2] - values[0]) * n.cross(e1)) / area2)
}

/// The in-plane axes of a face with unit normal `normal` on which library textures are laid:
/// "right" and "down" as seen from the side the normal points to, with up = +z (or +y for a
/// horizontal face), so images stand upright on walls and read from above on floors.
pub(crate) fn plane_axes(normal: DVec3) -> [DVec3; 2] {
    let up = if normal.z.abs() > 0.999 { DVec3::Y } else { DVec3::Z };
    let right = up.cross(normal).normalize();
    let down = -normal.cross(right);
    [right, down]
}

/// Places a texture on a face's plane: metres along the face's right and down axes
/// ([`plane_axes`]), shifted by `offset`, turned by `rotation` (radians, counter-clockwise as
/// seen from the front), and divided by `scale` (metres per repeat across, down).
pub(crate) fn planar_uv(
    anchor: DVec3,
    normal: DVec3,
    scale: DVec2,
    rotation: f64,
    offset: DVec2,
) -> (DVec2, [DVec3; 2]) {
    let [right, down] = plane_axes(normal);
    let (sin, cos) = rotation.sin_cos();
    // Texture axes in the world: the face's axes turned by `rotation`.
    let u_axis = right * cos - down * sin;
    let v_axis = right * sin + down * cos;
    let gradient = [u_axis / scale.x, v_axis / scale.y];
    let at_anchor = DVec2::new(
        (anchor.dot(u_axis) - offset.x) / scale.x,
        (anchor.dot(v_axis) - offset.y) / scale.y,
    );
    (at_anchor, gradient)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::dvec3;

    /// A `Surfaces` made through its public fields is read without panicking, even where its
    /// face index points past the list.
    #[test]
    fn surfaces_built_by_hand_are_read_safely() {
        let surface = Surface {
            anchor: DVec3::ZERO,
            uv: None,
            colours: None,
            unlit: true,
        };
        let surfaces = Surfaces {
            list: vec![surface],
            of_face: vec![NO_SURFACE, 0, 7],
            ..Surfaces::default()
        };
        assert!(surfaces.of(0).is_none() && surfaces.of(3).is_none());
        assert!(surfaces.of(1).is_some_and(|s| s.unlit));
        assert!(surfaces.of(2).is_none(), "index 7 lies past the list of one");
    }

    /// Surfaces given to faces from `first` on, one face between them without, after a face
    /// with one and faces without, are the same as given one face at a time.
    #[test]
    fn extending_equals_pushing_each_surface_in_turn() {
        let surface = |x: f64| Surface {
            anchor: DVec3::new(x, 0.0, 0.0),
            uv: None,
            colours: None,
            unlit: x > 3.0,
        };
        for (earlier, first) in [(None, 0), (None, 3), (Some(1), 1), (Some(1), 4)] {
            let (mut pushed, mut extended) = (Surfaces::default(), Surfaces::default());
            if let Some(face) = earlier {
                pushed.push(face, surface(-1.0));
                extended.push(face, surface(-1.0));
            }
            // Five faces with surfaces from `first`, with a face without one between the
            // second and the third.
            let faces: Vec<usize> = [0, 1, 3, 4, 5].map(|k| first + k).into();
            for (k, &face) in faces.iter().enumerate() {
                pushed.push(face, surface(k as f64));
            }
            extended.extend(&faces, (0..5u32).into_par_iter().map(|k| surface(f64::from(k))));
            assert_eq!(extended, pushed, "earlier {earlier:?}, first {first}");
            assert_eq!(extended.of_face.len(), first + 6);
            assert_eq!(extended.of(first as u32 + 2), None);
        }
    }

    #[test]
    fn triangle_gradients_reproduce_corner_values() {
        let corners = [dvec3(1.0, 2.0, 3.0), dvec3(2.5, 2.0, 3.5), dvec3(1.0, 4.0, 2.0)];
        let values = [0.25, -1.0, 3.0];
        let g = gradient(corners, values).unwrap();
        for k in 0..3 {
            let at = values[0] + g.dot(corners[k] - corners[0]);
            assert!((at - values[k]).abs() < 1e-12, "{at} vs {}", values[k]);
        }
        assert!(gradient([DVec3::ZERO, DVec3::X, DVec3::X * 2.0], values).is_none());
    }

    #[test]
    fn walls_read_upright_and_floors_from_above() {
        // A wall facing +x, seen from +x: right is +y, down is −z.
        assert_eq!(plane_axes(DVec3::X), [DVec3::Y, -DVec3::Z]);
        // A floor seen from above: right +x, down −y.
        assert_eq!(plane_axes(DVec3::Z), [DVec3::X, -DVec3::Y]);
        // 2 m per repeat, offset 0.5 m: u = (x − 0.5) / 2 on a floor.
        let (at, g) = planar_uv(
            dvec3(1.5, 0.0, 0.0),
            DVec3::Z,
            DVec2::splat(2.0),
            0.0,
            DVec2::new(0.5, 0.0),
        );
        assert_eq!(at, DVec2::new(0.5, 0.0));
        assert_eq!(g[0], DVec3::X / 2.0);
    }
}
