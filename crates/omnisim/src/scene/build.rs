//! Builds a [`Scene`] from a parsed scene file: each object's faces (the library's shapes and
//! textures, `library.rs`; a mesh's triangles, `mesh.rs`) checked on all threads and kept with
//! their surfaces, names checked and located in the file, the triangle cap asked after each
//! object, and the lighting section checked.

use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;

use glam::{DVec3, dvec3};
use rayon::prelude::*;

use super::file::{AngleUnit, LightFile, LightingFile, MeshFile, ObjectFile, SceneFile, TextureFile};
use super::library::{
    Placement, RawFace, box_face_textures, box_faces, floor_face, place, polygon_face, positive, wall_face,
};
use super::mesh_data::MeshTriangle;
use super::surface::Surfaces;
use super::texture_bank::TextureBank;
use super::{Face, Scene, SceneError, SceneObject, Vertices, mesh, names, validate};
use crate::input::locate;
use crate::pose::rotation_xyz;
use crate::scene::lighting::{Light, LightKind, Lighting, linear_rgb};

/// The scene of `file` (`text`, read from `path`, locates its errors).
pub(super) fn build(file: SceneFile, text: &str, path: &Path) -> Result<Scene, SceneError> {
    if let Err(problem) = names::check_scene_name(&file.name) {
        let (line, column) = locate::scene_field(text, "name").unwrap_or((1, 1));
        return Err(SceneError::Parse {
            path: path.to_path_buf(),
            line,
            column,
            message: problem,
        });
    }
    let mut scene = Scene {
        name: file.name,
        description: file.description,
        ..Scene::default()
    };
    let mut surfaces = Surfaces::default();
    let mut bank = TextureBank::default();
    // How many objects of each name came before: the n-th of a name is its n-th mention.
    let mut seen: HashMap<&str, usize> = HashMap::new();
    let mut triangles = 0;
    for object in &file.objects {
        let name = object.name();
        let earlier = *seen.entry(name).and_modify(|n| *n += 1).or_insert(0);
        let invalid = |message: String| SceneError::Invalid {
            path: path.to_path_buf(),
            location: locate::name_field(text, name, earlier),
            object: crate::input::shown(name, 64),
            message: format!("{}: {message}", object.kind()),
        };
        if name.trim().is_empty() {
            return Err(invalid("the name is empty; give every object a name".into()));
        }
        if let Some(problem) = unprintable(name) {
            return Err(invalid(problem));
        }
        if earlier > 0 {
            return Err(invalid("another object has this name; names must be unique".into()));
        }
        let index = scene.objects.len() as u32;
        let angle = |r: (f64, f64, f64)| {
            let v = dvec3(r.0, r.1, r.2);
            match file.angles {
                AngleUnit::Degrees => v * (std::f64::consts::PI / 180.0),
                AngleUnit::Radians => v,
            }
        };
        // Checks and loads a texture written at `field` of the object.
        let mut place_at = |texture: &TextureFile, field: &str| {
            place(texture, angle((texture.rotation, 0.0, 0.0)).x, path, &mut bank).map_err(|(key, message)| {
                SceneError::Invalid {
                    path: path.to_path_buf(),
                    location: locate::name_field(text, name, earlier)
                        .and_then(|at| locate::field_of_element(text, at, &format!("{field}.{key}")))
                        .or_else(|| locate::name_field(text, name, earlier)),
                    object: crate::input::shown(name, 64),
                    message: format!("{}: {field}.{key}: {message}", object.kind()),
                }
            })
        };
        let placement = object.texture().map(|t| place_at(t, "texture")).transpose()?;
        // A Box's own texture for each of its faces (in `box_faces` order), where it names one.
        let face_placements = match object {
            ObjectFile::Box(b) => box_face_textures(b)
                .map_err(&invalid)?
                .iter()
                .map(|chosen| {
                    chosen
                        .map(|(key, texture)| place_at(texture, &format!("face_textures.\"{key}\"")))
                        .transpose()
                })
                .collect::<Result<Vec<_>, _>>()?,
            _ => Vec::new(),
        };
        let is_mesh = matches!(object, ObjectFile::Mesh(_));
        let keeping = FaceKeeper {
            object: index,
            is_mesh,
            placement: placement.as_ref(),
            face_placements: &face_placements,
        };
        let keep = |mut faces: Vec<RawFace>, scene: &mut Scene, surfaces: &mut Surfaces| {
            keeping.keep(&mut faces, scene, surfaces)
        };
        let first_face = scene.faces.len();
        let dropped = match object {
            ObjectFile::Mesh(m) => keep_mesh_faces(
                m,
                angle(m.rotation),
                path,
                &mut bank,
                &keeping,
                &mut scene,
                &mut surfaces,
                triangles,
            ),
            ObjectFile::Box(b) => box_faces(b, angle(b.rotation)).and_then(|f| keep(f, &mut scene, &mut surfaces)),
            ObjectFile::Wall(w) => wall_face(w).and_then(|f| keep(f, &mut scene, &mut surfaces)),
            ObjectFile::Floor(f) => keep(floor_face(f), &mut scene, &mut surfaces),
            ObjectFile::Polygon(p) => keep(polygon_face(p), &mut scene, &mut surfaces),
        }
        .map_err(&invalid)?;
        // The object that passes the cap is named (the BVH's build refuses the scene without
        // naming it); a mesh is refused from its count before its faces are made.
        triangles += super::triangles_of(&scene.faces[first_face..]);
        check_scene_triangles(triangles).map_err(&invalid)?;
        if is_mesh && scene.faces.last().is_none_or(|f| f.object != index) {
            return Err(invalid("the mesh has no usable triangles (all have zero area)".into()));
        }
        if dropped > 0 {
            scene
                .warnings
                .push(format!("mesh '{name}': dropped {dropped} degenerate triangles"));
        }
        scene.objects.push(SceneObject {
            name: name.to_string(),
            kind: object.kind(),
        });
    }
    if scene.faces.is_empty() {
        return Err(SceneError::Scene {
            path: path.to_path_buf(),
            message: "the scene has no faces; add at least one object".into(),
        });
    }
    if let Some(lighting) = &file.lighting {
        scene.lighting = Some(build_lighting(lighting, &seen, text, path)?);
    }
    (surfaces.textures, surfaces.sources) = bank.into_textures();
    scene.surfaces = std::sync::Arc::new(surfaces);
    Ok(scene)
}

