// capture_mark: marks the capture's edge-on triangles once per placement, so that the capture's
// vertex shader (`capture.wgsl`) reads one corner per vertex instead of its triangle's three.
//
// A lane per entry of `capture_triangles` (the faces' lists, `vk::passes::capture`): the entry
// lies in the draw of `capture_views` whose `[first, first + count)` holds it (the draws cover
// the lists in order; found by bisection), and is set to CAPTURE_EDGE_ON where its triangle's
// plane passes through the CMO centre (`eye_plane_holds` on the corners made CMO-local, the
// test and the operations `capture.wgsl`'s vertex shader ran per vertex). The vertex shader
// sends such a triangle's corners outside the clip volume, as it did.
// A module of its own: here the lists are written, and a vertex shader may only read a storage
// buffer (no `vertexPipelineStoresAndAtomics`).

// The scene's bind group (shared/scene.wgsl).
const SCENE_GROUP: u32 = 0u;
//! import shared/scene.wgsl
//! import shared/eye_plane.wgsl
//! import shared/capture_view.wgsl

@group(1) @binding(0) var<storage, read> capture_views: array<CaptureView>;
@group(1) @binding(1) var<storage, read_write> capture_triangles: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * 64u;
    if i >= arrayLength(&capture_triangles) {
        return;
    }
    // The last draw whose first entry is at most i.
    var lo = 0u;
    var hi = arrayLength(&capture_views) - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if capture_views[mid].first <= i {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    let cv = capture_views[lo];
    if i < cv.first || i >= cv.first + cv.count {
        return;
    }
    let t = 3u * capture_triangles[i];
    let a = scene_vertices[scene_indices[t]].position - cv.centre;
    let b = scene_vertices[scene_indices[t + 1u]].position - cv.centre;
    let c = scene_vertices[scene_indices[t + 2u]].position - cv.centre;
    if eye_plane_holds(vec3<f32>(0.0), a, b, c) {
        capture_triangles[i] = CAPTURE_EDGE_ON;
    }
}
