// Pinhole ray generation. f64 twin: crates/omnisim/src/camera/pinhole.rs.
// Optical frame (x right, y down, z forward) mounted looking along body +x.

fn pinhole_ray(pixel: vec2<f32>) -> CameraRay {
    let optical = vec3<f32>((pixel - camera.projection.principal) / camera.projection.focal, 1.0);
    // body_from_optical: optical z → body x, optical x → body −y, optical y → body −z.
    let body = vec3<f32>(optical.z, -optical.x, -optical.y);
    return CameraRay(camera.projection.lens_origin, 0.0, normalize(body), true);
}
