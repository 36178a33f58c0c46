//! Compares two folders of EXR renders channel by channel, bit for bit: the check that a
//! refactor changed no image and no per-pixel record (`tests/records/render.sh` writes the
//! folders, one per commit; its header says how to run this).
//!
//! `CUBETRACE_RECORDS="OLD NEW"` names the folders; `CUBETRACE_RECORDS_SKIP` lists channels
//! left out (a deliberate renumbering). Without the variable the comparison is skipped: it needs
//! renders from two commits, which a plain `cargo test` does not have. The negative test below
//! shows the comparison fails on a one-bit change.
use std::collections::BTreeMap;
use std::path::Path;

use exr::prelude::*;

/// Every channel of an EXR as raw bits (f32 bits or u32).
fn channels(path: &Path) -> BTreeMap<String, Vec<u32>> {
    let image =
        read_all_flat_layers_from_file(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = BTreeMap::new();
    for layer in &image.layer_data {
        for ch in &layer.channel_data.list {
            let bits: Vec<u32> = match &ch.sample_data {
                FlatSamples::F32(v) => v.iter().map(|x| x.to_bits()).collect(),
                FlatSamples::U32(v) => v.clone(),
                FlatSamples::F16(v) => v.iter().map(|x| u32::from(x.to_bits())).collect(),
            };
            out.insert(ch.name.to_string(), bits);
        }
    }
    out
}

/// The differences between two renders: `file: channel: n samples differ (first at k)`.
fn compare_files(old: &Path, new: &Path, skip: &[String]) -> Vec<String> {
    let (a, b) = (channels(old), channels(new));
    let name = old.file_name().map(|n| n.to_string_lossy().to_string());
    let name = name.unwrap_or_default();
    let mut out = Vec::new();
    let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    for key in keys.into_iter().filter(|k| !skip.contains(k)) {
        match (a.get(key), b.get(key)) {
            (Some(x), Some(y)) if x == y => {}
            (Some(x), Some(y)) if x.len() == y.len() => {
                let n = x.iter().zip(y).filter(|(p, q)| p != q).count();
                let first = x.iter().zip(y).position(|(p, q)| p != q).unwrap_or(0);
                out.push(format!(
                    "{name}: {key}: {n} samples differ (first at {first})"
                ));
            }
            (x, y) => out.push(format!(
                "{name}: {key}: present {} / {}, or sizes differ",
                x.is_some(),
                y.is_some()
            )),
        }
    }
    out
}

/// Every `*.exr` of `old` against the file of the same name in `new`.
fn compare_folders(old: &Path, new: &Path, skip: &[String]) -> (usize, Vec<String>) {
    let mut names: Vec<_> = std::fs::read_dir(old)
        .unwrap_or_else(|e| panic!("{}: {e}", old.display()))
        .filter_map(|e| e.ok().map(|e| e.file_name()))
        .filter(|n| n.to_string_lossy().ends_with(".exr"))
        .collect();
    names.sort();
    let mut diffs = Vec::new();
    for n in &names {
        let other = new.join(n);
        if !other.exists() {
            diffs.push(format!(
                "{}: missing in {}",
                n.to_string_lossy(),
                new.display()
            ));
            continue;
        }
        diffs.extend(compare_files(&old.join(n), &other, skip));
    }
    (names.len(), diffs)
}

#[test]
#[ignore = "needs two folders of renders from two commits: see tests/records/render.sh"]
fn records_are_unchanged() {
    let Ok(dirs) = std::env::var("CUBETRACE_RECORDS") else {
        panic!("set CUBETRACE_RECORDS=\"OLD NEW\" (tests/records/render.sh)");
    };
    let dirs: Vec<&str> = dirs.split_whitespace().collect();
    assert_eq!(dirs.len(), 2, "CUBETRACE_RECORDS: two folders");
    let skip: Vec<String> = std::env::var("CUBETRACE_RECORDS_SKIP")
        .unwrap_or_default()
        .split_whitespace()
        .map(String::from)
        .collect();
    let (files, diffs) = compare_folders(Path::new(dirs[0]), Path::new(dirs[1]), &skip);
    assert!(files > 0, "no EXR in {}", dirs[0]);
    assert!(
        diffs.is_empty(),
        "{} differences in {files} files:\n{}",
        diffs.len(),
        diffs.join("\n")
    );
    println!("{files} renders equal bit for bit (skipped channels: {skip:?})");
}

/// Negative: one flipped bit in one sample of one channel is found, and a skipped channel is
/// not compared.
#[test]
fn a_one_bit_change_is_found() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (old, new) = (dir.path().join("old"), dir.path().join("new"));
    std::fs::create_dir_all(&old).expect("old");
    std::fs::create_dir_all(&new).expect("new");
    let write = |path: &Path, bump: bool| {
        let mut r = vec![0.25f32; 12];
        if bump {
            r[5] = f32::from_bits(r[5].to_bits() ^ 1);
        }
        let ids: Vec<u32> = (0..12).map(|k| k + u32::from(bump)).collect();
        cubetrace::output::write_exr(
            path,
            4,
            3,
            vec![
                ("R", cubetrace::output::Channel::F32(r)),
                ("primitive_id", cubetrace::output::Channel::U32(ids)),
            ],
        )
        .expect("write");
    };
    write(&old.join("a.exr"), false);
    write(&new.join("a.exr"), false);
    assert!(compare_folders(&old, &new, &[]).1.is_empty(), "equal files");
    write(&new.join("a.exr"), true);
    let (_, diffs) = compare_folders(&old, &new, &[]);
    assert_eq!(diffs.len(), 2, "{diffs:?}");
    assert!(
        diffs[0].contains("R: 1 samples differ (first at 5)"),
        "{diffs:?}"
    );
    let (_, diffs) = compare_folders(&old, &new, &["primitive_id".into()]);
    assert_eq!(diffs.len(), 1, "the skipped channel is left out: {diffs:?}");
}
