//! The object library: the planar faces of each kind of object a scene file describes (Box,
//! Wall, Floor, Polygon; meshes bring their own, `mesh.rs`), and how a library object's texture
//! lies on them. `build.rs` checks the faces and keeps them in the scene.

use std::path::Path;

use glam::{DVec2, DVec3, dvec3};

use super::file::{BoxFile, FloorFile, PolygonFile, TextureFile, WallFile};
use super::surface::{Surface, UvMap, planar_uv};
use super::texture::{Wrap, open_image};
use super::texture_bank::TextureBank;
use super::{Vertices, validate};
use crate::input::shown_number;
use crate::pose::rotation_xyz;

/// Box face names, in the order their colours are listed in error messages.
const BOX_FACES: [&str; 6] = ["front", "back", "left", "right", "top", "bottom"];

/// A face as an object makes it: vertices, colour, and the surface a mesh gives it.
pub(super) type RawFace = (Vertices, (u8, u8, u8), Option<Surface>);

/// Refuses a length that is not a positive finite number of metres, naming it `what`.
pub(super) fn positive(what: &str, value: f64) -> Result<(), String> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(format!(
            "{what} must be a positive finite number of metres, not {value}"
        ))
    }
}

/// A library object's texture, decoded, and how it lies on the object's faces.
pub(super) struct Placement {
    texture: u32,
    scale: DVec2,
    rotation: f64,
    offset: DVec2,
    wrap: Wrap,
}

impl Placement {
    /// The surface of a (validated) face of the object.
    pub(super) fn surface(&self, vertices: &[DVec3]) -> Surface {
        let anchor = vertices[0];
        let normal = validate::newell_normal(vertices).normalize();
        let (at_anchor, gradient) = planar_uv(anchor, normal, self.scale, self.rotation, self.offset);
        Surface {
            anchor,
            uv: Some(UvMap {
                texture: self.texture,
                wrap: [self.wrap; 2],
                at_anchor,
                gradient,
            }),
            colours: None,
            unlit: false,
        }
    }
}

/// Checks and loads a library object's `texture` (`rotation` already in radians); errors
/// name the field (below `texture`) and the problem.
pub(super) fn place(
    file: &TextureFile,
    rotation: f64,
    scene_path: &Path,
    bank: &mut TextureBank,
) -> Result<Placement, (&'static str, String)> {
    let texture = match (&file.image, &file.pattern) {
        (Some(image), None) => {
            let path = crate::input::inside_folder(scene_path, image, "texture image").map_err(|e| ("image", e))?;
            bank.add_image(format!("image {}", path.display()), || open_image(&path))
                .map_err(|e| ("image", e))?
        }
        (None, Some(pattern)) => bank
            .get_or_add(format!("pattern {pattern:?} baked to {}² texels", file.texels), || {
                pattern.bake(file.texels)
            })
            .map_err(|e| ("pattern", e))?,
        _ => {
            return Err((
                "image",
                "give exactly one of image: \"file.png\" or pattern: Checker(...) | Bricks(...) | Wood(...) | \
                 Noise(...)"
                    .into(),
            ));
        }
    };
    let (sx, sy) = file.scale;
    if !(sx.is_finite() && sx > 0.0 && sy.is_finite() && sy > 0.0) {
        return Err((
            "scale",
            format!(
                "scale must be two positive finite lengths in metres (one repeat across, down), not ({}, {})",
                shown_number(sx),
                shown_number(sy)
            ),
        ));
    }
    if !(rotation.is_finite() && file.offset.0.is_finite() && file.offset.1.is_finite()) {
        return Err(("rotation", "rotation and offset must be finite".into()));
    }
    Ok(Placement {
        texture,
        scale: DVec2::new(sx, sy),
        rotation,
        offset: DVec2::new(file.offset.0, file.offset.1),
        wrap: file.wrap,
    })
}

