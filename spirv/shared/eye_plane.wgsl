// Triangles seen edge-on: whose plane passes through the viewpoint (the G-buffer's eye, in world
// coordinates; a CMO centre, the origin of CMO-local ones) within f32 rounding.
// `eye_plane_offset` (src/camera.rs) is the host's twin of this test, with the same bound
// (`EYE_PLANE_BOUND`).
//
// In exact arithmetic such a triangle projects to a line and covers no pixel centre: every ray
// from the viewpoint meets its plane at t = 0 (the reference counts only t > 0) or lies in it.
// The rasteriser sees it through rounded vertices, whose plane passes some rounding error off
// the viewpoint: seen from that tiny distance, the triangle covers half the frame at a depth in
// front of everything else (the built-in `default` camera, in the plane of the room's front
// wall, got the wall over the whole frame for some targets). So the vertex shaders cull it.
//
// The test, with `o` the vertex nearest the viewpoint `p` and `n` the plane's unit normal:
// `|(p - o) . n| <= 2^-21 (|p| + |o| + |p - o|)`, i.e. the distance of `p` from the plane is at
// most 2^-21 of the coordinates' scale. That is the worst case of the rasteriser's error on the
// plane's offset: its clip w is `-back . p + back . eye`, three products and three sums in f32
// (2^-22 (sqrt 3 |p| + |eye|)) plus the rounding of `back . eye` on the host (2^-23 |eye|).
// `n` is well conditioned (`plane_normal` of src/camera.rs): the cross product of the two
// longest edges, each made unit, normalised; never divided by the sine of a small angle, so a
// sliver 5 units away is not culled because its corners nearly share a line. A triangle whose
// corners share a line in f32 has no normal (`dot(m, m)` is 0) and is never culled: it covers
// no pixel. Only a culled triangle may come nearer the viewpoint than the near plane (the host
// derives the near plane from the nearest triangle not culled, src/ranges.rs), so every drawn
// triangle lies wholly in front of it and covers what its projected corners cover, whatever its
// shape. Larger bounds cull real geometry: at 2^-18 and 2^-19 the silhouette triangles of
// `sphere-room`'s mirror (planes 0.3 to 0.4 from the eye), with the scene moved 6000 and 12400
// from the origin. This test's own arithmetic errs by some 2^-22 of the right-hand side's scale
// (half the bound) on a well-shaped triangle, which the host's twin allows for. Unit edges keep
// every product finite up to the coordinates `FrameRanges::check` allows.

const EYE_PLANE_BOUND: f32 = 4.76837158203125e-7; // 2^-21

fn eye_plane_holds(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> bool {
    let da = length(a - p);
    let db = length(b - p);
    let dc = length(c - p);
    var o = a;
    if db < da && db <= dc {
        o = b;
    } else if dc < da && dc < db {
        o = c;
    }
    // The two longest edges (the shortest, first of equals, left out), as `plane_normal`.
    let e0 = b - a;
    let e1 = c - b;
    let e2 = a - c;
    let l0 = length(e0);
    let l1 = length(e1);
    let l2 = length(e2);
    var u1 = e1;
    var u2 = e2;
    if l0 <= l1 && l0 <= l2 {
        u1 = e1;
        u2 = e2;
    } else if l1 <= l2 {
        u1 = e2;
        u2 = e0;
    } else {
        u1 = e0;
        u2 = e1;
    }
    let m = cross(normalize(u1), normalize(u2));
    let mm = dot(m, m);
    if !(mm > 0.0) {
        return false;
    }
    let n = m * inverseSqrt(mm);
    let s = p - o;
    return abs(dot(s, n)) <= EYE_PLANE_BOUND * (length(p) + length(o) + length(s));
}
