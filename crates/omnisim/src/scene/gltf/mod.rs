//! glTF 2.0 (`.gltf` with its buffers and images, or one `.glb`) through the gltf crate: the
//! default scene's node hierarchy with its transforms, triangle primitives (lists, strips and
//! fans), `baseColorFactor`, `baseColorTexture` (its sampler's wrap modes and its `texCoord`
//! set; or `KHR_materials_pbrSpecularGlossiness`'s diffuse factor and texture), `COLOR_0`, `KHR_texture_transform`, `KHR_materials_unlit`, `KHR_mesh_quantization`,
//! `EXT_mesh_gpu_instancing` and `EXT_texture_webp`.
//!
//! A glTF file becomes one scene object, each of its triangles a face (as for PLY and OBJ).
//! Buffers and images are resolved here rather than by gltf's `import`, so that a file opens
//! nothing outside the scene's folder: external URIs go through the mesh path rules, `data:`
//! URIs are decoded, and accessors are read by `accessor.rs` (every component type, sparse
//! and view-less ones) with every range checked first. What omnisim cannot show faithfully
//! (Draco and meshopt compression, compressed textures, any other required extension, points
//! and lines) is refused by name.

mod accessor;

use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

use base64::Engine as _;
use glam::{DMat4, DQuat, DVec2, DVec3, DVec4};
use gltf::accessor::Dimensions;
use gltf::mesh::Mode;
use gltf::texture::WrappingMode;
use rayon::prelude::*;

use super::lighting::linear_to_srgb;
use super::mesh_data::{CornerUvs, MAX_MESH_TRIANGLES, MeshParts, MeshTextures, MeshTriangle};
use super::texture::{self, PendingImage, Wrap};

/// Extensions omnisim implements; any other listed in `extensionsRequired` is refused.
const SUPPORTED_EXTENSIONS: [&str; 6] = [
    "KHR_texture_transform",
    "KHR_materials_unlit",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_mesh_quantization",
    "EXT_mesh_gpu_instancing",
    "EXT_texture_webp",
];

/// How to make a file that requires `extension` readable, for its refusal.
fn without_extension(extension: &str) -> &'static str {
    match extension {
        "KHR_draco_mesh_compression" => {
            "re-export without Draco compression (Blender: glTF export, Data > Compression off; gltf-pipeline \
             without -d)"
        }
        "EXT_meshopt_compression" => "re-export without meshopt compression (gltfpack without -c or -cc)",
        "KHR_texture_basisu" | "EXT_texture_avif" | "MSFT_texture_dds" => "re-export its textures as PNG, JPEG or WebP",
        _ => "re-export without it",
    }
}

/// Deepest node hierarchy followed, and most node visits (a node may be shared): a file whose
/// hierarchy loops or multiplies beyond these is refused rather than followed forever.
const MAX_DEPTH: usize = 256;
const MAX_NODE_VISITS: usize = 1_000_000;

/// Largest external buffer file read.
const BUFFER_LIMIT: u64 = crate::input::MESH_LIMIT;

/// What one primitive's material gives its triangles.
struct Look {
    colour: [u8; 3],
    factor: DVec4,
    /// The bank index of its image and the wrap modes (its coordinates: [`Sources::uvs`]).
    texture: Option<(u32, [Wrap; 2])>,
    unlit: bool,
}

/// `KHR_texture_transform`: uv' = offset + R(rotation) · (scale ⊙ uv), as the extension's GLSL
/// states it.
#[derive(Clone, Copy)]
struct UvTransform {
    offset: DVec2,
    rotation: f64,
    scale: DVec2,
}

impl UvTransform {
    const IDENTITY: UvTransform = UvTransform {
        offset: DVec2::ZERO,
        rotation: 0.0,
        scale: DVec2::ONE,
    };

    /// The transform's numbers, bit for bit: texture coordinates read under equal bits are equal.
    fn bits(self) -> [u64; 5] {
        [self.offset.x, self.offset.y, self.rotation, self.scale.x, self.scale.y].map(f64::to_bits)
    }

    fn apply(self, uv: DVec2) -> DVec2 {
        let s = uv * self.scale;
        let (sin, cos) = self.rotation.sin_cos();
        self.offset + DVec2::new(cos * s.x - sin * s.y, sin * s.x + cos * s.y)
    }
}

