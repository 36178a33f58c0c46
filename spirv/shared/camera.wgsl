// The camera's primary rays: `Camera::ray` (src/camera.rs), operation for operation, so that the
// G-buffer's start point and the mirror pixels' incoming direction are the reference's bits.

// The unit direction of the ray through pixel `pixel`'s sample of a `width` x `height` frame (its
// centre moved by `jitter` pixels, `Camera::jitter`; 0 but for frames of several samples per
// pixel), from the camera basis (`Camera::basis`), tan(fov_y / 2) and the aspect ratio as the CPU
// computes them.
fn camera_ray_dir(
    pixel: vec2<u32>, jitter: vec2<f32>, width: f32, height: f32, tan_half: f32, aspect: f32,
    right: vec3<f32>, up: vec3<f32>, back: vec3<f32>,
) -> vec3<f32> {
    let x_ndc = 2.0 * (f32(pixel.x) + 0.5 + jitter.x) / width - 1.0;
    let y_ndc = 2.0 * (f32(pixel.y) + 0.5 + jitter.y) / height - 1.0;
    let x = x_ndc * tan_half * aspect;
    let y = -y_ndc * tan_half;
    let v = right * x + up * y - back;
    // glam's `normalize`: the reciprocal of the length, then a multiply.
    let rcp = 1.0 / sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    return v * rcp;
}
