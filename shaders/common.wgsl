// Data shared by every stage: the camera uniform, the scene buffers, materials and lights, the
// hit and shaded planes.
// Host twins: crates/omnisim/src/gpu/layout.rs (a test checks sizes and offsets against naga).

const CAMERA_PINHOLE: u32 = 0u;
const CAMERA_EQUIRECTANGULAR: u32 = 1u;
const CAMERA_CATADIOPTRIC: u32 = 2u;
const CAMERA_CYLINDRICAL: u32 = 3u;
const CAMERA_TABLE: u32 = 4u;

const NO_FACE: u32 = 0xffffffffu;
// Larger than any distance in a scene; WGSL has no infinity literal.
const FAR: f32 = 3.0e38;
const PI: f32 = 3.14159265358979;

// The camera uniform: a block every camera has (the frame), then the projection's and the
// mirror's blocks, which the models that have none leave at their defaults.
struct FrameBlock {
    // world_from_body rotation of the pose.
    world_from_body: mat3x3<f32>,
    // Viewpoint relative to the scene offset (see accel/mod.rs), metres.
    origin: vec3<f32>,
    kind: u32,
    width: u32,
    height: u32,
    // First image row of this dispatch (large images are traced in bands).
    row_offset: u32,
    band_rows: u32,
    // Edge supersampling (antialias.wgsl): n for n×n samples per edge pixel.
    samples_per_axis: u32,
}

// Pinhole, cylindrical and the catadioptric camera's own lens.
struct ProjectionBlock {
    // Pixels per unit: fx, fy (pinhole, catadioptric); fy of the cylinder (cylindrical).
    focal: vec2<f32>,
    principal: vec2<f32>,
    // Pinhole: optical centre in the body frame. Catadioptric: body position of the origin of
    // the frame C the mirror is given in (C = the mirror frame shifted to the nominal camera).
    lens_origin: vec3<f32>,
}

// Catadioptric only.
struct MirrorBlock {
    // Rotation of the camera's optical axes in C (misalignment tilt).
    camera_tilt: mat3x3<f32>,
    // The mirror in C, x·diag·x + linear·x + constant = 0.
    mirror_diag: vec3<f32>,
    mirror_constant: f32,
    mirror_linear: vec3<f32>,
    // +1: mirror axis along body +z; −1: along body −z (body_from_C rotation diag(1, s, s)).
    mount_sign: f32,
    // Camera centre in C (misalignment offset).
    camera_offset: vec3<f32>,
    // Squared mirror rim radius; negative for none.
    rim_sq: f32,
    // Only mirror points with z_C above this count (hyperbola's upper sheet).
    mirror_min_z: f32,
    // Squared pixel radius hidden by the camera body.
    hidden_centre_sq: f32,
    // Booleans as u32: orthographic camera (parabolic), all rays through one viewpoint,
    // the paper's shortcut instead of reflection, the camera's lens model (its rays to the
    // mirror come from the ray table, camera_table.wgsl).
    orthographic: u32,
    central: u32,
    shortcut: u32,
    inner_lens: u32,
}

struct CameraParams {
    frame: FrameBlock,
    projection: ProjectionBlock,
    mirror: MirrorBlock,
}

// A node of the 8-wide BVH (bvh.wgsl): its children's boxes, lane i = child i; entry
// 2·axis + half holds children 4·half..4·half + 4 on that axis.
struct WideNode {
    min: array<vec4<f32>, 6>,
    max: array<vec4<f32>, 6>,
    // Inner node index, or LEAF | (triangle count − 1) << LEAF_COUNT_SHIFT | first triangle.
    child: array<vec4<u32>, 2>,
    // Bit i set where child i exists.
    lanes: u32,
}

// A triangle as corner v0 and edges e1 = v1 − v0, e2 = v2 − v0 (edges computed in f64), in
// the order the wide BVH's leaves reach it; leaf_order is its index in BVH leaf order.
struct Triangle {
    v0: vec3<f32>,
    face: u32,
    e1: vec3<f32>,
    leaf_order: u32,
    e2: vec3<f32>,
    _pad: u32,
}

// The hit planes of one pixel (trace.wgsl writes them, shade.wgsl reads them).
struct PixelHit {
    // Hit point relative to the scene offset.
    point: vec3<f32>,
    range: f32,
    // Unit face normal turned towards the ray origin.
    normal: vec3<f32>,
    face: u32,
}

// The shading stage's output for one pixel: linear colour and packed 8-bit sRGB.
struct ShadedPixel {
    linear: vec3<f32>,
    colour: u32,
}

const LIGHT_POINT: u32 = 0u;
const LIGHT_DIRECTIONAL: u32 = 1u;

// Point: vector = position relative to the scene offset, strength = linear colour × candela.
// Directional: vector = unit travel direction, strength = linear colour × lux.
struct GpuLight {
    vector: vec3<f32>,
    kind: u32,
    strength: vec3<f32>,
    _pad: u32,
}

struct ShadingParams {
    ambient: f32,
    // 1 / white: the exposure, lux⁻¹.
    inverse_white: f32,
    light_count: u32,
    // 0: flat face colours; 1: lit.
    lit: u32,
}

// A camera ray in the body frame; `valid` is false where the pixel sees nothing.
struct CameraRay {
    origin: vec3<f32>,
    t_min: f32,
    direction: vec3<f32>,
    valid: bool,
}

@group(0) @binding(0) var<uniform> camera: CameraParams;
@group(0) @binding(1) var<storage, read> nodes: array<WideNode>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
// A face's linear albedo (its colour; a textured face's tint) and its surface (texture.wgsl).
struct Material {
    rgb: vec3<f32>,
    surface: u32,
}

@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read_write> hits: array<PixelHit>;
@group(0) @binding(7) var<storage, read> lights: array<GpuLight>;
@group(0) @binding(8) var<uniform> shading: ShadingParams;
@group(0) @binding(9) var<storage, read_write> shaded: array<ShadedPixel>;

fn miss_ray() -> CameraRay {
    return CameraRay(vec3<f32>(0.0), 0.0, vec3<f32>(0.0, 0.0, 1.0), false);
}
