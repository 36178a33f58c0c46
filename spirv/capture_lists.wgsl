// capture_lists: the `bounded` criterion's sound per-texel bounds and candidate lists (the GPU of
// `src/cubemap/bounds.rs`, whose module docs derive the bounds; `src/vk/passes/capture_lists.rs`
// records the passes, each over every CMO in one dispatch):
// - `faces`: one invocation per (triangle, CMO), its six faces in turn: step 0
//   (`cb_face_missed`, a few products); the pairs it keeps go to the face queue (`lists_clips`,
//   whose buffer the clips use only later), sized on the CPU (`PoolBound::pairs`). A pair that
//   does not fit makes its face unknown (as below).
// - `jobs`: one invocation per queued pair (dispatch sized by `job_args`): steps 1-4
//   (`cb_face_rect`), then one job per 8x8 tile of the texel rect that is not wholly outside
//   the triangle (`cf_tile_outside`). A tile whose part of the rect holds at most
//   `LISTS_SMALL` texels is a small job. Jobs take slots of one buffer, tile jobs from the
//   front and small ones from the back, counted in `lists_counters.jobs` (all) and
//   `tile_jobs` / `small_jobs`. A job that does not fit the job buffer (or a rect of more than
//   `LISTS_TILE_CAP` tiles) sets its face's `lists_face_overflow` to 0: every texel of that
//   face is then unknown from distance 0 (sound).
// - `texels`: workgroups of 64 over the jobs (grid-stride; dispatch sized by `texel_args`):
//   four tile jobs of 16 lanes (up to four texels a lane) or 32 small jobs of 2 lanes (up to
//   eight texels a lane) per workgroup. An invocation runs the fast paths on its texels
//   (`cf_texel_cone_edges`): wholly inside the triangle, a node with the corner bounds;
//   undecided, an entry of the clip queue (`lists_clips`). A node `{triangle, lo, hi, next}`
//   goes onto the texel's list (`lists_heads`, atomicExchange). With the node pool full the
//   texel's `lists_overflow` takes the atomicMin of the lost entry's `lo` bits (non-negative
//   floats order as u32) and `nodes_dropped` counts it.
// - `clips`: one invocation per queued texel (dispatch sized by `clip_args`): step 5's four
//   clips (`cb_clip_bound`: streamed, no polygon stored, no workgroup memory or barrier), a
//   node where the triangle touches the texel.
// - The grid-stride loops of `texels` and `clips` test their end at the bottom, behind a
//   guard: their dispatches are sized for one turn (below 65535 workgroups), and a test at the
//   top cost a second turn that lavapipe ran, every lane masked: about a quarter of `texels`
//   and a third of `clips`.
// - `resolve`: one invocation per texel: selection of the `depth` smallest `(lo, triangle)` by
//   payload swapping along the list, RESOLVE_K of them per scan, or for a list of more than
//   RESOLVE_LONG nodes a merge sort that relinks them (the first `count_kept` nodes from the
//   head end up sorted),
//   `complete_to = min(overflow, face overflow, smallest lo beyond depth)`, then the record
//   `vec4(head, bits(complete_to), bits(hi), count_kept)`, the gap into `lists_gap`, and
//   `lo` into `lists_distance`
//   (CMO-major, `(face N + y) N + x`, like the CMO distance buffer). The walk is capped at
//   `walk_cap` node visits (lavapipe's 65535 back-edges per invocation): a capped texel gets
//   `complete_to = 0` and is counted in `walks_capped`. The scans' two loops test their end at
//   the bottom, so that a subgroup of 8 texels runs the turns of its longest list and no extra
//   turn with every lane masked.
// Records and nodes are stored a word per binding (`lists_rec_*`, `lists_node_*`: one u32
// per texel or node each, `src/vk/passes/lists.rs`), so that no binding exceeds
// maxStorageBufferRange before the pool holds range / 4 nodes; `ListsNode` is the value a
// node's four words make (`lists_node`).
// Which triangles: those of captured objects (`scene_is_captured`), reflectors only where the
// CMO captures reflectors (`ListsView.reflectors`, the capture's vertex-shader rule), all of
// them (no facing cull).

const SCENE_GROUP: u32 = 0u;
//! import shared/scene.wgsl
//! import shared/cube.wgsl
//! import shared/capture_bounds.wgsl

const LISTS_NIL: u32 = 0xffffffffu;
// Tiles one (triangle, face) may emit (its loop stays below lavapipe's 65535 back-edges per
// invocation): a whole face up to N = 1952; beyond, such a face is unknown (`tiles_capped`).
const LISTS_TILE_CAP: u32 = 60000u;
// A tile whose part of the rect holds at most this many texels is a small job: `texels` gives
// it LISTS_SMALL_LANES lanes, where a tile job takes LISTS_JOB_LANES (a dense mesh's triangles
// cover a few texels each).
const LISTS_SMALL: u32 = 16u;

struct ListsParams {
    size: u32,
    depth: u32,
    cmo_count: u32,
    triangle_count: u32,
    job_capacity: u32,
    node_capacity: u32,
    walk_cap: u32,
    // Invocations per dispatch row of `jobs` and `resolve` (64 x groups in x).
    row: u32,
    // Entries the clip queue holds.
    clip_capacity: u32,
    // Entries the face queue holds (in the clip queue's buffer, used before the clips).
    pair_capacity: u32,
}

// One CMO: its centre and whether it captures the reflectors.
struct ListsView {
    centre: vec3<f32>,
    reflectors: u32,
}

struct ListsJob {
    triangle: u32,
    // 6 cmo + face.
    cmo_face: u32,
    // x0 | x1 << 16 and y0 | y1 << 16 (inclusive).
    rect_x: u32,
    rect_y: u32,
    // Tile tx | ty << 16.
    tile: u32,
    m: f32,
    e: f32,
    whole: u32,
}

