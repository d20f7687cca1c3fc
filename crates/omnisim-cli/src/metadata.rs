//! render.json: everything needed to use a rendered data set without reading omnisim's code:
//! the camera and its parameters, the conventions of every file, the backend, every pose.

use std::path::Path;

use omnisim::camera::MirrorShape;
use omnisim::output;
use omnisim::{Camera, Pose, PreparedScene, Renderer, Scene};
use serde_json::json;

use crate::camera_args::Rig;

fn camera_json(camera: &Camera) -> serde_json::Value {
    let (width, height) = camera.size();
    let mut value =
        json!({ "model": camera.model_name(), "width": width, "height": height, "central": camera.is_central() });
    let extra = match camera {
        Camera::Pinhole(c) => json!({
            "fx": c.fx, "fy": c.fy, "cx": c.cx, "cy": c.cy, "position_in_body": c.position.to_array(),
            "optical_frame": "OpenCV (x right, y down, z forward); looks along body +x",
        }),
        Camera::Equirectangular(_) => json!({
            "azimuth_of_column_u": "pi - 2*pi*(u + 0.5)/width, counter-clockwise from body +x",
            "elevation_of_row_v": "pi/2 - pi*(v + 0.5)/height",
        }),
        Camera::Cylindrical(c) => json!({
            "fy": c.fy, "cy": c.cy,
            "azimuth_of_column_u": "pi - 2*pi*(u + 0.5)/width, counter-clockwise from body +x",
            "row_v": "a ray rises (cy - v)/fy per unit of horizontal distance",
        }),
        Camera::Catadioptric(c) => {
            let mirror = match c.mirror {
                MirrorShape::Hyperbolic { a, b } => json!({
                    "shape": "hyperbolic: (x^2+y^2)/a^2 - z^2/b^2 = -1, upper sheet; perspective camera at the outer focus",
                    "a": a, "b": b, "c": c.c() }),
                MirrorShape::Parabolic { a, b, h } => json!({
                    "shape": "parabolic: z = h*(x^2/a^2 + y^2/b^2); orthographic camera along the axis (focal = pixels per metre)",
                    "a": a, "b": b, "h": h }),
                MirrorShape::Spherical {
                    radius,
                    camera_distance,
                } => json!({
                    "shape": "spherical: x^2+y^2+z^2 = R^2; perspective camera at (0,0,-D); body origin at the centre",
                    "radius": radius, "camera_distance": camera_distance }),
            };
            json!({
                "mirror": mirror,
                "focal": c.focal, "cx": c.cx, "cy": c.cy,
                "rim_radius": c.rim_radius,
                "hidden_centre_px": c.hidden_centre_px,
                "mount": format!("{:?}", c.mount),
                "misalignment": { "offset_m": c.misalignment.offset.to_array(), "tilt_rad": c.misalignment.tilt.to_array() },
                "mirror_rays": format!("{:?}", c.rays),
                "body_origin_in_mirror_frame": c.body_origin_in_mirror().to_array(),
                "unified_model": c.unified_model().map(|m| json!({ "xi": m.xi, "gamma_x": m.gamma_x, "gamma_y": m.gamma_y,
                    "projection": "u = cx + gamma_x*s_x/(xi - s_z), v = cy + gamma_y*s_y/(xi - s_z), s = unit direction from F' in the mirror frame" })),
                "image_azimuth": "a point at body azimuth phi appears at atan2(v - cy, u - cx) = phi with the mirror mounted up, -phi mounted down (u right, v down): the image is mirrored on screen",
                "rays": "see raymap.exr: per-pixel origin and direction in the body frame",
            })
        }
    };
    if let (Some(map), serde_json::Value::Object(extra)) = (value.as_object_mut(), extra) {
        map.extend(extra);
    }
    value
}

pub fn metadata(
    scene: &Scene,
    scene_path: &Path,
    rig: &Rig,
    poses: &[Pose],
    (renderer, prepared): (&Renderer, &PreparedScene),
) -> serde_json::Value {
    let camera = match rig {
        Rig::Single(camera) => camera_json(camera),
        Rig::Stereo(stereo) => {
            let [left, right] = stereo.cameras();
            json!({ "model": "stereo", "baseline": stereo.baseline,
                    "left": camera_json(&Camera::Pinhole(left)), "right": camera_json(&Camera::Pinhole(right)),
                    "disparity": "<stem>-disparity.exr: u_left - u_right = fx*baseline/z for the left image" })
        }
    };
    json!({
        "omnisim": env!("CARGO_PKG_VERSION"),
        "scene": { "name": scene.name, "file": scene_path, "faces": scene.faces.len() },
        "camera": camera,
        "backend": { "name": prepared.backend_name(), "device": renderer.device_name(),
                     "reason": prepared.fallback().unwrap_or(renderer.reason()) },
        "conventions": {
            "units": "metres; angles in degrees here",
            "world": "right-handed, z up",
            "body": "x forward, y left, z up; pose position = the body origin: the optical centre (pinhole), the rig's centre (stereo), a central mirror's viewpoint F', the sphere's centre, or a non-central paraboloid's focus",
            "rotation": "world_from_body = Rx(theta_x)*Ry(theta_y)*Rz(theta_z)",
            "pixels": "u = column, v = row, pixel centres at integer coordinates, (0,0) top-left",
            "range": match rig {
                Rig::Single(camera) => output::range_convention(camera),
                Rig::Stereo(stereo) => output::range_convention(&Camera::Pinhole(stereo.cameras()[0].clone())),
            },
            "depth": format!("pinhole and stereo: <stem>-depth.exr ({}); <stem>-depth.png, TUM RGB-D 16-bit: value = z * {}, 0 = no hit or z > 13.1 m", output::AXIAL_DEPTH_CONVENTION, output::TUM_DEPTH_SCALE),
            "ray_map": output::RAY_MAP_CONVENTION,
            "point_cloud": "binary little-endian PLY, float x y z in world metres + uchar red green blue, hit pixels only",
        },
        "frames": poses.iter().enumerate().map(|(index, pose)| {
            let a = pose.angles_degrees();
            json!({
                "index": index,
                "stem": format!("{}-{index:04}", scene.file_stem()),
                "position": pose.position.to_array(),
                "angles_deg": [a.x, a.y, a.z],
                "quaternion_xyzw": pose.quaternion_xyzw(),
                "world_from_body": pose.world_from_body().transpose().to_cols_array_2d(),
            })
        }).collect::<Vec<_>>(),
    })
}
