//! Wavefront OBJ meshes through tobj, with their MTL materials: `Kd` (the face colour, a
//! linear reflectance) and `map_Kd` (a texture read through the `vt` coordinates, tinted by
//! `Kd` as the MTL format says). Every file of every `mtllib` line is opened under the rules of
//! meshes: relative to the OBJ's folder and inside it, regular files of bounded size together. A `map_Kd` statement's
//! options are read (`-s` and `-o` scale and shift the texture coordinates, `-clamp on` clamps
//! them; the others, which change no base colour omnisim shows, are passed over), and a
//! Windows path's backslashes are taken as folder separators.

use std::cell::{Cell, RefCell};
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use glam::{DVec2, dvec3};

use super::lighting::linear_to_srgb;
use super::mesh_data::{CornerUvs, MeshTextures, MeshTriangle, mean_colour, uv_from_v_up};
use super::texture::Wrap;

/// Most bytes of MTL files one OBJ reads, all its `mtllib` files together.
const MTL_LIMIT: u64 = 16 << 20;

/// One material as the triangles use it: sRGB face colour and texture, if any.
struct Material {
    colour: Option<[u8; 3]>,
    texture: Option<(u32, TextureMap)>,
}

/// A `map_Kd` statement: its file and the options that change where texels land.
#[derive(Clone, Copy, Default)]
struct TextureMap {
    /// `-s u v`: texture coordinates scaled (1, 1 when absent).
    scale: Option<DVec2>,
    /// `-o u v`: texture coordinates shifted, after scaling.
    offset: DVec2,
    /// `-clamp on`.
    clamp: bool,
}

/// The file name and options of a `map_Kd` statement's text (after `map_Kd`).
fn texture_map(text: &str) -> Result<(String, TextureMap), String> {
    let mut map = TextureMap::default();
    let mut words = text.split_whitespace().peekable();
    let bad = |option: &str| format!("map_Kd {text}: the option {option} lacks its value");
    while let Some(&option) = words.peek() {
        if !option.starts_with('-') {
            break;
        }
        words.next();
        // Up to three numbers (u, v, w); omitted ones as the MTL format defaults them.
        let mut numbers = |default: f64| {
            let mut values = Vec::new();
            while values.len() < 3
                && let Some(value) = words.peek().and_then(|w| w.parse::<f64>().ok())
            {
                values.push(value);
                words.next();
            }
            let first = *values.first().ok_or_else(|| bad(option))?;
            Ok::<DVec2, String>(DVec2::new(first, values.get(1).copied().unwrap_or(default)))
        };
        match option {
            "-s" => map.scale = Some(numbers(1.0)?),
            "-o" => map.offset = numbers(0.0)?,
            "-t" => {
                numbers(0.0)?;
            }
            "-mm" => {
                numbers(0.0)?;
            }
            "-clamp" => map.clamp = words.next().ok_or_else(|| bad(option))? == "on",
            "-blendu" | "-blendv" | "-bm" | "-boost" | "-cc" | "-imfchan" | "-texres" | "-type" => {
                words.next().ok_or_else(|| bad(option))?;
            }
            other => {
                return Err(format!(
                    "map_Kd {text}: {other} is no option of the MTL format (-blendu, -blendv, -bm, -boost, -cc, \
                     -clamp, -imfchan, -mm, -o, -s, -t, -texres, -type)"
                ));
            }
        }
    }
    let file = words.collect::<Vec<_>>().join(" ").replace('\\', "/");
    if file.is_empty() {
        return Err(format!("map_Kd {text}: names no file"));
    }
    Ok((file, map))
}

/// An MTL's text with every colour statement (`Ka`, `Kd`, `Ks`, `Ke`) of one number written
/// out as three: the format lets `Kd r` stand for `Kd r r r`, and tobj panics on fewer than
/// three. Two numbers are refused, naming the line.
fn colours_of_three(text: &str) -> Result<String, String> {
    let mut out = String::with_capacity(text.len());
    for (number, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match (words.next(), words.clone().count()) {
            (Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")), 1) => {
                let r = words.next().unwrap_or_default();
                out += &format!("{key} {r} {r} {r}");
            }
            (Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")), 0 | 2) => {
                return Err(format!(
                    "line {}: {key} needs one number (grey) or three (r g b)",
                    number + 1
                ));
            }
            _ => out += line,
        }
        out.push('\n');
    }
    Ok(out)
}

/// MTL file names an OBJ's `mtllib` lines may give in all (a name given twice counts twice): a
/// bound on the paths made and files opened, which the byte budget alone does not give (a line
/// of many names of empty files reads no bytes).
const MAX_MTL_FILES: usize = 64;

