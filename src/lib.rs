//! cubetrace: accurate mirror reflections on curved surfaces by cubemap tracing.
//!
//! The README says what the program does and how to run it; this page is for readers of the
//! code: where things live, the conventions every module keeps, and how results are checked.
//!
//! # Modules
//!
//! Everything outside [`vk`] forbids `unsafe`.
//! - [`app`]: the commands of the `cubetrace` binary (render, bench, scene export) as functions:
//!   their arguments and the lines they print; `src/main.rs` only parses the command line (clap)
//!   and calls them.
//! - [`bench`](mod@bench): the speed-against-error harness (`cubetrace bench`) and scaling curves:
//!   its grids, runs and reports.
//! - [`render`]: the frame engine between those two and [`vk`]: [`render::FrameRenderer`] (the
//!   frames of one run and its reuse rules), opened from a plain [`render::RenderSetup`]; the
//!   run's scene prepared from a plain [`render::scene::SceneSetup`]; the sample loop; the
//!   bench's timed frames; the checks around a render (memory, textures, validation); glossy
//!   frames. `app` and `bench` render through it; it knows neither (`tests/layout.rs` checks the
//!   layers).
//! - [`method`]: [`Method`], the one method type of the CLI, the harness and the renderer, and
//!   what each method supports (one file per method under `src/method/`).
//! - [`scene`]: the scene as data: scene files (TOML + OBJ/MTL/PNG), built-in scenes, mesh
//!   hygiene. It imports no algorithm (only the leaves [`camera`], [`shading`], [`files`] and
//!   [`lobe`]).
//! - [`placement`]: CMO placement search and set-up checks, algorithms over the scene.
//! - [`camera`]: the camera and its pixel convention (Vulkan's, pixel centres at +0.5).
//! - [`shading`]: the view-independent shading shared by the capture and the reference.
//! - [`reference`](mod@reference): the exact CPU ray tracer that every accuracy figure is measured against.
//! - [`metrics`]: error of a traced reflection against the reference.
//! - [`ranges`]: depth ranges and ray length of a GPU frame, and the f32 precision check.
//! - [`memory`]: the memory a render needs against what the machine and the device have.
//! - [`output`]: PNG and EXR writers, and the meaning of every EXR channel.
//! - [`film`]: samples per pixel and the pixel filter.
//! - [`lobe`]: glossy reflectors: the Phong lobe, its mirror cap and its sample directions.
//! - [`files`]: atomic file writes (temporary file, then rename) and safe file names.
//! - [`cubemap`]: cube face mapping and distance hierarchies (pure data, no GPU).
//! - [`cpu`]: CPU twins of the GPU passes, with the shaders' names and loop structure.
//! - [`model`]: the SIMT cost model: lockstep warp replay of the CPU twins' work counters (a
//!   model, not a measurement); each replayed method's blocks and recording in
//!   `src/model/methods/`.
//! - [`vk`]: the Vulkan backend (ash); the only module tree that may use `unsafe`:
//!   - `vk/backend/`: instance, device, buffers, images, shaders, pipelines, timestamps;
//!   - `vk/passes/`: stages shared by methods: capture, pyramids, cone pre-filter and pass,
//!     G-buffer, BVH, bounces, composite;
//!   - `vk/methods/`: one file per GPU method, each a `MethodSpec` and a `Technique`;
//!   - `vk/frame/`: `GpuRenderer`, the shared stages and one technique, and the frame plan;
//!   - `vk/budget.rs`: the one memory estimate of a frame, built from the methods'.
//!
//! Outside `src/`: `spirv/` holds the WGSL shaders, one per pass, compiled by naga in `build.rs`
//! (`spirv/README.md` has their conventions and what lavapipe does with them); `tests/` the
//! test suites and the scenes they load (`tests/scenes/`, with provenance and licences);
//! `benches/` the cargo bench and, in `benches/results/`, the bench's reports and how to read
//! them.
//!
//! # One name per method
//!
//! Method M's knowledge is in files named after it: what it is and supports in
//! `src/method/M.rs` (a [`method::MethodInfo`]: name, the options it reads, capabilities,
//! glossy lobe, known limits), its host code in `src/vk/methods/M.rs`, its cost model in
//! `src/model/methods/M.rs`, its CPU twin `src/cpu/M.rs`, its shaders `spirv/M*.wgsl` and its
//! test `tests/M.rs` (`envmap` shares `fragment`'s deferred pass, twin and test). A GPU method
//! is two small traits in `src/vk/methods/technique.rs`: its `MethodSpec` says, before anything
//! is allocated, which method it is, what it needs of the shared stages (capture contents,
//! pyramid, glossy handling), its device memory and how to create it; its `Technique` records
//! its passes into the frame's command buffer and reports its statistics for the bench.
//!
//! A new method takes a [`Method`] variant with its place in `Method::ALL` (and `GPU`), its line in
//! [`Method::info`] and its file under `src/method/`; on the GPU, its file under `src/vk/methods/`
//! and a line in `vk::methods::SPECS`; in the cost model (optional), its file under
//! `src/model/methods/` and a line in `model::methods::MODELS`. Generic code asks the method
//! ([`Method::glossy`], [`Method::known_limit`], ...) or names a role ([`Method::DEFAULT`],
//! [`Method::TRUTH`], [`Method::EXACT_GPU`], [`Method::SCALING`]). `tests/layout.rs` proves the
//! rule it can read: no variant is named in code outside `src/method.rs` and the files of a module
//! path with that method's name, test modules aside. The bench's reports are keyed by method
//! (rows built from [`Method::ALL`] and the role constants), so none of them names a variant.
//!
//! Each module's documentation (`//!`) holds its algorithm, invariants, known limits and
//! measurements. `tests/layout.rs` checks the shape: no import circle, no module using a layer
//! above its own (`app`, `bench`, `render`, `vk`), no function over 120 lines, no `ash` or
//! `unsafe` outside `src/vk/`, the method variant rule above, a README of at most 350 lines,
//! and no issue numbers, commit hashes or dates in the README, `src/`, `spirv/` or `tests/`.
//!
//! # Conventions
//!
//! - **Camera and pixels**: Vulkan's. Pixel `(i, j)` has its centre at `(i + 0.5, j + 0.5)`,
//!   row 0 at the top; NDC y points down.
//! - **Depth** ([`ranges`]): reversed depth (`near / z`) in D32_SFLOAT with no far plane; near
//!   planes derived from the geometry. A scene far from the world origin (its box's centre more
//!   than 8 diagonals out) is uploaded relative to that centre (exact shifts), so a site
//!   kilometres out renders as finely as one at the origin; one f32 still cannot hold (too
//!   large for its detail) is refused with its numbers. A triangle whose plane passes through
//!   the eye or a CMO centre, to f32 rounding of a well-conditioned normal (slivers included),
//!   is seen edge-on and drawn nowhere, as the reference (which counts hits at `t > 0`) sees
//!   it; an eye within that rounding of a surface itself is refused naming the triangle and the
//!   distance to move it; a CMO centre on a surface refuses only the methods that capture CMOs.
//!   A camera `up` within 1e-4 (sine) of its view direction is refused: f32 cannot fix its roll.
//! - **Shading** is view-independent ([`shading`]): unlit albedo, or albedo x (ambient +
//!   Lambert from one directional light). Capture, GPU methods and reference shade with the same
//!   function, so any difference between a method and the reference is tracing error.
//! - **Reference** ([`reference`](mod@reference)): one ray per pixel centre; mirrors reflect
//!   about the interpolated vertex normal; a reflected ray ignores the triangle it leaves and the
//!   neighbours within a proven rounding bound of its origin, never a distance bias.
//! - **Bit-for-bit twins**: every GPU pass has a CPU twin in [`cpu`] (the same loops and the
//!   same operations in the same order), and the tests compare them bit for bit where the
//!   arithmetic allows.
//! - **Files** are written atomically ([`files`]): a killed render leaves no half file.
//!
//! # How results are checked
//!
//! - **The reference** against closed forms: a planar mirror equals the mirrored camera's view,
//!   a mirror sphere's hits the analytic reflection within a derived tessellation bound; round
//!   trip of every built-in scene through export and load; determinism on one thread or many.
//! - **Every GPU pass against its CPU twin** (`src/cpu/`, the same loops in Rust), bit for bit
//!   where the arithmetic allows: capture, pyramids, the tracers on every mirror pixel of every
//!   built-in scene, ssr, the reflection-point search per vertex; `compute` against `fragment`
//!   per pixel.
//! - **Every method against the reference**, per built-in scene, with stated bounds on
//!   unresolved and wrong-surface shares and PSNR, plus hard cases (grazing rays, shared edges,
//!   slabs thinner than a texel, scales 1e-3 to 1e5, cube sizes 1 to 2048) with zero wrong hits
//!   allowed.
//! - **Thin geometry** (the bounded criterion, the default): a fence, a wire grid, chain link, foliage cards,
//!   a relief, edge-on fins and the Stanford bunny (`tests/scenes/PROVENANCE.md`) at cube sizes
//!   16 to 256 with 1 to 3 CMOs: no hit behind the reference's first; the centre criterion must
//!   fail there.
//! - **Every comparison has a negative**: a moved CMO centre, a shifted triangle ID, a turned
//!   normal must make it fail. The GPU tests run under the validation layer when installed.
//! - **Real scenes** (`tests/hard_cases/corpus.rs`): ten scenes built from public meshes as their exporters
//!   wrote them (`tests/scenes/`, provenance and licences in its `PROVENANCE.md`: an interior in
//!   centimetres, a 117k-triangle truck, CAD plates in millimetres, a robot link, an open mug,
//!   slivers and collinear n-gons, Blender's negative `Ns` and JPEG textures, a room 3.9 km out,
//!   facing mirrors). Every method renders every one (none refused); `bvh` and the bounded
//!   criterion put no mirror pixel behind the reference's first hit. CI runs them at 40x30;
//!   `cubetrace bench --corpus tests/scenes` runs them at full size.
//! - **Bad input**: one test per class, a fixed-seed fuzzing pass over scene, OBJ and MTL files.
//! - **Records**: `tests/records.rs` renders every built-in scene with every method and the main
//!   variants (criteria, `--spp`, `--filter`, fallbacks, bounces) at 32x24 through the `render`
//!   command and compares each EXR's hash with `tests/records/hashes.txt` on every run; a commit
//!   that moves a pixel regenerates the file (`CUBETRACE_RECORDS_UPDATE=1`) and says why.
//!   `tests/records/render.sh` and the ignored comparison repeat it at 160x120 between builds.
#![deny(unsafe_op_in_unsafe_fn)]

pub mod app;
pub mod bench;
pub mod camera;
pub mod cpu;
pub mod cubemap;
pub mod files;
pub mod film;
pub mod lobe;
pub mod memory;
pub mod method;
pub mod metrics;
pub mod model;
pub mod output;
pub mod placement;
pub mod ranges;
pub mod reference;
pub mod render;
pub mod scene;
pub mod shading;
pub mod vk;

pub use method::Method;
