//! The `bounded` criterion's per-texel bounds and candidate lists on the GPU: the
//! layout `spirv/shared/trace_bounded.wgsl` reads, and its upload from the CPU
//! [`TexelLists`] (a valid path for small scenes, and the tracer's test input until the GPU
//! capture, `capture_lists`, fills the same buffers).
//!
//! Logically a record per texel `[head, bits(complete_to), bits(hi), count_kept]` and a node
//! per entry `[triangle, bits(lo), bits(hi), next]` ([`PackedLists`] holds them so); on the GPU
//! each of the four words is a binding of its own, one `u32` per texel or node (structure of
//! arrays, [`columns`] / [`rows`]): a binding then takes 4 B per texel (as `cmo_distance`) or per
//! node, so the pool holds `maxStorageBufferRange / 4` nodes (33.5 M on lavapipe's 128 MiB)
//! where one `vec4` binding held a quarter of that ([`check_range`] refuses what still does not
//! fit, before anything is allocated).
//!
//! | binding (`@group(1)`) | WGSL name | contents |
//! |---|---|---|
//! | 2 | `cmo_distance` | per texel its `lo` (so pyramids, cut radius and skips work unchanged) |
//! | 6, 7, 8, 9 | `cmo_list_head`, `cmo_list_complete`, `cmo_list_hi`, `cmo_list_count` | per texel of CMO k at `k * 6 N N + index`: `head`, `bits(complete_to)`, `bits(hi)`, `count_kept` |
//! | 10, 11, 12, 13 | `cmo_node_triangle`, `cmo_node_lo`, `cmo_node_hi`, `cmo_node_next` | the node pool of all CMOs: `triangle`, `bits(lo)`, `bits(hi)`, `next` |
//!
//! A texel's entries are the first `count_kept` nodes from `head` along `next`, sorted by
//! `(lo, triangle)`; [`NO_NODE`] ends a chain (and is `head` of an empty texel). Node indices
//! are global over the pool (one pool for every CMO). The upload writes each texel's entries
//! as consecutive nodes; the GPU capture links them through its pool in any order.
use crate::cubemap::bounds::{Entry, TexelLists, pack_gap, texel_gap};

/// No node (`BOUNDED_NO_NODE`).
pub const NO_NODE: u32 = u32::MAX;

/// Bytes of one per-texel record (over its four bindings).
pub const RECORD_BYTES: u64 = 16;
/// Bytes of one node of the pool (over its four bindings).
pub const NODE_BYTES: u64 = 16;
/// Bytes of one record or node in each of its bindings (one `u32` word).
pub const COLUMN_BYTES: u64 = 4;
/// The record bindings' names, word by word (`@group(1)` bindings 6 to 9 of the tracers).
pub const RECORD_COLUMNS: [&str; 4] = [
    "cmo_list_head",
    "cmo_list_complete",
    "cmo_list_hi",
    "cmo_list_count",
];
/// The pool bindings' names, word by word (`@group(1)` bindings 10 to 13 of the tracers).
pub const NODE_COLUMNS: [&str; 4] = [
    "cmo_node_triangle",
    "cmo_node_lo",
    "cmo_node_hi",
    "cmo_node_next",
];
/// The tracers' `@group(1)` binding of the first record word; the other words and the pool's
/// follow ([`RECORD_COLUMNS`], then [`NODE_COLUMNS`]).
pub const FIRST_BINDING: u32 = 6;

/// Bytes the lists of `cmos` CMOs of face size `size` take on the GPU with a pool of
/// `pool_capacity` nodes (the records and the pool; `lo` is the CMO distance buffer, counted
/// with the CMO data).
pub fn lists_bytes(cmos: u32, size: u32, pool_capacity: u64) -> u64 {
    u64::from(cmos) * 6 * u64::from(size) * u64::from(size) * RECORD_BYTES
        + pool_capacity * NODE_BYTES
}

/// Whether the lists of `texels` texels (all CMOs) and a pool of `nodes` nodes fit bindings of
/// at most `limit` bytes each (the device's `maxStorageBufferRange`): each record and pool
/// binding takes [`COLUMN_BYTES`] per texel or node. `Err((what, limit))` in the words of
/// [`crate::vk::VkError::Limit`] otherwise, naming the binding, its count and size.
pub fn check_range(texels: u64, nodes: u64, limit: u64) -> Result<(), (String, String)> {
    let mib = |b: u64| {
        if b >= 1 << 20 {
            format!("{:.1} MiB", b as f64 / f64::from(1u32 << 20))
        } else {
            format!("{b} B")
        }
    };
    for (what, count, unit) in [
        ("per-texel record", texels, "texels"),
        ("node pool", nodes, "nodes"),
    ] {
        let bytes = count * COLUMN_BYTES;
        if bytes > limit {
            return Err((
                format!(
                    "the `--criterion bounded` lists' {what} ({count} {unit}: {} in each of its \
                     4 bindings of {COLUMN_BYTES} B per entry)",
                    mib(bytes)
                ),
                format!("maxStorageBufferRange = {}", mib(limit)),
            ));
        }
    }
    Ok(())
}

