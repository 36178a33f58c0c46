//! Compiles every `spirv/*.wgsl` (one file per pass) to SPIR-V 1.3 with naga and writes
//! `$OUT_DIR/shaders.rs`, a typed table `include!`d by `src/vk/backend/shaders.rs`.
//!
//! # Import directive
//! WGSL has no include. A line of the exact form
//!
//! ```text
//! //! import shared/cubemap.wgsl
//! ```
//!
//! (path relative to `spirv/`) makes the build splice that file in. It is a WGSL comment, so the
//! importing file is left byte-for-byte unchanged and imported files are **appended after it**
//! (WGSL module-scope declarations may be used before they appear). Hence a diagnostic in the
//! pass file keeps its real line numbers. Imports are transitive and each file is spliced once.
//! Every `spirv/shared/*.wgsl` is also validated on its own first, so an error in shared code is
//! reported against that shared file with its own line numbers. If a span still lands in an
//! imported part (e.g. a name defined twice), a note names the imported file and line.
//!
//! # Failure policy
//! A parse or validation error fails the build with naga's rendered diagnostic (file, line,
//! caret). Shaders are never skipped with a warning.
//!
//! # Writer options (set on purpose, not left to naga's defaults)
//! - `lang_version: (1, 3)`: subgroup ops are GroupNonUniform instructions, which need SPIR-V 1.3;
//!   with naga's default 1.0 the module is invalid (spirv-val rejects it).
//! - No `ADJUST_COORDINATE_SPACE`: naga would negate `position.y` to mimic WebGPU. We want Vulkan's
//!   native convention (framebuffer y down, NDC y down), the same as the CPU camera.
//! - No `DEBUG`: naga turns it on with `debug_assertions`, which would make debug and release
//!   SPIR-V differ. Object names come from the debug-utils labels instead. A second copy of each
//!   pass *with* `DEBUG` (OpName only, no line info) is written as `<pass>.debug.spv` and listed
//!   in `debug_spirv.rs` for the cost model's block weights (`src/model/weights.rs`, which checks
//!   that it is the shipped code plus names); it is never given to Vulkan.
//! - `LABEL_VARYINGS` kept off (some drivers treat names as semantic) and `CLAMP_FRAG_DEPTH` off
//!   (we never write frag depth; if a pass does, it must clamp on purpose).
//! - Bounds checks: `ReadZeroSkipWrite` for local/array indices and image loads (an out-of-range
//!   index must never read garbage or write out of bounds, even on drivers without robust
//!   access); `Unchecked` for storage/uniform buffers, whose runtime-sized arrays are indexed by
//!   trusted dispatch sizes and which robustBufferAccess covers where enabled.
//! - `force_loop_bounding: false`: tracing loops have explicit iteration caps in WGSL; naga's
//!   hidden counters would only cost registers and change timing.
//! - `zero_initialize_workgroup_memory: Polyfill`: WGSL semantics (workgroup memory starts at zero)
//!   without depending on `shaderZeroInitializeWorkgroupMemory`.
//! - `emit_int_div_checks: true`: WGSL-defined integer division by zero, as the CPU twins assume.
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use naga::back::spv;
use naga::valid::{Capabilities, ValidationFlags, Validator};

/// Import directive prefix; see the module docs.
const IMPORT_PREFIX: &str = "//! import ";

/// One contiguous piece of a spliced source.
struct Segment {
    /// Path relative to `spirv/`, for messages.
    file: String,
    /// Byte offset in the spliced source where this file starts.
    start: usize,
    /// Byte length of this file's text.
    len: usize,
}

/// A source with its imports appended, and where each piece came from.
struct Spliced {
    text: String,
    segments: Vec<Segment>,
}

/// The tests' probe shaders (`spirv/NAME.wgsl`): compiled into the shader table only with the
/// `test-hooks` feature.
const TEST_HOOK_SHADERS: [&str; 4] = ["cone_probe", "hit_probe", "selftest", "trace_probe"];