/// Checks the lighting section; light names share one namespace with object names so that
/// errors can be located by name and data-set specs can address either without ambiguity.
fn build_lighting(
    file: &LightingFile,
    object_names: &HashMap<&str, usize>,
    text: &str,
    path: &Path,
) -> Result<Lighting, SceneError> {
    let scene_error = |message: String| SceneError::Scene {
        path: path.to_path_buf(),
        message: format!("lighting: {message}"),
    };
    if !(file.ambient.is_finite() && file.ambient >= 0.0) {
        return Err(scene_error(format!(
            "ambient must be a finite illuminance ≥ 0 lux, not {}",
            file.ambient
        )));
    }
    if !(file.white.is_finite() && file.white > 0.0) {
        return Err(scene_error(format!(
            "white (the exposure) must be a positive finite illuminance in lux, not {}",
            file.white
        )));
    }
    let mut lights: Vec<Light> = Vec::with_capacity(file.lights.len());
    // How many lights of each name came before (a map: 200,000 lights took 28 s with a scan).
    let mut light_names: HashMap<&str, usize> = HashMap::new();
    for light in &file.lights {
        let name = light.name();
        let before = light_names.entry(name).or_insert(0);
        let earlier = object_names.get(name).map_or(0, |n| n + 1) + *before;
        *before += 1;
        let invalid = |message: String| SceneError::Invalid {
            path: path.to_path_buf(),
            location: locate::name_field(text, name, earlier),
            object: crate::input::shown(name, 64),
            message: format!("light: {message}"),
        };
        if name.trim().is_empty() {
            return Err(invalid("the name is empty; give every light a name".into()));
        }
        if let Some(problem) = unprintable(name) {
            return Err(invalid(problem));
        }
        if earlier > 0 {
            return Err(invalid(
                "an object or another light has this name; names must be unique".into(),
            ));
        }
        let finite = |what: &str, v: (f64, f64, f64)| {
            let v = dvec3(v.0, v.1, v.2);
            if v.is_finite() {
                Ok(v)
            } else {
                Err(invalid(format!("{what} must be finite, not {v}")))
            }
        };
        let strength = |what: &str, unit: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                Err(invalid(format!(
                    "{what} must be a finite number of {unit} ≥ 0, not {v}"
                )))
            }
        };
        let (kind, colour, on) = match light {
            LightFile::Point(p) => (
                LightKind::Point {
                    position: finite("position", p.position)?,
                    intensity: strength("intensity", "candela", p.intensity)?,
                },
                p.colour,
                p.on,
            ),
            LightFile::Directional(d) => {
                let direction = finite("direction", d.direction)?;
                // Scaled by its largest component first: (1e308, 0, -1e308) and (1e-300, 0,
                // -1e-300) are directions too, whose length overflows or underflows.
                let largest = direction.abs().max_element();
                if largest == 0.0 {
                    return Err(invalid("direction must not be (0, 0, 0)".into()));
                }
                (
                    LightKind::Directional {
                        direction: (direction / largest).normalize(),
                        illuminance: strength("illuminance", "lux", d.illuminance)?,
                    },
                    d.colour,
                    d.on,
                )
            }
        };
        lights.push(Light {
            name: name.to_string(),
            kind,
            colour: linear_rgb([colour.0, colour.1, colour.2]),
            on,
        });
    }
    Ok(Lighting {
        ambient: file.ambient,
        white: file.white,
        lights,
    })
}

