//! The source tree keeps the shape the crate documentation (`src/lib.rs`, "Modules") describes:
//! - no import circle: no module uses, directly or through others, a module that uses it back
//!   (at every depth of the module path: `vk`, `vk::passes`, `vk::passes::bvh`);
//! - the frame's layers ([`LAYERS`]): the commands (`app`) above the harness (`bench`), both above
//!   the frame engine (`render`), which is above the Vulkan backend (`vk`); no module uses one
//!   of a layer above its own;
//! - Vulkan stays in `src/vk/`: no `ash::` path and no `unsafe` outside it;
//! - no function in `src/` is longer than 120 lines;
//! - a method variant (`Method::Ssr`) is named only in the registry (`src/method.rs`) and in
//!   that method's own files (a module path with its name: `method::ssr`, `vk::methods::ssr`),
//!   test modules aside;
//! - the README is at most 350 lines;
//! - no words only the authors understand (an issue number, a commit hash, a date, "today")
//!   in the README, `src/`, `spirv/` or `tests/`.
//!
//! The checks read the sources as text (paths written `crate::a::b` or `super::a`, and
//! `use` groups `crate::{a, b}`), which is how this crate writes its imports. Each check has a
//! negative on a made-up tree that must fail it.
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `src/` but `main.rs` (the binary, which only uses the library), with
/// its module path (`vk::passes::bvh`; `lib.rs` is the root, "").
fn sources() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    let mut stack = vec![root.clone()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).expect("src is readable") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") && !p.ends_with("main.rs") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
        .into_iter()
        .map(|p| {
            (
                module_of(&root, &p),
                std::fs::read_to_string(&p).expect("readable"),
            )
        })
        .collect()
}

fn module_of(root: &Path, file: &Path) -> String {
    let rel: PathBuf = file
        .strip_prefix(root)
        .expect("under src")
        .with_extension("");
    let mut parts: Vec<String> = rel.iter().map(|s| s.to_string_lossy().into()).collect();
    if parts.last().is_some_and(|l| l == "mod" || l == "lib") {
        parts.pop();
    }
    parts.join("::")
}

/// The source without comments and string literals (so that prose naming a module is no edge).
fn code_only(src: &str) -> String {
    let mut out = String::with_capacity(src.len());
    for line in src.lines() {
        let mut in_str = false;
        let mut prev = ' ';
        let mut kept = String::new();
        let chars: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            let c = chars[i];
            if !in_str && c == '/' && chars.get(i + 1) == Some(&'/') {
                break;
            }
            if c == '"' && prev != '\\' {
                in_str = !in_str;
            } else if !in_str {
                kept.push(c);
            }
            prev = c;
            i += 1;
        }
        out.push_str(&kept);
        out.push('\n');
    }
    out
}

/// Module paths a file refers to: `crate::a::b::c` and `super::x` (resolved against `module`),
/// and each item of a `crate::{a, b::{c, d}}` group.
fn references(module: &str, src: &str) -> Vec<String> {
    let code = code_only(src);
    let mut out = Vec::new();
    for (prefix, base) in [("crate::", String::new()), ("super::", parent(module))] {
        let mut rest = code.as_str();
        while let Some(k) = rest.find(prefix) {
            let before = rest[..k].chars().last();
            rest = &rest[k + prefix.len()..];
            if before.is_some_and(is_path_char) {
                continue;
            }
            for path in expand(rest) {
                let path = path.trim_matches(':');
                out.push(if base.is_empty() {
                    path.to_string()
                } else {
                    format!("{base}::{path}")
                });
            }
        }
    }
    out
}

fn is_path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_' || c == ':'
}

/// The paths at the start of `text`: `a::b` alone, or `a::{b, c::{d}}` as `a::b`, `a::c::d`.
fn expand(text: &str) -> Vec<String> {
    let head: String = text.chars().take_while(|&c| is_path_char(c)).collect();
    let rest = &text[head.len()..];
    if !rest.starts_with('{') {
        return vec![head];
    }
    // The group's items, split at the commas outside nested braces.
    let (mut depth, mut items, mut item) = (0, Vec::new(), String::new());
    for c in rest[1..].chars() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => break,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(std::mem::take(&mut item));
                continue;
            }
            _ => {}
        }
        item.push(c);
    }
    items.push(item);
    items
        .iter()
        .flat_map(|i| expand(i.trim()))
        .filter(|p| !p.is_empty())
        .map(|p| format!("{head}{p}"))
        .collect()
}