/// Reads a glTF or GLB file's triangles (`bytes` its whole content): a part for each
/// placement of a primitive, in the order the node hierarchy is walked.
pub(super) fn load_gltf(bytes: &[u8], textures: &mut MeshTextures) -> Result<MeshParts, String> {
    let gltf = parse(bytes)?;
    let document = &gltf.document;
    let buffers = document
        .buffers()
        .map(|buffer| load_buffer(&buffer, gltf.blob.as_deref(), textures))
        .collect::<Result<Vec<_>, _>>()?;
    let placed = placements(document, &buffers)?;
    // Points and lines first: their accessors' counts are no triangles for the cap below.
    for (mesh, _) in &placed {
        if let Some(primitive) = mesh
            .primitives()
            .find(|primitive| triangles_of(primitive.mode(), 3).is_none())
        {
            return Err(format!(
                "mesh {} primitive {}: its mode is {:?}; omnisim reads triangle primitives only (lists, strips \
                 and fans): points and lines have no surface to see",
                mesh.index(),
                primitive.index(),
                primitive.mode()
            ));
        }
    }
    // The triangle cap, from the accessors' counts before anything is read: the primitives
    // are read all at once below, and several may share one large index accessor.
    let mut placed_triangles = 0usize;
    for (mesh, _) in &placed {
        for primitive in mesh.primitives() {
            let Some(corners) = primitive
                .indices()
                .or_else(|| primitive.get(&gltf::Semantic::Positions))
            else {
                continue;
            };
            let triangles = triangles_of(primitive.mode(), corners.count()).unwrap_or(0);
            placed_triangles = placed_triangles.saturating_add(triangles);
            if placed_triangles > MAX_MESH_TRIANGLES {
                return Err(format!(
                    "mesh {} primitive {} (accessor {}, {} corners): {}",
                    mesh.index(),
                    primitive.index(),
                    corners.index(),
                    corners.count(),
                    too_many_triangles()
                ));
            }
        }
    }
    // Each primitive once, however many nodes place it, in the order first placed.
    let mut primitives: Vec<(usize, gltf::Primitive)> = Vec::new();
    let mut slot_of: HashMap<(usize, usize), usize> = HashMap::new();
    for (mesh, _) in &placed {
        for primitive in mesh.primitives() {
            if let Entry::Vacant(entry) = slot_of.entry((mesh.index(), primitive.index())) {
                entry.insert(primitives.len());
                primitives.push((mesh.index(), primitive));
            }
        }
    }
    within_read_budget(&primitives, &buffers)?;
    let images = load_images(&primitives, document, &buffers, textures)?;
    let shared = SharedReads::new(&primitives, document.accessors().len());
    // On all threads.
    let mut read: Vec<Result<Vec<MeshTriangle>, String>> = primitives
        .par_iter()
        .map(|(mesh, primitive)| {
            read_primitive(primitive, &buffers, &images, &shared)
                .map_err(|e| format!("mesh {mesh} primitive {}: {e}", primitive.index()))
        })
        .collect();
    // How many placements of each primitive are still to come: the last one takes its
    // triangles instead of copying them (a primitive placed once is never copied).
    let mut uses = vec![0usize; primitives.len()];
    for (mesh, _) in &placed {
        for primitive in mesh.primitives() {
            uses[slot_of[&(mesh.index(), primitive.index())]] += 1;
        }
    }
    let mut parts = Vec::new();
    for (mesh, world) in &placed {
        for primitive in mesh.primitives() {
            let slot = slot_of[&(mesh.index(), primitive.index())];
            let local = read[slot].as_mut().map_err(|e| e.clone())?;
            uses[slot] -= 1;
            let part = if uses[slot] == 0 {
                std::mem::take(local)
            } else {
                local.clone()
            };
            parts.push((part, world));
        }
    }
    // Placed in one parallel pass over all parts, not one a part: a file of 200,000 primitives
    // spent most of its load handing them to the threads one by one (docs/benchmarks.md,
    // "2026-11-27 night2 (parts)").
    // A mirroring node (negative determinant) makes the file's clockwise triangles the front
    // ones (glTF 2.0, 3.7.2.1): each is turned round so that the faces keep their front.
    parts.par_iter_mut().for_each(|(part, world)| {
        let mirrored = world.determinant() < 0.0;
        part.par_iter_mut().with_min_len(PLACED_TOGETHER).for_each(|triangle| {
            triangle.vertices = triangle.vertices.map(|vertex| world.transform_point3(vertex));
            if mirrored {
                triangle.reverse_winding();
            }
        });
    });
    Ok(parts.into_iter().map(|(part, _)| part).collect())
}

/// The accessors one primitive's triangles are read from: the one list that the read budget,
/// the shared reads and the read itself take them from.
struct Sources<'a> {
    positions: Option<gltf::Accessor<'a>>,
    /// The TEXCOORD set the base colour texture reads, its `KHR_texture_transform`, and the
    /// primitive's accessor of that set, if it has one.
    uvs: Option<(u32, UvTransform, Option<gltf::Accessor<'a>>)>,
    indices: Option<gltf::Accessor<'a>>,
    colours: Option<gltf::Accessor<'a>>,
}

