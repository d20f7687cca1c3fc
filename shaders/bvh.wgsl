// Closest-hit and any-hit (shadow) traversal of the fast CPU tracer's 8-wide BVH
// (accel/wide.rs, laid out for the GPU by gpu/wide.rs). A node's eight boxes are tested at
// once; the children entered form a group (node << 8 | one bit per child) taken nearest child
// first, then in lane order; a leaf child is tested where it is taken, an inner one is visited
// next and the rest of its group waits on the stack, one entry per level. Sorting every child
// onto the stack by distance, as the CPU walk does, made lavapipe 1.1–1.8× slower than the BVH2
// walk this replaced: a software GPU scatters each per-invocation stack write
// (docs/benchmarks.md, "GPU walk of the wide BVH").
// CPU twin: crates/omnisim/src/trace/fast/wide.rs (WideBvh::traverse: the same boxes, slab
// test and leaves; it orders every child by distance).

// One group per level below the root: the host refuses wide BVHs deeper than this.
const STACK_SIZE: u32 = 64u;
// A child entry with this bit is a leaf: a run of triangles.
const LEAF: u32 = 0x80000000u;
const LEAF_COUNT_SHIFT: u32 = 26u;
const LEAF_FIRST: u32 = 0x3ffffffu;
// Barycentric slack that closes the gaps f32 rounding leaves along shared edges.
const EDGE_TOLERANCE: f32 = 1e-6;

struct Hit {
    t: f32,
    triangle: u32,
}

fn safe_inverse(x: f32) -> f32 {
    let epsilon = 1.1920929e-7;
    if abs(x) <= epsilon {
        return select(1.0, -1.0, x < 0.0) / epsilon;
    }
    return 1.0 / x;
}

// Möller–Trumbore; t where the ray meets the triangle, or FAR.
fn intersect_triangle(tri: Triangle, origin: vec3<f32>, direction: vec3<f32>) -> f32 {
    let p = cross(direction, tri.e2);
    let det = dot(tri.e1, p);
    if det == 0.0 {
        return FAR;
    }
    let inv = 1.0 / det;
    let s = origin - tri.v0;
    let u = dot(s, p) * inv;
    if u < -EDGE_TOLERANCE || u > 1.0 + EDGE_TOLERANCE {
        return FAR;
    }
    let q = cross(s, tri.e1);
    let v = dot(direction, q) * inv;
    if v < -EDGE_TOLERANCE || u + v > 1.0 + EDGE_TOLERANCE {
        return FAR;
    }
    return dot(tri.e2, q) * inv;
}

// A traversal request: the ray, the interval (t_min, best.t) searched, a face to ignore (the
// face a shadow ray leaves), and whether any hit ends the search.
struct Query {
    origin: vec3<f32>,
    direction: vec3<f32>,
    t_min: f32,
    skip_face: u32,
    any_hit: bool,
}

// Whether a closest-hit candidate at `t` on `triangle` beats `best`: the rule of the CPU
// tracers (trace/triangle.rs, `wins`) in f32. The nearer hit, and at exactly equal f32
// distance (a ray along an edge two faces share, coincident faces) the lower face id, then the
// lower triangle in BVH leaf order, so the traversal order never decides. FAR is no hit.
fn wins(t: f32, triangle: u32, best: Hit) -> bool {
    if t == best.t && t < FAR {
        let face = triangles[triangle].face;
        let best_face = triangles[best.triangle].face;
        return face < best_face
            || (face == best_face && triangles[triangle].leaf_order < triangles[best.triangle].leaf_order);
    }
    return t < best.t;
}

// Tests the triangles of leaf `entry` against the query; true when an any-hit query found one.
fn intersect_leaf(entry: u32, query: Query, best: ptr<function, Hit>) -> bool {
    let first = entry & LEAF_FIRST;
    let end = first + ((entry >> LEAF_COUNT_SHIFT) & 31u) + 1u;
    for (var i = first; i < end; i++) {
        let triangle = triangles[i];
        if triangle.face == query.skip_face {
            continue;
        }
        let t = intersect_triangle(triangle, query.origin, query.direction);
        // Any-hit queries keep t < t_max strictly (`best` starts at t_max, no triangle).
        let better = select(wins(t, i, *best), t < (*best).t, query.any_hit);
        if t > query.t_min && better {
            *best = Hit(t, i);
            if query.any_hit {
                return true;
            }
        }
    }
    return false;
}