/// Longest object or light name, bytes: names are listed, printed in errors and written into
/// exports and legends.
const MAX_OBJECT_NAME_BYTES: usize = 200;

/// Why `name` cannot name an object or a light: too long, or holding control characters
/// (a terminal would obey them, a listing would break at a newline).
fn unprintable(name: &str) -> Option<String> {
    if name.len() > MAX_OBJECT_NAME_BYTES {
        Some(format!(
            "the name is {} bytes long; at most {MAX_OBJECT_NAME_BYTES}",
            name.len()
        ))
    } else {
        name.chars()
            .find(|c| c.is_control())
            .map(|c| format!("the name holds the control character {c:?}; use printable characters"))
    }
}

/// What keeps an object's faces in the scene: its index, whether it is a mesh (whose faces
/// without area are dropped, not refused) and the library textures laid on its faces.
struct FaceKeeper<'a> {
    object: u32,
    is_mesh: bool,
    placement: Option<&'a Placement>,
    /// A Box's own texture for each of its faces, where it names one.
    face_placements: &'a [Option<Placement>],
}

impl FaceKeeper<'_> {
    /// Checks `faces` (all of a library object's, or a chunk of a mesh's) and moves them into
    /// the scene, with their surfaces, leaving `faces` empty; the number of faces dropped.
    /// Each face is checked on all threads (a million mesh triangles took 1.1 G instructions
    /// on one), then the failing ones in order: the first bad face is the one reported. Only
    /// the failing faces' places are kept (a scan may hold millions of zero-area triangles,
    /// and a message each would cost gigabytes); a failing face is checked again, in order,
    /// for its message.
    fn keep(&self, faces: &mut Vec<RawFace>, scene: &mut Scene, surfaces: &mut Surfaces) -> Result<usize, String> {
        let failing: Vec<usize> = faces
            .par_iter()
            .enumerate()
            .filter(|(_, (vertices, _, _))| {
                validate::check_coordinates(vertices).is_err() || validate::check_face(vertices).is_err()
            })
            .map(|(k, _)| k)
            .collect();
        for &k in &failing {
            validate::check_coordinates(&faces[k].0)?;
            if !self.is_mesh {
                validate::check_face(&faces[k].0)?;
            }
        }
        // Only a mesh's faces get here failing: a zero-area mesh triangle can never be hit, and
        // real scans contain many. A mesh has no library textures, so the faces' places in
        // `face_placements` below are those of a whole object that dropped none.
        if !failing.is_empty() {
            let (mut failing, mut k) = (failing.iter().peekable(), 0);
            faces.retain(|_| {
                k += 1;
                failing.next_if_eq(&&(k - 1)).is_none()
            });
        }
        for (k, (vertices, _, surface)) in faces.iter_mut().enumerate() {
            if let Some(placement) = self.face_placements.get(k).and_then(Option::as_ref).or(self.placement) {
                *surface = Some(placement.surface(vertices));
            }
        }
        let base = scene.faces.len();
        if self.is_mesh {
            // A mesh's surfaces are written on all threads, so that the pages of the list (208
            // bytes a face) are first touched on all threads too: written on one, they were a
            // sixth of a 1 M-triangle render's time (docs/benchmarks.md, "2026-11-27 evening2
            // (load)"). A chunk may mix faces with and without (a glTF's primitives of textured
            // and plain materials, docs/benchmarks.md "2026-11-27 night2 (parts)").
            let having: Vec<usize> = faces
                .iter()
                .enumerate()
                .filter(|(_, (_, _, surface))| surface.is_some())
                .map(|(k, _)| base + k)
                .collect();
            let faces = &*faces;
            surfaces.extend(
                &having,
                having.par_iter().map(|&face| {
                    let surface = faces[face - base].2.as_ref();
                    surface.expect("only faces with surfaces are listed").clone()
                }),
            );
        } else {
            for (k, (_, _, surface)) in faces.iter_mut().enumerate() {
                if let Some(surface) = surface.take() {
                    surfaces.push(base + k, surface);
                }
            }
        }
        let object = self.object;
        let face = |(vertices, colour, _): RawFace| Face {
            vertices,
            colour: [colour.0, colour.1, colour.2],
            object,
        };
        if self.is_mesh {
            scene.faces.par_extend(faces.par_drain(..).map(face));
        } else {
            scene.faces.extend(faces.drain(..).map(face));
        }
        Ok(failing.len())
    }
}

