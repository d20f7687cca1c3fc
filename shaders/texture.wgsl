// Face surfaces (textures, vertex colours), pixel footprints (ray cones) and texture filtering:
// the WGSL twin of crates/omnisim/src/shade/{footprint,filter}.rs, camera/cone.rs and
// scene/surface.rs (the same cones, texel centres, wrap rules, level choice and affine maps,
// in f32).

const NO_SURFACE: u32 = 0xffffffffu;
const NO_TEXTURE: u32 = 0xffffffffu;
const WRAP_REPEAT: u32 = 0u;
const WRAP_CLAMP: u32 = 1u;
const WRAP_MIRROR: u32 = 2u;
// GpuSurface.flags: the vertex colours replace the face colour; drawn in its albedo whatever
// the lights.
const SURFACE_COLOURS: u32 = 1u;
const SURFACE_UNLIT: u32 = 2u;

// A face's surface: u, v and the vertex colours as affine functions of the hit point,
// value + gradient · (point − anchor). Host twin: gpu/layout.rs GpuSurface.
struct GpuSurface {
    // Scene-local anchor.
    anchor: vec3<f32>,
    // Index in `textures` of the finest level's header, or NO_TEXTURE.
    levels_at: u32,
    u_gradient: vec3<f32>,
    u_at_anchor: f32,
    v_gradient: vec3<f32>,
    v_at_anchor: f32,
    // Linear vertex colour at the anchor (used where has_colours is 1).
    colour_at_anchor: vec3<f32>,
    level_count: u32,
    red_gradient: vec3<f32>,
    wrap_u: u32,
    green_gradient: vec3<f32>,
    wrap_v: u32,
    blue_gradient: vec3<f32>,
    // SURFACE_COLOURS | SURFACE_UNLIT.
    flags: u32,
}

@group(0) @binding(11) var<storage, read> surfaces: array<GpuSurface>;
// Every texture: level headers (first texel's index in this array, width, height; three u32
// each, finest level first) and texels (8-bit sRGB packed r | g << 8 | b << 16, row 0 at v = 0).
@group(0) @binding(12) var<storage, read> textures: array<u32>;

// Texel index i of a row or column of `size` texels, wrapped into 0..size.
fn wrap_index(i: i32, size: i32, wrap: u32) -> i32 {
    if wrap == WRAP_CLAMP {
        return clamp(i, 0, size - 1);
    }
    if wrap == WRAP_MIRROR {
        let k = ((i % (2 * size)) + 2 * size) % (2 * size);
        return select(2 * size - 1 - k, k, k < size);
    }
    return ((i % size) + size) % size;
}

fn srgb_decode(c: f32) -> f32 {
    return select(pow((c + 0.055) / 1.055, 2.4), c / 12.92, c <= 0.04045);
}

fn texel(first: u32, width: i32, x: i32, y: i32) -> vec3<f32> {
    let c = unpack4x8unorm(textures[first + u32(y * width + x)]).rgb;
    return vec3<f32>(srgb_decode(c.r), srgb_decode(c.g), srgb_decode(c.b));
}

// Bilinear sample of level `level` of the texture whose headers start at `levels_at`.
fn bilinear(levels_at: u32, level: u32, uv: vec2<f32>, wrap_u: u32, wrap_v: u32) -> vec3<f32> {
    let header = levels_at + 3u * level;
    let first = textures[header];
    let size = vec2<i32>(i32(textures[header + 1u]), i32(textures[header + 2u]));
    // NaN or infinite reads coordinate 0, as on the CPU (`filter.rs`, `reduced`).
    let safe = select(vec2<f32>(0.0), uv, abs(uv) <= vec2<f32>(3.4028235e38));
    let t = safe * vec2<f32>(size) - 0.5;
    let t0 = floor(t);
    let f = t - t0;
    let i = vec2<i32>(clamp(t0, vec2<f32>(-2.0e9), vec2<f32>(2.0e9)));
    let x0 = wrap_index(i.x, size.x, wrap_u);
    let x1 = wrap_index(i.x + 1, size.x, wrap_u);
    let y0 = wrap_index(i.y, size.y, wrap_v);
    let y1 = wrap_index(i.y + 1, size.y, wrap_v);
    let top = mix(texel(first, size.x, x0, y0), texel(first, size.x, x1, y0), f.x);
    let bottom = mix(texel(first, size.x, x0, y1), texel(first, size.x, x1, y1), f.x);
    return mix(top, bottom, f.y);
}

// One image axis of the ray cone of `ray`, the camera's body-frame ray at `pixel`: (width at
// the origin, spread), from the neighbouring pixel's ray (camera/cone.rs: ConeAxis::between,
// where it is derived).
fn cone_axis(pixel: vec2<f32>, step: vec2<f32>, ray: CameraRay) -> vec2<f32> {
    // The neighbour ahead where it lies inside the image and has a ray, else the one behind
    // where that does; neither: a zero axis (cone.rs: neighbours).
    let ahead = pixel + step;
    let behind = pixel - step;
    var neighbour = miss_ray();
    if ahead.x <= f32(camera.frame.width) - 1.0 && ahead.y <= f32(camera.frame.height) - 1.0 {
        neighbour = camera_ray(ahead);
    }
    if !neighbour.valid && behind.x >= 0.0 && behind.y >= 0.0 {
        neighbour = camera_ray(behind);
    }
    if !neighbour.valid {
        return vec2<f32>(0.0);
    }
    let d = ray.direction;
    let origins = neighbour.origin - ray.origin;
    let directions = neighbour.direction - d;
    let origins_across = origins - dot(origins, d) * d;
    let directions_across = directions - dot(directions, d) * d;
    let spread = length(directions_across);
    if spread > 0.0 {
        return vec2<f32>(dot(origins_across, directions_across) / spread, spread);
    }
    return vec2<f32>(length(origins_across), 0.0);
}

