// append: the compute path's ray queue. A full-screen fragment pass over the G-buffer: every
// mirror pixel appends its reflected ray (`mirror_ray`, the same ray the fragment path traces)
// to `rays` through the atomic `ray_counter.count`. The order of the queue is whatever the
// rasteriser's invocation order makes it; nothing downstream depends on it (each ray carries its
// pixel). Helper invocations do not run: nothing here takes derivatives.
//! import shared/mirror.wgsl
//! import shared/compute_rays.wgsl

@group(0) @binding(6) var<storage, read_write> ray_counter: RayCounter;
@group(0) @binding(7) var<storage, read_write> rays: array<AppendedRay>;
// The G-buffer's global triangle ID: the triangle each ray leaves.
@group(0) @binding(8) var gbuffer_triangle: texture_2d<u32>;

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) {
    let pixel = vec2<u32>(position.xy);
    let ray = mirror_ray(pixel);
    if !ray.mirror {
        return;
    }
    let i = atomicAdd(&ray_counter.count, 1u);
    let from_tri = textureLoad(gbuffer_triangle, vec2<i32>(pixel), 0).x;
    rays[i] = AppendedRay(ray.origin, pixel.y * frame.width + pixel.x, ray.dir, 0.0, from_tri, 0u, 0u, 0u);
}