impl<'a> Sources<'a> {
    fn of(primitive: &gltf::Primitive<'a>) -> Sources<'a> {
        let uvs = base_colour(&primitive.material()).1.map(|info| {
            let (set, transform) = texture_coordinates(&info);
            (set, transform, primitive.get(&gltf::Semantic::TexCoords(set)))
        });
        Sources {
            positions: primitive.get(&gltf::Semantic::Positions),
            uvs,
            indices: primitive.indices(),
            colours: primitive.get(&gltf::Semantic::Colors(0)),
        }
    }
}

/// Fewest elements the primitives of one file may read together, whatever its buffers' size.
const READ_FLOOR: usize = 1 << 20;

/// Refuses a file whose primitives would read more elements, all together, than its buffers
/// hold bytes (plus [`READ_FLOOR`]), before anything is read. Each accessor is bounded alone,
/// but accessors without a buffer view (zeros), or many over one view, each read by a
/// primitive, took a 1 MB file to 950 MB. Every element a file stores takes a byte at least,
/// so only such accessors pass. Counted as `read_primitive` reads: a POSITION or TEXCOORD list
/// once for all the primitives that share it ([`SharedReads`]), indices and `COLOR_0` for each
/// primitive.
fn within_read_budget(primitives: &[(usize, gltf::Primitive)], buffers: &[Vec<u8>]) -> Result<(), String> {
    let budget = buffers.iter().map(Vec::len).sum::<usize>().saturating_add(READ_FLOOR);
    let mut shared_positions = HashSet::new();
    let mut shared_uvs = HashSet::new();
    let mut read = 0usize;
    for (mesh, primitive) in primitives {
        let sources = Sources::of(primitive);
        // Named only in an error (formatting every name cost a twentieth of a many-part read:
        // docs/benchmarks.md, "2026-11-27 night2 (parts)"); a TEXCOORD list with its set.
        let positions = sources
            .positions
            .filter(|positions| shared_positions.insert(positions.index()));
        let uvs = sources.uvs.and_then(|(set, transform, uvs)| {
            uvs.filter(|uvs| shared_uvs.insert((uvs.index(), transform.bits())))
                .map(|uvs| (uvs, "TEXCOORD", Some(set)))
        });
        let reads = [
            positions.map(|positions| (positions, "POSITION", None)),
            uvs,
            sources.indices.map(|indices| (indices, "indices", None)),
            sources.colours.map(|colours| (colours, "COLOR_0", None)),
        ];
        for (accessor, name, set) in reads.into_iter().flatten() {
            read = read.saturating_add(accessor.count());
            if read > budget {
                let what = set.map_or_else(|| name.to_string(), |set| format!("{name}_{set}"));
                let view = if accessor.view().is_some() {
                    ""
                } else {
                    "no buffer view and "
                };
                return Err(format!(
                    "mesh {mesh} primitive {}: accessor {} ({what}) has {view}{} elements, which bring the elements \
                     read to {read}, more than the file's buffer bytes (plus {READ_FLOOR}), {budget}, could hold: \
                     its accessors lack buffer views or overlap; re-export the file, each accessor over its own bytes",
                    primitive.index(),
                    accessor.index(),
                    accessor.count()
                ));
            }
        }
    }
    Ok(())
}

/// The instance transforms of `node`'s `EXT_mesh_gpu_instancing`, each applied after the
/// node's own (as a child node of that TRS would be), or `None` without the extension. More
/// than `most` instances are refused from the accessors' counts, before any is read.
fn instances(
    node: &gltf::Node,
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    most: usize,
) -> Result<Option<Vec<DMat4>>, String> {
    let Some(extension) = node.extension_value("EXT_mesh_gpu_instancing") else {
        return Ok(None);
    };
    let what = format!("node {} (EXT_mesh_gpu_instancing)", node.index());
    let attribute = |name: &str| match extension.get("attributes").and_then(|list| list.get(name)) {
        None => Ok(None),
        Some(index) => index
            .as_u64()
            .and_then(|i| document.accessors().nth(usize::try_from(i).ok()?))
            .map(Some)
            .ok_or_else(|| format!("{what}: its {name} names no accessor")),
    };
    let in_node = |e: String| format!("{what}: {e}");
    let [translation, rotation, scale] = ["TRANSLATION", "ROTATION", "SCALE"].map(attribute);
    let (translation, rotation, scale) = (translation?, rotation?, scale?);
    if let Some(accessor) = [&translation, &rotation, &scale]
        .into_iter()
        .flatten()
        .find(|accessor| accessor.count() > most)
    {
        return Err(format!(
            "{what}: accessor {} holds {} instances, and with them the node visits pass {MAX_NODE_VISITS}",
            accessor.index(),
            accessor.count()
        ));
    }
    let translations = translation
        .as_ref()
        .map(|a| accessor::read(a, buffers, "TRANSLATION", DVec3::from_array))
        .transpose()
        .map_err(in_node)?;
    let rotations = rotation
        .as_ref()
        .map(|a| accessor::read(a, buffers, "ROTATION", |[x, y, z, w]| DQuat::from_xyzw(x, y, z, w)))
        .transpose()
        .map_err(in_node)?;
    let scales = scale
        .as_ref()
        .map(|a| accessor::read(a, buffers, "SCALE", DVec3::from_array))
        .transpose()
        .map_err(in_node)?;
    let counts = [
        translations.as_ref().map(Vec::len),
        rotations.as_ref().map(Vec::len),
        scales.as_ref().map(Vec::len),
    ];
    let count = counts
        .iter()
        .flatten()
        .copied()
        .max()
        .ok_or_else(|| format!("{what}: it has none of TRANSLATION, ROTATION and SCALE"))?;
    if counts.iter().flatten().any(|&n| n != count) {
        let listed: Vec<String> = ["TRANSLATION", "ROTATION", "SCALE"]
            .iter()
            .zip([&translation, &rotation, &scale])
            .filter_map(|(name, accessor)| {
                let accessor = accessor.as_ref()?;
                Some(format!("accessor {} ({name}) {}", accessor.index(), accessor.count()))
            })
            .collect();
        return Err(format!(
            "{what}: its TRANSLATION, ROTATION and SCALE counts differ ({}); give each one per instance",
            listed.join(", ")
        ));
    }
    (0..count)
        .map(|i| {
            let instance = DMat4::from_scale_rotation_translation(
                scales.as_ref().map_or(DVec3::ONE, |s| s[i]),
                // Normalized integer quaternions are only nearly unit ones.
                rotations.as_ref().map_or(DQuat::IDENTITY, |r| r[i].normalize()),
                translations.as_ref().map_or(DVec3::ZERO, |t| t[i]),
            );
            if instance.is_finite() {
                Ok(instance)
            } else {
                Err(format!("{what}: instance {i}'s transform is not finite"))
            }
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// The document of `bytes`, validated by gltf-json except where gltf-json refuses what omnisim
/// reads: `KHR_mesh_quantization` (which gltf-json does not know) and accessors without a
/// buffer view (all zeros by the spec; gltf-json asks for a view). A required extension
/// omnisim lacks is refused by name, with how to re-export the file without it.
fn parse(bytes: &[u8]) -> Result<gltf::Gltf, String> {
    use gltf::json::validation::{Error, Validate};
    let gltf =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| format!("not a readable glTF 2.0 file: {e}"))?;
    if let Some(unsupported) = gltf
        .document
        .extensions_required()
        .find(|name| !SUPPORTED_EXTENSIONS.contains(name))
    {
        return Err(format!(
            "the file requires the extension {unsupported}, which omnisim does not support (it reads {}); {}",
            SUPPORTED_EXTENSIONS.join(", "),
            without_extension(unsupported)
        ));
    }
    let json = gltf.document.as_json();
    // gltf-json's own check of a POSITION accessor indexes the accessors unchecked (a panic):
    // every attribute's accessor is checked here first.
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive
                .attributes
                .values()
                .map(gltf::json::Index::value)
                .find(|&index| index >= json.accessors.len())
            {
                return Err(format!(
                    "mesh {m} primitive {p}: an attribute names accessor {index}, but the file has {}",
                    json.accessors.len()
                ));
            }
        }
    }
    let mut problems = Vec::new();
    json.validate(json, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        let at = path.as_str();
        // A texture's own source may be left out for `EXT_texture_webp`'s (`texture_image`).
        let read_here = at.starts_with("extensionsRequired")
            || (at.starts_with("accessors[") && at.ends_with("].bufferView") && error == Error::Missing)
            || (at.starts_with("textures[") && at.ends_with("].source") && error == Error::Missing);
        if !read_here {
            problems.push(format!("{path}: {error}"));
        }
    });
    if !problems.is_empty() {
        return Err(format!("not a readable glTF 2.0 file: {}", problems.join("; ")));
    }
    Ok(gltf)
}