/// The four one-word bindings of records or nodes (`rows[i][w]` is `columns[w][i]`; at least
/// one word each: a binding cannot be empty).
pub fn columns(rows: &[[u32; 4]]) -> [Vec<u32>; 4] {
    std::array::from_fn(|w| {
        let mut c: Vec<u32> = rows.iter().map(|r| r[w]).collect();
        if c.is_empty() {
            c.push(NO_NODE);
        }
        c
    })
}

/// The records or nodes of four one-word bindings ([`columns`]' inverse), as long as the
/// shortest.
pub fn rows(columns: &[Vec<u32>; 4]) -> Vec<[u32; 4]> {
    let n = columns.iter().map(Vec::len).min().unwrap_or(0);
    (0..n)
        .map(|i| std::array::from_fn(|w| columns[w][i]))
        .collect()
}

/// [`TexelLists`] of every CMO in the GPU layout (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PackedLists {
    /// Face size N.
    pub size: u32,
    /// Per texel of every CMO: `lo` (the CMO distance buffer's contents).
    pub lo: Vec<f32>,
    /// Per texel of every CMO: `[head, bits(complete_to), bits(hi), count_kept]` (uploaded as
    /// four bindings, [`columns`]).
    pub records: Vec<[u32; 4]>,
    /// The node pool: `[triangle, bits(lo), bits(hi), next]` (uploaded as four bindings).
    pub nodes: Vec<[u32; 4]>,
}

/// Packs the CMOs' lists (in CMO order) into the GPU layout. Fails, naming the CMO, where the
/// face sizes differ or a list is malformed (offsets not covering the entries, a texel count
/// other than `6 N N`), or where the pool would need more than `u32::MAX - 1` nodes.
pub fn pack(lists: &[TexelLists]) -> Result<PackedLists, String> {
    let size = lists.first().map_or(0, |l| l.size);
    let per = 6 * size as usize * size as usize;
    let mut out = PackedLists {
        size,
        lo: Vec::with_capacity(per * lists.len()),
        records: Vec::with_capacity(per * lists.len()),
        nodes: Vec::new(),
    };
    for (k, l) in lists.iter().enumerate() {
        if l.size != size {
            return Err(format!(
                "CMO {k}: face size {} where CMO 0 has {size} (all must match)",
                l.size
            ));
        }
        let ok = l.lo.len() == per
            && l.hi.len() == per
            && l.complete_to.len() == per
            && l.offsets.len() == per + 1
            && l.offsets.windows(2).all(|w| w[0] <= w[1])
            && l.offsets
                .last()
                .is_some_and(|&e| e as usize == l.entries.len());
        if !ok {
            return Err(format!(
                "CMO {k}: lists malformed (want {per} texels and offsets 0..={} ascending)",
                l.entries.len()
            ));
        }
        for i in 0..per {
            let entries = &l.entries[l.offsets[i] as usize..l.offsets[i + 1] as usize];
            let first = out.nodes.len();
            if first + entries.len() >= NO_NODE as usize {
                return Err(format!("CMO {k}: more than {} nodes", NO_NODE - 1));
            }
            for (j, e) in entries.iter().enumerate() {
                let next = if j + 1 < entries.len() {
                    (first + j + 1) as u32
                } else {
                    NO_NODE
                };
                out.nodes
                    .push([e.triangle, e.lo.to_bits(), e.hi.to_bits(), next]);
            }
            let head = if entries.is_empty() {
                NO_NODE
            } else {
                first as u32
            };
            out.records.push([
                head,
                l.complete_to[i].to_bits(),
                l.hi[i].to_bits(),
                entries.len() as u32,
            ]);
            out.lo.push(l.lo[i]);
        }
    }
    if out.nodes.is_empty() {
        // A binding cannot be empty.
        out.nodes.push([NO_NODE; 4]);
    }
    Ok(out)
}

/// The per-texel entries the GPU layout holds: texel `i`'s first `count_kept` nodes from
/// `head`, as [`Entry`]s, or an error naming the texel where a chain ends early or loops past
/// the pool. For tests of the capture and of [`pack`].
pub fn walk(records: &[[u32; 4]], nodes: &[[u32; 4]], i: usize) -> Result<Vec<Entry>, String> {
    let [head, _, _, count] = records[i];
    let mut out = Vec::with_capacity(count as usize);
    let mut n = head;
    for j in 0..count {
        let Some(node) = nodes.get(n as usize) else {
            return Err(format!(
                "texel {i}: node {j} of {count} is {n:#x}, past the pool ({})",
                nodes.len()
            ));
        };
        out.push(Entry {
            triangle: node[0],
            lo: f32::from_bits(node[1]),
            hi: f32::from_bits(node[2]),
        });
        n = node[3];
    }
    Ok(out)
}

