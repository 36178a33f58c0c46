// Verified hits: the GPU twin of `src/cpu/verify.rs` (its module docs state the rule and its proof
// sketch). Where the centre criterion decides a hit at texel T of a CMO, the ray is intersected
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
// segment end `t_hi`, CMO centre `centre`, faces of `size` texels. Every valid ID is tested
// once, at its first place in the neighbourhood; the nearest hit (then the lowest ID) wins, which
// does not depend on the order. Written for lavapipe, which runs a loop until its last lane is
// done and reads an array indexed by a variable lane by lane: the first places are found with
// constant indices (`verify_first_places`), and the loop runs once per distinct ID, not 9 times.
fn verify_hit(a: vec3<f32>, d: vec3<f32>, t_done: f32, t_hi: f32, centre: vec3<f32>, size: u32, h: VerifyHood) -> VerifiedHit {
    var best = VerifiedHit(false, VERIFY_NO_TRIANGLE, 0.0, vec3<f32>(0.0), vec3<f32>(0.0));
    let triangles = arrayLength(&scene_indices) / 3u;
    var todo = verify_first_places(h, triangles);
    for (var n = 0u; n < 9u && todo != 0u; n++) {
        let k = firstTrailingBit(todo);
        todo &= todo - 1u;
        let id = verify_id_at(h, k);
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

// Bit k set where `h.ids[k]` is a valid triangle ID (not VERIFY_NO_TRIANGLE, below `triangles`)
// seen at no earlier place.
fn verify_first_places(h: VerifyHood, triangles: u32) -> u32 {
    let i0 = h.ids[0];
    let i1 = h.ids[1];
    let i2 = h.ids[2];
    let i3 = h.ids[3];
    let i4 = h.ids[4];
    let i5 = h.ids[5];
    let i6 = h.ids[6];
    let i7 = h.ids[7];
    let i8 = h.ids[8];
    var first = 0u;
    first |= select(0u, 1u, i0 < triangles);
    first |= select(0u, 2u, i1 < triangles && i1 != i0);
    first |= select(0u, 4u, i2 < triangles && i2 != i0 && i2 != i1);
    first |= select(0u, 8u, i3 < triangles && i3 != i0 && i3 != i1 && i3 != i2);
    first |= select(0u, 16u, i4 < triangles && i4 != i0 && i4 != i1 && i4 != i2 && i4 != i3);
    first |= select(0u, 32u, i5 < triangles && i5 != i0 && i5 != i1 && i5 != i2 && i5 != i3 && i5 != i4);
    first |= select(0u, 64u, i6 < triangles && i6 != i0 && i6 != i1 && i6 != i2 && i6 != i3 && i6 != i4 && i6 != i5);
    first |= select(0u, 128u, i7 < triangles && i7 != i0 && i7 != i1 && i7 != i2 && i7 != i3 && i7 != i4 && i7 != i5 && i7 != i6);
    first |= select(0u, 256u, i8 < triangles && i8 != i0 && i8 != i1 && i8 != i2 && i8 != i3 && i8 != i4 && i8 != i5 && i8 != i6 && i8 != i7);
    return first;
}

// `h.ids[k]` by selects (no array read at a variable index).
fn verify_id_at(h: VerifyHood, k: u32) -> u32 {
    var id = h.ids[0];
    id = select(id, h.ids[1], k == 1u);
    id = select(id, h.ids[2], k == 2u);
    id = select(id, h.ids[3], k == 3u);
    id = select(id, h.ids[4], k == 4u);
    id = select(id, h.ids[5], k == 5u);
    id = select(id, h.ids[6], k == 6u);
    id = select(id, h.ids[7], k == 7u);
    id = select(id, h.ids[8], k == 8u);
    return id;
}
