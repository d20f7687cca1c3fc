// Edge supersampling: one invocation per edge pixel traces samples_per_axis² stratified
// sub-pixel rays and writes their mean colour. CPU twin: crates/omnisim/src/antialias.rs.

@group(0) @binding(5) var<storage, read> edge_pixels: array<u32>;
@group(0) @binding(6) var<storage, read_write> edge_colours: array<u32>;

fn sample_colour(pixel: vec2<f32>) -> vec3<f32> {
    let ray = camera_ray(pixel);
    if !ray.valid {
        return vec3<f32>(0.0);
    }
    let origin = camera.origin + camera.world_from_body * ray.origin;
    let hit = closest_hit(origin, camera.world_from_body * ray.direction, ray.t_min);
    if hit.t >= FAR {
        return vec3<f32>(0.0);
    }
    return unpack4x8unorm(face_colours[triangles[hit.triangle].face]).rgb;
}

@compute @workgroup_size(64)
fn refine_edges(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    // Rows of workgroups when there are more edge pixels than one dimension can dispatch.
    let slot = id.y * groups.x * 64u + id.x;
    if slot >= arrayLength(&edge_pixels) {
        return;
    }
    let index = edge_pixels[slot];
    let centre = vec2<f32>(f32(index % camera.width), f32(index / camera.width));
    let n = camera.samples_per_axis;
    var sum = vec3<f32>(0.0);
    for (var sy = 0u; sy < n; sy++) {
        for (var sx = 0u; sx < n; sx++) {
            let offset = (vec2<f32>(f32(sx), f32(sy)) + 0.5) / f32(n) - 0.5;
            sum += sample_colour(centre + offset);
        }
    }
    edge_colours[slot] = pack4x8unorm(vec4<f32>(sum / f32(n * n), 1.0));
}
