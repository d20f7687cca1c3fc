//! The RON schema of a scene file, exactly as a person writes it.
//!
//! Everything here is plain data deserialised by serde; `deny_unknown_fields` makes a misspelt
//! field an error instead of a silently ignored line. Geometry is produced from these
//! descriptions in `build.rs` (the library's shapes in `library.rs`, meshes in `mesh.rs`) and
//! checked in `validate.rs`.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::texture::Wrap;

/// An sRGB colour, 0–255 per channel.
pub type Rgb = (u8, u8, u8);

/// How the angles of this file are written.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
pub enum AngleUnit {
    /// Angles in degrees (the default).
    #[default]
    Degrees,
    /// Angles in radians.
    Radians,
}

/// A whole scene file: `Scene(name: ..., objects: [...])`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "Scene")]
pub struct SceneFile {
    /// Scene name; names output files.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Unit of every `rotation` in the file.
    #[serde(default)]
    pub angles: AngleUnit,
    /// The objects, each from the library.
    pub objects: Vec<ObjectFile>,
    /// Light points and exposure; without it faces are drawn in their flat colours.
    #[serde(default)]
    pub lighting: Option<LightingFile>,
}

/// The lighting of a scene (model in `scene/lighting.rs` and README).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightingFile {
    /// Uniform, unshadowed illuminance on every face, lux.
    #[serde(default)]
    pub ambient: f64,
    /// Exposure: the illuminance, lux, at which a white face reaches full scale.
    #[serde(default = "default_white")]
    pub white: f64,
    /// Light points and directional lights.
    #[serde(default)]
    pub lights: Vec<LightFile>,
}

fn default_white() -> f64 {
    100.0
}

/// One light of the `lights` list.
#[derive(Debug, Clone, Deserialize)]
pub enum LightFile {
    /// A light point: inverse-square fall-off, hard shadows.
    Point(PointLightFile),
    /// A light at infinity (the sun): parallel rays, hard shadows.
    Directional(DirectionalLightFile),
}

/// `Point(...)`: a light point.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightFile {
    /// Name, unique in the scene; data-set specs switch lights by name.
    pub name: String,
    /// World position, metres.
    pub position: (f64, f64, f64),
    /// Luminous intensity, candela.
    pub intensity: f64,
    /// sRGB tint; white by default.
    #[serde(default = "white_light")]
    pub colour: Rgb,
    /// Whether the light is switched on.
    #[serde(default = "yes")]
    pub on: bool,
}

/// `Directional(...)`: a light at infinity.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLightFile {
    /// Name, unique in the scene.
    pub name: String,
    /// Direction the light travels in (towards the scene), world frame; need not be unit.
    pub direction: (f64, f64, f64),
    /// Illuminance on a surface facing the light, lux.
    pub illuminance: f64,
    /// sRGB tint; white by default.
    #[serde(default = "white_light")]
    pub colour: Rgb,
    /// Whether the light is switched on.
    #[serde(default = "yes")]
    pub on: bool,
}

fn white_light() -> Rgb {
    (255, 255, 255)
}

fn yes() -> bool {
    true
}

impl LightFile {
    /// The light's name.
    pub fn name(&self) -> &str {
        match self {
            LightFile::Point(l) => &l.name,
            LightFile::Directional(l) => &l.name,
        }
    }
}

/// One entry of the object library.
#[derive(Debug, Clone, Deserialize)]
pub enum ObjectFile {
    /// A parallelepiped of edge lengths `size` = (l1, l2, l3) along its own x, y, z.
    Box(BoxFile),
    /// A vertical rectangle standing on the segment `from`–`to` of the floor plan.
    Wall(WallFile),
    /// A horizontal polygon at height `z` (floors, ceilings, rugs).
    Floor(FloorFile),
    /// Any planar polygon, vertices in order around its boundary.
    Polygon(PolygonFile),
    /// A triangle mesh read from a PLY or OBJ file.
    Mesh(MeshFile),
}