/// Mesh triangles made into faces this many at a time: the faces being made (about 300 bytes
/// each, 10 MB) are one list reused for every chunk, where a list for the whole mesh took
/// 300 MB at 1 M triangles (docs/benchmarks.md, "2026-11-27 evening2 (load)").
const MESH_CHUNK: usize = 1 << 15;

/// Loads mesh `m` and keeps its faces (through `keeping`), each part of the mesh freed once
/// kept; the number of faces dropped. Refuses it unmade if its triangles and the scene's
/// `scene_triangles` so far pass the scene's cap ([`super::MAX_TRIANGLES`]).
#[allow(clippy::too_many_arguments)]
fn keep_mesh_faces(
    m: &MeshFile,
    angles: DVec3,
    scene_path: &Path,
    bank: &mut TextureBank,
    keeping: &FaceKeeper,
    scene: &mut Scene,
    surfaces: &mut Surfaces,
    scene_triangles: usize,
) -> Result<usize, String> {
    positive("scale", m.scale)?;
    let mesh_path = crate::input::inside_folder(scene_path, &m.path, "mesh")?;
    let mut parts = mesh::load(&mesh_path, bank)?;
    let world_from_object = rotation_xyz(angles);
    let position = dvec3(m.position.0, m.position.1, m.position.2);
    let face = |triangle: &MeshTriangle| -> RawFace {
        let vertices = Vertices::from_buf(triangle.vertices.map(|v| position + world_from_object * (v * m.scale)));
        // A textured triangle without a colour of its own shows its texture untinted.
        let colour = triangle
            .colour
            .or(triangle.texture.as_ref().map(|_| [255; 3]))
            .map_or(m.colour, |c| (c[0], c[1], c[2]));
        let surface = triangle.surface(&vertices);
        (vertices, colour, surface)
    };
    // The mesh's faces and surfaces allocated once, at their size: grown by doubling, the
    // surfaces' list of a 1 M-triangle mesh passed through blocks of 436 MB in all for its 208.
    let triangles: usize = parts.iter().map(Vec::len).sum();
    // Refused from the counts before its faces are made (its triangles as read: zero-area ones,
    // dropped as the faces are made, count too).
    super::check_triangle_count(scene_triangles + triangles)
        .map_err(|e| format!("with this mesh's triangles as read (zero-area ones included), the scene has {e}"))?;
    scene.faces.reserve_exact(triangles);
    let with_surface = parts.par_iter().flatten().filter(|t| t.carries_surface()).count();
    if with_surface > 0 {
        surfaces.list.reserve_exact(with_surface);
        surfaces
            .of_face
            .reserve_exact(scene.faces.len() + triangles - surfaces.of_face.len());
    }
    let mut faces = Vec::with_capacity(MESH_CHUNK.min(triangles));
    let mut dropped = 0;
    let lengths: Vec<usize> = parts.iter().map(Vec::len).collect();
    for chunk in chunks_across(lengths, MESH_CHUNK) {
        let in_chunk: Vec<&MeshTriangle> = chunk
            .iter()
            .flat_map(|(part, range)| &parts[*part][range.clone()])
            .collect();
        faces.par_extend(in_chunk.par_iter().map(|triangle| face(triangle)));
        dropped += keeping.keep(&mut faces, scene, surfaces)?;
        // The parts made whole are freed.
        for (part, range) in &chunk {
            if range.end == parts[*part].len() {
                parts[*part] = Vec::new();
            }
        }
    }
    Ok(dropped)
}

