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
// `m = u1 x u2` (length sin(angle at o)): `|(p - o) . m| <= 2^-19 (|p| + |o| + |p - o|)`, i.e. the
// distance of `p` from the plane is at most 2^-19 (|p| + |o| + |p - o|) / sin(angle at o). The
// rasteriser's clip coordinates err by some 2^-21 of the coordinates (a few roundings of the
// view matrix's products), which moves a triangle's plane by about that over sin(angle), and this
// test's own arithmetic errs by some 2^-21 of the right-hand side's scale: a plane that is not
// culled lies at least 3 of those rounding errors from the viewpoint, whose depth stays within a
// quarter of the true one (the near plane is at most half of it). A larger bound (2^-18 was
// tried) culled thin triangles of `sphere-room`'s mirror when the scene is moved 6000 from the
// origin, well inside the precision check's limit. Unit edges keep every product finite up to
// the coordinates `FrameRanges::check` allows.

const EYE_PLANE_BOUND: f32 = 1.9073486328125e-6; // 2^-19

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