struct ListsNode {
    triangle: u32,
    lo: u32,
    hi: u32,
    next: u32,
}

struct ListsCounters {
    jobs: atomic<u32>,
    jobs_dropped: atomic<u32>,
    nodes: atomic<u32>,
    nodes_dropped: atomic<u32>,
    walks_capped: atomic<u32>,
    tiles_capped: atomic<u32>,
    // Texels queued for the clips (may exceed the capacity), and those that did not fit.
    clips: atomic<u32>,
    clips_dropped: atomic<u32>,
    // Of the jobs kept: the tile jobs (from the buffer's front) and the small jobs (from its
    // back; `LISTS_SMALL`).
    tile_jobs: atomic<u32>,
    small_jobs: atomic<u32>,
    // (Triangle, CMO face) pairs `faces` queued (may exceed the capacity), and those that did
    // not fit (their face is then unknown).
    pairs: atomic<u32>,
    pairs_dropped: atomic<u32>,
    // Of the pairs: those whose rect needs a clip, queued for `jobs_hard`.
    hard_pairs: atomic<u32>,
}

// A dispatch's size (`vkCmdDispatchIndirect`).
struct ListsArgs {
    x: u32,
    y: u32,
    z: u32,
}

@group(1) @binding(0) var<storage, read> lists_params: ListsParams;
@group(1) @binding(1) var<storage, read> lists_views: array<ListsView>;
@group(1) @binding(2) var<storage, read_write> lists_jobs: array<ListsJob>;
@group(1) @binding(3) var<storage, read_write> lists_heads: array<atomic<u32>>;
@group(1) @binding(4) var<storage, read_write> lists_overflow: array<atomic<u32>>;
@group(1) @binding(5) var<storage, read_write> lists_face_overflow: array<atomic<u32>>;
@group(1) @binding(6) var<storage, read_write> lists_counters: ListsCounters;
@group(1) @binding(7) var<storage, read_write> lists_distance: array<f32>;
// The per-texel record `[head, bits(complete_to), bits(hi), count_kept]`, a word per binding.
@group(1) @binding(8) var<storage, read_write> lists_rec_head: array<u32>;
@group(1) @binding(9) var<storage, read_write> lists_rec_complete: array<u32>;
@group(1) @binding(10) var<storage, read_write> lists_rec_hi: array<u32>;
@group(1) @binding(11) var<storage, read_write> lists_rec_count: array<u32>;
// The node pool `[triangle, bits(lo), bits(hi), next]`, a word per binding.
@group(1) @binding(12) var<storage, read_write> lists_node_triangle: array<u32>;
@group(1) @binding(13) var<storage, read_write> lists_node_lo: array<u32>;
@group(1) @binding(14) var<storage, read_write> lists_node_hi: array<u32>;
@group(1) @binding(15) var<storage, read_write> lists_node_next: array<u32>;
// The clip queue: per entry the job index and the texel `x | y << 16`.
@group(1) @binding(16) var<storage, read_write> lists_clips: array<vec2<u32>>;
// The sizes of the `texels`, `clips`, `jobs` and `jobs_hard` dispatches.
@group(1) @binding(17) var<storage, read_write> lists_args: array<ListsArgs, 4>;
// The texels' gaps, packed (`resolve`; the tracers' `cmo_gap`, shared/trace.wgsl), as
// `lists_distance`.
@group(1) @binding(18) var<storage, read_write> lists_gap: array<u32>;

fn lists_node(i: u32) -> ListsNode {
    return ListsNode(lists_node_triangle[i], lists_node_lo[i], lists_node_hi[i], lists_node_next[i]);
}

// Writes a node's payload (triangle, lo, hi), its `next` unchanged.
fn lists_set_payload(i: u32, n: ListsNode) {
    lists_node_triangle[i] = n.triangle;
    lists_node_lo[i] = n.lo;
    lists_node_hi[i] = n.hi;
}

fn lists_vertex(t: u32, corner: u32) -> vec3<f32> {
    return scene_vertices[scene_indices[3u * t + corner]].position;
}

// Step 0 (`face_missed`) on every (triangle, CMO, face), an invocation per (triangle, CMO) taking
// the six faces in turn (so the corners are read once, not once per face): the pairs it keeps go
// to the face queue (the clip queue's buffer, free until `texels`) for `jobs`. Cheap and
// branch-free, so that on lavapipe, which runs every lane of a subgroup through `jobs`' clips,
// only the kept pairs pay for them.
@compute @workgroup_size(64)
fn faces(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * lists_params.row;
    let cmos = lists_params.cmo_count;
    if i >= lists_params.triangle_count * cmos {
        return;
    }
    let t = i / cmos;
    let cmo = i % cmos;
    let view = lists_views[cmo];
    let object = scene_vertices[scene_indices[3u * t]].object;
    if !scene_is_captured(object) || (view.reflectors == 0u && scene_is_reflector(object)) {
        return;
    }
    let w0 = lists_vertex(t, 0u) - view.centre;
    let w1 = lists_vertex(t, 1u) - view.centre;
    let w2 = lists_vertex(t, 2u) - view.centre;
    for (var face = 0u; face < 6u; face++) {
        if cb_face_missed(to_face_local(face, w0), to_face_local(face, w1), to_face_local(face, w2)) {
            continue;
        }
        let cmo_face = cmo * 6u + face;
        let q = atomicAdd(&lists_counters.pairs, 1u);
        if q < lists_params.pair_capacity {
            lists_clips[q] = vec2<u32>(t, cmo_face);
        } else {
            atomicMin(&lists_face_overflow[cmo_face], 0u);
            atomicAdd(&lists_counters.pairs_dropped, 1u);
        }
    }
}

