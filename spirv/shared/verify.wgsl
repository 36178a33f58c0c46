// Verified hits: the GPU twin of `src/cpu/verify.rs` (its module docs state the rule and its proof
// sketch). Where the exact criterion decides a hit at texel T of a CMO, the ray is intersected
// (watertight) with the triangles whose IDs the capture stored in T's 3x3 neighbourhood; the
// nearest intersection in [t_done, t_hi] whose direction from the CMO centre falls in the
// neighbourhood is the hit, on a real triangle; with none there is no hit at T.
// The caller fills the neighbourhood's IDs (from wherever its pass binds the capture's triangle
// IDs) for the texels `verify_hood_texels` gives, in that order.
//! import shared/hit.wgsl
//! import shared/watertight.wgsl
//! import shared/cube.wgsl

const VERIFY_NO_TRIANGLE: u32 = 0xffffffffu;

struct VerifyHood {
    texels: array<Texel, 9>,
    ids: array<u32, 9>,
}

struct VerifiedHit {
    hit: bool,
    triangle: u32,
    t: f32,
    position: vec3<f32>,
    bary: vec3<f32>,
}

// The 3x3 texels around `c`, row-major (index 4 is `c`), wrapping across face edges
// (`Neighbourhood::around`); IDs left VERIFY_NO_TRIANGLE for the caller to fill.
fn verify_hood_texels(c: Texel, size: u32) -> VerifyHood {
    let left = neighbour_across(c, 0u, size);
    let right = neighbour_across(c, 1u, size);
    var h: VerifyHood;
    h.texels[0] = neighbour_across(left, 2u, size);
    h.texels[1] = neighbour_across(c, 2u, size);
    h.texels[2] = neighbour_across(right, 2u, size);
    h.texels[3] = left;
    h.texels[4] = c;
    h.texels[5] = right;
    h.texels[6] = neighbour_across(left, 3u, size);
    h.texels[7] = neighbour_across(c, 3u, size);
    h.texels[8] = neighbour_across(right, 3u, size);
    for (var k = 0u; k < 9u; k++) {
        h.ids[k] = VERIFY_NO_TRIANGLE;
    }
    return h;
}

fn verify_same_texel(a: Texel, b: Texel) -> bool {
    return a.face == b.face && a.x == b.x && a.y == b.y;
}

// `Neighbourhood::contains_dir`.
fn verify_hood_contains(h: VerifyHood, r: vec3<f32>, size: u32) -> bool {
    let t = dir_to_texel(r, size);
    var found = false;
    for (var k = 0u; k < 9u; k++) {
        if verify_same_texel(h.texels[k], t) {
            found = true;
        }
    }
    return found;
}

// Corner `corner` of global triangle `tri`.
fn verify_corner(tri: u32, corner: u32) -> vec3<f32> {
    return hit_vertex(tri, corner).position;
}

// `cpu::verify::verify_hit` of the ray `a + t d` with proven-empty prefix up to `t_done`,
// segment end `t_hi`, CMO centre `centre`, faces of `size` texels.
fn verify_hit(a: vec3<f32>, d: vec3<f32>, t_done: f32, t_hi: f32, centre: vec3<f32>, size: u32, h: VerifyHood) -> VerifiedHit {
    var best = VerifiedHit(false, VERIFY_NO_TRIANGLE, 0.0, vec3<f32>(0.0), vec3<f32>(0.0));
    let triangles = arrayLength(&scene_indices) / 3u;
    for (var k = 0u; k < 9u; k++) {
        let id = h.ids[k];
        var seen = id == VERIFY_NO_TRIANGLE || id >= triangles;
        for (var j = 0u; j < k; j++) {
            if h.ids[j] == id {
                seen = true;
            }
        }
        if seen {
            continue;
        }
        let w = wt_intersect(a, d, verify_corner(id, 0u), verify_corner(id, 1u), verify_corner(id, 2u));
        if !w.hit || w.t < t_done || w.t > t_hi {
            continue;
        }
        let position = a + d * w.t;
        if !verify_hood_contains(h, position - centre, size) {
            continue;
        }
        if !best.hit || w.t < best.t || (w.t == best.t && id < best.triangle) {
            best = VerifiedHit(true, id, w.t, position, w.bary);
        }
    }
    return best;
}
