//! Merging: checking a folder's frames (or copying shards' frames in), then the layouts'
//! index files, contact sheets and `manifest.json`.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use super::DatasetError;
use super::contact_sheet::{self, CONTACT_SHEET};
use super::layout::{self};
use super::manifest::{
    FileEntry, FileKind, FrameEntry, Manifest, ManifestSet, SetEntry, Stamp, inside, read_verified, sha256_hex,
    to_json, verify, verify_size,
};
use crate::files::{ENTRIES, MANIFEST, SET_ENTRY, STAMP, entry_path, io, read_entry_paths, read_json, write_file};
use crate::folder::{
    describe, hold, prepare_dir, prepare_subdir, read_stamp, refuse_nested, refuse_unrecorded, same_renderer,
};
use omnisim::Rig;

/// What `merge` found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MergeSummary {
    /// Frames over every set.
    pub frames: usize,
    /// Files listed in the manifest.
    pub files: usize,
    /// Their bytes.
    pub bytes: u64,
}

/// Copies the frames of `sources` (shard folders of the same spec, checked by hash) into
/// `dest`, checks that every frame of every set is there with the size and hash its entry
/// records, and writes the layouts' index files and `manifest.json`. With no `sources`, shards
/// wrote into `dest` itself (a shared file system).
pub fn merge(dest: &Path, sources: &[PathBuf]) -> Result<MergeSummary, DatasetError> {
    refuse_nested(dest)?;
    // Held as a run holds it: an --overwrite cannot remove the data set under the merge.
    let _held = if dest.join(STAMP).is_file() {
        Some(hold(dest)?)
    } else {
        None
    };
    assemble(dest, sources, &HashSet::new())
}

