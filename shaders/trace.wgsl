// Entry point: one invocation per pixel generates the camera ray, turns it into the world,
// finds the closest face and writes colour, range, face id and hit point.

fn camera_ray(pixel: vec2<f32>) -> CameraRay {
    switch camera.kind {
        case CAMERA_PINHOLE: { return pinhole_ray(pixel); }
        case CAMERA_EQUIRECTANGULAR: { return equirect_ray(pixel); }
        case CAMERA_CATADIOPTRIC: { return catadioptric_ray(pixel); }
        case CAMERA_CYLINDRICAL: { return cylindrical_ray(pixel); }
        default: { return miss_ray(); }
    }
}

@compute @workgroup_size(8, 8)
fn trace_pixels(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= camera.width || id.y >= camera.band_rows {
        return;
    }
    let row = id.y + camera.row_offset;
    let index = id.y * camera.width + id.x;
    var out = PixelHit(vec3<f32>(0.0), FAR, NO_FACE, 0u);
    let ray = camera_ray(vec2<f32>(f32(id.x), f32(row)));
    if ray.valid {
        let origin = camera.origin + camera.world_from_body * ray.origin;
        let direction = camera.world_from_body * ray.direction;
        let hit = closest_hit(origin, direction, ray.t_min);
        if hit.t < FAR {
            let face = triangles[hit.triangle].face;
            out = PixelHit(origin + hit.t * direction, hit.t, face, face_colours[face]);
        }
    }
    hits[index] = out;
}
