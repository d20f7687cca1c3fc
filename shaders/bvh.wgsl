// Closest-hit and any-hit (shadow) traversal of obvhs's BVH2 (32-byte `small_bvh2_node`
// nodes), following obvhs's `Bvh2::ray_traverse_dynamic` step for step.
// CPU twin: crates/omnisim/src/trace/reference.rs (closest_hit, occluded).

const STACK_SIZE: u32 = 64u;
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

// Entry distance of the ray into a node's box, or FAR.
fn box_entry(node: BvhNode, origin: vec3<f32>, inv_direction: vec3<f32>) -> f32 {
    let t1 = (node.min - origin) * inv_direction;
    let t2 = (node.max - origin) * inv_direction;
    let near = min(t1, t2);
    let far = max(t1, t2);
    let t_near = max(max(near.x, near.y), near.z);
    let t_far = min(min(far.x, far.y), far.z);
    if t_far >= t_near && t_far >= 0.0 {
        return t_near;
    }
    return FAR;
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
// lower triangle (BVH leaf order), so the traversal order never decides. FAR is no hit.
fn wins(t: f32, triangle: u32, best: Hit) -> bool {
    if t == best.t && t < FAR {
        let face = triangles[triangle].face;
        let best_face = triangles[best.triangle].face;
        return face < best_face || (face == best_face && triangle < best.triangle);
    }
    return t < best.t;
}

fn intersect_leaf(node: BvhNode, query: Query, best: ptr<function, Hit>) {
    for (var i = node.first_index; i < node.first_index + node.prim_count; i++) {
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
                return;
            }
        }
    }
}

fn closest_hit(origin: vec3<f32>, direction: vec3<f32>, t_min: f32) -> Hit {
    return traverse(Query(origin, direction, t_min, NO_FACE, false), FAR);
}

// Whether anything but `skip_face` lies on the ray strictly between 0 and t_max.
fn occluded(origin: vec3<f32>, direction: vec3<f32>, t_max: f32, skip_face: u32) -> bool {
    return traverse(Query(origin, direction, 0.0, skip_face, true), t_max).t < t_max;
}

// The hit nearest in (query.t_min, t_max), or Hit(t_max, 0) if none; with any_hit, the first
// found.
fn traverse(query: Query, t_max: f32) -> Hit {
    var best = Hit(t_max, 0u);
    if arrayLength(&nodes) == 0u {
        return best;
    }
    let origin = query.origin;
    let direction = query.direction;
    let inv_direction = vec3<f32>(safe_inverse(direction.x), safe_inverse(direction.y), safe_inverse(direction.z));
    let root = nodes[0];
    if box_entry(root, origin, inv_direction) >= FAR {
        return best;
    }
    if root.prim_count > 0u {
        intersect_leaf(root, query, &best);
        return best;
    }
    var stack: array<u32, STACK_SIZE>;
    var stack_len = 0u;
    var current = root.first_index;
    loop {
        var left = nodes[current];
        var right = nodes[current + 1u];
        var left_t = box_entry(left, origin, inv_direction);
        var right_t = box_entry(right, origin, inv_direction);
        if left_t > right_t {
            let node = left;
            left = right;
            right = node;
            let t = left_t;
            left_t = right_t;
            right_t = t;
        }
        var go_left = false;
        // A box entered at the best distance may hold a triangle that wins the tie.
        if left_t <= best.t && left_t < FAR {
            if left.prim_count > 0u {
                intersect_leaf(left, query, &best);
                if query.any_hit && best.t < t_max {
                    return best;
                }
            } else {
                go_left = true;
            }
        }
        var go_right = false;
        if right_t <= best.t && right_t < FAR {
            if right.prim_count > 0u {
                intersect_leaf(right, query, &best);
                if query.any_hit && best.t < t_max {
                    return best;
                }
            } else {
                go_right = true;
            }
        }
        if go_left && go_right {
            current = left.first_index;
            stack[stack_len] = right.first_index;
            stack_len += 1u;
        } else if go_left {
            current = left.first_index;
        } else if go_right {
            current = right.first_index;
        } else {
            if stack_len == 0u {
                break;
            }
            stack_len -= 1u;
            current = stack[stack_len];
        }
    }
    return best;
}
