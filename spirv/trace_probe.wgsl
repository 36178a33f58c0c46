// Trace probe pass: traces a list of world rays with the shared tracer (`shared/trace.wgsl`) and
// writes one `TraceOut` per ray. It exists to compare the GPU tracer with its CPU twin
// (`tests/tracer/gpu_twin.rs`); the frame's fragment trace pass calls the same `trace_ray`.
// Group 0: the rays and results; group 1: the CMO data declared by `shared/trace.wgsl`.
//! import shared/trace.wgsl

// One ray (Rust: `tests/common/trace_probe.rs`'s `ProbeRay`): origin + t dir, t in [t_lo, t_hi].
struct ProbeRay {
    origin: vec3<f32>,
    t_lo: f32,
    dir: vec3<f32>,
    t_hi: f32,
}

struct ProbeParams {
    count: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> probe_params: ProbeParams;
@group(0) @binding(1) var<storage, read> probe_rays: array<ProbeRay>;
@group(0) @binding(2) var<storage, read_write> probe_out: array<TraceOut>;

// `main`: any options; `main_exact_mip`: the exact criterion's mip march only (as the
// fragment pass's `fs_main` and `fs_exact_mip`).
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    probe(gid.x, TRACE_ANY);
}

@compute @workgroup_size(64)
fn main_exact_mip(@builtin(global_invocation_id) gid: vec3<u32>) {
    probe(gid.x, TRACE_EXACT_MIP);
}

fn probe(i: u32, variant: u32) {
    if i >= probe_params.count {
        return;
    }
    let ray = probe_rays[i];
    probe_out[i] = trace_ray_variant(ray.origin, ray.dir, ray.t_lo, ray.t_hi, variant);
}