/// `Box(...)`: a box, each face its own colour if asked.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxFile {
    /// Name, unique in the scene.
    pub name: String,
    /// (l1, l2, l3): lengths along the box's own x, y, z axes, metres.
    pub size: (f64, f64, f64),
    /// Centre of the bottom face, world metres.
    #[serde(default)]
    pub position: (f64, f64, f64),
    /// (θx, θy, θz), `world_from_object` = Rx·Ry·Rz, in the file's angle unit.
    #[serde(default)]
    pub rotation: (f64, f64, f64),
    /// sRGB colour of every face not named in `faces`.
    pub colour: Rgb,
    /// Per-face colours overriding `colour`: keys front (+x), back (−x), left (+y),
    /// right (−y), top (+z), bottom (−z).
    #[serde(default)]
    pub faces: BTreeMap<String, Rgb>,
    /// A texture laid on every face, tinted by `colour` (white leaves it as it is).
    #[serde(default)]
    pub texture: Option<TextureFile>,
    /// Per-face textures overriding `texture`: keys as in `faces`, or `sides` for the four
    /// vertical faces (a named face wins over `sides`).
    #[serde(default)]
    pub face_textures: BTreeMap<String, TextureFile>,
}

/// `Wall(...)`: a vertical rectangle.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallFile {
    /// Name, unique in the scene.
    pub name: String,
    /// Floor-plan start point (x, y), metres.
    pub from: (f64, f64),
    /// Floor-plan end point (x, y), metres.
    pub to: (f64, f64),
    /// Height of the bottom edge, metres.
    #[serde(default)]
    pub bottom: f64,
    /// Height above `bottom`, metres.
    pub height: f64,
    /// sRGB colour.
    pub colour: Rgb,
    /// A texture laid on every face, tinted by `colour` (white leaves it as it is).
    #[serde(default)]
    pub texture: Option<TextureFile>,
}

/// `Floor(...)`: a horizontal polygon.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorFile {
    /// Name, unique in the scene.
    pub name: String,
    /// Floor-plan corners (x, y) in order around the boundary, metres.
    pub corners: Vec<(f64, f64)>,
    /// Height, metres.
    #[serde(default)]
    pub z: f64,
    /// sRGB colour.
    pub colour: Rgb,
    /// A texture laid on every face, tinted by `colour` (white leaves it as it is).
    #[serde(default)]
    pub texture: Option<TextureFile>,
}

/// `Polygon(...)`: any planar polygon.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolygonFile {
    /// Name, unique in the scene.
    pub name: String,
    /// Vertices (x, y, z) in order around the boundary, metres.
    pub vertices: Vec<(f64, f64, f64)>,
    /// sRGB colour.
    pub colour: Rgb,
    /// A texture laid on every face, tinted by `colour` (white leaves it as it is).
    #[serde(default)]
    pub texture: Option<TextureFile>,
}

/// `texture: (...)`: an image or a procedural pattern laid on a face's plane, in metres.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureFile {
    /// PNG, JPEG, TGA, BMP or WebP file (by its extension), relative to the scene file's folder (and inside it).
    #[serde(default)]
    pub image: Option<String>,
    /// A seeded procedural pattern instead of an image.
    #[serde(default)]
    pub pattern: Option<Pattern>,
    /// Side of a baked pattern, texels.
    #[serde(default = "pattern_texels")]
    pub texels: u32,
    /// Metres one repeat of the image covers (across, down).
    #[serde(default = "unit_scale")]
    pub scale: (f64, f64),
    /// Turn of the image on the face, counter-clockwise as seen from the front, in the file's
    /// angle unit.
    #[serde(default)]
    pub rotation: f64,
    /// Where the image's top-left corner sits, metres along the face's right and down axes.
    #[serde(default)]
    pub offset: (f64, f64),
    /// How the image continues past its edges.
    #[serde(default)]
    pub wrap: Wrap,
}

