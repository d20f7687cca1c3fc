// Edge supersampling: one invocation per edge pixel traces samples_per_axis² stratified
// sub-pixel rays, shades each, and writes the mean linear colour and the mean of the 8-bit
// colours. CPU twin: crates/omnisim/src/shade/antialias.rs.

@group(0) @binding(5) var<storage, read> edge_pixels: array<u32>;
@group(0) @binding(6) var<storage, read_write> edge_colours: array<ShadedPixel>;

@compute @workgroup_size(64)
fn refine_edges(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    // Rows of workgroups when there are more edge pixels than one dimension can dispatch.
    let slot = id.y * groups.x * 64u + id.x;
    if slot >= arrayLength(&edge_pixels) {
        return;
    }
    let index = edge_pixels[slot];
    let centre = vec2<f32>(f32(index % camera.frame.width), f32(index / camera.frame.width));
    let n = camera.frame.samples_per_axis;
    var linear = vec3<f32>(0.0);
    var encoded = vec3<u32>(0u);
    for (var sy = 0u; sy < n; sy++) {
        for (var sx = 0u; sx < n; sx++) {
            let offset = (vec2<f32>(f32(sx), f32(sy)) + 0.5) / f32(n) - 0.5;
            let sample = shade_hit(trace_pixel(centre + offset), centre + offset);
            linear += sample.linear;
            encoded += vec3<u32>(unpack4x8unorm(sample.colour).rgb * 255.0 + 0.5);
        }
    }
    let count = n * n;
    let mean = (encoded + count / 2u) / count;
    edge_colours[slot] = ShadedPixel(linear / f32(count), mean.r | (mean.g << 8u) | (mean.b << 16u));
}
