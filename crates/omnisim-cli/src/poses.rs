//! Poses as people type them: `x,y,z,θx,θy,θz` in metres and degrees, on the command line or
//! one per line in a file.

use std::path::Path;

use anyhow::{Context, bail};
use glam::dvec3;
use omnisim::Pose;
use omnisim::input::shown;
use omnisim::scene::MAX_COORDINATE;

/// Largest angle a pose may give, degrees: beyond it, rounding to 1e-9° is no longer finite
/// in every step, and no one means it.
const MAX_ANGLE_DEGREES: f64 = 1e6;

/// Refuses a coordinate of `position` (metres, as `text` gave it) beyond where scenes may lie.
pub(crate) fn check_position(position: &[f64], text: &str) -> Result<(), String> {
    match position.iter().find(|v| v.abs() > MAX_COORDINATE) {
        Some(v) => Err(format!(
            "{v:e} m in '{text}' is beyond ±{MAX_COORDINATE:e} m, where scenes may lie"
        )),
        None => Ok(()),
    }
}

/// Parses `x,y,z,θx,θy,θz` (commas or spaces; angles in degrees; missing angles are 0). An
/// empty value between commas is an error, not skipped: `1,,2,3` is not (1, 2, 3).
pub(crate) fn parse_pose(text: &str) -> Result<Pose, String> {
    let shown = shown(text, 80);
    let mut fields = Vec::new();
    for part in text.split(',') {
        if part.trim().is_empty() && text.contains(',') {
            return Err(format!("'{shown}' has an empty value between commas"));
        }
        fields.extend(part.split_whitespace());
    }
    if fields.len() != 3 && fields.len() != 6 {
        let tum = if fields.len() == 8 {
            " (eight numbers look like a TUM line, index tx ty tz qx qy qz qw, as poses.txt holds: give the angles \
             instead, as render.json's angles_deg lists them)"
        } else {
            ""
        };
        return Err(format!(
            "'{shown}' has {} numbers; a pose is x,y,z (metres) optionally followed by θx,θy,θz (degrees){tum}",
            fields.len()
        ));
    }
    let mut values = [0.0f64; 6];
    for (value, field) in values.iter_mut().zip(&fields) {
        *value = field.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
            format!(
                "'{}' in '{shown}' is not a finite number",
                omnisim::input::shown(field, 40)
            )
        })?;
    }
    check_position(&values[..3], &shown)?;
    if let Some(v) = values[3..].iter().find(|v| v.abs() > MAX_ANGLE_DEGREES) {
        return Err(format!(
            "{v:e}° in '{shown}' is beyond ±{MAX_ANGLE_DEGREES:e}°: angles are in degrees"
        ));
    }
    Ok(Pose::from_degrees(
        dvec3(values[0], values[1], values[2]),
        dvec3(values[3], values[4], values[5]),
    ))
}

/// Reads a pose file (a regular file of at most 256 MiB): one pose per line as for `--pose`;
/// `#` starts a comment.
pub(crate) fn read_pose_file(path: &Path) -> anyhow::Result<Vec<Pose>> {
    let text = omnisim::input::read_text(path, omnisim::input::POSE_FILE_LIMIT).context("cannot read the pose file")?;
    let mut poses = Vec::new();
    for (number, line) in omnisim::input::without_bom(&text).lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let pose = parse_pose(line).map_err(|e| anyhow::anyhow!("{}:{}: {e}", path.display(), number + 1))?;
        poses.push(pose);
    }
    if poses.is_empty() {
        bail!(
            "{}: no poses in the file (one 'x y z θx θy θz' per line)",
            path.display()
        );
    }
    Ok(poses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_commas_spaces_and_defaults() {
        let pose = parse_pose("1.5, 0 0.4,0,0,60").unwrap();
        assert_eq!(pose.position, dvec3(1.5, 0.0, 0.4));
        assert!((pose.angles.z - 60f64.to_radians()).abs() < 1e-15);
        assert_eq!(parse_pose("1,2,3").unwrap().angles, dvec3(0.0, 0.0, 0.0));
        assert!(parse_pose("1,2").unwrap_err().contains("2 numbers"));
        assert!(parse_pose("1,2,nan").unwrap_err().contains("not a finite"));
        assert!(parse_pose("1,,2,3").unwrap_err().contains("empty value"));
        assert!(parse_pose("1,2,3,").unwrap_err().contains("empty value"));
        assert!(parse_pose("1,2,1e7").unwrap_err().contains("beyond"));
        assert!(
            parse_pose("1,2,3,1e308,0,0")
                .unwrap_err()
                .contains("angles are in degrees")
        );
        assert!(parse_pose("0 1 2 3 0 0 0 1").unwrap_err().contains("TUM line"));
        assert!(
            parse_pose("1,2,\u{1b}[31m").unwrap_err().contains("\\u{1b}"),
            "escapes are shown, not sent"
        );
        let long = format!("1 2 {}", "3".repeat(10_000_000));
        assert!(parse_pose(&long).unwrap_err().len() < 300);
    }
}