/// Sets `CUBETRACE_GIT_COMMIT` to the checkout's `git rev-parse HEAD`, the commit the bench
/// records for its figures, and asks for a rerun when HEAD or its branch moves. Nothing where
/// the folder is no git checkout (a packaged crate) or git is missing.
fn git_commit(root: &Path) {
    let git = root.join(".git");
    if !git.is_dir() {
        return;
    }
    let head = git.join("HEAD");
    println!("cargo:rerun-if-changed={}", head.display());
    if let Ok(text) = std::fs::read_to_string(&head)
        && let Some(branch) = text.strip_prefix("ref: ")
    {
        for moved in [git.join(branch.trim()), git.join("packed-refs")] {
            if moved.exists() {
                println!("cargo:rerun-if-changed={}", moved.display());
            }
        }
    }
    let out = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(root)
        .output();
    if let Ok(out) = out
        && out.status.success()
    {
        let commit = String::from_utf8_lossy(&out.stdout).trim().to_string();
        if !commit.is_empty() {
            println!("cargo:rustc-env=CUBETRACE_GIT_COMMIT={commit}");
        }
    }
}

fn main() {
    let root =
        PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let spirv_dir = root.join("spirv");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed=spirv");
    println!("cargo:rerun-if-changed=spirv/shared");
    git_commit(&root);

    let mut errors = Vec::new();

    // Shared files first, each on its own, so their diagnostics carry their own line numbers.
    for path in wgsl_files(&spirv_dir.join("shared")) {
        let rel = relative(&spirv_dir, &path);
        if let Err(e) = compile(&spirv_dir, &rel, false) {
            errors.push(e);
        }
    }

    let mut table = String::new();
    table.push_str("// @generated by build.rs from spirv/*.wgsl. Do not edit.\n\n");
    let mut names = Vec::new();
    let mut debug_table = String::from(
        "// @generated by build.rs: each pass's debug-named SPIR-V (src/model/weights.rs).\n\
         pub const DEBUG_SPIRV: &[(&str, &[u8])] = &[\n",
    );
    // The tests' probe shaders go into the library only with the `test-hooks` feature (which the
    // integration tests turn on); they are still validated without it.
    let hooks = std::env::var_os("CARGO_FEATURE_TEST_HOOKS").is_some();
    for path in wgsl_files(&spirv_dir) {
        let rel = relative(&spirv_dir, &path);
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if !hooks && TEST_HOOK_SHADERS.contains(&stem) {
            if let Err(e) = compile(&spirv_dir, &rel, false) {
                errors.push(e);
            }
            continue;
        }
        match compile(&spirv_dir, &rel, true) {
            Ok(Some(pass)) => {
                std::fs::write(
                    out_dir.join(format!("{}.spv", pass.name)),
                    words_to_bytes(&pass.words),
                )
                .expect("write .spv into OUT_DIR");
                write_pass(&mut table, &pass);
                write_debug_copy(&out_dir, &pass, &mut debug_table)
                    .unwrap_or_else(|e| errors.push(e));
                names.push(pass.name.clone());
            }
            Ok(None) => {}
            Err(e) => errors.push(e),
        }
    }
    if !errors.is_empty() {
        for e in &errors {
            eprintln!("{e}");
        }
        panic!(
            "{} WGSL shader(s) failed to compile; see the diagnostics above",
            errors.len()
        );
    }
    table.push_str("/// Every pass, in file-name order.\npub const PASSES: &[&Pass] = &[");
    for n in &names {
        let _ = write!(table, "&{}, ", n.to_uppercase());
    }
    table.push_str("];\n");
    std::fs::write(out_dir.join("shaders.rs"), table).expect("write shaders.rs into OUT_DIR");
    debug_table.push_str("];\n");
    std::fs::write(out_dir.join("debug_spirv.rs"), debug_table)
        .expect("write debug_spirv.rs into OUT_DIR");
}

