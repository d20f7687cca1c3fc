//! `omnisim scene`: check and export scene files.

use std::path::PathBuf;

use anyhow::Context;
use clap::Subcommand;
use omnisim::Scene;
use omnisim::pose::{MICROMETRES, rounded};
use omnisim::scene::ExportFormat;

#[derive(Debug, Subcommand)]
pub(crate) enum SceneCommand {
    /// Load and validate a scene; print its objects, faces and bounds.
    ///
    /// The scene name must be 1-100 bytes of letters, digits, '-', '_', '.' and spaces (it names
    /// output files); coordinates must lie within ±1e6 m; meshes, their material files, buffers
    /// and textures are read from the scene's (or the mesh's) folder and below only (no '..'
    /// or absolute paths); only regular files are read (scenes up to 64 MiB, meshes 2 GiB).
    /// Textures are listed with their source, size, mip levels, bytes and the objects that
    /// show them.
    Check {
        /// Scene file (RON).
        scene: PathBuf,
    },
    /// Write the triangulated scene with face colours (.ply binary or .obj with vertex colours),
    /// so other tools load exactly the geometry omnisim traces.
    Export {
        /// Scene file (RON).
        scene: PathBuf,
        /// Output file: .ply or .obj. An existing file there is replaced only if it is an
        /// omnisim export (never a scene's own mesh or another tool's file).
        output: PathBuf,
    },
}

pub(crate) fn run(command: SceneCommand) -> anyhow::Result<()> {
    match command {
        SceneCommand::Check { scene } => {
            let scene = Scene::load(&scene)?;
            for warning in &scene.warnings {
                crate::streams::stderr(format_args!("warning: {warning}"))?;
            }
            let (lo, hi) = scene.bounds().context("the scene is empty")?;
            crate::streams::stdout(format_args!(
                "scene '{}': {} objects, {} faces, {} triangles",
                scene.name,
                scene.objects.len(),
                scene.faces.len(),
                scene.triangulate().len()
            ))?;
            // Bounds to the micrometre: 2.3, not 2.3000000000000003.
            let (lo, hi) = (lo.map(|v| rounded(v, MICROMETRES)), hi.map(|v| rounded(v, MICROMETRES)));
            crate::streams::stdout(format_args!(
                "bounds: x [{}, {}], y [{}, {}], z [{}, {}] m",
                lo.x, hi.x, lo.y, hi.y, lo.z, hi.z
            ))?;
            let mut faces = vec![0usize; scene.objects.len()];
            for face in &scene.faces {
                faces[face.object as usize] += 1;
            }
            for (object, faces) in scene.objects.iter().zip(faces) {
                crate::streams::stdout(format_args!("  {:<8} {:<24} {faces} faces", object.kind, object.name))?;
            }
            list_textures(&scene)?;
        }
        SceneCommand::Export { scene, output } => {
            let format = ExportFormat::from_path(&output)
                .with_context(|| format!("{}: use a .ply or .obj file name", output.display()))?;
            let loaded = Scene::load(&scene)?;
            crate::commands::prepare_file(&output)?;
            // Never over a file omnisim did not export (a scene's own mesh, say).
            let exported = |start: &[u8]| format.wrote(start);
            crate::commands::refuse_replacing_other_files(&output, exported, "a scene omnisim exported")?;
            loaded.export(&output, format)?;
            crate::streams::stdout(output.display())?;
        }
    }
    Ok(())
}

/// One line per texture: where it came from, its size, mip levels and bytes (mips included),
/// and the objects that show it.
fn list_textures(scene: &Scene) -> anyhow::Result<()> {
    let surfaces = &scene.surfaces;
    if surfaces.textures.is_empty() {
        return Ok(());
    }
    let total: usize = surfaces
        .textures
        .iter()
        .map(omnisim::scene::texture::Texture::bytes)
        .sum();
    crate::streams::stdout(format_args!(
        "textures: {}, {total} bytes with their mip levels",
        surfaces.textures.len()
    ))?;
    for (index, ((texture, source), users)) in surfaces
        .textures
        .iter()
        .zip(&surfaces.sources)
        .zip(scene.texture_objects())
        .enumerate()
    {
        let (width, height) = texture.size();
        let names: Vec<&str> = users.iter().map(|&o| scene.objects[o as usize].name.as_str()).collect();
        crate::streams::stdout(format_args!(
            "  texture {index}: {width}×{height} texels, {} mip levels, {} bytes; used by {}; from {source}",
            texture.levels.len(),
            texture.bytes(),
            if names.is_empty() {
                "no face".to_string()
            } else {
                names.join(", ")
            }
        ))?;
    }
    Ok(())
}