/// Refuses a scene of `triangles` so far, this object's included, over the cap
/// ([`super::check_triangle_count`]).
fn check_scene_triangles(triangles: usize) -> Result<(), String> {
    super::check_triangle_count(triangles).map_err(|e| format!("the scene now has {e}"))
}

/// Cuts parts of `lengths` (in order) into chunks of at most `size` items, each chunk its
/// pieces: (part, range in the part). A chunk spans as many parts as fit, so that a mesh of
/// many small parts (a glTF of thousands of primitives) pays each parallel pass once a chunk
/// rather than once a part (docs/benchmarks.md, "2026-11-27 night2 (parts)"). Chunks are cut as
/// they are asked for: a file of millions of placed parts holds one chunk's pieces at a time.
fn chunks_across(
    lengths: impl IntoIterator<Item = usize>,
    size: usize,
) -> impl Iterator<Item = Vec<(usize, Range<usize>)>> {
    assert!(size > 0, "a chunk holds at least one item");
    let mut lengths = lengths.into_iter().enumerate().peekable();
    // Items of the part `lengths` is at that earlier chunks took.
    let mut at = 0;
    std::iter::from_fn(move || {
        let mut chunk = Vec::new();
        let mut room = size;
        while room > 0 {
            let Some(&(part, length)) = lengths.peek() else { break };
            let taken = (length - at).min(room);
            if taken > 0 {
                chunk.push((part, at..at + taken));
            }
            at += taken;
            room -= taken;
            if at == length {
                lengths.next();
                at = 0;
            }
        }
        (!chunk.is_empty()).then_some(chunk)
    })
}

#[cfg(test)]
mod chunk_tests {
    use super::chunks_across;

    /// Chunks hold `size` items but the last, span parts, skip empty parts and keep the order.
    #[test]
    fn chunks_span_parts_in_order() {
        let chunks = |lengths: &[usize], size| chunks_across(lengths.to_vec(), size).collect::<Vec<_>>();
        assert_eq!(
            chunks(&[3, 0, 2, 7, 1], 4),
            vec![
                vec![(0, 0..3), (2, 0..1)],
                vec![(2, 1..2), (3, 0..3)],
                vec![(3, 3..7)],
                vec![(4, 0..1)],
            ]
        );
        assert_eq!(chunks(&[0, 0], 4), Vec::<Vec<_>>::new());
        assert_eq!(chunks(&[8], 4), vec![vec![(0, 0..4)], vec![(0, 4..8)]]);
        // A part over three chunks, begun and ended inside them.
        assert_eq!(
            chunks(&[1, 10, 2], 4),
            vec![
                vec![(0, 0..1), (1, 0..3)],
                vec![(1, 3..7)],
                vec![(1, 7..10), (2, 0..1)],
                vec![(2, 1..2)]
            ]
        );
    }
}

#[cfg(test)]
mod triangle_cap_tests {
    use super::*;
    use crate::scene::{MAX_TRIANGLES, check_triangle_count};