// Sizes the `jobs` dispatch: one invocation per queued pair, in groups of 64, rows of at most
// 65535 groups (no invocation takes two pairs: a pair's tile loop may take up to
// LISTS_TILE_CAP of lavapipe's 65535 back-edges).
@compute @workgroup_size(1)
fn job_args() {
    let n = min(atomicLoad(&lists_counters.pairs), lists_params.pair_capacity);
    let groups = (n + 63u) / 64u;
    lists_args[2] = ListsArgs(min(groups, 65535u), (groups + 65534u) / 65535u, 1u);
}

// Steps 1-4 and the tiles of every queued pair that needs no clip (`cb_face_rect_unclipped`:
// most of a dense mesh's); the others go to the back of the pair queue's buffer (the hard
// queue, `hard_pairs`) for `jobs_hard`. Lavapipe runs a branch's code with every lane masked
// (spirv/README.md), so the clips in `jobs` cost every pair: truck-garage's `jobs` took 16.7 ms
// with its body never taken, 2.8 ms without the clips' code.
@compute @workgroup_size(64)
fn jobs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * 64u;
    if i < min(atomicLoad(&lists_counters.pairs), lists_params.pair_capacity) {
        let pair = lists_clips[i];
        let l = lists_pair_local(pair.x, pair.y);
        let r = cb_face_rect_unclipped(l.l0, l.l1, l.l2, lists_params.size);
        if r.hit == 2u {
            // The buffer holds twice the pair capacity (`clip_queue_bytes`): the hard queue,
            // at most the pairs, stays clear of them.
            let k = atomicAdd(&lists_counters.hard_pairs, 1u);
            lists_clips[arrayLength(&lists_clips) - 1u - k] = pair;
        } else {
            lists_pair_tiles(pair.x, pair.y, l, r);
        }
    }
}

// Sizes the `jobs_hard` dispatch as `job_args` sizes `jobs`.
@compute @workgroup_size(1)
fn hard_args() {
    let groups = (atomicLoad(&lists_counters.hard_pairs) + 63u) / 64u;
    lists_args[3] = ListsArgs(min(groups, 65535u), (groups + 65534u) / 65535u, 1u);
}

// Steps 1-4 with their clips (`cb_face_rect`) and the tiles of every pair in the hard queue.
@compute @workgroup_size(64)
fn jobs_hard(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * 64u;
    if i < atomicLoad(&lists_counters.hard_pairs) {
        let pair = lists_clips[arrayLength(&lists_clips) - 1u - i];
        let l = lists_pair_local(pair.x, pair.y);
        lists_pair_tiles(pair.x, pair.y, l, cb_face_rect(l.l0, l.l1, l.l2, lists_params.size));
    }
}

// Triangle `t` in the frame of CMO face `cmo_face`, CMO-local.
fn lists_pair_local(t: u32, cmo_face: u32) -> ListsLocal {
    let face = cmo_face % 6u;
    let centre = lists_views[cmo_face / 6u].centre;
    return ListsLocal(
        to_face_local(face, lists_vertex(t, 0u) - centre),
        to_face_local(face, lists_vertex(t, 1u) - centre),
        to_face_local(face, lists_vertex(t, 2u) - centre),
    );
}

// The jobs of triangle `t` (`l` in its face's frame) on CMO face `cmo_face`, whose rect is `r`.
fn lists_pair_tiles(t: u32, cmo_face: u32, l: ListsLocal, r: CbRect) {
    if r.hit == 0u {
        return;
    }
    let size = lists_params.size;
    let tiles_x = (r.x1 - r.x0) / CB_TILE + 1u;
    let tiles = tiles_x * ((r.y1 - r.y0) / CB_TILE + 1u);
    if tiles > LISTS_TILE_CAP {
        atomicMin(&lists_face_overflow[cmo_face], 0u);
        atomicAdd(&lists_counters.tiles_capped, 1u);
        return;
    }
    // A tile wholly outside the triangle gets no job (`cf_tile_outside`; never for a `whole`
    // rect, whose texels all take the whole triangle's bounds).
    let g = cf_edges(l.l0, l.l1, l.l2, r.e);
    let cap = lists_params.job_capacity;
    for (var k = 0u; k < tiles; k++) {
        let tx = r.x0 + (k % tiles_x) * CB_TILE;
        let ty = r.y0 + (k / tiles_x) * CB_TILE;
        let tx1 = min(tx + CB_TILE - 1u, r.x1);
        let ty1 = min(ty + CB_TILE - 1u, r.y1);
        if r.whole == 0u && cf_tile_outside(g, tx, tx1, ty, ty1, size, r.m) {
            continue;
        }
        if atomicAdd(&lists_counters.jobs, 1u) >= cap {
            atomicMin(&lists_face_overflow[cmo_face], 0u);
            atomicAdd(&lists_counters.jobs_dropped, 1u);
            continue;
        }
        // Kept jobs take disjoint slots: at most `cap` of them, tile jobs counted from the
        // front, small ones from the back.
        var j = 0u;
        if (tx1 - tx + 1u) * (ty1 - ty + 1u) <= LISTS_SMALL {
            j = cap - 1u - atomicAdd(&lists_counters.small_jobs, 1u);
        } else {
            j = atomicAdd(&lists_counters.tile_jobs, 1u);
        }
        lists_jobs[j] = ListsJob(
            t,
            cmo_face,
            r.x0 | (r.x1 << 16u),
            r.y0 | (r.y1 << 16u),
            (k % tiles_x) | ((k / tiles_x) << 16u),
            r.m,
            r.e,
            r.whole,
        );
    }
}

