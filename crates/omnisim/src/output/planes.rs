//! Writers for the planes beyond colour and range: segmentation ids (16-bit PNG and a legend),
//! world-frame normals and linear colour (f32 EXR).

use std::path::Path;

use image::ImageEncoder;
use serde::Serialize;

use super::{ExrCompression, OutputError, OutputProblem, failed, write_xyz_exr};
use crate::frame::{Frame, NO_FACE};
use crate::output::store::FileStore;
use crate::scene::Scene;

/// Text stored in normal-map EXR headers (`quantity` = `normal`).
pub const NORMAL_CONVENTION: &str = "unit geometric normal of the surface hit, world frame (z up), turned towards the \
     camera: channels R, G, B = x, y, z; NaN where nothing is hit";

/// Text stored in linear-colour EXR headers.
pub const LINEAR_CONVENTION: &str = "linear colour after shading, before sRGB encoding and clamping: channels R, G, B; \
     1.0 = full scale (albedo x illuminance / white, see the scene's lighting); 0 where nothing is hit";

/// The largest id a 16-bit segmentation image holds (0 is the background).
pub const MAX_SEGMENT_ID: u32 = u16::MAX as u32;

/// What the ids of the segmentation images mean: the same for every pose of a scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SegmentationLegend {
    /// What the pixel values mean.
    pub convention: &'static str,
    /// Object ids in scene-file order, from 1.
    pub objects: Vec<SegmentObject>,
}

/// One object of the legend.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SegmentObject {
    /// Value in the object-id image.
    pub id: u32,
    /// Name in the scene file.
    pub name: String,
    /// Library kind (Box, Wall, ...).
    pub kind: &'static str,
    /// Its faces' values in the face-id image: `first_face ..= last_face`.
    pub first_face: u32,
    /// Last face id of the object.
    pub last_face: u32,
}

impl SegmentationLegend {
    /// The legend of `scene`: objects count from 1 in file order, faces from 1 in scene order.
    pub fn of(scene: &Scene) -> Self {
        // One pass over the faces: (first, last) face id of each object, 0 for none.
        let mut spans = vec![(0u32, 0u32); scene.objects.len()];
        for (index, face) in scene.faces.iter().enumerate() {
            let id = index as u32 + 1;
            if let Some(span) = spans.get_mut(face.object as usize) {
                *span = (if span.0 == 0 { id } else { span.0 }, id);
            }
        }
        let objects = scene
            .objects
            .iter()
            .zip(spans)
            .enumerate()
            .map(|(index, (object, (first, last)))| SegmentObject {
                id: index as u32 + 1,
                name: object.name.clone(),
                kind: object.kind,
                first_face: first,
                last_face: last,
            })
            .collect();
        Self {
            convention: "16-bit grey PNGs: <stem>-object.png holds the object id, <stem>-face.png the face id \
                         (scene face index + 1); 0 = nothing hit. Faces of one object are numbered consecutively.",
            objects,
        }
    }
}

/// 16-bit grey PNG of ids (0 = background). Refuses ids a 16-bit image cannot hold.
pub fn write_id_png(to: &mut impl FileStore, path: &Path, size: (u32, u32), ids: &[u32]) -> Result<(), OutputError> {
    if let Some(&id) = ids.iter().find(|&&id| id > MAX_SEGMENT_ID) {
        return Err(OutputError::at(path, OutputProblem::IdTooLarge { id }));
    }
    let mut bytes = Vec::with_capacity(2 * ids.len());
    for &id in ids {
        bytes.extend_from_slice(&(id as u16).to_ne_bytes());
    }
    to.store(path, |out| {
        super::png_encoder(out)
            .write_image(&bytes, size.0, size.1, image::ExtendedColorType::L16)
            .map_err(std::io::Error::other)
    })
    .map_err(failed(path))
}

/// Face ids of a frame as segmentation values: face index + 1, 0 where nothing is hit.
pub fn face_ids(frame: &Frame) -> Vec<u32> {
    frame
        .pixels()
        .iter()
        .map(|p| if p.face == NO_FACE { 0 } else { p.face + 1 })
        .collect()
}

/// Three-channel f32 EXR of world-frame unit normals (`R G B` = x y z, `quantity` =
/// `normal`), NaN where nothing is hit.
pub fn write_normal_exr(
    to: &mut impl FileStore,
    path: &Path,
    frame: &Frame,
    compression: ExrCompression,
) -> Result<(), OutputError> {
    // Sized up front: grown by doubling, three channels of a large frame left holes that
    // raised the peak memory of a render by a few bytes a pixel.
    let mut channels: [Vec<f32>; 3] = std::array::from_fn(|_| Vec::with_capacity(frame.pixels().len()));
    for p in frame.pixels() {
        let normal = if p.is_hit() { p.normal.to_array() } else { [f32::NAN; 3] };
        for (channel, value) in channels.iter_mut().zip(normal) {
            channel.push(value);
        }
    }
    write_xyz_exr(
        to,
        path,
        (frame.width, frame.height),
        "normal",
        NORMAL_CONVENTION,
        &channels,
        compression,
    )
}

/// Three-channel f32 EXR (R, G, B) of the frame's linear colour plane.
pub fn write_linear_exr(
    to: &mut impl FileStore,
    path: &Path,
    frame: &Frame,
    compression: ExrCompression,
) -> Result<(), OutputError> {
    let linear = frame.linear_colour().ok_or_else(|| {
        OutputError::at(
            path,
            OutputProblem::MissingPlane {
                plane: "linear colour",
                request: "Plane::LinearColour",
            },
        )
    })?;
    let channel = |k: usize| linear.iter().map(|c| c[k]).collect();
    write_xyz_exr(
        to,
        path,
        (frame.width, frame.height),
        "linear colour",
        LINEAR_CONVENTION,
        &[channel(0), channel(1), channel(2)],
        compression,
    )
}