fn closest_hit(origin: vec3<f32>, direction: vec3<f32>, t_min: f32) -> Hit {
    return traverse(Query(origin, direction, t_min, NO_FACE, false), FAR);
}

// Whether anything but `skip_face` lies on the ray strictly between 0 and t_max.
fn occluded(origin: vec3<f32>, direction: vec3<f32>, t_max: f32, skip_face: u32) -> bool {
    return traverse(Query(origin, direction, 0.0, skip_face, true), t_max).t < t_max;
}

// Whether a component of `v` is NaN, read from its bits: WGSL lets an implementation assume
// that float values are never NaN, so `x != x` may be folded away.
fn has_nan(v: vec3<f32>) -> bool {
    return any((bitcast<vec3<u32>>(v) & vec3<u32>(0x7fffffffu)) > vec3<u32>(0x7f800000u));
}

// The hit nearest in (query.t_min, t_max), or Hit(t_max, 0) if none; with any_hit, the first
// found.
fn traverse(query: Query, t_max: f32) -> Hit {
    var best = Hit(t_max, 0u);
    // A NaN ray hits nothing (every distance on it is NaN, which no comparison keeps), but its
    // slab tests admit every box: without this it walked the whole tree to find so.
    if has_nan(query.origin) || has_nan(query.direction) {
        return best;
    }
    let origin = query.origin;
    let inv_direction = vec3<f32>(
        safe_inverse(query.direction.x),
        safe_inverse(query.direction.y),
        safe_inverse(query.direction.z),
    );
    // Groups waiting: node << 8 | the children entered and not taken yet.
    var stack: array<u32, STACK_SIZE>;
    var len = 0u;
    var node = 0u;
    loop {
        // The children of inner node `node` the ray enters between 0 and the best distance (a
        // box entered at the best distance may hold a triangle that wins the tie), and the
        // nearest of them.
        let lanes = nodes[node].lanes;
        var entered_lanes = 0u;
        var nearest = 0u;
        var nearest_t = FAR;
        for (var half = 0u; half < 2u; half++) {
            var near = vec4<f32>(0.0);
            var far = vec4<f32>(best.t);
            for (var axis = 0u; axis < 3u; axis++) {
                let t1 = (nodes[node].min[2u * axis + half] - origin[axis]) * inv_direction[axis];
                let t2 = (nodes[node].max[2u * axis + half] - origin[axis]) * inv_direction[axis];
                near = max(near, min(t1, t2));
                far = min(far, max(t1, t2));
            }
            let entered = near <= far;
            for (var k = 0u; k < 4u; k++) {
                let lane = 4u * half + k;
                if entered[k] && ((lanes >> lane) & 1u) != 0u {
                    entered_lanes |= 1u << lane;
                    if near[k] < nearest_t {
                        nearest_t = near[k];
                        nearest = lane;
                    }
                }
            }
        }
        var group = (node << 8u) | entered_lanes;
        // Take children until an inner one is found (popping groups as they run out).
        loop {
            if (group & 0xffu) == 0u {
                if len == 0u {
                    return best;
                }
                len -= 1u;
                group = stack[len];
                continue;
            }
            // The nearest child first (while its bit is still set), then lane order; a popped
            // group may share `nearest`'s bit by chance, which changes the order only.
            let lane = select(firstTrailingBit(group & 0xffu), nearest, ((group >> nearest) & 1u) != 0u);
            group &= ~(1u << lane);
            let child = nodes[group >> 8u].child[lane / 4u][lane % 4u];
            if (child & LEAF) != 0u {
                if intersect_leaf(child, query, &best) {
                    return best;
                }
                continue;
            }
            if (group & 0xffu) != 0u {
                stack[len] = group;
                len += 1u;
            }
            node = child;
            break;
        }
    }
    return best;
}