/// [`merge`], checking only the sizes of the files of the frames in `written` ((set name,
/// frame) written by the calling run, which hashed them as it wrote them).
pub(crate) fn assemble(
    dest: &Path,
    sources: &[PathBuf],
    written: &HashSet<(&str, usize)>,
) -> Result<MergeSummary, DatasetError> {
    let mut stamp = read_stamp(dest)?;
    // Every stamp met is checked against its spec before anything is copied; shards of one
    // identity carry the same spec text.
    let mut spec = stamp.as_ref().map(|ours| checked_spec(dest, ours)).transpose()?;
    for source in sources {
        let theirs = read_stamp(source)?.ok_or_else(|| DatasetError::NotADataSet { dir: source.clone() })?;
        let their_spec = checked_spec(source, &theirs)?;
        let ours = if let Some(ours) = &stamp {
            ours
        } else {
            prepare_dir(dest)?;
            refuse_unrecorded(dest)?;
            let bytes = std::fs::read(source.join(STAMP)).map_err(io(source))?;
            write_file(&dest.join(STAMP), &bytes)?;
            spec = Some(their_spec);
            stamp.insert(theirs.clone())
        };
        if ours.identity != theirs.identity {
            return Err(DatasetError::ShardOfAnotherSpec {
                dir: source.clone(),
                dest: dest.to_path_buf(),
                theirs: describe(&theirs),
            });
        }
        same_renderer(source, &theirs, ours)?;
        copy_frames(source, dest, ours)?;
    }
    let (Some(stamp), Some(spec)) = (stamp, spec) else {
        return Err(DatasetError::NotADataSet {
            dir: dest.to_path_buf(),
        });
    };
    // The index files and contact sheets are this binary's: they must be the renderer's.
    let merging = Stamp {
        version: env!("CARGO_PKG_VERSION").into(),
        ..stamp.clone()
    };
    same_renderer(dest, &stamp, &merging)?;
    let spec_path = dest.join(&stamp.spec_file);
    let rig = spec.rig.build().map_err(|e| DatasetError::Spec {
        path: spec_path.clone(),
        location: None,
        set: None,
        field: "rig".into(),
        message: e.to_string(),
    })?;
    let mut summary = MergeSummary::default();
    let mut sets = Vec::new();
    for set in &stamp.sets {
        let set_dir = inside(dest, &set.name).ok_or_else(|| DatasetError::Link {
            path: dest.join(&set.name),
        })?;
        let own_path = set_dir.join(ENTRIES).join(SET_ENTRY);
        let mut own: SetEntry = read_json(&own_path)?;
        // Not `with_capacity(set.frames)`: the count comes from a file that may have been edited.
        let mut frames = Vec::new();
        let mut missing = Vec::new();
        for index in 0..set.frames {
            let path = entry_path(&set_dir, index);
            if !path.exists() {
                missing.push(index);
                continue;
            }
            let entry: FrameEntry = read_json(&path)?;
            check_frame_entry(&entry, index, &path)?;
            let fresh = written.contains(&(set.name.as_str(), index));
            for file in &entry.files {
                if fresh {
                    verify_size(dest, file, &path)?;
                } else {
                    verify(dest, file, &path)?;
                }
            }
            frames.push(entry);
        }
        if let Some(&first) = missing.first() {
            return Err(DatasetError::Incomplete {
                set: set.name.clone(),
                missing: missing.len(),
                total: set.frames,
                first,
            });
        }
        for file in &own.files {
            verify(dest, file, &own_path)?;
        }
        for layout in &set.layouts {
            for (name, text) in layout::index_files(layout, &rig, &frames) {
                let path = set_dir.join(&name);
                prepare_subdir(dest, path.parent().unwrap_or(&set_dir))?;
                write_file(&path, text.as_bytes())?;
                own.files.push(FileEntry {
                    path: format!("{}/{name}", set.name),
                    kind: FileKind::Index,
                    bytes: text.len() as u64,
                    sha256: sha256_hex(text.as_bytes()),
                });
            }
        }
        if spec.outputs.colour {
            let sheet = set_dir.join(CONTACT_SHEET);
            let bytes = set_contact_sheet(&set_dir, &rig, &frames)?;
            write_file(&sheet, &bytes)?;
            own.files.push(FileEntry {
                path: format!("{}/{CONTACT_SHEET}", set.name),
                kind: FileKind::Overview,
                bytes: bytes.len() as u64,
                sha256: sha256_hex(&bytes),
            });
        }
        let counted = own.files.iter().chain(frames.iter().flat_map(|f| &f.files));
        for file in counted {
            summary.files += 1;
            summary.bytes += file.bytes;
        }
        summary.frames += frames.len();
        sets.push(ManifestSet {
            set: own,
            frame_entries: frames,
        });
    }
    let manifest = Manifest {
        tool: "omnisim".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        spec_file: stamp.spec_file.clone(),
        spec: stamp.spec_text.clone(),
        spec_sha256: stamp.spec_sha256.clone(),
        scene_file: stamp.scene_file.clone(),
        scene_sha256: stamp.scene_sha256.clone(),
        geometry_sha256: stamp.geometry_sha256.clone(),
        renderer: stamp.renderer.clone(),
        seed: spec.seed,
        rig: spec.rig.clone(),
        outputs: spec.outputs,
        sets,
    };
    write_file(&dest.join(MANIFEST), &to_json(&manifest))?;
    Ok(summary)
}

/// The spec a stamp carries, refusing a stamp that is not its own spec's (the text's hash,
/// the sets' names in order, layouts and noise, a possible frame count): merges trust it for
/// what to check and write.
fn checked_spec(dir: &Path, stamp: &Stamp) -> Result<super::spec::Spec, DatasetError> {
    let spec = super::spec::parse(&stamp.spec_text, &dir.join(&stamp.spec_file))?;
    let problem = if sha256_hex(stamp.spec_text.as_bytes()) != stamp.spec_sha256 {
        Some("its spec text does not have its recorded hash".to_string())
    } else if stamp.sets.len() != spec.sets.len() {
        Some(format!(
            "it lists {} sets; its spec has {}",
            stamp.sets.len(),
            spec.sets.len()
        ))
    } else {
        stamp.sets.iter().zip(&spec.sets).find_map(|(ours, theirs)| {
            let same = ours.name == theirs.name && ours.layouts == theirs.layouts && ours.noise == theirs.noise;
            let possible = (1..=super::spec::MAX_POSES).contains(&ours.frames);
            (!(same && possible)).then(|| {
                format!(
                    "set '{}' is not its spec's set, or has an impossible frame count",
                    omnisim::input::shown(&ours.name, 64)
                )
            })
        })
    };
    match problem {
        Some(problem) => Err(DatasetError::BadStamp {
            path: dir.join(STAMP),
            problem,
        }),
        None => Ok(spec),
    }
}

