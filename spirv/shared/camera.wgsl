// The camera's primary rays: `Camera::ray` (src/camera.rs), operation for operation, so that the
// G-buffer's start point and the mirror pixels' incoming direction are the reference's bits.

// The unit direction of the ray through the centre of pixel `pixel` of a `width` x `height`
// frame, from the camera basis (`Camera::basis`), tan(fov_y / 2) and the aspect ratio as the CPU
// computes them.
fn camera_ray_dir(
    pixel: vec2<u32>, width: f32, height: f32, tan_half: f32, aspect: f32,
    right: vec3<f32>, up: vec3<f32>, back: vec3<f32>,
) -> vec3<f32> {
    let x_ndc = 2.0 * (f32(pixel.x) + 0.5) / width - 1.0;
    let y_ndc = 2.0 * (f32(pixel.y) + 0.5) / height - 1.0;
    let x = x_ndc * tan_half * aspect;
    let y = -y_ndc * tan_half;
    let v = right * x + up * y - back;
    // glam's `normalize`: the reciprocal of the length, then a multiply.
    let rcp = 1.0 / sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    return v * rcp;
}
