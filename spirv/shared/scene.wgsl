// The scene as the capture and G-buffer passes read it: vertex pulling from storage buffers, and
// the view-independent shading of `src/shading.rs`, written expression for expression so that a
// captured texel and the CPU reference shade a point alike.
//
// Layouts mirror `src/scene/gpu_data.rs` (checked against naga's layout in tests/capture/gpu_raster.rs).
// Every pass that imports this file binds the scene as @group(SCENE_GROUP), a constant its root
// file defines: 0 where the scene is the pass's first group, another where group 0 is taken
// (the trace passes: fragment_trace 2, compute_trace 3).

struct GpuVertex {
    position: vec3<f32>,
    object: u32,
    normal: vec3<f32>,
    // The vertex colour (`WorldGeometry::colours`; 1 where the scene has none): red here, green
    // and blue in `colour_gb`.
    colour_r: f32,
    uv: vec2<f32>,
    colour_gb: vec2<f32>,
}

struct GpuObject {
    material: u32,
    // Bit 0: a reflector; bit 1: its vertex normals point into its closed mesh
    // (`ObjectInfo::normals_inward`): `scene_front_normal` turns them round.
    reflector: u32,
    // 1 where the cubemap capture draws the object: a non-reflector, or a reflector that sees
    // itself (Scene::self_capture).
    captured: u32,
    // A glossy reflector's Phong specular power (below lobe::MIRROR_POWER, src/lobe.rs); -1 on a
    // mirror and on every non-reflector.
    specular_power: f32,
    // 1 where its vertex colours multiply its material's colour (`ObjectInfo::vertex_colours`).
    vertex_colours: u32,
}

struct GpuMaterial {
    diffuse: vec3<f32>,
    // Index into scene_textures, or -1.
    texture: i32,
}

struct GpuTexture {
    offset: u32,
    width: u32,
    height: u32,
    _pad: u32,
}

struct GpuShading {
    // 0: unlit, 1: Lambert.
    model: u32,
    ambient: f32,
    light_intensity: f32,
    _pad: u32,
    // Towards the light.
    light_direction: vec3<f32>,
    _pad2: u32,
    background: vec3<f32>,
    _pad3: u32,
}

@group(SCENE_GROUP) @binding(0) var<storage, read> scene_vertices: array<GpuVertex>;
@group(SCENE_GROUP) @binding(1) var<storage, read> scene_indices: array<u32>;
@group(SCENE_GROUP) @binding(2) var<storage, read> scene_objects: array<GpuObject>;
@group(SCENE_GROUP) @binding(3) var<storage, read> scene_materials: array<GpuMaterial>;
@group(SCENE_GROUP) @binding(4) var<storage, read> scene_textures: array<GpuTexture>;
// Packed sRGB RGBA8, red in the low byte.
@group(SCENE_GROUP) @binding(5) var<storage, read> scene_texels: array<u32>;
// The CPU's sRGB decode table (`shading::srgb_to_linear` of 0..=255).
@group(SCENE_GROUP) @binding(6) var<storage, read> scene_srgb: array<f32>;
@group(SCENE_GROUP) @binding(7) var<storage, read> scene_shading: GpuShading;

// `a.lerp(b, s)` as glam computes it.
fn scene_lerp3(a: vec3<f32>, b: vec3<f32>, s: f32) -> vec3<f32> {
    return a + (b - a) * s;
}

// Euclidean remainder (always in 0..n), as Rust's `rem_euclid`.
fn scene_wrap(v: i32, n: i32) -> i32 {
    let r = v % n;
    return select(r, r + n, r < 0);
}

fn scene_texel_linear(tex: GpuTexture, x: i32, y: i32) -> vec3<f32> {
    let w = i32(tex.width);
    let h = i32(tex.height);
    let i = tex.offset + u32(scene_wrap(y, h) * w + scene_wrap(x, w));
    let p = scene_texels[i];
    return vec3<f32>(scene_srgb[p & 0xffu], scene_srgb[(p >> 8u) & 0xffu], scene_srgb[(p >> 16u) & 0xffu]);
}

// Bilinear, repeat-addressed lookup in linear space at OBJ coordinates `uv` (`Texture::sample`).
fn scene_texture_sample(tex: GpuTexture, uv: vec2<f32>) -> vec3<f32> {
    let fx = uv.x * f32(tex.width) - 0.5;
    let fy = (1.0 - uv.y) * f32(tex.height) - 0.5;
    let x0 = floor(fx);
    let y0 = floor(fy);
    let ax = fx - x0;
    let ay = fy - y0;
    let x = i32(x0);
    let y = i32(y0);
    let top = scene_lerp3(scene_texel_linear(tex, x, y), scene_texel_linear(tex, x + 1, y), ax);
    let bottom = scene_lerp3(scene_texel_linear(tex, x, y + 1), scene_texel_linear(tex, x + 1, y + 1), ax);
    return scene_lerp3(top, bottom, ay);
}

// `shading::albedo`.
fn scene_albedo(object: u32, uv: vec2<f32>) -> vec3<f32> {
    let m = scene_materials[scene_objects[object].material];
    if m.texture < 0 {
        return m.diffuse;
    }
    return m.diffuse * scene_texture_sample(scene_textures[u32(m.texture)], uv);
}

// `normalize_or_zero`.
fn scene_normalize(n: vec3<f32>) -> vec3<f32> {
    let l2 = dot(n, n);
    if l2 > 0.0 {
        let r = 1.0 / sqrt(l2);
        return n * r;
    }
    return vec3<f32>(0.0);
}

// A vertex's colour (`GpuVertex::colour_r`, `colour_gb`).
fn scene_vertex_colour(v: GpuVertex) -> vec3<f32> {
    return vec3<f32>(v.colour_r, v.colour_gb);
}

// `Tracer::shade` of a point with interpolated (not yet normalised) normal `n` and vertex colour
// `colour` (read only where the object has vertex colours: `albedo * colour`, as the reference).
fn scene_shade(object: u32, uv: vec2<f32>, n: vec3<f32>, colour: vec3<f32>) -> vec3<f32> {
    var albedo = scene_albedo(object, uv);
    if scene_objects[object].vertex_colours != 0u {
        albedo = albedo * colour;
    }
    if scene_shading.model == 0u {
        return albedo;
    }
    let nn = scene_normalize(n);
    let l = scene_shading.light_direction;
    let ndl = nn.x * l.x + nn.y * l.y + nn.z * l.z;
    return albedo * (scene_shading.ambient + scene_shading.light_intensity * max(ndl, 0.0));
}

fn scene_is_captured(object: u32) -> bool {
    return scene_objects[object].captured != 0u;
}

fn scene_is_reflector(object: u32) -> bool {
    return scene_objects[object].reflector != 0u;
}

// A reflector's normal `n` turned to its front, the side a reflected ray can come from: `-n`
// where its normals point into its closed mesh (`ObjectInfo::normals_inward`), else `n`.
fn scene_front_normal(object: u32, n: vec3<f32>) -> vec3<f32> {
    if (scene_objects[object].reflector & 2u) != 0u {
        return -n;
    }
    return n;
}