/// Every texel's gap, packed ([`crate::cubemap::bounds::texel_gap`],
/// [`crate::cubemap::bounds::pack_gap`]): what the GPU's capture writes beside the records,
/// for lists uploaded from the CPU. A texel whose chain is malformed gets no gap (the word 0:
/// `g1 = 0`).
pub fn packed_gaps(packed: &PackedLists) -> Vec<u32> {
    (0..packed.records.len())
        .map(|i| match walk(&packed.records, &packed.nodes, i) {
            Ok(entries) => pack_gap(texel_gap(&entries, f32::from_bits(packed.records[i][1]))),
            Err(_) => 0,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lists(size: u32, per_texel: &[&[Entry]]) -> TexelLists {
        let mut offsets = vec![0];
        let mut entries = Vec::new();
        for e in per_texel {
            entries.extend_from_slice(e);
            offsets.push(entries.len() as u32);
        }
        let n = per_texel.len();
        TexelLists {
            size,
            depth: 16,
            lo: (0..n).map(|i| i as f32).collect(),
            hi: (0..n).map(|i| 10.0 + i as f32).collect(),
            complete_to: vec![f32::INFINITY; n],
            offsets,
            entries,
        }
    }

    #[test]
    fn pack_links_each_texels_entries_in_order() {
        let e = |t, lo| Entry {
            triangle: t,
            lo,
            hi: lo + 1.0,
        };
        let a: &[Entry] = &[e(3, 1.0), e(1, 2.0)];
        let b: &[Entry] = &[e(7, 0.5)];
        let mut texels: Vec<&[Entry]> = vec![&[]; 6];
        texels[0] = a;
        texels[4] = b;
        let l0 = lists(1, &texels);
        let mut l1 = l0.clone();
        l1.complete_to[2] = 4.0;
        let p = pack(&[l0.clone(), l1.clone()]).unwrap();
        assert_eq!(p.records.len(), 12);
        assert_eq!(p.lo[6..], l1.lo[..]);
        for (k, l) in [&l0, &l1].into_iter().enumerate() {
            for i in 0..6 {
                let t = crate::cubemap::face::Texel {
                    face: i as u32,
                    x: 0,
                    y: 0,
                };
                let got = walk(&p.records, &p.nodes, k * 6 + i).unwrap();
                assert_eq!(got, l.entries_at(t), "CMO {k} texel {i}");
                let r = p.records[k * 6 + i];
                assert_eq!(f32::from_bits(r[1]), l.complete_to[i]);
                assert_eq!(f32::from_bits(r[2]), l.hi[i]);
            }
        }
        assert_eq!(p.records[1][0], NO_NODE);
        // Negative: a record claiming more nodes than its chain holds is reported.
        let mut bad = p.records.clone();
        bad[4][3] = 2;
        assert!(walk(&bad, &p.nodes, 4).is_err());
    }

    #[test]
    fn pack_refuses_mixed_sizes_and_bad_offsets() {
        let none: &[Entry] = &[];
        let l = lists(1, &[none; 6]);
        let mut other = lists(2, &[none; 24]);
        assert!(
            pack(&[l.clone(), other.clone()])
                .unwrap_err()
                .contains("CMO 1")
        );
        other = l.clone();
        other.offsets[3] = 5;
        assert!(pack(&[other]).unwrap_err().contains("malformed"));
        assert_eq!(lists_bytes(2, 4, 10), 2 * 6 * 16 * 16 + 160);
    }

    #[test]
    fn columns_and_rows_are_inverse() {
        let r = vec![[1, 2, 3, 4], [5, 6, 7, 8], [9, 10, 11, NO_NODE]];
        let c = columns(&r);
        assert_eq!(c[1], vec![2, 6, 10]);
        assert_eq!(c[3], vec![4, 8, NO_NODE]);
        assert_eq!(rows(&c), r);
        // Negative: a word changed in one binding changes exactly that row.
        let mut bad = c.clone();
        bad[2][1] ^= 1;
        let back = rows(&bad);
        assert_ne!(back[1], r[1]);
        assert_eq!(back[0], r[0]);
        // An empty set still gets one word per binding.
        assert!(columns(&[]).iter().all(|c| c.len() == 1));
    }

    /// The limit binds each one-word binding: a pool a `vec4` binding could not hold fits, one
    /// word more than the limit is refused, naming the count, the size and the limit.
    #[test]
    fn check_range_is_per_binding_word() {
        let limit = 1000;
        // 250 nodes: 4000 B as one vec4 binding, 1000 B in each of four.
        assert!(250 * NODE_BYTES > limit);
        assert_eq!(check_range(10, 250, limit), Ok(()));
        assert_eq!(check_range(250, 10, limit), Ok(()));
        let (what, lim) = check_range(10, 251, limit).unwrap_err();
        assert!(what.contains("node pool (251 nodes"), "{what}");
        assert!(lim.contains("maxStorageBufferRange"), "{lim}");
        let (what, _) = check_range(251, 10, limit).unwrap_err();
        assert!(what.contains("record (251 texels"), "{what}");
    }
}