// Pushes the node `(triangle, lo, hi)` onto texel `texel`'s list, or, with the pool full,
// lowers the texel's overflow to `lo`.
fn lists_push(texel: u32, triangle: u32, lo: f32, hi: f32) {
    let node = atomicAdd(&lists_counters.nodes, 1u);
    if node < lists_params.node_capacity {
        lists_node_triangle[node] = triangle;
        lists_node_lo[node] = bitcast<u32>(lo);
        lists_node_hi[node] = bitcast<u32>(hi);
        lists_node_next[node] = atomicExchange(&lists_heads[texel], node);
    } else {
        atomicMin(&lists_overflow[texel], bitcast<u32>(lo));
        atomicAdd(&lists_counters.nodes_dropped, 1u);
    }
}

// A job's triangle in its face's frame, CMO-local.
struct ListsLocal {
    l0: vec3<f32>,
    l1: vec3<f32>,
    l2: vec3<f32>,
}

fn lists_local(job: ListsJob) -> ListsLocal {
    return lists_pair_local(job.triangle, job.cmo_face);
}

// Lanes per tile job in `texels`: its 64 texels four each (a turn per two rows of the tile).
const LISTS_JOB_LANES: u32 = 16u;
// Lanes per small job in `texels`: its texels (at most LISTS_SMALL, two on average on a dense
// mesh) in turns. At 16 lanes, as a tile job, a subgroup of 8 lanes ran about two texels:
// truck-garage's `texels` took 59.5 ms at N = 64, against 24.8 ms at 4 lanes, 17.4 at 2 and
// 15.3 at 1 (cad-mm: 13.5, 7.9, 6.6, 7.1; benches/results/lavapipe-bounded-cost.md).
const LISTS_SMALL_LANES: u32 = 2u;

// The job loop is a grid-stride loop over the jobs the `jobs` pass appended: the tile jobs
// first, LISTS_JOB_LANES lanes each (lane `l` takes texels `l`, `l + 16`, ... of its 8x8 tile,
// one per turn, as many turns as the rect's rows in the tile need, so that the job's load, its
// triangle in the face's frame and its edge planes are made once for up to four texels), then
// the small jobs, LISTS_SMALL_LANES lanes each (lane `l` takes texels `l`, `l + 2`, ... of its
// tile's part of the rect, row by row). Both kinds run the same per-texel code. No clip
// runs here: lavapipe executes both arms of a divergent branch, so a clip in this loop would
// cost every texel. A texel the fast paths leave goes to the clip queue; with the queue full it
// gets the whole triangle's bounds (sound, looser; `clips_dropped`).
@compute @workgroup_size(64)
fn texels(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let cap = lists_params.job_capacity;
    let tile_jobs = min(atomicLoad(&lists_counters.tile_jobs), cap);
    let small_jobs = min(atomicLoad(&lists_counters.small_jobs), cap);
    let per_group = 64u / LISTS_JOB_LANES;
    let small_per_group = 64u / LISTS_SMALL_LANES;
    let tile_groups = (tile_jobs + per_group - 1u) / per_group;
    let count = tile_groups + (small_jobs + small_per_group - 1u) / small_per_group;
    let stride = nwg.x * nwg.y;
    var v = wid.x + wid.y * nwg.x;
    // The end is tested at the bottom, behind a guard (module docs).
    if v < count {
        loop {
            let tiles = v < tile_groups;
            var lanes = LISTS_JOB_LANES;
            var slot = lane / LISTS_JOB_LANES;
            var s = v * per_group + slot;
            var j = min(s, tile_jobs - 1u);
            var valid = s < tile_jobs;
            if !tiles {
                lanes = LISTS_SMALL_LANES;
                slot = lane / LISTS_SMALL_LANES;
                s = (v - tile_groups) * small_per_group + slot;
                valid = s < small_jobs;
                j = cap - 1u - min(s, small_jobs - 1u);
            }
            let sub = lane % lanes;
            let job = lists_jobs[j];
            let tx = (job.rect_x & 0xffffu) + (job.tile & 0xffffu) * CB_TILE;
            let ty = (job.rect_y & 0xffffu) + (job.tile >> 16u) * CB_TILE;
            let x1 = min(tx + CB_TILE - 1u, job.rect_x >> 16u);
            let y1 = min(ty + CB_TILE - 1u, job.rect_y >> 16u);
            let w = x1 - tx + 1u;
            // A small job's lanes past its texels skip the set-up, and a job takes only the
            // turns its texels need (the set-up run for every lane made truck-garage's
            // `texels` 18 % slower, benches/results/lavapipe-shaders.md).
            var n = (y1 - ty + 1u) * CB_TILE;
            if !tiles {
                n = w * (y1 - ty + 1u);
            }
            valid = valid && sub < n;
            let turns = (n - sub + lanes - 1u) / lanes;
            if valid {
                let l = lists_local(job);
                let g = cf_edges(l.l0, l.l1, l.l2, job.e);
                for (var t = 0u; t < turns; t++) {
                    let k = sub + t * lanes;
                    var dx = k % CB_TILE;
                    var dy = k / CB_TILE;
                    if !tiles {
                        dx = k % w;
                        dy = k / w;
                    }
                    let x = tx + dx;
                    let y = ty + dy;
                    if x <= x1 && y <= y1 {
                        lists_texel(j, job, l, g, x, y);
                    }
                }
            }
            v += stride;
            if v >= count {
                break;
            }
        }
    }
}

