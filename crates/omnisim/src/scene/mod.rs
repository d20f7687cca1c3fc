//! Scenes: a face soup of coloured planar polygons grouped into named objects.
//!
//! `Scene::load` reads a RON file (schema in `file.rs`) and builds the scene (`build.rs`):
//! each library object's faces and textures (`library.rs`), each mesh's triangles (`mesh.rs`
//! and its formats, filling `mesh_data.rs`), their textures decoded once (`texture_bank.rs`), every face checked
//! (`validate.rs`), and any problem reported with the file, line and object it comes from.

mod build;
mod error;
mod export;
pub mod file;
mod gltf;
mod library;
pub mod lighting;
mod mesh;
mod mesh_data;
mod names;
mod obj;
pub mod pattern;
pub mod surface;
pub mod texture;
mod texture_bank;
pub(crate) mod triangulate;
mod validate;

use std::path::{Path, PathBuf};

use crate::input::locate;

use glam::DVec3;

pub use error::SceneError;
pub use export::ExportFormat;
pub use names::MAX_NAME_BYTES;
pub use triangulate::Triangles;
pub use validate::MAX_COORDINATE;

/// A face's vertices. Most faces of large scenes are mesh triangles, so three are held inline
/// (no heap allocation): 24 bytes less per triangle, where memory limits scene size.
pub type Vertices = smallvec::SmallVec<[DVec3; 3]>;

/// The most triangles a scene may have (faces split as [`Scene::triangulate`] splits them): the
/// BVH's wide leaves address them in 29 bits (about 110 GB of BVH).
pub const MAX_TRIANGLES: usize = 1 << 29;

/// A scene of more triangles than omnisim traces ([`MAX_TRIANGLES`]).
#[derive(Debug, thiserror::Error)]
#[error(
    "{triangles} triangles, more than the {MAX_TRIANGLES} (2^29) omnisim traces in one scene (its BVH addresses \
     triangles in 29 bits): split the scene into several, or simplify its meshes"
)]
pub struct TooManyTriangles {
    /// The scene's triangles (faces split as [`Scene::triangulate`] splits them).
    pub triangles: usize,
}

/// Refuses `triangles` over [`MAX_TRIANGLES`], the one check of the cap: loading asks it before
/// a mesh's faces are made and after each object (to name the object that passes it), and the
/// BVH's build before anything is made.
pub fn check_triangle_count(triangles: usize) -> Result<(), TooManyTriangles> {
    if triangles > MAX_TRIANGLES {
        return Err(TooManyTriangles { triangles });
    }
    Ok(())
}

/// A planar convex-or-concave polygon with one colour, the unit a scene is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct Face {
    /// Vertices in order around the boundary, world metres.
    pub vertices: Vertices,
    /// sRGB colour.
    pub colour: [u8; 3],
    /// Index into `Scene::objects`.
    pub object: u32,
}

/// A named object of the scene file, kept so faces can be traced back to what the user wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneObject {
    /// Name from the scene file, unique in the scene.
    pub name: String,
    /// Library kind: Box, Wall, Floor, Polygon or Mesh.
    pub kind: &'static str,
}

/// A validated scene.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    /// Name from the scene file; names output files.
    pub name: String,
    /// Free text from the scene file.
    pub description: String,
    /// Where it was loaded from, if from a file.
    pub source: Option<PathBuf>,
    /// Objects in file order; `Face::object` indexes this list.
    pub objects: Vec<SceneObject>,
    /// Every face of every object, in object order.
    pub faces: Vec<Face>,
    /// Light points and exposure; `None` draws every face in its flat colour.
    pub lighting: Option<lighting::Lighting>,
    /// Textures, vertex colours and which face has them; faces without a surface are drawn in
    /// their flat colour. Shared, since textures can be large.
    pub surfaces: std::sync::Arc<surface::Surfaces>,
    /// Things the user may want to know that did not stop loading (e.g. dropped degenerate
    /// mesh triangles).
    pub warnings: Vec<String>,
}