/// How many triangles a primitive of `mode` draws through `corners` vertices; `None` for
/// points and lines.
fn triangles_of(mode: Mode, corners: usize) -> Option<usize> {
    match mode {
        Mode::Triangles => Some(corners / 3),
        Mode::TriangleStrip | Mode::TriangleFan => Some(corners.saturating_sub(2)),
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => None,
    }
}

/// The corners of each triangle, three by three, of a primitive of `mode` drawn through the
/// vertices `order`, as glTF 2.0 (3.7.2.1) defines them: a strip's odd triangles flipped so
/// that all keep one winding (pᵢ = {vᵢ, vᵢ₊₁₊ᵢ﹪₂, vᵢ₊₂₋ᵢ﹪₂}), a fan's around its first
/// vertex (pᵢ = {vᵢ₊₁, vᵢ₊₂, v₀}).
fn triangle_corners(mode: Mode, order: Vec<u32>) -> Result<Vec<u32>, String> {
    let n = order.len();
    match mode {
        Mode::Triangles if n.is_multiple_of(3) => Ok(order),
        Mode::Triangles => Err(format!("{n} indices is not a whole number of triangles")),
        Mode::TriangleStrip | Mode::TriangleFan if n < 3 => {
            Err(format!("its {mode:?} has {n} vertices; a strip or fan needs 3 or more"))
        }
        Mode::TriangleStrip => Ok((0..n - 2)
            .flat_map(|i| [order[i], order[i + 1 + i % 2], order[i + 2 - i % 2]])
            .collect()),
        Mode::TriangleFan => Ok((0..n - 2)
            .flat_map(|i| [order[i + 1], order[i + 2], order[0]])
            .collect()),
        other => Err(format!("its mode is {other:?}, not triangles")),
    }
}

/// Fewest triangles of a part placed by one task: a small primitive's stay on one thread.
const PLACED_TOGETHER: usize = 4096;