/// The contact sheet of a set's frames (the first view's ground-truth colour).
fn set_contact_sheet(set_dir: &Path, rig: &Rig, frames: &[FrameEntry]) -> Result<Vec<u8>, DatasetError> {
    let suffix = rig.views().first().map(|v| v.suffix).unwrap_or_default();
    let paths: Vec<(usize, PathBuf)> = contact_sheet::chosen(frames.len())
        .into_iter()
        .map(|i| (frames[i].index, set_dir.join(format!("{}{suffix}.png", frames[i].stem))))
        .collect();
    let shown: Vec<(usize, &Path)> = paths.iter().map(|(i, p)| (*i, p.as_path())).collect();
    contact_sheet::contact_sheet(&shown)
}

/// Copies every done frame (and the set files) of `source` into `dest`, each file checked
/// against its entry first; entries last, so a copy killed half-way leaves no false "done".
fn copy_frames(source: &Path, dest: &Path, stamp: &Stamp) -> Result<(), DatasetError> {
    for set in &stamp.sets {
        let from = inside(source, &set.name).ok_or_else(|| DatasetError::Link {
            path: source.join(&set.name),
        })?;
        let to = inside(dest, &set.name).ok_or_else(|| DatasetError::Link {
            path: dest.join(&set.name),
        })?;
        prepare_subdir(dest, &to.join(ENTRIES))?;
        let mut entries = read_entry_paths(&from.join(ENTRIES))?;
        entries.push(from.join(ENTRIES).join(SET_ENTRY));
        for entry in entries {
            if !entry.exists() {
                continue;
            }
            let files: Vec<FileEntry> = if entry.ends_with(SET_ENTRY) {
                read_json::<SetEntry>(&entry)?.files
            } else {
                // Checked here, so that a bad entry is named in the shard it came from (its
                // name is its index: `read_entry_paths` lists only such names).
                let frame: FrameEntry = read_json(&entry)?;
                let index = (entry.file_stem().and_then(|stem| stem.to_str()))
                    .and_then(|stem| stem.parse().ok())
                    .unwrap_or(usize::MAX);
                check_frame_entry(&frame, index, &entry)?;
                frame.files
            };
            for file in &files {
                let bytes = read_verified(source, file, &entry)?;
                // Checked by read_verified: the path stays inside.
                let to_file = dest.join(&file.path);
                if let Some(parent) = to_file.parent() {
                    prepare_subdir(dest, parent)?;
                }
                write_file(&to_file, &bytes)?;
            }
            let name = entry.file_name().map(PathBuf::from).unwrap_or_default();
            write_file(
                &to.join(ENTRIES).join(name),
                &std::fs::read(&entry).map_err(io(&entry))?,
            )?;
        }
    }
    Ok(())
}

/// Refuses a frame entry whose index is not `index` or whose stem is not a plain name (it names
/// files, which the contact sheet reads), as the frame was written.
fn check_frame_entry(entry: &FrameEntry, index: usize, path: &Path) -> Result<(), DatasetError> {
    if entry.index != index || entry.stem.is_empty() || entry.stem.starts_with('.') || entry.stem.contains(['/', '\\'])
    {
        return Err(DatasetError::Corrupt {
            path: path.to_path_buf(),
            entry: path.to_path_buf(),
            problem: "its index or stem is not the one this frame was written with".into(),
        });
    }
    Ok(())
}