/// The files of an `mtllib` line: the whole line where it names a file (a name with spaces, as
/// Blender writes it), else each of its words (the format's list of names); `named` counts the
/// OBJ's names so far, which may not pass [`MAX_MTL_FILES`].
fn mtl_files(mesh: &Path, line: &str, named: &Cell<usize>) -> Result<Vec<PathBuf>, String> {
    let whole = crate::input::inside_folder(mesh, line, "mtllib");
    let one_file = !line.contains(char::is_whitespace) || whole.as_ref().is_ok_and(|path| path.is_file());
    let count = if one_file { 1 } else { line.split_whitespace().count() };
    if named.get() + count > MAX_MTL_FILES {
        return Err(format!(
            "mtllib: the OBJ's mtllib lines give more than {MAX_MTL_FILES} MTL file names in all (a name given \
             twice counts twice); name each file once, or merge the materials into fewer files"
        ));
    }
    named.set(named.get() + count);
    if one_file {
        return whole.map(|path| vec![path]);
    }
    line.split_whitespace()
        .map(|name| crate::input::inside_folder(mesh, name, "mtllib"))
        .collect()
}

/// The materials of MTL file `path` (a regular file) as tobj reads them, its bytes added to
/// `read`, the OBJ's MTL bytes so far, which may not pass [`MTL_LIMIT`].
fn read_mtl(path: &Path, read: &Cell<u64>) -> Result<tobj::MTLLoadResult, String> {
    let left = MTL_LIMIT - read.get();
    let mut bytes = Vec::new();
    crate::input::open_regular(path, MTL_LIMIT)
        .map_err(|e| format!("mtllib: {e}"))?
        .take(left + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("mtllib: {e}"))?;
    let named = |problem: &str| format!("mtllib {}: {problem}", path.display());
    if bytes.len() as u64 > left {
        return Err(named(&format!(
            "the OBJ's MTL files hold more than {MTL_LIMIT} bytes together"
        )));
    }
    read.set(read.get() + bytes.len() as u64);
    let text = colours_of_three(&String::from_utf8_lossy(&bytes)).map_err(|e| named(&e))?;
    Ok(tobj::load_mtl_buf(&mut text.as_bytes()))
}