/// The meshes of the default scene's node hierarchy (else of the first scene, else of every
/// root node: one that is no node's child), each with its node's world transform, in the order
/// the hierarchy is walked.
fn placements<'a>(document: &'a gltf::Document, buffers: &[Vec<u8>]) -> Result<Vec<(gltf::Mesh<'a>, DMat4)>, String> {
    let roots: Vec<gltf::Node> = if let Some(scene) = document.default_scene().or_else(|| document.scenes().next()) {
        scene.nodes().collect()
    } else {
        let mut is_child = vec![false; document.nodes().len()];
        for child in document.nodes().flat_map(|node| node.children()) {
            is_child[child.index()] = true;
        }
        document.nodes().filter(|node| !is_child[node.index()]).collect()
    };
    let mut stack: Vec<(gltf::Node, DMat4, usize)> = roots.into_iter().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    let mut visits = 0usize;
    let mut placed = Vec::new();
    while let Some((node, parent, depth)) = stack.pop() {
        visits += 1;
        if depth > MAX_DEPTH || visits > MAX_NODE_VISITS {
            return Err(format!(
                "node {}: the node hierarchy is deeper than {MAX_DEPTH} or has more than {MAX_NODE_VISITS} node \
                 visits (a loop?)",
                node.index()
            ));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if !world.is_finite() {
            return Err(format!("node {}: its transform is not finite", node.index()));
        }
        if let Some(mesh) = node.mesh() {
            match instances(&node, document, buffers, MAX_NODE_VISITS - visits)? {
                None => placed.push((mesh, world)),
                Some(instances) => {
                    // Each instance a placement, counted as a node visit against the cap
                    // (`instances` refuses more than the visits left).
                    visits += instances.len();
                    placed.extend(instances.into_iter().map(|instance| (mesh.clone(), world * instance)));
                }
            }
        }
        stack.extend(node.children().map(|child| (child, world, depth + 1)));
    }
    Ok(placed)
}

/// The image `texture` shows: `EXT_texture_webp`'s source where it names one (the texture's
/// own `source` is then a fallback for viewers without WebP), else the texture's own.
fn texture_image<'a>(texture: &gltf::Texture, document: &'a gltf::Document) -> Result<gltf::Image<'a>, String> {
    let webp = texture
        .extension_value("EXT_texture_webp")
        .and_then(|webp| webp.get("source")?.as_u64());
    // gltf-json marks a texture without a source by u32::MAX, which names no image.
    let own = document.as_json().textures[texture.index()].source.value() as u64;
    let index = webp.unwrap_or(own);
    usize::try_from(index)
        .ok()
        .and_then(|index| document.images().nth(index))
        .ok_or_else(|| match webp {
            Some(index) => format!(
                "texture {}: its EXT_texture_webp source names image {index}, but the file has {}",
                texture.index(),
                document.images().len()
            ),
            None => format!(
                "texture {} names no image (no source, no EXT_texture_webp source)",
                texture.index()
            ),
        })
}

/// The bank index of the image each texture shown by the base colour of one of `primitives`
/// (each with its mesh's index) shows, by texture index: read from their headers in the order
/// first shown, then decoded on all threads. An error names the first primitive that shows the
/// image.
fn load_images(
    primitives: &[(usize, gltf::Primitive)],
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    textures: &mut MeshTextures,
) -> Result<Vec<Option<u32>>, String> {
    // Each image shown, with the first primitive that shows it, and each texture's image.
    let mut shown: Vec<(gltf::Image, String)> = Vec::new();
    let mut is_shown = vec![false; document.images().len()];
    let mut image_of_texture = vec![None; document.textures().len()];
    for (mesh, primitive) in primitives {
        if let (_, Some(info)) = base_colour(&primitive.material()) {
            let texture = info.texture();
            if image_of_texture[texture.index()].is_some() {
                continue;
            }
            let primitive = format!("mesh {mesh} primitive {}", primitive.index());
            let image = texture_image(&texture, document).map_err(|e| format!("{primitive}: {e}"))?;
            image_of_texture[texture.index()] = Some(image.index());
            if !std::mem::replace(&mut is_shown[image.index()], true) {
                shown.push((image, primitive));
            }
        }
    }
    let shown = &shown;
    let shown_by = |i: usize| move |e: String| format!("{}: {e}", shown[i].1);
    // A file the glTF names is keyed by its path (shared with any other mesh or object that
    // shows it); an embedded image by the glTF and its index.
    let keys = shown
        .iter()
        .enumerate()
        .map(|(i, (image, _))| match image.source() {
            gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => percent_decoded(uri)
                .and_then(|name| crate::input::inside_folder(textures.mesh, &name, "texture"))
                .map(|path| format!("image {}", path.display()))
                .map_err(shown_by(i)),
            _ => Ok(format!("image {} inside {}", image.index(), textures.mesh.display())),
        })
        .collect::<Result<Vec<String>, String>>()?;
    let mesh = textures.mesh;
    let added = textures
        .bank
        .add_images(&keys, |i| open_image(&shown[i].0, buffers, mesh, &shown[i].1))?;
    let mut images = vec![None; document.images().len()];
    for ((image, _), index) in shown.iter().zip(added) {
        images[image.index()] = Some(index);
    }
    Ok(image_of_texture
        .into_iter()
        .map(|image| image.and_then(|image| images[image]))
        .collect())
}

