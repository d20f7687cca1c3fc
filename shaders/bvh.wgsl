// Closest-hit traversal of obvhs's BVH2 (32-byte `small_bvh2_node` nodes), following
// obvhs's `Bvh2::ray_traverse_dynamic` step for step. CPU twin: crates/omnisim/src/cpu.rs.

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

fn intersect_leaf(node: BvhNode, origin: vec3<f32>, direction: vec3<f32>, t_min: f32, best: ptr<function, Hit>) {
    for (var i = node.first_index; i < node.first_index + node.prim_count; i++) {
        let t = intersect_triangle(triangles[i], origin, direction);
        if t > t_min && t < (*best).t {
            *best = Hit(t, i);
        }
    }
}

fn closest_hit(origin: vec3<f32>, direction: vec3<f32>, t_min: f32) -> Hit {
    var best = Hit(FAR, 0u);
    if arrayLength(&nodes) == 0u {
        return best;
    }
    let inv_direction = vec3<f32>(safe_inverse(direction.x), safe_inverse(direction.y), safe_inverse(direction.z));
    let root = nodes[0];
    if box_entry(root, origin, inv_direction) >= FAR {
        return best;
    }
    if root.prim_count > 0u {
        intersect_leaf(root, origin, direction, t_min, &best);
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
        if left_t < best.t {
            if left.prim_count > 0u {
                intersect_leaf(left, origin, direction, t_min, &best);
            } else {
                go_left = true;
            }
        }
        var go_right = false;
        if right_t < best.t {
            if right.prim_count > 0u {
                intersect_leaf(right, origin, direction, t_min, &best);
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