// The fast paths for texel (x, y) of job `j` (`texels`), whose triangle in the face's frame is
// `l` with edge planes `g`.
fn lists_texel(j: u32, job: ListsJob, l: ListsLocal, g: CfEdges, x: u32, y: u32) {
    let size = lists_params.size;
    let w = cb_texel_centre_unit(x, y, size);
    var b = CbBound(0.0, 0.0, false);
    // A `whole` rect's texels, a small rect's texels that the fast paths leave, and a texel the
    // full queue turned away: the whole triangle.
    var whole = job.whole != 0u;
    if !whole {
        let f = cf_texel_cone_edges(g, cb_texel_k(x, y, size, job.m), w, job.e);
        b = CbBound(f.lo, f.hi, f.kind == CF_INSIDE);
        // A small rect's texels take the whole triangle's bounds, not a clip
        // (`cubemap::bounds::UNCLIPPED_TEXELS`).
        let rect_texels = ((job.rect_x >> 16u) - (job.rect_x & 0xffffu) + 1u) * ((job.rect_y >> 16u) - (job.rect_y & 0xffffu) + 1u);
        if f.kind == CF_CLIP && rect_texels <= CB_UNCLIPPED_TEXELS {
            whole = true;
        } else if f.kind == CF_CLIP {
            let q = atomicAdd(&lists_counters.clips, 1u);
            if q < lists_params.clip_capacity {
                lists_clips[q] = vec2<u32>(j, x | (y << 16u));
            } else {
                atomicAdd(&lists_counters.clips_dropped, 1u);
                whole = true;
            }
        }
    }
    if whole {
        b = cb_whole_bound(l.l0, l.l1, l.l2, w, job.e);
    }
    if b.hit {
        lists_push((job.cmo_face * size + y) * size + x, job.triangle, b.lo, b.hi);
    }
}

// Sizes the `texels` dispatch: a workgroup per 64 / LISTS_JOB_LANES tile jobs and per as many
// small jobs, at most 65535 (the kernel strides). An idle workgroup is not free on lavapipe, so
// the dispatch follows the jobs appended, not the capacity.
@compute @workgroup_size(1)
fn texel_args() {
    let cap = lists_params.job_capacity;
    let per_group = 64u / LISTS_JOB_LANES;
    let small = min(atomicLoad(&lists_counters.small_jobs), cap);
    let tiles = min(atomicLoad(&lists_counters.tile_jobs), cap);
    let small_per_group = 64u / LISTS_SMALL_LANES;
    let n = (tiles + per_group - 1u) / per_group + (small + small_per_group - 1u) / small_per_group;
    lists_args[0] = ListsArgs(min(n, 65535u), 1u, 1u);
}

// Sizes the `clips` dispatch: one invocation per queued texel, in groups of 64, at most
// 65535 groups (the kernel strides).
@compute @workgroup_size(1)
fn clip_args() {
    let n = min(atomicLoad(&lists_counters.clips), lists_params.clip_capacity);
    lists_args[1] = ListsArgs(min((n + 63u) / 64u, 65535u), 1u, 1u);
}

// The four clips of every queued texel (`cb_clip_bound`).
@compute @workgroup_size(64)
fn clips(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let n = min(atomicLoad(&lists_counters.clips), lists_params.clip_capacity);
    let size = lists_params.size;
    // The end is tested at the bottom, behind a guard (module docs).
    var i = gid.x;
    if i < n {
        loop {
            let entry = lists_clips[i];
            let job = lists_jobs[entry.x];
            let x = entry.y & 0xffffu;
            let y = entry.y >> 16u;
            let l = lists_local(job);
            let b = cb_clip_bound(l.l0, l.l1, l.l2, job.m, job.e, x, y, size);
            if b.hit {
                lists_push((job.cmo_face * size + y) * size + x, job.triangle, b.lo, b.hi);
            }
            i += nwg.x * 64u;
            if i >= n {
                break;
            }
        }
    }
}

// The gap `(g0, g1)` in one word, each end rounded inwards to bfloat16 (`g1` down in the high
// half, `g0` up in the low half; `cubemap::bounds::pack_gap`). Both are >= +0.0, so truncating
// the bits rounds down.
fn pack_gap(g1: f32, g0: f32) -> u32 {
    let b0 = bitcast<u32>(g0);
    return (bitcast<u32>(g1) & 0xffff0000u) | ((b0 >> 16u) + select(0u, 1u, (b0 & 0xffffu) != 0u));
}

// The RESOLVE_K smallest entries one scan of `resolve` found, in order of (lo bits, triangle),
// and the nodes holding them; a slot no entry took holds LISTS_NIL keys, which sort after every
// entry (an entry's lo is a non-negative float: never -0.0 or NaN, so its bits stay below).
const RESOLVE_K: u32 = 4u;
// Lists longer than this are sorted by merging (`resolve`). A dense scene's long lists are few
// (truck-garage at N = 64: p99 248 nodes, max 2,924) but their subgroups set the pass's time:
// at depth 256, scans alone took 47 ms there, merges above 32 nodes 22 ms (16, 64 and 128
// within noise of 32; benches/results/lavapipe-bounded-cost.md; the merges have since become
// cheaper).
const RESOLVE_LONG: u32 = 32u;

struct ResolveTop {
    lo: vec4<u32>,
    tri: vec4<u32>,
    at: vec4<u32>,
}

// `t` with the entry (lo, tri) held by node `at` inserted in order (the largest falls off): slot
// s takes the entry where it sorts before slot s and not before slot s - 1, and slot s - 1's
// old value where it sorts before both.
fn resolve_insert(t: ResolveTop, lo: u32, tri: u32, at: u32) -> ResolveTop {
    let l = vec4<u32>(lo);
    let one = vec4<u32>(1u);
    let zero = vec4<u32>(0u);
    let b = select(zero, one, l < t.lo) | (select(zero, one, l == t.lo) & select(zero, one, vec4<u32>(tri) < t.tri));
    let before = b != zero;
    let shift = vec4<u32>(0u, b.xyz) != zero;
    return ResolveTop(
        select(t.lo, select(l, vec4<u32>(lo, t.lo.xyz), shift), before),
        select(t.tri, select(vec4<u32>(tri), vec4<u32>(tri, t.tri.xyz), shift), before),
        select(t.at, select(vec4<u32>(at), vec4<u32>(at, t.at.xyz), shift), before),
    );
}