/// The bytes of a buffer: the GLB's binary chunk, a `data:` URI, or a file beside the glTF.
fn load_buffer(buffer: &gltf::Buffer, blob: Option<&[u8]>, textures: &MeshTextures) -> Result<Vec<u8>, String> {
    let what = format!("buffer {}", buffer.index());
    let data = match buffer.source() {
        gltf::buffer::Source::Bin => blob
            .ok_or_else(|| format!("{what} is the GLB binary chunk, but the file has none"))?
            .to_vec(),
        gltf::buffer::Source::Uri(uri) => {
            if let Some(encoded) = data_uri(uri) {
                encoded.map_err(|e| format!("{what}: {e}"))?
            } else {
                let path = crate::input::inside_folder(textures.mesh, &percent_decoded(uri)?, "buffer")?;
                let mut bytes = Vec::new();
                std::io::Read::read_to_end(
                    &mut crate::input::open_regular(&path, BUFFER_LIMIT).map_err(|e| format!("{what}: {e}"))?,
                    &mut bytes,
                )
                .map_err(|e| format!("{what}: {e}"))?;
                bytes
            }
        }
    };
    if data.len() < buffer.length() {
        return Err(format!(
            "{what} holds {} bytes but declares {}: the file is truncated",
            data.len(),
            buffer.length()
        ));
    }
    Ok(data)
}

/// The file name a relative URI stands for: its `%XX` escapes decoded (glTF's URIs are RFC
/// 3986's, so `my%20tiles.png` names `my tiles.png`).
fn percent_decoded(uri: &str) -> Result<String, String> {
    let bytes = uri.as_bytes();
    let mut name = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let byte = bytes
                .get(i + 1..i + 3)
                .and_then(|hex| std::str::from_utf8(hex).ok())
                .and_then(|hex| u8::from_str_radix(hex, 16).ok())
                .ok_or_else(|| format!("the URI {uri} has a % not followed by two hexadecimal digits"))?;
            name.push(byte);
            i += 3;
        } else {
            name.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(name).map_err(|_| format!("the URI {uri} decodes to a name that is not UTF-8"))
}

/// The decoded bytes of a `data:...;base64,` URI, or `None` for any other URI.
fn data_uri(uri: &str) -> Option<Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    Some(match rest.split_once(";base64,") {
        Some((_, encoded)) => base64::engine::general_purpose::STANDARD
            .decode(encoded)
            .map_err(|_| "its data URI is not valid base64".to_string()),
        None => Err("a data URI must be base64-encoded".to_string()),
    })
}

fn wrap(mode: WrappingMode) -> Wrap {
    match mode {
        WrappingMode::ClampToEdge => Wrap::Clamp,
        WrappingMode::MirroredRepeat => Wrap::Mirror,
        WrappingMode::Repeat => Wrap::Repeat,
    }
}

/// The TEXCOORD set a base-colour texture reads, and the `KHR_texture_transform` applied to it.
fn texture_coordinates(info: &gltf::texture::Info) -> (u32, UvTransform) {
    match info.texture_transform() {
        None => (info.tex_coord(), UvTransform::IDENTITY),
        Some(t) => (
            t.tex_coord().unwrap_or(info.tex_coord()),
            UvTransform {
                offset: DVec2::from_array(t.offset().map(f64::from)),
                rotation: f64::from(t.rotation()),
                scale: DVec2::from_array(t.scale().map(f64::from)),
            },
        ),
    }
}

/// A material's base colour factor and texture: `KHR_materials_pbrSpecularGlossiness`'s diffuse
/// ones where the material has it (older Sketchfab and 3ds Max exports; its metallic-roughness
/// values are then a fallback for viewers without the extension), else `baseColorFactor` and
/// `baseColorTexture`.
fn base_colour<'a>(material: &gltf::Material<'a>) -> ([f32; 4], Option<gltf::texture::Info<'a>>) {
    if let Some(diffuse) = material.pbr_specular_glossiness() {
        (diffuse.diffuse_factor(), diffuse.diffuse_texture())
    } else {
        let pbr = material.pbr_metallic_roughness();
        (pbr.base_color_factor(), pbr.base_color_texture())
    }
}

/// The look of a primitive's material, its base-colour texture's image one of `images` (by
/// texture index, [`load_images`]).
fn look(material: &gltf::Material, images: &[Option<u32>]) -> Look {
    let (factor, texture) = base_colour(material);
    let factor = DVec4::from_array(factor.map(f64::from));
    let texture = match texture {
        None => None,
        Some(info) => {
            let texture = info.texture();
            let id = images[texture.index()].expect("load_images decodes every image a placed primitive shows");
            let sampler = texture.sampler();
            Some((id, [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())]))
        }
    };
    Look {
        colour: [factor.x, factor.y, factor.z].map(linear_to_srgb),
        factor,
        texture,
        unlit: material.unlit(),
    }
}

