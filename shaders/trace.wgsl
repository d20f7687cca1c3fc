// Entry point: one invocation per pixel generates the camera ray, turns it into the world,
// finds the closest face and writes the hit planes: point, range, face id and normal.
// CPU twin: crates/omnisim/src/trace/mod.rs (trace_pixel).

fn camera_ray(pixel: vec2<f32>) -> CameraRay {
    switch camera.frame.kind {
        case CAMERA_PINHOLE: { return pinhole_ray(pixel); }
        case CAMERA_EQUIRECTANGULAR: { return equirect_ray(pixel); }
        case CAMERA_CATADIOPTRIC: { return catadioptric_ray(pixel); }
        case CAMERA_CYLINDRICAL: { return cylindrical_ray(pixel); }
        case CAMERA_TABLE: { return table_ray(pixel); }
        default: { return miss_ray(); }
    }
}

// The hit planes of the camera ray through `pixel` (sub-pixel positions allowed).
fn trace_pixel(pixel: vec2<f32>) -> PixelHit {
    var out = PixelHit(vec3<f32>(0.0), FAR, vec3<f32>(0.0), NO_FACE);
    let ray = camera_ray(pixel);
    if ray.valid {
        let origin = camera.frame.origin + camera.frame.world_from_body * ray.origin;
        let direction = camera.frame.world_from_body * ray.direction;
        let hit = closest_hit(origin, direction, ray.t_min);
        if hit.t < FAR {
            let triangle = triangles[hit.triangle];
            let normal = normalize(cross(triangle.e1, triangle.e2));
            let facing = select(normal, -normal, dot(normal, direction) > 0.0);
            out = PixelHit(origin + hit.t * direction, hit.t, facing, triangle.face);
        }
    }
    return out;
}

@compute @workgroup_size(8, 8)
fn trace_pixels(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= camera.frame.width || id.y >= camera.frame.band_rows {
        return;
    }
    let row = id.y + camera.frame.row_offset;
    hits[id.y * camera.frame.width + id.x] = trace_pixel(vec2<f32>(f32(id.x), f32(row)));
}
