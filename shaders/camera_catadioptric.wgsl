// Catadioptric ray generation: the camera's ray to the mirror (through its lens model from the
// ray table where it has one), reflected by the law of reflection (or, for the paper's
// shortcut, taken from the viewpoint through the mirror point).
// f64 twin and the frames: crates/omnisim/src/camera/catadioptric.rs. Everything here is in
// the frame C: the mirror frame shifted (in f64, on the host) to the nominal camera, so the
// quadric's coefficients carry no cancellation into f32.

fn body_from_c(v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(v.x, camera.mirror.mount_sign * v.y, camera.mirror.mount_sign * v.z);
}

fn catadioptric_ray(pixel: vec2<f32>) -> CameraRay {
    let centred = pixel - camera.projection.principal;
    if dot(centred, centred) < camera.mirror.hidden_centre_sq {
        return miss_ray();
    }
    let offset = centred / camera.projection.focal;
    var origin = camera.mirror.camera_offset;
    var d: vec3<f32>;
    if camera.mirror.orthographic != 0u {
        origin += camera.mirror.camera_tilt * vec3<f32>(offset, 0.0);
        d = camera.mirror.camera_tilt * vec3<f32>(0.0, 0.0, 1.0);
    } else if camera.mirror.inner_lens != 0u {
        // The lens's f64 inverse, per pixel centre, from the table (camera_table.wgsl).
        let towards = camera_rays[u32(pixel.y) * camera.frame.width + u32(pixel.x)];
        if towards.w == 0.0 {
            return miss_ray();
        }
        d = normalize(camera.mirror.camera_tilt * towards.xyz);
    } else {
        d = normalize(camera.mirror.camera_tilt * vec3<f32>(offset, 1.0));
    }
    let qa = dot(camera.mirror.mirror_diag * d, d);
    let qb = 2.0 * dot(camera.mirror.mirror_diag * origin, d) + dot(camera.mirror.mirror_linear, d);
    let qc = dot(camera.mirror.mirror_diag * origin, origin) + dot(camera.mirror.mirror_linear, origin) + camera.mirror.mirror_constant;
    var roots: array<f32, 2>;
    if abs(qa) <= 1e-12 * (abs(qb) + abs(qc)) {
        // Parallel to an asymptote or to a paraboloid's axis: the equation is linear.
        roots = array<f32, 2>(-qc / qb, -1.0);
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc < 0.0 {
            return miss_ray();
        }
        // Cancellation-free roots.
        let q = -0.5 * (qb + select(-1.0, 1.0, qb >= 0.0) * sqrt(disc));
        roots = array<f32, 2>(q / qa, qc / q);
    }
    var t = FAR;
    for (var k = 0; k < 2; k++) {
        let root = roots[k];
        if root > 0.0 && root < t && origin.z + root * d.z > camera.mirror.mirror_min_z {
            t = root;
        }
    }
    if t == FAR {
        return miss_ray();
    }
    let hit = origin + t * d;
    if camera.mirror.rim_sq >= 0.0 && dot(hit.xy, hit.xy) > camera.mirror.rim_sq {
        return miss_ray();
    }
    let normal = normalize(2.0 * camera.mirror.mirror_diag * hit + camera.mirror.mirror_linear);
    let reflected = body_from_c(normalize(d - 2.0 * dot(d, normal) * normal));
    let hit_body = body_from_c(hit) + camera.projection.lens_origin;
    if camera.mirror.shortcut != 0u {
        return CameraRay(vec3<f32>(0.0), length(hit_body), normalize(hit_body), true);
    }
    if camera.mirror.central != 0u {
        return CameraRay(vec3<f32>(0.0), length(hit_body), reflected, true);
    }
    return CameraRay(hit_body, 0.0, reflected, true);
}
