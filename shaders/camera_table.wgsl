// Lens cameras (fisheye, distorted pinhole): each pixel's body-frame ray read from the table the
// host computes once per camera in f64 (crates/omnisim/src/camera/lens_camera.rs) and uploads
// as f32: xyz the unit direction, w = 1 where the pixel has a ray, 0 beyond the lens's field of
// view. Rays start at the lens's optical centre. Pixel centres only: edge supersampling of
// these cameras runs on the CPU. A catadioptric camera with a lens model reads its inner
// camera's optical-frame directions (before the misalignment tilt) here too.

@group(0) @binding(10) var<storage, read> camera_rays: array<vec4<f32>>;

fn table_ray(pixel: vec2<f32>) -> CameraRay {
    let ray = camera_rays[u32(pixel.y) * camera.frame.width + u32(pixel.x)];
    if ray.w == 0.0 {
        return miss_ray();
    }
    return CameraRay(camera.projection.lens_origin, 0.0, ray.xyz, true);
}