/// Reads an OBJ's triangles, their vertex colours, and through its MTL their colours and
/// textures.
pub(super) fn load_obj(mut reader: impl BufRead, textures: &mut MeshTextures) -> Result<Vec<MeshTriangle>, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // tobj's material loader can only say that it failed: the first reason waits here.
    let mtl_problem: RefCell<Option<String>> = RefCell::new(None);
    // The bytes of MTL files read for all of the OBJ's `mtllib` lines, against one MTL_LIMIT.
    let mtl_bytes = Cell::new(0u64);
    // The MTL file names given so far, against MAX_MTL_FILES.
    let mtl_named = Cell::new(0usize);
    let load_mtl = |line: &Path| {
        let libraries = line
            .to_str()
            .ok_or_else(|| "the mtllib name is not UTF-8".to_string())
            .and_then(|line| mtl_files(textures.mesh, line, &mtl_named))
            .and_then(|files| {
                files
                    .iter()
                    .map(|file| {
                        read_mtl(file, &mtl_bytes)?
                            .map_err(|_| format!("mtllib {}: not a readable MTL file", file.display()))
                    })
                    .collect::<Result<Vec<_>, _>>()
            });
        match libraries {
            // One library, as tobj merges those of several `mtllib` lines: a later file's
            // material takes the name of an earlier one.
            Ok(libraries) => Ok(libraries
                .into_iter()
                .reduce(|(mut materials, mut names), (more, more_names)| {
                    let offset = materials.len();
                    materials.extend(more);
                    names.extend(more_names.into_iter().map(|(name, i)| (name, i + offset)));
                    (materials, names)
                })
                .unwrap_or_default()),
            Err(problem) => {
                mtl_problem.borrow_mut().get_or_insert(problem);
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    };
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, load_mtl).map_err(|e| {
        let unlocated = || format!("not a readable OBJ file: {e}");
        match e {
            // tobj names only the kind of index: the file is read again to find the face.
            tobj::LoadError::FaceVertexOutOfBounds
            | tobj::LoadError::FaceTexCoordOutOfBounds
            | tobj::LoadError::FaceNormalOutOfBounds => bad_face_index(textures.mesh).unwrap_or_else(unlocated),
            _ => unlocated(),
        }
    })?;
    if let Some(problem) = mtl_problem.into_inner() {
        return Err(problem);
    }
    // An OBJ without an mtllib has no materials; one whose mtllib failed was refused above.
    let materials = materials.unwrap_or_default();
    // Every material's texture at once: they decode on all threads.
    let maps = materials
        .iter()
        .filter_map(|m| m.diffuse_texture.as_deref())
        .map(texture_map)
        .collect::<Result<Vec<_>, String>>()?;
    let names: Vec<&str> = maps.iter().map(|(file, _)| file.as_str()).collect();
    let mut images = textures
        .images(&names)?
        .into_iter()
        .zip(maps.iter().map(|(_, map)| *map));
    let materials: Vec<Material> = materials
        .iter()
        .map(|m| Material {
            colour: m.diffuse.map(|kd| kd.map(|k| linear_to_srgb(f64::from(k)))),
            texture: m.diffuse_texture.as_ref().and_then(|_| images.next()),
        })
        .collect();
    let mut triangles = Vec::new();
    for model in models {
        let mesh = &model.mesh;
        let missing = |what: &str| {
            bad_face_index(textures.mesh)
                .unwrap_or_else(|| format!("object '{}' refers to a {what} that does not exist", model.name))
        };
        let position = |i: u32| {
            let i = i as usize * 3;
            mesh.positions
                .get(i..i + 3)
                .map(|p| dvec3(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
                .ok_or_else(|| missing("vertex"))
        };
        let colour = |i: u32| {
            let i = i as usize * 3;
            mesh.vertex_color
                .get(i..i + 3)
                .map(|c| [c[0], c[1], c[2]].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
        };
        let material = match mesh.material_id {
            Some(id) => Some(materials.get(id).ok_or_else(|| missing("material"))?),
            None => None,
        };
        let texture = material.and_then(|m| m.texture).filter(|_| !mesh.texcoords.is_empty());
        for (t, corners) in mesh.indices.chunks_exact(3).enumerate() {
            let corner_colours: Option<Vec<[u8; 3]>> = corners.iter().map(|&i| colour(i)).collect();
            let uv = |i: u32| {
                let i = i as usize * 2;
                let what = || format!("object '{}' triangle {t}", model.name);
                let uv = mesh
                    .texcoords
                    .get(i..i + 2)
                    .ok_or_else(|| missing("texture coordinate"))?;
                let map = texture.map(|(_, map)| map).unwrap_or_default();
                let uv = DVec2::new(f64::from(uv[0]), f64::from(uv[1])) * map.scale.unwrap_or(DVec2::ONE) + map.offset;
                uv_from_v_up(uv.x, uv.y, &what)
            };
            let texture = match texture {
                Some((texture, map)) => Some(CornerUvs {
                    texture,
                    wrap: [if map.clamp { Wrap::Clamp } else { Wrap::Repeat }; 2],
                    uv: [uv(corners[0])?, uv(corners[1])?, uv(corners[2])?],
                }),
                None => None,
            };
            triangles.push(MeshTriangle {
                vertices: [position(corners[0])?, position(corners[1])?, position(corners[2])?],
                colour: material
                    .and_then(|m| m.colour)
                    .or_else(|| mean_colour(corner_colours.iter().flatten().map(|&c| Some(c)))),
                texture,
                corner_colours: corner_colours.map(|c| [c[0], c[1], c[2]]),
                unlit: false,
            });
        }
    }
    Ok(triangles)
}

/// The elements an OBJ face corner's `v/vt/vn` indices name: statement, one, several.
const CORNER_ELEMENTS: [(&str, &str, &str); 3] = [
    ("v", "vertex", "vertices"),
    ("vt", "texture coordinate", "texture coordinates"),
    ("vn", "normal", "normals"),
];

/// The first face index of the OBJ at `path` that names no element, with its line, the
/// element count and how to mend it; else the first that names an element defined only after
/// its face (tobj reads a face against the elements before its object ends). Read again, after
/// tobj refused the file (its error names no line), so that a good file pays nothing for it.
/// `None` where every index is in range.
fn bad_face_index(path: &Path) -> Option<String> {
    let mut text = Vec::new();
    crate::input::open_regular(path, crate::input::MESH_LIMIT)
        .ok()?
        .read_to_end(&mut text)
        .ok()?;
    let text = String::from_utf8_lossy(&text);
    let element = |line: &str| {
        let key = line.split_whitespace().next()?;
        CORNER_ELEMENTS.iter().position(|&(statement, _, _)| statement == key)
    };
    let mut totals = [0i128; 3];
    for k in text.lines().filter_map(element) {
        totals[k] += 1;
    }
    let mut defined = [0i128; 3];
    let mut later = None;
    for (number, line) in text.lines().enumerate() {
        if let Some(k) = element(line) {
            defined[k] += 1;
            continue;
        }
        let mut words = line.split_whitespace();
        if !matches!(words.next(), Some("f" | "l")) {
            continue;
        }
        for corner in words {
            for (k, index) in corner.split('/').enumerate().take(3) {
                // tobj passes over vt and vn indices where the file has none of them.
                let Ok(raw) = index.parse::<i128>() else { continue };
                if k > 0 && totals[k] == 0 {
                    continue;
                }
                let at = if raw < 0 { defined[k] + raw } else { raw - 1 };
                let (statement, one, several) = CORNER_ELEMENTS[k];
                let out_of_range = |count: i128, before: &str| {
                    format!(
                        "line {}: face index {raw} names no {one}: the file has {count} {several} (`{statement}` \
                         lines){before}; OBJ indices count from 1, and negative ones back from the face: mend the \
                         face or re-export the file",
                        number + 1
                    )
                };
                if at < 0 {
                    return Some(out_of_range(defined[k], " before this face"));
                }
                if at >= totals[k] {
                    return Some(out_of_range(totals[k], ""));
                }
                if at >= defined[k] && later.is_none() {
                    later = Some(out_of_range(defined[k], " before this face"));
                }
            }
        }
    }
    later
}
