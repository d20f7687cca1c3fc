// Equirectangular panorama ray generation. f64 twin: crates/omnisim/src/camera/equirect.rs.
// Column u: azimuth π − 2π(u + ½)/W; row v: elevation π/2 − π(v + ½)/H.

fn equirect_ray(pixel: vec2<f32>) -> CameraRay {
    let size = vec2<f32>(f32(camera.frame.width), f32(camera.frame.height));
    let azimuth = PI - 2.0 * PI * (pixel.x + 0.5) / size.x;
    let elevation = 0.5 * PI - PI * (pixel.y + 0.5) / size.y;
    let direction = vec3<f32>(cos(elevation) * cos(azimuth), cos(elevation) * sin(azimuth), sin(elevation));
    return CameraRay(vec3<f32>(0.0), 0.0, direction, true);
}