/// Writes `<pass>.debug.spv`: the same module with `WriterFlags::DEBUG` (OpName on functions,
/// variables and types, no source or line info), read only by the cost model's block weights
/// (`src/model/weights.rs`) to find WGSL functions by name. The shipped SPIR-V (`<pass>.spv`, the
/// table above) is unchanged; the model checks that the copy differs from it only by names.
fn write_debug_copy(out_dir: &Path, pass: &CompiledPass, table: &mut String) -> Result<(), String> {
    let mut options = writer_options();
    options.flags = spv::WriterFlags::DEBUG;
    let words = spv::write_vec(&pass.module, &pass.info, &options, None).map_err(|e| {
        format!(
            "error: naga's SPIR-V writer failed on spirv/{} (debug copy): {e}",
            pass.file
        )
    })?;
    let file = format!("{}.debug.spv", pass.name);
    std::fs::write(out_dir.join(&file), words_to_bytes(&words))
        .map_err(|e| format!("error: cannot write {file} into OUT_DIR: {e}"))?;
    let _ = writeln!(
        table,
        "    ({:?}, include_bytes!(concat!(env!(\"OUT_DIR\"), \"/{file}\"))),",
        pass.name
    );
    Ok(())
}

/// `*.wgsl` files directly in `dir`, sorted for a stable table.
fn wgsl_files(dir: &Path) -> Vec<PathBuf> {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "wgsl"))
        .collect();
    v.sort();
    v
}

fn relative(base: &Path, p: &Path) -> String {
    p.strip_prefix(base)
        .unwrap_or(p)
        .to_string_lossy()
        .replace('\\', "/")
}

/// Splices `rel` and (transitively, once each) its imports.
fn splice(spirv_dir: &Path, rel: &str) -> Result<Spliced, String> {
    let mut out = Spliced {
        text: String::new(),
        segments: Vec::new(),
    };
    let mut queue = vec![rel.to_string()];
    let mut seen = std::collections::BTreeSet::new();
    while let Some(file) = queue.pop() {
        if !seen.insert(file.clone()) {
            continue;
        }
        let path = spirv_dir.join(&file);
        println!("cargo:rerun-if-changed={}", path.display());
        let text = std::fs::read_to_string(&path).map_err(|e| {
            format!("error: cannot read spirv/{file} (imported by spirv/{rel}): {e}")
        })?;
        let mut imports = Vec::new();
        for (i, line) in text.lines().enumerate() {
            if let Some(target) = line.trim_end().strip_prefix(IMPORT_PREFIX) {
                let target = target.trim();
                if !target.ends_with(".wgsl") || target.contains("..") {
                    return Err(format!(
                        "error: spirv/{file}:{}: bad import `{target}`",
                        i + 1
                    ));
                }
                imports.push(target.to_string());
            }
        }
        if !out.text.is_empty() && !out.text.ends_with('\n') {
            out.text.push('\n');
        }
        out.segments.push(Segment {
            file: file.clone(),
            start: out.text.len(),
            len: text.len(),
        });
        out.text.push_str(&text);
        // Reverse so imports are spliced in the order written.
        queue.extend(imports.into_iter().rev());
    }
    Ok(out)
}

/// Renders a diagnostic against the root file, with a note when the span lies in an import.
fn render(spliced: &Spliced, rel: &str, rendered: String, offset: Option<u32>) -> String {
    let mut msg = format!("error: naga rejected spirv/{rel}\n{rendered}");
    if let Some(off) = offset {
        let off = off as usize;
        if let Some(seg) = spliced
            .segments
            .iter()
            .skip(1)
            .find(|s| off >= s.start && off < s.start + s.len)
        {
            let line = spliced.text[seg.start..off].matches('\n').count() + 1;
            let _ = write!(
                msg,
                "note: the span above lies in imported spirv/{} at line {line} \
                 (the rendered line number counts the spliced source)",
                seg.file
            );
        }
    }
    msg
}

struct CompiledPass {
    name: String,
    file: String,
    words: Vec<u32>,
    module: naga::Module,
    info: naga::valid::ModuleInfo,
}

