//! The scene's textures as loading gathers them: each image file, glTF image or pattern decoded
//! or baked once however many objects use it, and every new one counted against the scene's
//! texel cap before it is decoded. Library objects (`library.rs`) and mesh readers
//! (`mesh.rs` and its formats) add to one bank; the scene build hands its textures to
//! [`super::surface::Surfaces`].

use std::collections::HashMap;

use rayon::prelude::*;

use super::texture::{BYTES_PER_TEXEL_WITH_MIPS, MAX_SCENE_TEXELS, PendingImage, Texture};

/// The scene's textures so far, each file or pattern decoded or baked once however many
/// objects use it.
#[derive(Default)]
pub(super) struct TextureBank {
    textures: Vec<Texture>,
    /// The source of each texture, which is also its key in `by_key`.
    sources: Vec<String>,
    by_key: HashMap<String, u32>,
    /// Texels of the finest levels of the textures so far, counted against
    /// [`MAX_SCENE_TEXELS`] before each is made.
    texels: u64,
}

impl TextureBank {
    /// The index of the texture `source` names (a pattern: one texture per source), made by
    /// `make` the first time (a pattern is small: counted once made).
    pub(super) fn get_or_add(
        &mut self,
        source: String,
        make: impl FnOnce() -> Result<Texture, String>,
    ) -> Result<u32, String> {
        if let Some(&index) = self.by_key.get(&source) {
            return Ok(index);
        }
        let texture = make()?;
        let (width, height) = texture.size();
        self.count(u64::from(width) * u64::from(height), &source)?;
        Ok(self.insert(source, texture))
    }

    /// [`TextureBank::add_images`] of one image.
    pub(super) fn add_image<'a>(
        &mut self,
        key: String,
        open: impl Fn() -> Result<PendingImage<'a>, String>,
    ) -> Result<u32, String> {
        Ok(self.add_images(&[key], |_| open())?[0])
    }

    /// The indices of the images keyed `keys` (a file, a glTF's image: one texture per key);
    /// `open(i)` reads the header of the i-th where its key is new. The new images are counted
    /// against the scene's texel cap in order, from their headers, and only when every header
    /// has passed are they decoded and mipped, on all threads (four 2048² PNGs took 3.1 G
    /// instructions one after another: docs/benchmarks.md, 2026-11-27 night (load)). The error
    /// is the first header failure in key order, else the first decoding failure in key order.
    pub(super) fn add_images<'a>(
        &mut self,
        keys: &[String],
        open: impl Fn(usize) -> Result<PendingImage<'a>, String>,
    ) -> Result<Vec<u32>, String> {
        let mut pending: Vec<(&String, PendingImage)> = Vec::new();
        for (i, key) in keys.iter().enumerate() {
            if !self.by_key.contains_key(key) && !pending.iter().any(|(earlier, _)| *earlier == key) {
                let image = open(i)?;
                let (width, height) = image.size();
                self.count(u64::from(width) * u64::from(height), image.name())?;
                pending.push((key, image));
            }
        }
        // Every result kept, in order (rayon's collect into a `Result` keeps whichever error
        // came first in time).
        let decoded: Vec<(&String, Result<Texture, String>)> = pending
            .into_par_iter()
            .map(|(key, image)| (key, image.decode()))
            .collect();
        for (key, texture) in decoded {
            self.insert(key.clone(), texture?);
        }
        Ok(keys.iter().map(|key| self.by_key[key]).collect())
    }

    /// The textures in the order they were added, and the source of each (what
    /// `Surfaces::textures` and `Surfaces::sources` hold).
    pub(super) fn into_textures(self) -> (Vec<Texture>, Vec<String>) {
        (self.textures, self.sources)
    }

    /// Counts `texels` more texels of the texture `name` names, unless that takes the scene
    /// past [`MAX_SCENE_TEXELS`].
    fn count(&mut self, texels: u64, name: &str) -> Result<(), String> {
        let total = self.texels + texels;
        if total > MAX_SCENE_TEXELS {
            return Err(format!(
                "{name}: its {texels} texels would bring the scene's textures to {total} texels, more than omnisim \
                 loads ({MAX_SCENE_TEXELS} texels, {:.1} GB at {BYTES_PER_TEXEL_WITH_MIPS:.1} bytes a texel with \
                 mips); scale the textures down or use fewer",
                MAX_SCENE_TEXELS as f64 * BYTES_PER_TEXEL_WITH_MIPS / 1e9
            ));
        }
        self.texels = total;
        Ok(())
    }

    /// Adds `texture` under `source`; its index.
    fn insert(&mut self, source: String, texture: Texture) -> u32 {
        let index = self.textures.len() as u32;
        self.textures.push(texture);
        self.sources.push(source.clone());
        self.by_key.insert(source, index);
        index
    }
}