/// The texture of each face of box `b`, in `box_faces` order, where `face_textures` gives
/// one: the face's own key, else `sides` for a vertical face. Unknown keys are refused.
pub(super) fn box_face_textures(b: &BoxFile) -> Result<[Option<(&str, &TextureFile)>; 6], String> {
    if let Some(unknown) = b
        .face_textures
        .keys()
        .find(|k| k.as_str() != "sides" && !BOX_FACES.contains(&k.as_str()))
    {
        return Err(format!(
            "unknown face '{}' in face_textures; the faces are {} and sides (front, back, left and right)",
            crate::input::shown(unknown, 40),
            BOX_FACES.join(", ")
        ));
    }
    let of_name = |name: &'static str| b.face_textures.get(name).map(|t| (name, t));
    Ok(BOX_FACES.map(|name| {
        let vertical = !matches!(name, "top" | "bottom");
        of_name(name).or_else(|| if vertical { of_name("sides") } else { None })
    }))
}

pub(super) fn box_faces(b: &BoxFile, angles: DVec3) -> Result<Vec<RawFace>, String> {
    positive("size.0 (l1)", b.size.0)?;
    positive("size.1 (l2)", b.size.1)?;
    positive("size.2 (l3)", b.size.2)?;
    if let Some(unknown) = b.faces.keys().find(|k| !BOX_FACES.contains(&k.as_str())) {
        return Err(format!(
            "unknown face '{unknown}' in faces; the faces are {}",
            BOX_FACES.join(", ")
        ));
    }
    let (hx, hy, h) = (b.size.0 / 2.0, b.size.1 / 2.0, b.size.2);
    let corner = |x: f64, y: f64, z: f64| dvec3(x, y, z);
    let local: [(&str, [DVec3; 4]); 6] = [
        (
            "front",
            [
                corner(hx, -hy, 0.0),
                corner(hx, hy, 0.0),
                corner(hx, hy, h),
                corner(hx, -hy, h),
            ],
        ),
        (
            "back",
            [
                corner(-hx, hy, 0.0),
                corner(-hx, -hy, 0.0),
                corner(-hx, -hy, h),
                corner(-hx, hy, h),
            ],
        ),
        (
            "left",
            [
                corner(hx, hy, 0.0),
                corner(-hx, hy, 0.0),
                corner(-hx, hy, h),
                corner(hx, hy, h),
            ],
        ),
        (
            "right",
            [
                corner(-hx, -hy, 0.0),
                corner(hx, -hy, 0.0),
                corner(hx, -hy, h),
                corner(-hx, -hy, h),
            ],
        ),
        (
            "top",
            [
                corner(-hx, -hy, h),
                corner(hx, -hy, h),
                corner(hx, hy, h),
                corner(-hx, hy, h),
            ],
        ),
        (
            "bottom",
            [
                corner(-hx, hy, 0.0),
                corner(hx, hy, 0.0),
                corner(hx, -hy, 0.0),
                corner(-hx, -hy, 0.0),
            ],
        ),
    ];
    let world_from_object = rotation_xyz(angles);
    let position = dvec3(b.position.0, b.position.1, b.position.2);
    Ok(local
        .iter()
        .map(|(name, corners)| {
            let colour = b.faces.get(*name).copied().unwrap_or(b.colour);
            let vertices = corners.iter().map(|c| position + world_from_object * *c).collect();
            (vertices, colour, None)
        })
        .collect())
}

pub(super) fn wall_face(w: &WallFile) -> Result<Vec<RawFace>, String> {
    positive("height", w.height)?;
    let (a, b) = (w.from, w.to);
    let top = w.bottom + w.height;
    Ok(vec![(
        smallvec::smallvec![
            dvec3(a.0, a.1, w.bottom),
            dvec3(b.0, b.1, w.bottom),
            dvec3(b.0, b.1, top),
            dvec3(a.0, a.1, top),
        ],
        w.colour,
        None,
    )])
}

pub(super) fn floor_face(f: &FloorFile) -> Vec<RawFace> {
    let vertices = f.corners.iter().map(|c| dvec3(c.0, c.1, f.z)).collect();
    vec![(vertices, f.colour, None)]
}

pub(super) fn polygon_face(p: &PolygonFile) -> Vec<RawFace> {
    let vertices = p.vertices.iter().map(|v| dvec3(v.0, v.1, v.2)).collect();
    vec![(vertices, p.colour, None)]
}