/// Parses, validates and (for passes) writes SPIR-V. Returns `None` for a shared file.
fn compile(spirv_dir: &Path, rel: &str, is_pass: bool) -> Result<Option<CompiledPass>, String> {
    let mut spliced = splice(spirv_dir, rel)?;
    // shared/scene.wgsl binds the scene at @group(SCENE_GROUP), a constant each root file
    // defines; a shared file validated on its own gets one appended (after every segment, so
    // the line numbers of the diagnostics stay the file's own).
    if !is_pass
        && spliced.text.contains("SCENE_GROUP")
        && !spliced.text.contains("const SCENE_GROUP")
    {
        spliced.text.push_str("\nconst SCENE_GROUP: u32 = 0u;\n");
    }
    let label = format!("spirv/{rel}");
    let module = naga::front::wgsl::parse_str(&spliced.text).map_err(|e| {
        let off = e.location(&spliced.text).map(|l| l.offset);
        render(
            &spliced,
            rel,
            e.emit_to_string_with_path(&spliced.text, &label),
            off,
        )
    })?;
    let caps = Capabilities::SUBGROUP | Capabilities::SUBGROUP_BARRIER;
    let info = Validator::new(ValidationFlags::all(), caps)
        .validate(&module)
        .map_err(|e| {
            let off = e.location(&spliced.text).map(|l| l.offset);
            render(
                &spliced,
                rel,
                e.emit_to_string_with_path(&spliced.text, &label),
                off,
            )
        })?;
    if !is_pass {
        return Ok(None);
    }
    let options = writer_options();
    let words = spv::write_vec(&module, &info, &options, None)
        .map_err(|e| format!("error: naga's SPIR-V writer failed on spirv/{rel}: {e}"))?;
    let name = rel.trim_end_matches(".wgsl").to_string();
    if !name
        .chars()
        .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
    {
        return Err(format!(
            "error: pass file spirv/{rel}: name must be lower_snake_case"
        ));
    }
    Ok(Some(CompiledPass {
        name,
        file: rel.to_string(),
        words,
        module,
        info,
    }))
}

/// The writer options; each choice is explained in the module docs.
fn writer_options() -> spv::Options<'static> {
    use naga::proc::{BoundsCheckPolicies, BoundsCheckPolicy};
    spv::Options {
        lang_version: (1, 3),
        flags: spv::WriterFlags::empty(),
        // Despite its name, `true` means: use each resource's WGSL `@group/@binding` as its
        // descriptor set/binding. (`false` demands an explicit `binding_map`.)
        fake_missing_bindings: true,
        bounds_check_policies: BoundsCheckPolicies {
            index: BoundsCheckPolicy::ReadZeroSkipWrite,
            buffer: BoundsCheckPolicy::Unchecked,
            image_load: BoundsCheckPolicy::ReadZeroSkipWrite,
            binding_array: BoundsCheckPolicy::ReadZeroSkipWrite,
        },
        zero_initialize_workgroup_memory:
            naga::back::spv::ZeroInitializeWorkgroupMemoryMode::Polyfill,
        force_loop_bounding: false,
        emit_int_div_checks: true,
        ..spv::Options::default()
    }
}

fn words_to_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

fn stage_name(s: naga::ShaderStage) -> &'static str {
    match s {
        naga::ShaderStage::Vertex => "Vertex",
        naga::ShaderStage::Fragment => "Fragment",
        naga::ShaderStage::Compute => "Compute",
        other => panic!("unsupported shader stage {other:?}"),
    }
}

