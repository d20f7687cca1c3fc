//! Light and colour changes of a set, turned into the [`Appearance`] of one frame: what the
//! renderer re-shades with, without rebuilding any geometry.

use std::collections::BTreeMap;

use glam::DVec3;
use rand::Rng;
use serde::Serialize;

use super::rng::{Purpose, stream};
use super::spec::{ColourChange, LightChange, SetSpec};
use omnisim::advanced::Appearance;
use omnisim::scene::Scene;
use omnisim::scene::lighting::{LightKind, linear_rgb};

/// What a frame's lights and colours were, for its manifest entry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct AppearanceRecord {
    /// Every light after the set's and the frame's changes (absent in unlit scenes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lighting: Option<omnisim::scene::lighting::Lighting>,
    /// The 8-bit shift of each shifted object, per channel.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub colour_shifts: BTreeMap<String, [i16; 3]>,
}

/// Checks that the lights and objects a set names exist in `scene`, as (field, message).
pub(crate) fn check(scene: &Scene, set: &SetSpec) -> Result<(), (String, String)> {
    for (i, change) in set.lights.iter().enumerate() {
        let field = format!("lights[{i}]");
        let name = match change {
            LightChange::Switch { light, .. }
            | LightChange::Move { light, .. }
            | LightChange::Intensity { light, .. }
            | LightChange::Colour { light, .. }
            | LightChange::Flicker { light, .. } => light,
            LightChange::Ambient(_) => {
                if scene.lighting.is_none() {
                    return Err((field, "the scene has no lighting section to change".into()));
                }
                continue;
            }
        };
        let light = scene
            .lighting
            .as_ref()
            .and_then(|l| l.lights.iter().find(|l| &l.name == name));
        match (light, change) {
            (None, _) => {
                let known: Vec<String> = scene
                    .lighting
                    .iter()
                    .flat_map(|l| l.lights.iter().map(|l| omnisim::input::shown(&l.name, 40)))
                    .collect();
                return Err((
                    field,
                    format!(
                        "the scene has no light '{}' (it has: {})",
                        omnisim::input::shown(name, 40),
                        omnisim::input::excerpt(&known.join(", "), 400)
                    ),
                ));
            }
            (Some(l), LightChange::Move { .. }) if !matches!(l.kind, LightKind::Point { .. }) => {
                return Err((
                    field,
                    format!(
                        "'{}' is directional: only point lights move",
                        omnisim::input::shown(name, 40)
                    ),
                ));
            }
            _ => {}
        }
    }
    for (i, change) in set.colours.iter().enumerate() {
        let names = match change {
            ColourChange::Paint { object, .. } => std::slice::from_ref(object),
            ColourChange::Shift { objects, .. } => objects.as_slice(),
        };
        if let Some(missing) = names.iter().find(|n| !scene.objects.iter().any(|o| &o.name == *n)) {
            return Err((
                format!("colours[{i}]"),
                format!("the scene has no object '{}'", omnisim::input::shown(missing, 40)),
            ));
        }
    }
    Ok(())
}

/// The appearance of frame `index` of `set` in `scene` (which may hold occluders after its
/// first `scene_objects` objects; they keep their own colours and are never shifted).
pub(crate) fn frame_appearance(
    scene: &Scene,
    scene_objects: usize,
    set: &SetSpec,
    seed: u64,
    index: usize,
) -> (Appearance, AppearanceRecord) {
    let mut appearance = Appearance::of(scene);
    let mut flicker = stream(seed, &set.name, Some(index), Purpose::Lights);
    if let Some(lighting) = appearance.lighting.as_mut() {
        for change in &set.lights {
            if let LightChange::Ambient(lux) = change {
                lighting.ambient = *lux;
                continue;
            }
            let (LightChange::Switch { light, .. }
            | LightChange::Move { light, .. }
            | LightChange::Intensity { light, .. }
            | LightChange::Colour { light, .. }
            | LightChange::Flicker { light, .. }) = change
            else {
                continue;
            };
            // Checked on load: the light exists.
            let Some(target) = lighting.light_mut(light) else {
                continue;
            };
            let applies = change.applies_to(index);
            match change {
                // Flicker draws below whether it applies or not.
                _ if !applies && !matches!(change, LightChange::Flicker { .. }) => {}
                LightChange::Switch { on, .. } => target.on = *on,
                LightChange::Move { position, .. } => {
                    if let LightKind::Point { position: p, .. } = &mut target.kind {
                        *p = DVec3::from(*position);
                    }
                }
                LightChange::Intensity { value, .. } => set_strength(&mut target.kind, |_| *value),
                LightChange::Colour { colour, .. } => target.colour = linear_rgb([colour.0, colour.1, colour.2]),
                LightChange::Flicker { off, jitter, .. } => {
                    // Both draws always happen, so one light's settings never move another's draws.
                    let (dark, scale) = (flicker.random_bool(*off), flicker.random_range(-1.0..=1.0));
                    if applies {
                        target.on &= !dark;
                        set_strength(&mut target.kind, |s| s * (1.0 + jitter * scale));
                    }
                }
                LightChange::Ambient(_) => {}
            }
        }
    }
    let mut colour_shifts = BTreeMap::new();
    for change in &set.colours {
        match change {
            ColourChange::Paint { object, colour } => {
                let id = scene.objects.iter().position(|o| &o.name == object);
                for (face, c) in scene.faces.iter().zip(&mut appearance.face_colours) {
                    if Some(face.object as usize) == id {
                        *c = [colour.0, colour.1, colour.2];
                    }
                }
            }
            ColourChange::Shift {
                objects,
                range,
                per_frame,
            } => {
                let mut rng = stream(seed, &set.name, per_frame.then_some(index), Purpose::Colours);
                let range = i16::from(*range);
                for (id, object) in scene.objects[..scene_objects].iter().enumerate() {
                    // Every object draws, listed or not, so the list does not move the draws.
                    let shift: [i16; 3] = std::array::from_fn(|_| rng.random_range(-range..=range));
                    if !objects.is_empty() && !objects.contains(&object.name) {
                        continue;
                    }
                    for (face, c) in scene.faces.iter().zip(&mut appearance.face_colours) {
                        if face.object as usize == id {
                            *c = std::array::from_fn(|k| (i16::from(c[k]) + shift[k]).clamp(0, 255) as u8);
                        }
                    }
                    let total = colour_shifts.entry(object.name.clone()).or_insert([0; 3]);
                    *total = std::array::from_fn(|k| total[k] + shift[k]);
                }
            }
        }
    }
    let record = AppearanceRecord {
        lighting: appearance.lighting.clone(),
        colour_shifts,
    };
    (appearance, record)
}

fn set_strength(kind: &mut LightKind, f: impl Fn(f64) -> f64) {
    match kind {
        LightKind::Point { intensity, .. } => *intensity = f(*intensity),
        LightKind::Directional { illuminance, .. } => *illuminance = f(*illuminance),
    }
}