// Whether the entry (lo bits `alo`, triangle `atri`) sorts before (`blo`, `btri`): by lo, then
// triangle (an entry's lo is a non-negative float, never -0.0 or NaN, so its bits order as the
// floats do; a texel's list holds a triangle once, so no two keys are equal).
fn resolve_before(alo: u32, atri: u32, blo: u32, btri: u32) -> bool {
    return alo < blo || (alo == blo && atri < btri);
}

// `resolve`'s gap so far (`cubemap::bounds::texel_gap`): the placed entries' end, the widest
// gap `(lo, hi)` by ratio, and whether one opened.
struct ResolveGap {
    end: f32,
    lo: f32,
    hi: f32,
    found: bool,
}

// Whether the gap `(c0, c1)` is wider by ratio than `(b0, b1)`: `c1 b0 > b1 c0` (products,
// which round alike on every device; the first of equals stays).
fn resolve_wider(c0: f32, c1: f32, b0: f32, b1: f32) -> bool {
    return c1 * b0 > b1 * c0;
}

// The gap after placing the entry `(lo, e_hi)` as the `kept`-th (from 0): it opens a gap where
// it starts past the end, kept where it is wider than the widest so far (`resolve_wider`).
fn resolve_gap(g: ResolveGap, kept: u32, lo: f32, e_hi: f32) -> ResolveGap {
    if kept == 0u {
        return ResolveGap(e_hi, g.lo, g.hi, g.found);
    }
    var out = g;
    if lo > g.end && (!g.found || resolve_wider(g.end, lo, g.lo, g.hi)) {
        out.lo = g.end;
        out.hi = lo;
        out.found = true;
    }
    out.end = max(g.end, e_hi);
    return out;
}

// Nodes per run that `resolve` sorts before its merges.
const RESOLVE_RUN: u32 = 8u;

// The RESOLVE_RUN entries of a run (`resolve`'s long lists), entries 0-3 in the first vector of
// each pair and 4-7 in the second: keys (lo bits, triangle) and their nodes; LISTS_NIL keys
// past the list's end sort last.
struct ResolveRun {
    lo0: vec4<u32>,
    lo1: vec4<u32>,
    tri0: vec4<u32>,
    tri1: vec4<u32>,
    at0: vec4<u32>,
    at1: vec4<u32>,
}

// Entry `i` of `r`: (lo bits, triangle, node).
fn resolve_run_get(r: ResolveRun, i: u32) -> vec3<u32> {
    let k = i & 3u;
    if i < 4u {
        return vec3<u32>(r.lo0[k], r.tri0[k], r.at0[k]);
    }
    return vec3<u32>(r.lo1[k], r.tri1[k], r.at1[k]);
}

// `r` with entry `i` set to (lo bits, triangle, node).
fn resolve_run_set(r: ResolveRun, i: u32, lo: u32, tri: u32, at: u32) -> ResolveRun {
    var out = r;
    let k = i & 3u;
    if i < 4u {
        out.lo0[k] = lo;
        out.tri0[k] = tri;
        out.at0[k] = at;
    } else {
        out.lo1[k] = lo;
        out.tri1[k] = tri;
        out.at1[k] = at;
    }
    return out;
}

// `r` with entries `a` < `b` in order (a compare-exchange of the sorting network).
fn resolve_run_ce(r: ResolveRun, a: u32, b: u32) -> ResolveRun {
    let x = resolve_run_get(r, a);
    let y = resolve_run_get(r, b);
    let swap = resolve_before(y.x, y.y, x.x, x.y);
    let lo = select(x, y, swap);
    let hi = select(y, x, swap);
    return resolve_run_set(resolve_run_set(r, a, lo.x, lo.y, lo.z), b, hi.x, hi.y, hi.z);
}

