// Triangles seen edge-on: whose plane passes through the viewpoint (the G-buffer's eye, in world
// coordinates; a CMO centre, the origin of CMO-local ones) within f32 rounding. `Camera::plane_holds_viewpoint` (src/camera.rs) is the host's twin
// of this test, with the same bound (`EYE_PLANE_BOUND`).
//
// In exact arithmetic such a triangle projects to a line and covers no pixel centre: every ray
// from the viewpoint meets its plane at t = 0 (the reference counts only t > 0) or lies in it.
// The rasteriser sees it through rounded vertices, whose plane passes some rounding error off
// the viewpoint: seen from that tiny distance, the triangle covers half the frame at a depth in
// front of everything else (the built-in `default` camera, in the plane of the room's front
// wall, got the wall over the whole frame for some targets). So the vertex shaders cull it.
//
// The test, with `o` the vertex nearest the viewpoint `p`, `u1`, `u2` the unit edges from `o` and
// `m = u1 x u2` (length sin(angle at o)): `|(p - o) . m| <= 2^-21 (|p| + |o| + |p - o|)`, i.e. the
// distance of `p` from the plane is at most 2^-21 (|p| + |o| + |p - o|) / sin(angle at o). That
// is the worst case of the rasteriser's error: its clip w is `-back . p + back . eye`, three
// products and three sums in f32 (2^-22 (sqrt 3 |p| + |eye|)) plus the rounding of `back . eye`
// on the host (2^-23 |eye|), and a vertex moved by e moves the plane at the foot of `p` by about
// e / sin(angle) where the foot lies outside the triangle. A plane that is not culled therefore
// cannot appear on the other side of the viewpoint. Larger bounds cull real geometry: at 2^-18
// and 2^-19 the silhouette triangles of `sphere-room`'s mirror (planes 0.3 to 0.4 from the eye),
// with the scene moved 6000 and 12400 from the origin, well inside the precision check's limit.
// This test's own arithmetic errs by some 2^-22 of the right-hand side's scale (half the bound),
// which the host's twin allows for. Unit edges keep every product finite up to the coordinates
// `FrameRanges::check` allows.

const EYE_PLANE_BOUND: f32 = 4.76837158203125e-7; // 2^-21

fn eye_plane_holds(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> bool {
    let da = length(a - p);
    let db = length(b - p);
    let dc = length(c - p);
    var o = a;
    var x = b;
    var y = c;
    if db < da && db <= dc {
        o = b;
        x = c;
        y = a;
    } else if dc < da && dc < db {
        o = c;
        x = a;
        y = b;
    }
    let u1 = normalize(x - o);
    let u2 = normalize(y - o);
    let m = cross(u1, u2);
    let s = p - o;
    return abs(dot(s, m)) <= EYE_PLANE_BOUND * (length(p) + length(o) + length(s));
}
