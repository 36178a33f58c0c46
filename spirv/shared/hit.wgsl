// Shading at a hit on a scene triangle: the GPU twin of `reference::Tracer::shade`. Needs
// shared/scene.wgsl (its index buffer is in `WorldGeometry::triangles` order, so global triangle
// `tri` is `scene_indices[3 tri ..]`).
//! import shared/scene.wgsl

// Vertex `corner` (0..3) of global triangle `tri`.
fn hit_vertex(tri: u32, corner: u32) -> GpuVertex {
    return scene_vertices[scene_indices[3u * tri + corner]];
}

// `Tracer::shade` of a hit on `tri` with barycentric weights `bary` of vertices 1 and 2
// (`Hit::bary`; vertex 0 gets 1 - u - v): the interpolated uv and normal (`Tracer::uv`,
// `Tracer::normal`, normalised), then `scene_shade` with the triangle's object's material.
fn hit_shade(tri: u32, bary: vec2<f32>) -> vec3<f32> {
    let v0 = hit_vertex(tri, 0u);
    let v1 = hit_vertex(tri, 1u);
    let v2 = hit_vertex(tri, 2u);
    let u = bary.x;
    let v = bary.y;
    let w = 1.0 - u - v;
    let n = scene_normalize(v0.normal * w + v1.normal * u + v2.normal * v);
    let uv = v0.uv * w + v1.uv * u + v2.uv * v;
    let c = scene_vertex_colour(v0) * w + scene_vertex_colour(v1) * u + scene_vertex_colour(v2) * v;
    return scene_shade(v0.object, uv, n, c);
}