/// A procedural pattern of a scene file's `texture`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub enum Pattern {
    /// `squares × squares` squares per repeat in two colours.
    Checker {
        /// The two colours, the first at the top-left square.
        colours: (Rgb, Rgb),
        /// Squares along each side of one repeat.
        #[serde(default = "eight")]
        squares: u32,
    },
    /// Courses of bricks, every other course shifted by half a brick, in mortar.
    Bricks {
        /// Mean brick colour; each brick varies around it (seeded).
        brick: Rgb,
        /// Mortar colour.
        mortar: Rgb,
        /// Courses per repeat.
        #[serde(default = "four")]
        rows: u32,
        /// Bricks per course per repeat.
        #[serde(default = "two")]
        columns: u32,
        /// Seed of the brick colours.
        #[serde(default)]
        seed: u64,
    },
    /// Wood-like grain: rings along u, disturbed by noise.
    Wood {
        /// Light wood colour.
        light: Rgb,
        /// Dark grain colour.
        dark: Rgb,
        /// Rings per repeat.
        #[serde(default = "eight")]
        rings: u32,
        /// Seed of the grain.
        #[serde(default)]
        seed: u64,
    },
    /// Smooth value noise between two colours.
    Noise {
        /// Colour at noise 0.
        low: Rgb,
        /// Colour at noise 1.
        high: Rgb,
        /// Noise cells along each side of one repeat.
        #[serde(default = "eight")]
        cells: u32,
        /// Seed of the noise.
        #[serde(default)]
        seed: u64,
    },
}

fn two() -> u32 {
    2
}

fn four() -> u32 {
    4
}

fn eight() -> u32 {
    8
}

fn pattern_texels() -> u32 {
    256
}

fn unit_scale() -> (f64, f64) {
    (1.0, 1.0)
}

/// `Mesh(...)`: triangles from a PLY or OBJ file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshFile {
    /// Name, unique in the scene.
    pub name: String,
    /// PLY or OBJ file, relative to the scene file's folder.
    pub path: String,
    /// Colour of faces the mesh file gives no colour, texture or vertex colours.
    pub colour: Rgb,
    /// Uniform scale applied first (e.g. 0.001 for a mesh in millimetres).
    #[serde(default = "one")]
    pub scale: f64,
    /// (θx, θy, θz), Rx·Ry·Rz, in the file's angle unit; applied after `scale`.
    #[serde(default)]
    pub rotation: (f64, f64, f64),
    /// Translation applied last, metres.
    #[serde(default)]
    pub position: (f64, f64, f64),
}

fn one() -> f64 {
    1.0
}

impl ObjectFile {
    /// The texture of a library object (meshes bring their own).
    pub fn texture(&self) -> Option<&TextureFile> {
        match self {
            ObjectFile::Box(o) => o.texture.as_ref(),
            ObjectFile::Wall(o) => o.texture.as_ref(),
            ObjectFile::Floor(o) => o.texture.as_ref(),
            ObjectFile::Polygon(o) => o.texture.as_ref(),
            ObjectFile::Mesh(_) => None,
        }
    }

    /// The object's name.
    pub fn name(&self) -> &str {
        match self {
            ObjectFile::Box(o) => &o.name,
            ObjectFile::Wall(o) => &o.name,
            ObjectFile::Floor(o) => &o.name,
            ObjectFile::Polygon(o) => &o.name,
            ObjectFile::Mesh(o) => &o.name,
        }
    }

    /// The library kind, as written in the file (Box, Wall, ...).
    pub fn kind(&self) -> &'static str {
        match self {
            ObjectFile::Box(_) => "Box",
            ObjectFile::Wall(_) => "Wall",
            ObjectFile::Floor(_) => "Floor",
            ObjectFile::Polygon(_) => "Polygon",
            ObjectFile::Mesh(_) => "Mesh",
        }
    }
}