/// The module `super` names inside `module` (in `a/b.rs` and in `a/b/mod.rs` alike: `a`).
fn parent(module: &str) -> String {
    match module.rfind("::") {
        Some(k) => module[..k].to_string(),
        None => String::new(),
    }
}

/// The first `depth` segments of a module path.
fn prefix(path: &str, depth: usize) -> String {
    path.split("::").take(depth).collect::<Vec<_>>().join("::")
}

/// The module graph at `depth`: an edge a -> b where a file of a refers to a path in b.
fn graph(files: &[(String, String)], depth: usize) -> BTreeMap<String, BTreeSet<String>> {
    let known: BTreeSet<String> = files.iter().map(|(m, _)| prefix(m, depth)).collect();
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (module, src) in files {
        let a = prefix(module, depth);
        for r in references(module, src) {
            let b = prefix(&r, depth);
            if b != a && !b.is_empty() && known.contains(&b) {
                edges.entry(a.clone()).or_default().insert(b);
            }
        }
    }
    edges
}

/// A cycle of the graph, if there is one (depth-first search for a back edge).
fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        v: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(v.to_string(), 1);
        path.push(v.to_string());
        for w in edges.get(v).into_iter().flatten() {
            match state.get(w.as_str()).copied().unwrap_or(0) {
                1 => {
                    let start = path.iter().position(|p| p == w).expect("on the path");
                    let mut cycle = path[start..].to_vec();
                    cycle.push(w.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(w, edges, state, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        state.insert(v.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for v in edges.keys() {
        if state.get(v.as_str()).copied().unwrap_or(0) == 0 {
            let mut path = Vec::new();
            if let Some(c) = visit(v, edges, &mut state, &mut path) {
                return Some(c);
            }
        }
    }
    None
}

fn cycles_of(files: &[(String, String)]) -> Vec<String> {
    (1..=4)
        .filter_map(|d| {
            find_cycle(&graph(files, d)).map(|c| format!("depth {d}: {}", c.join(" -> ")))
        })
        .collect()
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let files = sources();
    assert!(files.len() > 50, "the sources were found: {}", files.len());
    let cycles = cycles_of(&files);
    assert!(cycles.is_empty(), "import circles:\n{}", cycles.join("\n"));
}

/// Negative: a made-up tree in which `scene` uses `placement`, which uses `scene` back, and one
/// in which `vk::a` reaches itself through `super::` paths, are caught; the same trees without
/// the back edge are not.
#[test]
fn an_import_circle_is_found() {
    let file = |m: &str, src: &str| (m.to_string(), src.to_string());
    let circle = vec![
        file("scene", "use crate::placement::resolve;"),
        file("placement", "use crate::{camera::Camera, scene::Scene};"),
        file("camera", ""),
    ];
    let cycles = cycles_of(&circle);
    assert!(
        cycles.len() == 1
            && cycles[0].starts_with("depth 1: ")
            && cycles[0].contains("scene -> placement")
            && cycles[0].contains("placement -> scene"),
        "{cycles:?}"
    );
    let fine = vec![
        file(
            "scene",
            "// crate::placement in a comment is no edge\nlet s = \"crate::placement\";",
        ),
        file("placement", "use crate::{camera::Camera, scene::Scene};"),
        file("camera", ""),
    ];
    assert!(cycles_of(&fine).is_empty());
    let nested = vec![
        file("vk::a", "use super::b::X;"),
        file("vk::b", "use super::c::Y;"),
        file("vk::c", "use crate::vk::a::Z;"),
    ];
    let cycles = cycles_of(&nested);
    assert!(
        cycles.iter().any(|c| c.starts_with("depth 2")),
        "{cycles:?}"
    );
}

/// The layers of the frame's path, top first: a module of one may use the layers below it, never
/// one above (`app` runs `bench`, both render through `render`, which drives `vk`).
const LAYERS: [&str; 4] = ["app", "bench", "render", "vk"];

/// The edges that go up [`LAYERS`], as `from -> to`.
fn upward_edges(files: &[(String, String)]) -> Vec<String> {
    let rank = |m: &str| LAYERS.iter().position(|l| *l == m);
    let mut up = Vec::new();
    for (from, tos) in graph(files, 1) {
        for to in tos {
            if let (Some(a), Some(b)) = (rank(&from), rank(&to))
                && b < a
            {
                up.push(format!("{from} -> {to}"));
            }
        }
    }
    up
}

#[test]
fn no_layer_uses_one_above_it() {
    let up = upward_edges(&sources());
    assert!(up.is_empty(), "layers used from below:\n{}", up.join("\n"));
    // Negative: the frame engine calling the harness, and the harness calling a command, are
    // caught; the other way round is not.
    let file = |m: &str, src: &str| (m.to_string(), src.to_string());
    let bad = vec![
        file("render::checks", "use crate::bench::check_memory;"),
        file(
            "bench::runs",
            "use crate::{app::render::timed, render::FrameRenderer};",
        ),
        file("app", "use crate::bench;"),
    ];
    assert_eq!(
        upward_edges(&bad),
        vec!["bench -> app".to_string(), "render -> bench".to_string()]
    );
}

/// Lines of each `fn` in `src`, from its `fn` line to the line closing its body, as
/// `(lines, name, first line)`. Braces in strings and comments are skipped by [`code_only`]. The
/// body opens at the first `{` outside parentheses and brackets; a `;` outside them before it
/// ends a declaration without a body (a trait method), while one inside them (a parameter typed
/// `[f32; 3]`) does not.
fn function_lengths(src: &str) -> Vec<(usize, String, usize)> {
    let code = code_only(src);
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (n, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        let Some(k) = t.find("fn ") else { continue };
        let head = &t[..k];
        let is_fn = head.split_whitespace().all(|w| {
            matches!(w, "pub" | "const" | "async" | "unsafe" | "extern") || w.starts_with("pub(")
        });
        if !is_fn {
            continue;
        }
        let name: String = t[k + 3..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if let Some(last) = body_end(&lines, n) {
            out.push((last - n + 1, name, n + 1));
        }
    }
    out
}

/// The index of the line that closes the body of the function whose signature starts on line
/// `first`, or `None` for a declaration without a body.
fn body_end(lines: &[&str], first: usize) -> Option<usize> {
    let (mut depth, mut nest, mut started) = (0i32, 0i32, false);
    for (m, l) in lines.iter().enumerate().skip(first) {
        for c in l.chars() {
            match c {
                '(' | '[' if !started => nest += 1,
                ')' | ']' if !started => nest -= 1,
                '{' if started || nest == 0 => {
                    depth += 1;
                    started = true;
                }
                '}' if started => depth -= 1,
                ';' if !started && nest == 0 => return None,
                _ => {}
            }
        }
        if started && depth == 0 {
            return Some(m);
        }
    }
    None
}

/// The functions of `files` longer than 120 lines, as `module:line name: N lines`.
fn too_long(files: &[(String, String)]) -> Vec<String> {
    let mut long = Vec::new();
    for (module, src) in files {
        for (len, name, line) in function_lengths(src) {
            if len > 120 {
                long.push(format!("{module}:{line} {name}: {len} lines"));
            }
        }
    }
    long
}

#[test]
fn no_function_is_longer_than_120_lines() {
    let long = too_long(&sources());
    assert!(long.is_empty(), "split these:\n{}", long.join("\n"));
}

/// Negative: a 121-line function is measured as such, a 3-line one too; so is one whose
/// parameters hold a `;` (`[f32; 3]`, over several lines), and a trait method without a body
/// is no function.
#[test]
fn a_long_function_is_measured() {
    let body = "    let x = 1;\n".repeat(119);
    let src = format!("pub fn long() {{\n{body}}}\nfn short() {{\n    1;\n}}\n");
    let lengths = function_lengths(&src);
    assert_eq!(lengths[0], (121, "long".to_string(), 1), "{lengths:?}");
    assert_eq!(lengths[1], (3, "short".to_string(), 122), "{lengths:?}");

    let src = format!(
        "trait T {{\n    fn declared(a: [f32; 3]) -> f32;\n}}\n\
         pub(crate) fn nearest(origin: [f32; 3], dir: [f32; 3]) -> f32 {{\n{body}}}\n\
         fn wrapped(\n    a: [u32; 2],\n    b: &[[f32; 3]],\n) -> [f32; 3] {{\n{body}}}\n"
    );
    let lengths = function_lengths(&src);
    assert_eq!(
        lengths,
        vec![
            (121, "nearest".to_string(), 4),
            (124, "wrapped".to_string(), 125)
        ],
        "{lengths:?}"
    );
    assert_eq!(
        too_long(&[("m".to_string(), src)]),
        vec![
            "m:4 nearest: 121 lines".to_string(),
            "m:125 wrapped: 124 lines".to_string()
        ]
    );
}

/// Files outside `vk` that name `ash::` or contain `unsafe` code.
fn vulkan_outside_vk(files: &[(String, String)]) -> Vec<String> {
    files
        .iter()
        .filter(|(m, _)| m != "vk" && !m.starts_with("vk::") && !m.is_empty())
        .filter(|(_, src)| {
            let code = code_only(src);
            let word = |w: &str| {
                code.match_indices(w).any(|(k, _)| {
                    let before = code[..k].chars().last();
                    !before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_')
                })
            };
            word("ash::") || word("unsafe {") || word("unsafe fn") || word("unsafe impl")
        })
        .map(|(m, _)| m.clone())
        .collect()
}

#[test]
fn vulkan_stays_in_its_module_tree() {
    let files = sources();
    let outside = vulkan_outside_vk(&files);
    assert!(
        outside.is_empty(),
        "ash or unsafe outside src/vk: {outside:?}"
    );
    // Negative: the same check flags a module outside `vk` that calls ash.
    let mut bad = files.clone();
    bad.push((
        "scene::gpu".into(),
        "fn f() { let _ = ash::vk::Format::UNDEFINED; }".into(),
    ));
    assert_eq!(vulkan_outside_vk(&bad), vec!["scene::gpu".to_string()]);
}

/// The README's length limit: it is for users; essays belong in the module docs, figures in
/// `benches/results/`.
const README_MAX_LINES: usize = 350;

/// What is wrong with a README of this text, if anything: more than [`README_MAX_LINES`] lines.
fn readme_too_long(text: &str) -> Option<String> {
    let lines = text.lines().count();
    (lines > README_MAX_LINES)
        .then(|| format!("README.md has {lines} lines, more than {README_MAX_LINES}"))
}

#[test]
fn the_readme_is_at_most_350_lines() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let text = std::fs::read_to_string(&path).expect("README.md is readable");
    assert!(text.lines().count() > 20, "the README was read: {path:?}");
    if let Some(problem) = readme_too_long(&text) {
        panic!("{problem}");
    }
    // Negative: a text one line over the limit fails the same check, one at the limit passes.
    assert!(readme_too_long(&"line\n".repeat(README_MAX_LINES + 1)).is_some());
    assert_eq!(readme_too_long(&"line\n".repeat(README_MAX_LINES)), None);
}

/// Words only the authors understand, in any case: pointers to a conversation or a moment
/// rather than to the code (`issue 123`, `#123`, "today", "as before", "the redesign",
/// "since 2026", a date `2026-12-02`) and commit hashes (7 to 40 hex digits with both a digit
/// and a letter, not after `0x`). Each as `line: what`.
fn authors_words(text: &str) -> Vec<String> {
    const PHRASES: [&str; 3] = ["today", "as before", "the redesign"];
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let lower = line.to_lowercase();
        let bytes = lower.as_bytes();
        let word_at = |k: usize, len: usize| {
            let before = k.checked_sub(1).map(|b| bytes[b]);
            let after = bytes.get(k + len).copied();
            let inner = |c: Option<u8>| c.is_some_and(|c| c.is_ascii_alphanumeric() || c == b'_');
            !inner(before) && !inner(after)
        };
        let digits_at = |k: usize| bytes[k..].iter().take_while(|c| c.is_ascii_digit()).count();
        let mut found: Vec<String> = Vec::new();
        for phrase in PHRASES {
            for (k, _) in lower.match_indices(phrase) {
                if word_at(k, phrase.len()) {
                    found.push(format!("\"{phrase}\""));
                }
            }
        }
        for (k, _) in lower.match_indices("issue ") {
            if word_at(k, 5) && digits_at(k + 6) > 0 {
                found.push("an issue number".into());
            }
        }
        for (k, _) in lower.match_indices('#') {
            let d = digits_at(k + 1);
            if d >= 2 && word_at(k + 1, d) {
                found.push("an issue number".into());
            }
        }
        for (k, _) in lower.match_indices("since 20") {
            if word_at(k, 5) && digits_at(k + 6) == 4 {
                found.push("\"since <year>\"".into());
            }
        }
        // Dates and hashes: runs of hex digits and dashes between word boundaries.
        let mut k = 0;
        while k < bytes.len() {
            let len = bytes[k..]
                .iter()
                .take_while(|c| c.is_ascii_hexdigit())
                .count();
            if len == 0 {
                k += 1;
                continue;
            }
            let run = &lower[k..k + len];
            // A number: `1e13`, `1e13f32`, the exponent or fraction of `1.2676506e30`.
            let mantissa = run.trim_end_matches("f32").trim_end_matches("f64");
            let number = lower[..k].ends_with('.')
                || mantissa.bytes().filter(|c| !c.is_ascii_digit()).count() <= 1
                    && mantissa.bytes().all(|c| c.is_ascii_digit() || c == b'e');
            let bounded = word_at(k, len) && !lower[..k].ends_with("0x") && !number;
            let date = len == 4
                && run.starts_with("20")
                && run.bytes().all(|c| c.is_ascii_digit())
                && lower[k + 4..].len() >= 6
                && {
                    let rest = &bytes[k + 4..k + 10];
                    rest[0] == b'-'
                        && rest[3] == b'-'
                        && rest[1..3].iter().chain(&rest[4..6]).all(u8::is_ascii_digit)
                };
            if date {
                found.push("a date".into());
            } else if bounded
                && (7..=40).contains(&len)
                && run.bytes().any(|c| c.is_ascii_digit())
                && run.bytes().any(|c| c.is_ascii_alphabetic())
            {
                found.push(format!("a commit hash ({run})"));
            }
            k += len;
        }
        out.extend(found.into_iter().map(|f| format!("{}: {f}", n + 1)));
    }
    out
}

/// The files [`authors_words`] reads: the README and every text file under `src/`, `spirv/`
/// and `tests/`, but the test scenes' data (`tests/scenes/`, with checksums and licences) and
/// the records' hashes (`tests/records/hashes.txt`), and this file, which names the words.
fn documented_files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![root.join("README.md")];
    let mut stack: Vec<PathBuf> = ["src", "spirv", "tests"]
        .iter()
        .map(|d| root.join(d))
        .collect();
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).expect("readable") {
            let p = e.expect("entry").path();
            if p.starts_with(root.join("tests/scenes"))
                || p.ends_with("tests/records/hashes.txt")
                || p.ends_with("tests/layout.rs")
            {
                continue;
            }
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| {
                ["rs", "wgsl", "md", "sh", "txt", "toml"].contains(&x.to_str().unwrap_or(""))
            }) {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

#[test]
fn no_words_only_the_authors_understand() {
    let files = documented_files();
    assert!(files.len() > 100, "the files were read: {}", files.len());
    let mut found = Vec::new();
    for p in &files {
        let text = std::fs::read_to_string(p).unwrap_or_default();
        let rel = p.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap_or(p);
        found.extend(
            authors_words(&text)
                .into_iter()
                .map(|w| format!("{}:{w}", rel.display())),
        );
    }
    assert!(
        found.is_empty(),
        "words only the authors understand (say it in plain terms: what the code does, what \
         was measured, on which scene):\n{}",
        found.join("\n")
    );
    // Negatives: each kind is found; hex constants, long numbers, words of hex letters and a
    // test's own `#[...]` are not.
    let made_up = "see issue 123\n(#12)\nas measured today\nworks as before\nafter the redesign\n\
                   since 2026 it\non 2026-12-02\nat 23b29a4\n";
    let caught = authors_words(made_up);
    assert_eq!(caught.len(), 8, "{caught:?}");
    let quiet = "0x9e3779b9 and 6364136223846793005, a facade, #[cfg(test)], 2^-20, \
                 e-2026 issues, 1.2676506e30, 9.5367431640625e-7, [1e13f32], `2048x2048`\n";
    assert_eq!(authors_words(quiet), Vec::<String>::new());
}

/// The variants of `Method`, read from its enum in `src/method.rs` (the last word of each
/// comma-separated entry, so that attributes before a variant are skipped).
fn method_variants(registry: &str) -> Vec<String> {
    let code = code_only(registry);
    let start = code
        .find("pub enum Method {")
        .expect("the enum is in method.rs");
    let body = &code[start + "pub enum Method {".len()..];
    let body = &body[..body.find('}').expect("the enum closes")];
    body.split(',')
        .filter_map(|entry| entry.split([' ', '\n', ']']).rfind(|w| !w.is_empty()))
        .map(String::from)
        .collect()
}

/// A variant's name in file and module names: `ReflectionPoint` -> `reflection_point`.
fn snake(variant: &str) -> String {
    let mut out = String::new();
    for (k, c) in variant.chars().enumerate() {
        if c.is_ascii_uppercase() && k > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_lowercase());
    }
    out
}

/// The code of `src` (as [`code_only`]) with its `#[cfg(test)]` modules blanked, line numbers
/// kept.
fn shipping_code(src: &str) -> String {
    let code = code_only(src);
    let lines: Vec<&str> = code.lines().collect();
    let mut out = String::with_capacity(code.len());
    let mut n = 0;
    while n < lines.len() {
        let test_mod = lines[n].trim() == "#[cfg(test)]"
            && lines
                .get(n + 1)
                .is_some_and(|l| l.trim_start().starts_with("mod "));
        if test_mod && let Some(end) = body_end(&lines, n + 1) {
            out.push_str(&"\n".repeat(end + 1 - n));
            n = end + 1;
            continue;
        }
        out.push_str(lines[n]);
        out.push('\n');
        n += 1;
    }
    out
}

/// Every place in `files` that names a variant of `Method` outside the registry (the module
/// `method`, `src/method.rs`) and that method's own files (a module path with a part equal to
/// the method's name: `method::compute`, `vk::methods::reflection_point`, `model::methods::bvh`),
/// as `module:line Method::Variant`. A group or glob import of the variants (`Method::{`,
/// `Method::*`) is never in a method's own file. Comments, strings and `#[cfg(test)]` modules
/// are not read.
fn variants_outside(files: &[(String, String)], variants: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    for (module, src) in files {
        if module == "method" {
            continue;
        }
        let parts: Vec<&str> = module.split("::").collect();
        for (n, line) in shipping_code(src).lines().enumerate() {
            for (k, _) in line.match_indices("Method::") {
                let before = line[..k].chars().last();
                if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
                    continue;
                }
                let rest = &line[k + "Method::".len()..];
                let word: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                let own = if rest.starts_with('{') || rest.starts_with('*') {
                    false
                } else if variants.contains(&word) {
                    parts.contains(&snake(&word).as_str())
                } else {
                    continue;
                };
                if !own {
                    let what = if word.is_empty() { &rest[..1] } else { &word };
                    out.push(format!("{module}:{} Method::{what}", n + 1));
                }
            }
        }
    }
    out
}

#[test]
fn only_the_registry_and_a_methods_own_files_name_its_variant() {
    let files = sources();
    let registry = &files
        .iter()
        .find(|(m, _)| m == "method")
        .expect("method.rs")
        .1;
    let variants = method_variants(registry);
    assert!(variants.len() >= 7, "the variants were read: {variants:?}");
    let outside = variants_outside(&files, &variants);
    assert!(
        outside.is_empty(),
        "{} places name a method variant outside src/method.rs and the method's own files \
         (ask the method instead: a property in its file under src/method/, or a registry \
         constant such as Method::DEFAULT):\n{}",
        outside.len(),
        outside.join("\n")
    );
    // Negatives: a variant named in a wrong file is caught, in its own file or the registry
    // it is not; a glob import is caught anywhere but the registry; test modules, comments and
    // strings are not read; `GpuMethod::Compute` is another type.
    let made_up = |module: &str, src: &str| {
        variants_outside(&[(module.to_string(), src.to_string())], &variants)
    };
    let wrong = "fn f(m: Method) -> bool {\n    m == crate::Method::Ssr\n}\n";
    assert_eq!(
        made_up("bench::report", wrong),
        ["bench::report:2 Method::Ssr"]
    );
    assert!(made_up("vk::methods::ssr", wrong).is_empty());
    assert!(made_up("method::ssr", wrong).is_empty());
    assert!(made_up("method", wrong).is_empty());
    assert_eq!(
        made_up("model::methods::bvh", wrong),
        ["model::methods::bvh:2 Method::Ssr"]
    );
    assert_eq!(
        made_up("app::render", "use crate::method::Method::{Bvh, Ssr};\n"),
        ["app::render:1 Method::{"]
    );
    assert_eq!(
        made_up(
            "model::methods::reflection_point",
            "use Method::*;\nconst M: Method = Method::ReflectionPoint;\n"
        ),
        ["model::methods::reflection_point:1 Method::*"]
    );
    let quiet = "// Method::Ssr\nfn f() -> &'static str {\n    \"Method::Ssr\"\n}\n\
                 fn g() -> bool {\n    GpuMethod::Compute.x()\n}\n\
                 #[cfg(test)]\nmod tests {\n    const M: Method = Method::Bvh;\n}\n";
    assert!(made_up("app::summary", quiet).is_empty());
    assert_eq!(snake("ReflectionPoint"), "reflection_point");
    assert!(
        variants.contains(&"ReflectionPoint".to_string()),
        "{variants:?}"
    );
}
