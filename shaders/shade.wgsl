// The shading stage: hit planes, materials and lights in, colour out. WGSL twin of
// crates/omnisim/src/shade/mod.rs (the model is stated there and in README); nothing else maps a
// hit to a colour.

// Shadow rays start this far off the face (relative to the point's distance from the scene
// centre, plus one), on the lit side; the face itself is skipped too. Larger than the CPU's
// because hit points carry f32 rounding.
const SHADOW_OFFSET: f32 = 1e-5;

// Linear colour of a hit seen through `pixel` (1.0 = full scale).
fn shade(point: vec3<f32>, normal: vec3<f32>, face: u32, pixel: vec2<f32>) -> vec3<f32> {
    let material = materials[face];
    let albedo = surface_albedo(material.rgb, material.surface, point, normal, pixel);
    if shading.lit == 0u || is_unlit(material.surface) {
        return albedo;
    }
    let extent = abs(point);
    let origin = point + normal * (SHADOW_OFFSET * (1.0 + max(max(extent.x, extent.y), extent.z)));
    var total = vec3<f32>(shading.ambient);
    for (var i = 0u; i < shading.light_count; i++) {
        let light = lights[i];
        var towards = -light.vector;
        var distance = FAR;
        var strength = light.strength;
        if light.kind == LIGHT_POINT {
            let offset = light.vector - point;
            let squared = dot(offset, offset);
            distance = sqrt(squared);
            towards = offset / distance;
            strength = light.strength / squared;
        }
        let cosine = dot(normal, towards);
        if !(cosine > 0.0) || occluded(origin, towards, distance, face) {
            continue;
        }
        total += strength * cosine;
    }
    return albedo * total * shading.inverse_white;
}

// sRGB encoding (IEC 61966-2-1) of one linear channel, clamped to [0, 1].
fn srgb_encode(linear: f32) -> f32 {
    let c = clamp(linear, 0.0, 1.0);
    if c <= 0.0031308 {
        return 12.92 * c;
    }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

// 8-bit sRGB packed r | g << 8 | b << 16 (rounded to nearest, as the CPU does).
fn pack_srgb(linear: vec3<f32>) -> u32 {
    let encoded = vec3<f32>(srgb_encode(linear.r), srgb_encode(linear.g), srgb_encode(linear.b));
    return pack4x8unorm(vec4<f32>(encoded, 0.0));
}

// The shaded pixel of a hit seen through `pixel`; black where nothing is hit.
fn shade_hit(hit: PixelHit, pixel: vec2<f32>) -> ShadedPixel {
    if hit.face == NO_FACE {
        return ShadedPixel(vec3<f32>(0.0), 0u);
    }
    let linear = shade(hit.point, hit.normal, hit.face, pixel);
    return ShadedPixel(linear, pack_srgb(linear));
}

@compute @workgroup_size(8, 8)
fn shade_pixels(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= camera.frame.width || id.y >= camera.frame.band_rows {
        return;
    }
    let index = id.y * camera.frame.width + id.x;
    shaded[index] = shade_hit(hits[index], vec2<f32>(f32(id.x), f32(id.y + camera.frame.row_offset)));
}
