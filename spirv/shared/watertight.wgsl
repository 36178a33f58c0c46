// Watertight ray-triangle intersection (Woop, Benthin and Wald 2013), the GPU twin of
// `src/cpu/watertight.rs`: the same operations in the same order, so that both give the same bits
// (`tests/tracer/gpu_verify.rs`). Conventions (see the Rust module): no culling, inclusive edges, t > 0 in
// units of |d|, det == 0 (degenerate, or a ray in the triangle's plane) never hits, no fused
// multiply-add (lavapipe does not contract; see `prod` in shared/frustum.wgsl for other drivers).

struct WtHit {
    hit: bool,
    t: f32,
    // Barycentric weights of p0, p1, p2.
    bary: vec3<f32>,
}

fn wt_is_nan(x: f32) -> bool {
    let b = bitcast<u32>(x);
    return (b & 0x7f800000u) == 0x7f800000u && (b & 0x007fffffu) != 0u;
}

fn wt_is_inf(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) == 0x7f800000u;
}

fn wt_miss() -> WtHit {
    return WtHit(false, 0.0, vec3<f32>(0.0));
}

// The ray `org + t d` (t > 0) against triangle (p0, p1, p2).
fn wt_intersect(org: vec3<f32>, d: vec3<f32>, p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>) -> WtHit {
    let adx = abs(d.x);
    let ady = abs(d.y);
    let adz = abs(d.z);
    var kz = 2u;
    if adx >= ady && adx >= adz {
        kz = 0u;
    } else if ady >= adz {
        kz = 1u;
    }
    let dz = d[kz];
    if wt_is_nan(dz) || dz == 0.0 {
        return wt_miss();
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if dz < 0.0 {
        let swap = kx;
        kx = ky;
        ky = swap;
    }
    let sz = 1.0 / dz;
    let sx = d[kx] * sz;
    let sy = d[ky] * sz;
    let a = p0 - org;
    let b = p1 - org;
    let c = p2 - org;
    let a_z = a[kz];
    let b_z = b[kz];
    let c_z = c[kz];
    let ax = a[kx] - sx * a_z;
    let ay = a[ky] - sy * a_z;
    let bx = b[kx] - sx * b_z;
    let by = b[ky] - sy * b_z;
    let cx = c[kx] - sx * c_z;
    let cy = c[ky] - sy * c_z;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return wt_miss();
    }
    let det = u + v + w;
    if det == 0.0 || wt_is_nan(det) {
        return wt_miss();
    }
    let t_scaled = u * (sz * a_z) + v * (sz * b_z) + w * (sz * c_z);
    let rcp = 1.0 / det;
    let t = t_scaled * rcp;
    if wt_is_nan(t) || t <= 0.0 || wt_is_inf(t) {
        return wt_miss();
    }
    return WtHit(true, t, vec3<f32>(u * rcp, v * rcp, w * rcp));
}