@compute @workgroup_size(64)
fn resolve(@builtin(global_invocation_id) gid: vec3<u32>) {
    let texel = gid.x + gid.y * lists_params.row;
    let size = lists_params.size;
    let per_face = size * size;
    if texel >= lists_params.cmo_count * 6u * per_face {
        return;
    }
    let head = atomicLoad(&lists_heads[texel]);
    let over = min(atomicLoad(&lists_overflow[texel]), atomicLoad(&lists_face_overflow[texel / per_face]));
    var complete = bitcast<f32>(over);
    let none = vec4<u32>(LISTS_NIL);
    var top_lo = none;
    var top_tri = none;
    var top_at = none;
    var hi = -f32_inf();
    // The gap (`cubemap::bounds::texel_gap`): the end (largest hi) of the entries placed so far,
    // and the widest gap by ratio that an entry past that end opened, `(gap_lo, gap_hi)`, where
    // one did (`gap_found`).
    var gap_end = 0.0;
    var gap_lo = 0.0;
    var gap_hi = 0.0;
    var gap_found = false;
    var kept = 0u;
    var node = head;
    var steps = 0u;
    var capped = false;
    var rest = f32_inf();
    let depth = lists_params.depth;
    let walk_cap = lists_params.walk_cap;
    var long_list = false;
    var first = head;
    // A list of one node (most texels of a smooth scene) is sorted: its entry is kept as it is
    // (depth >= 1), and the walk below is skipped.
    if node != LISTS_NIL {
        let first = lists_node(node);
        if first.next == LISTS_NIL {
            hi = bitcast<f32>(first.hi);
            gap_end = hi;
            kept = 1u;
            node = LISTS_NIL;
        }
    }
    // Each turn scans the list from `node` (the nodes not yet placed) for its RESOLVE_K smallest
    // entries and places them, in order, on the scan's first nodes by payload swapping; the
    // `depth`-th placed, the smallest entry left is `rest`. So the first `kept` nodes from the
    // head hold the `depth` smallest entries sorted by (lo, triangle), a list of n nodes taking
    // n / RESOLVE_K scans of its remainder where one smallest per scan took n. Both loops test
    // their end at the bottom, behind a guard: a subgroup then runs as many turns as its longest
    // remainder needs (one, masked, where no lane has any), not one more in which every lane
    // leaves at the top (lavapipe runs each turn's whole body for all lanes).
    if node != LISTS_NIL {
        loop {
            top_lo = none;
            top_tri = none;
            top_at = none;
            // The scan's first RESOLVE_K nodes, where its entries go, and the node after them.
            var pos = none;
            var after = LISTS_NIL;
            var seen = 0u;
            var j = node;
            // Every update is a select on `live`: lavapipe gave a lane that had left this loop
            // the values of its neighbours' later turns (spirv/README.md).
            var live = true;
            loop {
                let t = resolve_insert(ResolveTop(top_lo, top_tri, top_at), lists_node_lo[j], lists_node_triangle[j], j);
                top_lo = select(top_lo, t.lo, live);
                top_tri = select(top_tri, t.tri, live);
                top_at = select(top_at, t.at, live);
                pos = select(pos, vec4<u32>(j), vec4<u32>(seen) == vec4<u32>(0u, 1u, 2u, 3u) & vec4<bool>(live));
                after = select(after, j, seen == RESOLVE_K && live);
                seen += select(0u, 1u, live);
                j = lists_node_next[j];
                // The first scan stops at a long list's RESOLVE_LONG + 1st node: the merge
                // below sorts it, and the scan's entries are not used.
                live = live && j != LISTS_NIL && !(kept == 0u && seen > RESOLVE_LONG);
                if !live {
                    break;
                }
                steps += 1u;
                if steps > walk_cap {
                    capped = true;
                    break;
                }
            }
            if capped {
                break;
            }
            // A long list is sorted by the merge below instead (its first scan stopped past
            // RESOLVE_LONG nodes).
            if kept == 0u && seen > RESOLVE_LONG {
                long_list = true;
                break;
            }
            let found = min(seen, RESOLVE_K);
            let placed = min(found, depth - kept);
            // The scan's entries in order go to its first nodes, each to the list's node at
            // position `kept`: the payload there moves to the entry's node, and a later entry of
            // the scan held there is now found at that node. Then the entry counts towards `hi`
            // and the gap (`cubemap::bounds::texel_gap`). The vectors turn by one after
            // each placement, so that the next entry and node are always their first component.
            for (var m = 0u; m < placed; m++) {
                let dst = pos.x;
                let src = top_at.x;
                let lo = top_lo.x;
                let e_hi = lists_node_hi[src];
                if src != dst {
                    lists_set_payload(src, lists_node(dst));
                    lists_set_payload(dst, ListsNode(top_tri.x, lo, e_hi, 0u));
                    top_at = select(top_at, vec4<u32>(src), top_at == vec4<u32>(dst));
                }
                hi = max(hi, bitcast<f32>(e_hi));
                let g = resolve_gap(ResolveGap(gap_end, gap_lo, gap_hi, gap_found), kept, bitcast<f32>(lo), bitcast<f32>(e_hi));
                gap_end = g.end;
                gap_lo = g.lo;
                gap_hi = g.hi;
                gap_found = g.found;
                kept += 1u;
                pos = pos.yzwx;
                top_at = top_at.yzwx;
                top_lo = top_lo.yzwx;
                top_tri = top_tri.yzwx;
            }
            if found > placed {
                rest = bitcast<f32>(top_lo.x);
                break;
            }
            node = after;
            if node == LISTS_NIL {
                break;
            }
        }
    }
    // A long list (more than RESOLVE_LONG nodes, counted by its first scan, which placed
    // nothing) is sorted whole by (lo, triangle) by relinking its nodes: a bottom-up merge sort
    // of the linked list (runs of RESOLVE_RUN nodes sorted first, then runs of `width` nodes
    // merged four at a time, `width` growing fourfold per pass until one merge takes the whole
    // list), about n (2 + 0.9 log2 (n / 8)) node visits where the scans take about n^2 / 8 up to
    // the depth (the scans stay below RESOLVE_LONG, where they cost less). Runs of eight and
    // merges of four took truck-garage's `resolve` at N = 64 from 21 ms (merges of two from runs
    // of one) to 12 (benches/results/lavapipe-bounded-cost.md). The head is then the first node
    // of the sorted list. Its visits are capped at half the walk cap: lavapipe's limiter counts the
    // subgroup's turns of every loop, each as long as the lane that needs most. Its loops test
    // their end at the top (spirv/README.md: a lane past a bottom break keeps writing).
    if long_list {
        // Runs of RESOLVE_RUN nodes sorted first, each node read once and the run relinked in
        // order (a sorting network on their keys), so that the merges start at runs of
        // RESOLVE_RUN.
        var p = first;
        var tail = LISTS_NIL;
        loop {
            if p == LISTS_NIL {
                break;
            }
            let none = vec4<u32>(LISTS_NIL);
            var r = ResolveRun(none, none, none, none, none, none);
            var j = p;
            var c = 0u;
            for (var m = 0u; m < RESOLVE_RUN; m++) {
                let ok = j != LISTS_NIL;
                let jj = select(0u, j, ok);
                r = resolve_run_set(r, m, select(LISTS_NIL, lists_node_lo[jj], ok), select(LISTS_NIL, lists_node_triangle[jj], ok), select(LISTS_NIL, jj, ok));
                c += select(0u, 1u, ok);
                j = select(j, lists_node_next[jj], ok);
            }
            // The optimal network for eight (19 compare-exchanges; Knuth, TAOCP 5.3.4).
            r = resolve_run_ce(r, 0u, 2u);
            r = resolve_run_ce(r, 1u, 3u);
            r = resolve_run_ce(r, 4u, 6u);
            r = resolve_run_ce(r, 5u, 7u);
            r = resolve_run_ce(r, 0u, 4u);
            r = resolve_run_ce(r, 1u, 5u);
            r = resolve_run_ce(r, 2u, 6u);
            r = resolve_run_ce(r, 3u, 7u);
            r = resolve_run_ce(r, 0u, 1u);
            r = resolve_run_ce(r, 2u, 3u);
            r = resolve_run_ce(r, 4u, 5u);
            r = resolve_run_ce(r, 6u, 7u);
            r = resolve_run_ce(r, 2u, 4u);
            r = resolve_run_ce(r, 3u, 5u);
            r = resolve_run_ce(r, 1u, 4u);
            r = resolve_run_ce(r, 3u, 6u);
            r = resolve_run_ce(r, 1u, 2u);
            r = resolve_run_ce(r, 3u, 4u);
            r = resolve_run_ce(r, 5u, 6u);
            for (var m = 0u; m < c; m++) {
                let e = resolve_run_get(r, m).z;
                if tail == LISTS_NIL {
                    first = e;
                } else {
                    lists_node_next[tail] = e;
                }
                tail = e;
            }
            steps += c;
            p = j;
        }
        lists_node_next[tail] = LISTS_NIL;
        // Then merges of four runs at a time: the first three runs walked to find their heads
        // (the fourth ends at its count or the list's end), then the smallest of the runs'
        // heads appended, one node at a time.
        var width = RESOLVE_RUN;
        loop {
            var g = first;
            tail = LISTS_NIL;
            var merges = 0u;
            loop {
                if g == LISTS_NIL || capped {
                    break;
                }
                merges += 1u;
                var head = vec4<u32>(LISTS_NIL);
                var left = vec4<u32>(0u);
                var q = g;
                for (var r = 0u; r < 3u; r++) {
                    head[r] = q;
                    var c = 0u;
                    loop {
                        if c == width || q == LISTS_NIL {
                            break;
                        }
                        c += 1u;
                        q = lists_node_next[q];
                    }
                    left[r] = c;
                    steps += c;
                }
                head.w = q;
                left.w = select(0u, width, q != LISTS_NIL);
                var key_lo = vec4<u32>(LISTS_NIL);
                var key_tri = vec4<u32>(LISTS_NIL);
                for (var r = 0u; r < 4u; r++) {
                    let h = select(0u, head[r], left[r] > 0u);
                    key_lo[r] = select(LISTS_NIL, lists_node_lo[h], left[r] > 0u);
                    key_tri[r] = select(LISTS_NIL, lists_node_triangle[h], left[r] > 0u);
                }
                steps += 1u;
                loop {
                    if all(left == vec4<u32>(0u)) {
                        break;
                    }
                    // The smallest head: a run with nodes left has a key below LISTS_NIL's, an
                    // empty one LISTS_NIL's, which sorts last.
                    let a = select(0u, 1u, resolve_before(key_lo.y, key_tri.y, key_lo.x, key_tri.x));
                    let b = select(2u, 3u, resolve_before(key_lo.w, key_tri.w, key_lo.z, key_tri.z));
                    let r = select(a, b, resolve_before(key_lo[b], key_tri[b], key_lo[a], key_tri[a]));
                    let e = head[r];
                    let after = lists_node_next[e];
                    let n = select(left[r] - 1u, 0u, after == LISTS_NIL);
                    left[r] = n;
                    head[r] = after;
                    let h = select(0u, after, n > 0u);
                    key_lo[r] = select(LISTS_NIL, lists_node_lo[h], n > 0u);
                    key_tri[r] = select(LISTS_NIL, lists_node_triangle[h], n > 0u);
                    if tail == LISTS_NIL {
                        first = e;
                    } else {
                        lists_node_next[tail] = e;
                    }
                    tail = e;
                    steps += 1u;
                }
                // The fourth run's last node is followed by the next group (or the end).
                g = head.w;
                capped = steps > walk_cap / 2u;
            }
            if capped {
                break;
            }
            lists_node_next[tail] = LISTS_NIL;
            if merges <= 1u {
                break;
            }
            width *= 4u;
        }
    }
    // The first `depth` entries count towards `hi` and the gap (`cubemap::bounds::texel_gap`);
    // the next one's lo is `rest`.
    if long_list && !capped {
        node = first;
        loop {
            if node == LISTS_NIL {
                break;
            }
            let lo = bitcast<f32>(lists_node_lo[node]);
            if kept == depth {
                rest = lo;
                break;
            }
            let e_hi = bitcast<f32>(lists_node_hi[node]);
            hi = max(hi, e_hi);
            let g = resolve_gap(ResolveGap(gap_end, gap_lo, gap_hi, gap_found), kept, lo, e_hi);
            gap_end = g.end;
            gap_lo = g.lo;
            gap_hi = g.hi;
            gap_found = g.found;
            kept += 1u;
            node = lists_node_next[node];
        }
    }
    if capped {
        complete = 0.0;
        atomicAdd(&lists_counters.walks_capped, 1u);
    }
    complete = min(complete, rest);
    if complete < f32_inf() {
        hi = f32_inf();
    }
    var lo = complete;
    if kept > 0u {
        lo = min(bitcast<f32>(lists_node_lo[first]), complete);
    }
    lists_rec_head[texel] = first;
    lists_rec_complete[texel] = bitcast<u32>(complete);
    lists_rec_hi[texel] = bitcast<u32>(hi);
    lists_rec_count[texel] = kept;
    lists_distance[texel] = lo;
    // The gap after the last entry, up to `complete`, where no other opened or where it is
    // finite and wider.
    var g0 = gap_end;
    var g1 = complete;
    if gap_found && !(complete < f32_inf() && complete > gap_end && resolve_wider(gap_end, complete, gap_lo, gap_hi)) {
        g0 = gap_lo;
        g1 = min(gap_hi, complete);
    }
    lists_gap[texel] = pack_gap(g1, g0);
}
