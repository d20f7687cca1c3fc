// Hyperbolic catadioptric ray generation by reflection at the mirror surface.
// f64 twin and the frames: crates/omnisim/src/camera/hyperbolic.rs. Mirror: upper sheet of
// (x²+y²)/a² − z²/b² = −1 in the hyperbola frame H; camera at F = (0,0,−c); viewpoint F' = (0,0,c).

fn hyperbolic_ray(pixel: vec2<f32>) -> CameraRay {
    let a2 = camera.mirror_a * camera.mirror_a;
    let b2 = camera.mirror_b * camera.mirror_b;
    let c = camera.mirror_c;
    let d = normalize(vec3<f32>((pixel - camera.principal) / camera.focal, 1.0));
    // Ray from F: origin (0,0,−c) in H.
    let qa = (d.x * d.x + d.y * d.y) / a2 - d.z * d.z / b2;
    let qb = 2.0 * c * d.z / b2;
    let qc = -a2 / b2;
    let disc = qb * qb - 4.0 * qa * qc;
    if disc < 0.0 {
        return miss_ray();
    }
    // Cancellation-free roots; qb > 0 whenever the ray goes towards the mirror.
    let q = -0.5 * (qb + sign(qb) * sqrt(disc));
    var t = FAR;
    for (var k = 0; k < 2; k++) {
        var root: f32;
        if k == 0 { root = q / qa; } else { root = qc / q; }
        if root > 0.0 && root < t && -c + root * d.z > 0.0 {
            t = root;
        }
    }
    if t == FAR {
        return miss_ray();
    }
    let hit_h = vec3<f32>(0.0, 0.0, -c) + t * d;
    if camera.rim_sq >= 0.0 && dot(hit_h.xy, hit_h.xy) > camera.rim_sq {
        return miss_ray();
    }
    let normal = normalize(vec3<f32>(hit_h.x / a2, hit_h.y / a2, -hit_h.z / b2));
    let reflected = normalize(d - 2.0 * dot(d, normal) * normal);
    let hit_m = hit_h - vec3<f32>(0.0, 0.0, c);
    return CameraRay(vec3<f32>(0.0), length(hit_m), reflected, true);
}