    /// A mesh that would take the scene past the triangle cap is refused from the counts, none of
    /// its faces made, with the cap's message (which scene loading gives with the object's
    /// place); one that fits is kept.
    #[test]
    fn a_mesh_past_the_cap_is_refused_before_its_faces_are_made() {
        let dir = tempfile::tempdir().unwrap();
        let square = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
        std::fs::write(dir.path().join("square.obj"), square).unwrap();
        let mesh = MeshFile {
            name: "square".into(),
            path: "square.obj".into(),
            colour: (9, 9, 9),
            scale: 1.0,
            rotation: (0.0, 0.0, 0.0),
            position: (0.0, 0.0, 0.0),
        };
        let keeping = FaceKeeper {
            object: 0,
            is_mesh: true,
            placement: None,
            face_placements: &[],
        };
        let keep = |scene_triangles| {
            let mut scene = Scene::default();
            let kept = keep_mesh_faces(
                &mesh,
                DVec3::ZERO,
                &dir.path().join("s.ron"),
                &mut TextureBank::default(),
                &keeping,
                &mut scene,
                &mut Surfaces::default(),
                scene_triangles,
            );
            (kept, scene.faces.len())
        };
        assert_eq!(keep(MAX_TRIANGLES - 2), (Ok(0), 2));
        let refusal = check_triangle_count(MAX_TRIANGLES + 1).unwrap_err();
        assert_eq!(
            keep(MAX_TRIANGLES - 1),
            (
                Err(format!(
                    "with this mesh's triangles as read (zero-area ones included), the scene has {refusal}"
                )),
                0
            )
        );
    }
}

#[cfg(test)]
mod name_tests {
    use crate::scene::Scene;

    #[test]
    fn names_with_control_characters_or_megabytes_are_refused_and_shown_escaped() {
        for (name, expected) in [
            ("\\u{1b}[31mred", "control character"),
            ("two\\nlines", "control character"),
            (&"x".repeat(300), "300 bytes"),
        ] {
            let text = format!(
                r#"Scene(name: "s", objects: [Floor(name: "{name}", corners: [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], colour: (9, 9, 9))])"#
            );
            let message = Scene::from_ron(&text, std::path::Path::new("s.ron"))
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(message.contains(expected), "{message}");
            assert!(
                !message.contains('\u{1b}') && !message.contains("two\nlines") && message.len() < 400,
                "{message}"
            );
        }
    }
}

#[cfg(test)]
mod box_texture_tests {
    use crate::scene::{Scene, SceneError};

    fn checker(grey: u8) -> String {
        format!("(pattern: Checker(colours: (({grey}, 0, 0), (0, {grey}, 0)), squares: 2), texels: 4)")
    }

    fn load(face_textures: &str) -> Result<Scene, SceneError> {
        let text = format!(
            "Scene(name: \"s\", objects: [\n  Box(name: \"crate\", size: (1.0, 1.0, 1.0), colour: (255, 255, 255),\n    \
             texture: {},\n    face_textures: {face_textures})])",
            checker(10)
        );
        Scene::from_ron(&text, std::path::Path::new("s.ron"))
    }

    #[test]
    fn a_named_face_wins_over_sides_which_wins_over_the_box_texture() {
        let scene = load(&format!(
            "{{ \"top\": {}, \"sides\": {}, \"front\": {} }}",
            checker(20),
            checker(30),
            checker(40)
        ))
        .unwrap();
        // Textures in the order first met: the box's, then top, sides, front as BTreeMap keys
        // are placed face by face (front, back, left, right, top, bottom).
        let texture_of = |face: u32| scene.surfaces.of(face).and_then(|s| s.uv.as_ref()).map(|uv| uv.texture);
        let pattern_of = |face: u32| {
            let texture = &scene.surfaces.textures[texture_of(face).unwrap() as usize];
            texture.levels[0].texel(0, 0)[0]
        };
        // Checker texel (0, 0) is the first colour's red: the pattern's grey.
        let reds: Vec<u8> = (0..6).map(pattern_of).collect();
        assert_eq!(reds, [40, 30, 30, 30, 20, 10], "front, back, left, right, top, bottom");
        // Four faces share the sides' texture: baked once.
        assert_eq!(scene.surfaces.textures.len(), 4);
    }

    #[test]
    fn unknown_faces_and_bad_fields_are_located() {
        let error = load(&format!("{{ \"lid\": {} }}", checker(20)))
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("unknown face 'lid' in face_textures") && error.contains("sides"),
            "{error}"
        );
        // 1e-300 shown as such, not as its 300 zeros.
        let bad = "{ \"top\": (pattern: Checker(colours: ((0, 0, 0), (9, 9, 9)), squares: 2), scale: (0.0, 1e-300)) }";
        let error = load(bad).unwrap_err().to_string();
        assert!(error.contains("face_textures.\"top\".scale"), "{error}");
        assert!(error.contains("not (0, 1e-300)") && error.len() < 400, "{error}");
        // Line 4 of the file, where face_textures is written.
        assert!(error.contains("s.ron:4:"), "{error}");
    }
}
