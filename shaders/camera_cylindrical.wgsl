// Cylindrical panorama ray generation. f64 twin: crates/omnisim/src/camera/cylindrical.rs.
// Column u: azimuth π − 2π(u + ½)/W; row v: rise (cy − v)/fy per unit horizontal distance.

fn cylindrical_ray(pixel: vec2<f32>) -> CameraRay {
    let azimuth = PI - 2.0 * PI * (pixel.x + 0.5) / f32(camera.frame.width);
    let rise = (camera.projection.principal.y - pixel.y) / camera.projection.focal.y;
    let direction = normalize(vec3<f32>(cos(azimuth), sin(azimuth), rise));
    return CameraRay(vec3<f32>(0.0), 0.0, direction, true);
}
