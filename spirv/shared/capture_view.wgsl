// A capture draw's view (`vk::passes::capture::CaptureView`) and the marker of an edge-on
// triangle in the faces' lists, shared by `capture.wgsl` and `capture_mark.wgsl`.

// One draw: part of one face of one CMO.
struct CaptureView {
    centre: vec3<f32>,
    face: u32,
    near: f32,
    // 1: the reflectors that see themselves are drawn; 0: no reflector is (`face_triangles`).
    reflectors: u32,
    // The draw's triangles in `capture_triangles`.
    first: u32,
    count: u32,
}

// An entry of `capture_triangles` whose triangle is seen edge-on from the CMO centre
// (`capture_mark.wgsl`).
const CAPTURE_EDGE_ON: u32 = 0xffffffffu;
