// Verified hits in the trace passes: the WGSL twin of
// `cpu::multi::trace_cmos_verified_by`, whose module docs give the rule for a failed
// verification and why it is safe. A hit the centre criterion decides at texel T of CMO k is
// verified (shared/verify.wgsl) over T's 3x3 neighbourhood of captured triangle IDs; with no
// verified hit, T counts as behind at its entry and the occlusion handoff goes on from there.
// Needs the capture's triangle IDs (@group(1) binding 5 below, `CmoData`'s `cmo_triangle`) and
// the scene (@group(SCENE_GROUP), defined by the root file).
//! import shared/trace.wgsl
//! import shared/verify.wgsl

// CMO k's triangle IDs at `k * 6 * N * N`, `texel_index` order.
@group(1) @binding(5) var<storage, read> cmo_triangle: array<u32>;

// `verify_hit` of the decision at `texel` of CMO k for the world ray `origin + t dir`, and where
// T counts as behind when it fails (`t_behind`: T's entry within `seg`, else `t_done`).
struct VerifyStep {
    hit: VerifiedHit,
    t_behind: f32,
}

fn verify_decision(k: u32, seg: Segment, texel: Texel, origin: vec3<f32>, dir: vec3<f32>, t_done: f32, t_hi: f32) -> VerifyStep {
    let n = trace_config.size;
    var hood = verify_hood_texels(texel, n);
    for (var j = 0u; j < 9u; j++) {
        hood.ids[j] = cmo_triangle[k * 6u * n * n + texel_index(hood.texels[j], n)];
    }
    let v = verify_hit(origin, dir, t_done, t_hi, cmo_centres[k].xyz, n, hood);
    var t_b = t_done;
    let iv = texel_interval(seg, texel, n, seg.t_lo, seg.t_hi);
    if crosses(iv) {
        t_b = iv.t0;
    }
    return VerifyStep(v, t_b);
}

// `trace_ray_variant` with every hit verified: the hit's point is the verified one, and
// `triangle` / `bary` say where (VERIFY_NO_TRIANGLE / 0 without a hit).
struct VerifiedOut {
    out: TraceOut,
    triangle: u32,
    bary: vec3<f32>,
}

fn trace_ray_verified(origin: vec3<f32>, dir: vec3<f32>, t_lo: f32, t_hi: f32, variant: u32) -> VerifiedOut {
    var t_done = t_lo;
    var traces = 0u;
    var last = TraceResult(ONE_ESCAPED, 0.0, Texel(0u, 0u, 0u), false, vec3<f32>(0.0), Counters(0u, 0u));
    for (var round = 0u; round < MAX_ROUNDS; round++) {
        var progress = false;
        for (var k = 0u; k < trace_config.cmo_count; k++) {
            let centre = cmo_centres[k].xyz;
            let seg = Segment(origin - centre, dir, t_done, t_hi, TRACE_NO_TRIANGLE);
            var r = trace_one(k, seg, variant);
            traces += 1u;
            last = r;
            if r.status == ONE_HIT {
                let v = verify_decision(k, seg, r.texel, origin, dir, t_done, t_hi);
                if v.hit.hit {
                    return VerifiedOut(trace_out(STATUS_HIT, k, r, v.hit.position, t_done, traces), v.hit.triangle, v.hit.bary);
                }
                r.status = ONE_BEHIND;
                r.t = v.t_behind;
            }
            if r.status == ONE_ESCAPED {
                return VerifiedOut(trace_out(STATUS_ESCAPED, k, r, r.point + centre, t_done, traces), VERIFY_NO_TRIANGLE, vec3<f32>(0.0));
            }
            if r.t > t_done {
                t_done = r.t;
                progress = true;
            }
        }
        if !progress {
            break;
        }
    }
    let p = vec3<f32>(origin.x + prod(t_done, dir.x), origin.y + prod(t_done, dir.y), origin.z + prod(t_done, dir.z));
    return VerifiedOut(trace_out(STATUS_UNRESOLVED, 0xffffffffu, last, p, t_done, traces), VERIFY_NO_TRIANGLE, vec3<f32>(0.0));
}