/// Reads the header of image `image` (from a buffer view, a data URI or a file beside the
/// glTF `mesh`), which `primitive` shows first (an embedded image is named by both).
fn open_image<'a>(
    image: &gltf::Image,
    buffers: &'a [Vec<u8>],
    mesh: &Path,
    primitive: &str,
) -> Result<PendingImage<'a>, String> {
    let what = format!("{primitive}: image {}", image.index());
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let buffer = &buffers[view.buffer().index()];
            let bytes = view
                .offset()
                .checked_add(view.length())
                .and_then(|end| buffer.get(view.offset()..end))
                .ok_or_else(|| format!("{what}: its buffer view reaches beyond the buffer"))?;
            texture::open_bytes(bytes, &what)
        }
        gltf::image::Source::Uri { uri, .. } => match data_uri(uri) {
            Some(bytes) => texture::open_bytes(bytes.map_err(|e| format!("{what}: {e}"))?, &what),
            None => percent_decoded(uri)
                .and_then(|name| crate::input::inside_folder(mesh, &name, "texture"))
                .and_then(|path| texture::open_image(&path))
                .map_err(|e| format!("{primitive}: {e}")),
        },
    }
}

/// A list read from an accessor once, whichever primitive asks first. Its `get_or_init`
/// closure must not call rayon: a thread waiting there for its jobs may run another primitive's
/// read of the same list, re-entering the initialisation, which deadlocks.
type ReadOnce<T> = Arc<OnceLock<T>>;

/// The lists read once, by key.
type ReadOnceByKey<K, T> = Mutex<HashMap<K, ReadOnce<T>>>;

/// Vertex positions and texture coordinates read once however many primitives share their
/// accessor: `bench/make_big_gltf.py`'s four primitives share one of each, and reading them
/// once took the file's read from 2.33 G instructions to 1.90 G (docs/benchmarks.md,
/// "2026-11-27 evening2 (load)"). An accessor that one primitive reads is read by it alone and
/// never kept here: kept, the lists of a file of 200,000 small primitives were a tenth of its
/// read and all held until its end (docs/benchmarks.md, "2026-11-27 night2 (parts)").
struct SharedReads {
    /// How many of the primitives read each accessor (by index) as POSITION or TEXCOORD.
    readers: Vec<u32>,
    /// By POSITION accessor.
    positions: ReadOnceByKey<usize, Result<Vec<DVec3>, String>>,
    /// By TEXCOORD accessor and the bits of the `KHR_texture_transform` applied to them.
    uvs: ReadOnceByKey<(usize, [u64; 5]), Result<Vec<DVec2>, String>>,
}

/// A list one primitive reads: its own, or one kept in [`SharedReads`] for all its readers.
enum Read<T> {
    Alone(T),
    Shared(ReadOnce<T>),
}

impl<T> Read<T> {
    fn list(&self) -> &T {
        match self {
            Read::Alone(list) => list,
            Read::Shared(once) => once.get().expect("a shared list is read before it is handed out"),
        }
    }
}

impl SharedReads {
    /// No lists yet, and how many of `primitives` read each of the file's `accessors`.
    fn new(primitives: &[(usize, gltf::Primitive)], accessors: usize) -> SharedReads {
        let mut readers = vec![0u32; accessors];
        for (_, primitive) in primitives {
            let sources = Sources::of(primitive);
            for accessor in [sources.positions, sources.uvs.and_then(|(_, _, uvs)| uvs)]
                .into_iter()
                .flatten()
            {
                readers[accessor.index()] += 1;
            }
        }
        SharedReads {
            readers,
            positions: Mutex::default(),
            uvs: Mutex::default(),
        }
    }

    /// The list of `accessor` (`key` in `lists`) made by `read`: by this caller alone where it
    /// is the accessor's only reader, else by whichever of its readers comes first.
    fn read<K: std::hash::Hash + Eq, T>(
        &self,
        lists: &ReadOnceByKey<K, T>,
        accessor: usize,
        key: K,
        read: impl FnOnce() -> T,
    ) -> Read<T> {
        if self.readers[accessor] < 2 {
            return Read::Alone(read());
        }
        let once = {
            let mut lists = lists.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            Arc::clone(lists.entry(key).or_default())
        };
        once.get_or_init(read);
        Read::Shared(once)
    }
}