/// Reflected descriptor kind, as Rust source for `BindingKind`.
fn binding_kind(module: &naga::Module, var: &naga::GlobalVariable) -> Result<String, String> {
    use naga::{AddressSpace, ImageClass, ImageDimension, StorageAccess, TypeInner};
    let inner = &module.types[var.ty].inner;
    Ok(match (var.space, inner) {
        (AddressSpace::Uniform, _) => "BindingKind::UniformBuffer".into(),
        (AddressSpace::Storage { access }, _) => {
            format!(
                "BindingKind::StorageBuffer {{ read_only: {} }}",
                !access.contains(StorageAccess::STORE)
            )
        }
        (AddressSpace::Handle, TypeInner::Sampler { comparison }) => {
            format!("BindingKind::Sampler {{ comparison: {comparison} }}")
        }
        (
            AddressSpace::Handle,
            TypeInner::Image {
                dim,
                arrayed,
                class,
            },
        ) => {
            let dim = match (dim, arrayed) {
                (ImageDimension::D2, false) => "TextureDim::D2",
                (ImageDimension::D2, true) => "TextureDim::D2Array",
                (ImageDimension::Cube, false) => "TextureDim::Cube",
                (ImageDimension::D3, false) => "TextureDim::D3",
                other => return Err(format!("unsupported image dimension {other:?}")),
            };
            match class {
                ImageClass::Sampled { kind, multi: false } => {
                    format!(
                        "BindingKind::SampledTexture {{ dim: {dim}, sample: SampleKind::{kind:?} }}"
                    )
                }
                ImageClass::Depth { multi: false } => {
                    format!(
                        "BindingKind::SampledTexture {{ dim: {dim}, sample: SampleKind::Depth }}"
                    )
                }
                ImageClass::Storage { format, access } => {
                    let read = access.contains(StorageAccess::LOAD);
                    let write = access.contains(StorageAccess::STORE);
                    format!(
                        "BindingKind::StorageTexture {{ dim: {dim}, format: TexelFormat::{format:?}, \
                         read: {read}, write: {write} }}"
                    )
                }
                other => return Err(format!("unsupported image class {other:?}")),
            }
        }
        (space, _) => return Err(format!("unsupported resource address space {space:?}")),
    })
}

fn write_pass(out: &mut String, p: &CompiledPass) {
    let up = p.name.to_uppercase();
    let m = &p.module;
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(m.to_ctx())
        .expect("naga layouter on a validated module");

    let _ = writeln!(out, "/// Pass `{}` from `spirv/{}`.", p.name, p.file);
    let _ = writeln!(out, "pub const {up}: Pass = Pass {{");
    let _ = writeln!(out, "    name: {:?},", p.name);
    let _ = writeln!(out, "    source_file: {:?},", format!("spirv/{}", p.file));
    out.push_str("    spirv: &[");
    for (i, w) in p.words.iter().enumerate() {
        if i % 8 == 0 {
            out.push_str("\n        ");
        }
        let _ = write!(out, "{w:#010x}, ");
    }
    out.push_str("\n    ],\n    entry_points: &[\n");
    for (i, ep) in m.entry_points.iter().enumerate() {
        let ep_info = p.info.get_entry_point(i);
        let [x, y, z] = ep.workgroup_size;
        let _ = writeln!(
            out,
            "        EntryPoint {{ name: {:?}, stage: Stage::{}, workgroup_size: [{x}, {y}, {z}], bindings: &[",
            ep.name,
            stage_name(ep.stage)
        );
        for (h, var) in m.global_variables.iter() {
            let Some(rb) = &var.binding else { continue };
            if ep_info[h].is_empty() {
                continue;
            }
            let kind = binding_kind(m, var).unwrap_or_else(|e| panic!("spirv/{}: {e}", p.file));
            let size = layouter[var.ty].size;
            let name = var.name.clone().unwrap_or_default();
            let _ = writeln!(
                out,
                "            Binding {{ name: {name:?}, group: {}, binding: {}, kind: {kind}, min_size: {size} }},",
                rb.group, rb.binding
            );
        }
        out.push_str("        ] },\n");
    }
    out.push_str("    ],\n    structs: &[\n");
    let mut structs = BTreeMap::new();
    for (h, ty) in m.types.iter() {
        if let (Some(name), naga::TypeInner::Struct { members, span }) = (&ty.name, &ty.inner) {
            let mut s = format!(
                "        StructLayout {{ name: {name:?}, size: {span}, align: {}, members: &[",
                layouter[h].alignment
            );
            for mem in members {
                let _ = write!(
                    s,
                    "({:?}, {}), ",
                    mem.name.clone().unwrap_or_default(),
                    mem.offset
                );
            }
            s.push_str("] },\n");
            structs.insert(name.clone(), s);
        }
    }
    for s in structs.values() {
        out.push_str(s);
    }
    out.push_str("    ],\n};\n\n");
}