impl Scene {
    /// Reads, expands and validates a scene file (a regular file of at most
    /// [`crate::input::SCENE_LIMIT`] bytes).
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let text = crate::input::read_text(path, crate::input::SCENE_LIMIT)?;
        let mut scene = Self::from_ron(&text, path)?;
        scene.source = Some(path.to_path_buf());
        Ok(scene)
    }

    /// Parses scene text; `path` names the file in errors and anchors mesh paths.
    pub fn from_ron(text: &str, path: &Path) -> Result<Scene, SceneError> {
        let text = crate::input::without_bom(text);
        let parsed: file::SceneFile = crate::input::ron_options().from_str(text).map_err(|e| {
            let (line, column) = (e.span.start.line, e.span.start.col);
            let field = locate::field_of_error(text, &e)
                .map(|field| format!("{field}: "))
                .unwrap_or_default();
            let message = match locate::element_at(text, "objects", line, column) {
                Some(object) => format!("object '{}': {field}{}", crate::input::shown(&object, 64), e.code),
                None => format!("{field}{}", e.code),
            };
            SceneError::Parse {
                path: path.to_path_buf(),
                line,
                column,
                message,
            }
        })?;
        build::build(parsed, text, path)
    }

    /// The stem of this scene's output file names: the name itself when it was loaded from a
    /// file (names are checked on load), otherwise the name made safe.
    pub fn file_stem(&self) -> String {
        names::file_stem(&self.name)
    }

    /// Splits every face into triangles, keeping face and object ids.
    pub fn triangulate(&self) -> Triangles {
        triangulate::triangulate(self)
    }

    /// How many triangles [`Scene::triangulate`] splits the faces into, without splitting them.
    pub fn triangle_count(&self) -> usize {
        triangles_of(&self.faces)
    }

    /// The triangles of [`Scene::triangulate`] by reference (face and vertex indices).
    pub(crate) fn triangle_indices(&self) -> Vec<triangulate::TriangleIndex> {
        triangulate::triangle_indices(self)
    }

    /// Unit normal of face `face`, oriented by its vertex order (Newell's method).
    pub fn face_normal(&self, face: usize) -> DVec3 {
        validate::newell_normal(&self.faces[face].vertices).normalize()
    }

    /// Axis-aligned bounds of all vertices, or `None` for an empty scene.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        bounds_of(self.faces.iter())
    }

    /// Axis-aligned bounds of one object's faces; `None` for an object without faces.
    pub fn object_bounds(&self, object: u32) -> Option<(DVec3, DVec3)> {
        bounds_of(self.faces.iter().filter(|f| f.object == object))
    }

    /// For each texture (in `surfaces.textures` order), the objects with a face that shows it,
    /// in object order.
    pub fn texture_objects(&self) -> Vec<Vec<u32>> {
        let mut users = vec![Vec::new(); self.surfaces.textures.len()];
        for (index, face) in self.faces.iter().enumerate() {
            let Some(uv) = self.surfaces.of(index as u32).and_then(|s| s.uv.as_ref()) else {
                continue;
            };
            let objects: &mut Vec<u32> = &mut users[uv.texture as usize];
            if objects.last() != Some(&face.object) {
                objects.push(face.object);
            }
        }
        users
    }

    /// Writes the triangulated scene with face colours, for other tools to load exactly the
    /// geometry omnisim traces.
    pub fn export(&self, path: &Path, format: ExportFormat) -> Result<(), SceneError> {
        export::export(self, path, format)
    }
}

/// The triangles `faces` split into: n − 2 a face of n vertices (a fan, or ear clipping's).
fn triangles_of(faces: &[Face]) -> usize {
    faces.iter().map(|face| face.vertices.len().saturating_sub(2)).sum()
}

/// Axis-aligned bounds of the vertices of `faces`.
fn bounds_of<'a>(faces: impl Iterator<Item = &'a Face>) -> Option<(DVec3, DVec3)> {
    let mut points = faces.flat_map(|f| f.vertices.iter().copied());
    let first = points.next()?;
    Some(points.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
}
