// Cube face selection and texel addressing: the WGSL twin of `src/cubemap/face.rs` (read its
// module docs for the conventions). Vulkan face order +X, -X, +Y, -Y, +Z, -Z; face-local frame
// `(sc, tc, |ma|)`; texel (x, y) covers s in [x/N, (x+1)/N), t in [y/N, (y+1)/N), the last texel
// also owns s = 1; tie rule: the earliest of X, Y, Z among the maximal magnitudes.
//
// Every expression keeps the CPU twin's f32 operation order. No `normalize`/`length` builtins
// (they may be inverse-square-root approximations); see `spirv/shared/frustum.wgsl` for the
// contraction guard used where a product feeds a sum.

const FACE_COUNT: u32 = 6u;

// One texel: face and integer coordinates (row 0 at t = 0).
struct Texel {
    face: u32,
    x: u32,
    y: u32,
}

// Linear index `(face * N + y) * N + x`.
fn texel_index(t: Texel, size: u32) -> u32 {
    return (t.face * size + t.y) * size + t.x;
}

fn select_face(r: vec3<f32>) -> u32 {
    let ax = abs(r.x);
    let ay = abs(r.y);
    let az = abs(r.z);
    if ax >= ay && ax >= az {
        return select(1u, 0u, r.x >= 0.0);
    } else if ay >= az {
        return select(3u, 2u, r.y >= 0.0);
    }
    return select(5u, 4u, r.z >= 0.0);
}

// CMO-local vector to the face's frame `(sc, tc, ma)`: a signed permutation, exact.
fn to_face_local(face: u32, r: vec3<f32>) -> vec3<f32> {
    switch face {
        case 0u: { return vec3<f32>(-r.z, -r.y, r.x); }
        case 1u: { return vec3<f32>(r.z, -r.y, -r.x); }
        case 2u: { return vec3<f32>(r.x, r.z, r.y); }
        case 3u: { return vec3<f32>(r.x, -r.z, -r.y); }
        case 4u: { return vec3<f32>(r.x, -r.y, r.z); }
        default: { return vec3<f32>(-r.x, -r.y, -r.z); }
    }
}

// Inverse of `to_face_local`; exact.
fn from_face_local(face: u32, l: vec3<f32>) -> vec3<f32> {
    switch face {
        case 0u: { return vec3<f32>(l.z, -l.y, -l.x); }
        case 1u: { return vec3<f32>(-l.z, -l.y, l.x); }
        case 2u: { return vec3<f32>(l.x, l.z, l.y); }
        case 3u: { return vec3<f32>(l.x, -l.z, -l.y); }
        case 4u: { return vec3<f32>(l.x, -l.y, l.z); }
        default: { return vec3<f32>(-l.x, -l.y, -l.z); }
    }
}

// Rust's `f32::clamp` (for lo <= hi, no NaN): x itself unless below lo or above hi, so that a
// -0.0 clamped to [0, hi] stays -0.0 as on the CPU (WGSL's `clamp` may return either zero).
fn clamp_rust(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        return lo;
    } else if x > hi {
        return hi;
    }
    return x;
}

// Texel column (or row) for s in [0, 1]: half-open, s = 1 in the last texel.
fn st_to_texel_coord(s: f32, size: u32) -> u32 {
    let k = floor(s * f32(size));
    if k < 0.0 {
        return 0u;
    } else if k >= f32(size) {
        return size - 1u;
    }
    return u32(k);
}

// The one texel a direction lands in (`dir_to_face_st` + `st_to_texel_coord`).
fn dir_to_texel(r: vec3<f32>, size: u32) -> Texel {
    let face = select_face(r);
    let l = to_face_local(face, r);
    var s = 0.5;
    var t = 0.5;
    if l.z > 0.0 {
        s = clamp_rust(0.5 * (l.x / l.z + 1.0), 0.0, 1.0);
        t = clamp_rust(0.5 * (l.y / l.z + 1.0), 0.0, 1.0);
    }
    return Texel(face, st_to_texel_coord(s, size), st_to_texel_coord(t, size));
}

// Texel boundary k (0..=N) in face coordinates: 2k/N - 1 (exactly -1 and 1 at the edges).
fn face_coord(k: u32, size: u32) -> f32 {
    return f32(2u * k) / f32(size) - 1.0;
}

// Direction (non-normalised, |major| = 1) through a texel's centre.
fn texel_centre_dir(t: Texel, size: u32) -> vec3<f32> {
    let n = f32(size);
    let u = f32(2u * t.x + 1u) / n - 1.0;
    let v = f32(2u * t.y + 1u) / n - 1.0;
    return from_face_local(t.face, vec3<f32>(u, v, 1.0));
}

// Which face edges belong to the face under the tie rule: bits 0..3 for u = -1, u = +1,
// v = -1, v = +1 (±X own all four, ±Y their v edges, ±Z none).
fn edge_inclusive_bits(face: u32) -> u32 {
    if face < 2u {
        return 15u;
    } else if face < 4u {
        return 12u;
    }
    return 0u;
}

// The texel across side `side` (0: x-1, 1: x+1, 2: y-1, 3: y+1), wrapping across face edges,
// by looking up the direction a quarter texel beyond the side's midpoint.
fn neighbour_across(t: Texel, side: u32, size: u32) -> Texel {
    let n = f32(size);
    var u = f32(2u * t.x + 1u) / n - 1.0;
    var v = f32(2u * t.y + 1u) / n - 1.0;
    let step = 1.25 / n;
    switch side {
        case 0u: { u -= step; }
        case 1u: { u += step; }
        case 2u: { v -= step; }
        default: { v += step; }
    }
    return dir_to_texel(from_face_local(t.face, vec3<f32>(u, v, 1.0)), size);
}
