// The per-pixel record every reflection pass writes (`frame::PixelRecord` in Rust; layout
// checked in the tests) and its status values; read by `composite` and the metrics.

struct PixelRecord {
    origin: vec3<f32>,
    status: u32,
    dir: vec3<f32>,
    // CMO that decided (0xffffffff when unresolved).
    cmo: u32,
    // World hit point (the escape point when escaped, the end of the proven-empty part when
    // unresolved).
    point: vec3<f32>,
    riser: u32,
    // Linear colour of the hit (or the background).
    colour: vec3<f32>,
    face: u32,
    x: u32,
    y: u32,
    texels: u32,
    cells: u32,
    traces: u32,
    t: f32,
    t_done: f32,
    // Verified hits: the global triangle hit (0xffffffff otherwise, and for methods that do not
    // verify).
    triangle: u32,
    // 1 where the compute path's step loop ended before the ray did (`main_retrace` finishes
    // it); 0 elsewhere.
    cut: u32,
    // 1 where `--fallback trace` finished the ray with the BVH (`bvh_trace`); 0 elsewhere.
    fallback: u32,
    // Reflections the pixel's path took (`--bounces`): 1 from every method's own pass, k + 1
    // from the bounce round that traced the path's k-th reflected ray, 0 with `--bounces 0`.
    bounces: u32,
    // 1 where the reflector check (vk::passes::bvh::ReflectorCheck) replaced the method's result with a
    // nearer hit on a reflector (`fallback` stays 0: the check is not the fallback); 2 where it
    // found the method's hit at the ray's own start and left the pixel to the fallback; 0
    // elsewhere.
    checked: u32,
}

const RECORD_HIT: u32 = 0u;
const RECORD_ESCAPED: u32 = 1u;
const RECORD_UNRESOLVED: u32 = 2u;