// The longer axis (metres) of the footprint of the pixel at `pixel` on a face with unit
// `normal` at scene-local `point`: the ray cone's width at the hit over |cos| of the angle
// between ray and normal (shade/footprint.rs: Footprint::longer_axis).
fn footprint_length(pixel: vec2<f32>, point: vec3<f32>, normal: vec3<f32>) -> f32 {
    let ray = camera_ray(pixel);
    if !ray.valid {
        return 0.0;
    }
    let x = cone_axis(pixel, vec2<f32>(1.0, 0.0), ray);
    let y = cone_axis(pixel, vec2<f32>(0.0, 1.0), ray);
    let direction = camera.frame.world_from_body * ray.direction;
    let range = dot(point - (camera.frame.origin + camera.frame.world_from_body * ray.origin), direction);
    let width = max(abs(x.x + range * x.y), abs(y.x + range * y.y));
    return width / max(abs(dot(direction, normal)), 1.17549435e-38);
}

// The squared texels per metre, along the direction where it is largest, of gradients `u`,
// `v` on a texture of `texels` (filter.rs: texels_per_metre_squared).
fn texels_per_metre_squared(u: vec3<f32>, v: vec3<f32>, texels: vec2<f32>) -> f32 {
    let su = u * texels.x;
    let sv = v * texels.y;
    let uu = dot(su, su);
    let uv = dot(su, sv);
    let vv = dot(sv, sv);
    let half_difference = 0.5 * (uu - vv);
    return 0.5 * (uu + vv) + sqrt(half_difference * half_difference + uv * uv);
}

// log2 of `x` (positive, normal) from its bits: the exponent plus a quadratic in the mantissa's
// fraction, exact at powers of two, within 0.0077 between (filter.rs: log2_by_bits).
const LOG2_BEND: f32 = 0.34655;
fn log2_by_bits(x: f32) -> f32 {
    let bits = bitcast<u32>(x);
    let exponent = i32(bits >> 23u) - 127;
    let fraction = f32(bits & 0x7fffffu) * (1.0 / 8388608.0);
    return f32(exponent) + (fraction + LOG2_BEND * (fraction * (1.0 - fraction)));
}

// Whether surface `index` is drawn in its albedo whatever the lights.
fn is_unlit(index: u32) -> bool {
    return index != NO_SURFACE && (surfaces[index].flags & SURFACE_UNLIT) != 0u;
}

// The albedo of a face of colour `colour` and surface `index` at a hit seen through `pixel`:
// the colour (or the vertex colours), times the texture filtered to the pixel's footprint.
fn surface_albedo(colour: vec3<f32>, index: u32, point: vec3<f32>, normal: vec3<f32>, pixel: vec2<f32>) -> vec3<f32> {
    if index == NO_SURFACE {
        return colour;
    }
    let surface = surfaces[index];
    let d = point - surface.anchor;
    var factor = colour;
    if (surface.flags & SURFACE_COLOURS) != 0u {
        let interpolated = surface.colour_at_anchor
            + vec3<f32>(dot(surface.red_gradient, d), dot(surface.green_gradient, d), dot(surface.blue_gradient, d));
        factor = clamp(interpolated, vec3<f32>(0.0), vec3<f32>(1.0));
    }
    if surface.levels_at == NO_TEXTURE {
        return factor;
    }
    let uv = vec2<f32>(surface.u_at_anchor + dot(surface.u_gradient, d), surface.v_at_anchor + dot(surface.v_gradient, d));
    let texels = vec2<f32>(f32(textures[surface.levels_at + 1u]), f32(textures[surface.levels_at + 2u]));
    let length = footprint_length(pixel, point, normal);
    let squared = texels_per_metre_squared(surface.u_gradient, surface.v_gradient, texels) * length * length;
    let last = f32(surface.level_count - 1u);
    // A NaN or overflowing footprint: the coarsest level (NaN < FAR is false; filter.rs:
    // level_of_detail).
    var lod = last;
    if squared < FAR {
        lod = clamp(0.5 * log2_by_bits(max(squared, 1.0)), 0.0, last);
    }
    let fine = floor(lod);
    let fraction = lod - fine;
    var sample = bilinear(surface.levels_at, u32(fine), uv, surface.wrap_u, surface.wrap_v);
    if fraction > 0.0 {
        sample = mix(sample, bilinear(surface.levels_at, u32(fine) + 1u, uv, surface.wrap_u, surface.wrap_v), fraction);
    }
    return factor * sample;
}