/// The triangles of one primitive (a list, strip or fan: `load_gltf` refuses other modes
/// first), in its mesh's own coordinates.
fn read_primitive(
    primitive: &gltf::Primitive,
    buffers: &[Vec<u8>],
    images: &[Option<u32>],
    shared: &SharedReads,
) -> Result<Vec<MeshTriangle>, String> {
    let look = look(&primitive.material(), images);
    let sources = Sources::of(primitive);
    let accessor = sources.positions.ok_or("it has no POSITION attribute")?;
    let positions = shared.read(&shared.positions, accessor.index(), accessor.index(), || {
        accessor::read(&accessor, buffers, "POSITION", DVec3::from_array)
    });
    let positions: &Vec<DVec3> = positions.list().as_ref().map_err(Clone::clone)?;
    // The accessor the corners come from, for errors: the indices, else the positions.
    let order_from = sources.indices;
    let order: Vec<u32> = match &order_from {
        Some(indices) => accessor::read_indices(indices, buffers)?,
        // At most `accessor::MAX_ELEMENTS` vertices: u32 indices.
        None => (0..positions.len() as u32).collect(),
    };
    // Named only in an error, as in `within_read_budget`.
    let position_count = |accessor: &gltf::Accessor| {
        format!(
            "accessor {} (POSITION)'s {} vertices",
            accessor.index(),
            positions.len()
        )
    };
    if let Some(&i) = order.iter().find(|&&i| i as usize >= positions.len()) {
        let indices = order_from.as_ref().map_or(accessor.index(), gltf::Accessor::index);
        return Err(format!(
            "accessor {indices} (indices): index {i} is out of range of {}",
            position_count(&accessor)
        ));
    }
    // `load_gltf` capped every primitive's triangles from these counts before any read.
    debug_assert!(triangles_of(primitive.mode(), order.len()).is_none_or(|n| n <= MAX_MESH_TRIANGLES));
    let corners = triangle_corners(primitive.mode(), order).map_err(|e| match &order_from {
        Some(indices) => format!("accessor {} (indices): {e}", indices.index()),
        None => format!("accessor {} (POSITION, no indices): {e}", accessor.index()),
    })?;
    let uv_list = match sources.uvs {
        None => None,
        Some((set, transform, uv_accessor)) => {
            let uv_accessor = uv_accessor.ok_or_else(|| {
                format!(
                    "material {}'s base colour texture reads TEXCOORD_{set}, which the primitive does not have",
                    primitive
                        .material()
                        .index()
                        .map_or("default".to_string(), |m| m.to_string())
                )
            })?;
            let list = shared.read(
                &shared.uvs,
                uv_accessor.index(),
                (uv_accessor.index(), transform.bits()),
                || {
                    let uvs = accessor::read(&uv_accessor, buffers, format_args!("TEXCOORD_{set}"), DVec2::from_array)?;
                    uvs.into_iter()
                        .enumerate()
                        .map(|(i, uv)| {
                            if uv.is_finite() {
                                Ok(transform.apply(uv))
                            } else {
                                Err(format!(
                                    "accessor {} (TEXCOORD_{set}) vertex {i}: texture coordinate {uv} is not finite",
                                    uv_accessor.index()
                                ))
                            }
                        })
                        .collect()
                },
            );
            Some((uv_accessor, set, list))
        }
    };
    let uvs: Option<&Vec<DVec2>> = match &uv_list {
        None => None,
        Some((uv_accessor, set, read)) => {
            let uvs = read.list().as_ref().map_err(Clone::clone)?;
            if uvs.len() < positions.len() {
                return Err(format!(
                    "accessor {} (TEXCOORD_{set}) has {} entries, fewer than {}",
                    uv_accessor.index(),
                    uvs.len(),
                    position_count(&accessor)
                ));
            }
            Some(uvs)
        }
    };
    let colour_accessor = sources.colours;
    let colours: Option<Vec<[u8; 3]>> = match &colour_accessor {
        None => None,
        Some(accessor) => {
            let encode = |linear: DVec4| {
                let linear = linear * look.factor;
                [linear.x, linear.y, linear.z].map(linear_to_srgb)
            };
            Some(match accessor.dimensions() {
                Dimensions::Vec3 => accessor::read(accessor, buffers, "COLOR_0", |[r, g, b]| {
                    encode(DVec4::new(r, g, b, 1.0))
                })?,
                Dimensions::Vec4 => {
                    accessor::read(accessor, buffers, "COLOR_0", |rgba| encode(DVec4::from_array(rgba)))?
                }
                other => {
                    return Err(format!(
                        "accessor {} (COLOR_0) is {other:?}; COLOR_0 must be VEC3 or VEC4",
                        accessor.index()
                    ));
                }
            })
        }
    };
    if let (Some(colours), Some(colour_accessor)) = (&colours, &colour_accessor)
        && colours.len() < positions.len()
    {
        return Err(format!(
            "accessor {} (COLOR_0) has {} entries, fewer than {}",
            colour_accessor.index(),
            colours.len(),
            position_count(&accessor)
        ));
    }
    let mut triangles = Vec::with_capacity(corners.len() / 3);
    for corners in corners.chunks_exact(3) {
        let at = |k: usize| corners[k] as usize;
        triangles.push(MeshTriangle {
            vertices: [positions[at(0)], positions[at(1)], positions[at(2)]],
            colour: Some(look.colour),
            texture: look
                .texture
                .as_ref()
                .zip(uvs.as_ref())
                .map(|((id, wrap), uvs)| CornerUvs {
                    texture: *id,
                    wrap: *wrap,
                    uv: [uvs[at(0)], uvs[at(1)], uvs[at(2)]],
                }),
            corner_colours: colours.as_ref().map(|c| [c[at(0)], c[at(1)], c[at(2)]]),
            unlit: look.unlit,
        });
    }
    Ok(triangles)
}

fn too_many_triangles() -> String {
    format!("more than {MAX_MESH_TRIANGLES} triangles; omnisim reads at most that many per mesh")
}
