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

// `main`: any options; `main_exact_mip`: the centre criterion's mip march only (as the
// fragment pass's `fs_main` and `fs_exact_mip`); `main_faces` below: one step of them.
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    probe(gid.x, TRACE_ANY);
}

@compute @workgroup_size(64)
fn main_exact_mip(@builtin(global_invocation_id) gid: vec3<u32>) {
    probe(gid.x, TRACE_EXACT_MIP);
}

// `main_faces`: `faces_crossed` alone, of the CMO-local segment `origin + t dir` over
// [t_lo, t_hi] at the config's cube size, packed into the ray's `TraceOut`: `status` the count,
// `cmo` the faces in order (3 bits each), and the faces' entry t, as bits, in `face`, `x`, `y`,
// `riser`, `texels` and `cells` (`tests/tracer/face_order.rs` unpacks them).
@compute @workgroup_size(64)
fn main_faces(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= probe_params.count {
        return;
    }
    let ray = probe_rays[i];
    let seg = Segment(ray.origin, ray.dir, ray.t_lo, ray.t_hi, TRACE_NO_TRIANGLE);
    probe_out[i] = face_list_out(faces_crossed(seg, ray.t_lo, ray.t_hi, trace_config.size));
}

// `main_face_order`: `face_order` alone, of the six entry t `origin.xyz, t_lo, dir.xy` (packed
// as `main_faces` packs its list). It reads the config's size only so that it binds the pass's
// two groups as the other entry points do.
@compute @workgroup_size(64)
fn main_face_order(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= probe_params.count {
        return;
    }
    _ = trace_config.size;
    let r = probe_rays[i];
    let t0 = array<f32, FACE_COUNT>(r.origin.x, r.origin.y, r.origin.z, r.t_lo, r.dir.x, r.dir.y);
    probe_out[i] = face_list_out(face_order(t0));
}

fn face_list_out(fl: FaceList) -> TraceOut {
    var out: TraceOut;
    out.status = fl.count;
    out.cmo = fl.face[0] | (fl.face[1] << 3u) | (fl.face[2] << 6u) | (fl.face[3] << 9u) | (fl.face[4] << 12u) | (fl.face[5] << 15u);
    out.face = bitcast<u32>(fl.t0[0]);
    out.x = bitcast<u32>(fl.t0[1]);
    out.y = bitcast<u32>(fl.t0[2]);
    out.riser = bitcast<u32>(fl.t0[3]);
    out.texels = bitcast<u32>(fl.t0[4]);
    out.cells = bitcast<u32>(fl.t0[5]);
    return out;
}

fn probe(i: u32, variant: u32) {
    if i >= probe_params.count {
        return;
    }
    let ray = probe_rays[i];
    probe_out[i] = trace_ray_variant(ray.origin, ray.dir, ray.t_lo, ray.t_hi, variant);
}
