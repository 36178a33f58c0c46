//! A short, fixed-seed fuzz pass over the scene loader: scene TOML, OBJ and
//! MTL inputs built from a corpus of the odd inputs the loader handles (two-vertex faces, `l`
//! elements, concave and self-intersecting polygons, byte order marks, Latin-1 bytes, tabs,
//! one-value `Kd`, undefined materials, extra array items, ...) and mutated (bytes and tokens
//! inserted, lines dropped, doubled and spliced between files).
//!
//! Each case must load or fail with an error, never panic (nor fail inside `tobj`, which parses
//! only text the loader has checked); must finish (a watchdog fails a case
//! that runs for a minute, far beyond the milliseconds one takes); and must not amplify its
//! input (what a scene holds is bounded by the input's size; the loader refuses files over
//! `MAX_INPUT_BYTES`). A loaded scene also goes through `diagnose`.

use std::path::Path;
use std::sync::{Arc, Mutex, mpsc};
use std::time::Duration;

use cubetrace::scene::{self, LoadReport, Scene, SceneError};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};

const SEED: [u8; 16] = *b"cubetrace-fuzz-1";
const CASES: u32 = 500;

const OBJ_CORPUS: &[&[u8]] = &[
    b"mtllib lib.mtl\nv 0 0 -1\nv 1 0 -1\nv 1 1 -1\nv 0 1 -1\nusemtl grey\nf 1 2 3 4\n",
    b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 2\nf 2 3\nf 1\nf\nl 1 2 3\np 1\n",
    b"v 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\nv 2 0 0\nf 1 2 3 4 5 6\nf 1 4 2 5 3 6\n",
    b"\xEF\xBB\xBFmtllib lib.mtl\n# caf\xE9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\n\
      vn 0 0 1\nusemtl tex\nf 1/1/1 2/2/1 3/1/1\nf 1 2 3\ng second\nusemtl nothere\nf -3 -2 -1\n",
    b"v\t0\t0\t0\r\nv 1 0 0\r\nv 0 1 0 1\r\nv 1 1 0 0.5 0.5 0.5\r\nf\t1//\t2//\t3//\r\no x\r\nf 2 4 3\r\n",
    b"v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 0 0\nf 1 2 3\nf 1 1 2\nf 1 2 4\nvn 0 0 0\nf 1//1 2//1 3//1\n",
    b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\nf 1 2 3 4 5\nf 4 3 2 1\ns off\nvp 0.1\n",
];

const MTL_CORPUS: &[&[u8]] = &[
    b"newmtl grey\nKd 0.5\nKa 1\nKs 0 0\nKe 0\n",
    b"\xEF\xBB\xBF# r\xE9sum\xE9\nnewmtl\tgrey\nKd\t0.1\t0.2\t0.3\nNs 10\nillum 2\n",
    b"newmtl tex\nKd 1 1 1\nmap_Kd -s 1 1 1 -clamp on tex.png\nnewmtl grey\nKd spectral x.rfl\n",
    b"newmtl grey\nKd xyz 0.1 0.2 0.3\nnewmtl grey\nKd 0.2 0.2 0.2\n",
];

const TOML_CORPUS: &[&[u8]] = &[
    b"name = \"fuzz\"\nbackground = [0.1, 0.1, 0.1]\n[shading]\nambient = 0.3\n\
      light_direction = [0, 1, 0]\n[[mesh]]\nobj = \"mirror.obj\"\nreflector = true\n\
      [[mesh]]\nobj = \"mesh.obj\"\ntransform = { translate = [0, 0, 0], scale = [1, 1, 1] }\n\
      [[camera]]\neye = [0, 0.5, 3]\ntarget = [0, 0.5, 0]\nresolution = [8, 8]\n\
      [cmo]\ncentres = [[0, 0.3, 0]]\nresolution = 8\n",
    b"background = [0, 0, 0, 0]\n[shading]\nambient = 1.5\n[[mesh]]\nobj = \"mesh.obj\"\n\
      reflector = true\ntransform = { rotate_deg = [0, 90, 0], scale = 2 }\n[[camera]]\n\
      eye = [0, 0.5, 3]\ntarget = [0, 0.5, 0]\nup = [0, 1, 0, 1]\nresolution = [8, 8]\n\
      [cmo]\ncount = 2\n",
    b"[[mesh]]\nobj = \"mirror.obj\"\nreflector = true\n[[mesh]]\nobj = \"mesh.obj\"\n\
      reflector = true\n[[camera]]\neye = [1, 1, 1]\ntarget = [0, 0, 0]\nresolution = [4, 4]\n",
];

/// Tokens the mutations insert.
const TOKENS: &[&str] = &[
    " ",
    "\t",
    "\n",
    "\r\n",
    "/",
    "//",
    "-",
    "#",
    "\u{FEFF}",
    "0",
    "1",
    "-1",
    "3",
    "99999999999",
    "1e39",
    "nan",
    "inf",
    "-0",
    "0.5",
    "f",
    "l",
    "p",
    "v",
    "vt",
    "vn",
    "o",
    "g",
    "usemtl",
    "mtllib lib.mtl",
    "mtllib nowhere.mtl",
    "newmtl",
    "Kd",
    "map_Kd",
    "-s",
    "grey",
    "tex",
    "[",
    "]",
    "[0, 0, 0, 0]",
    "=",
    "\"",
    "reflector = true",
    "ambient = -1",
    "[[mesh]]",
    "obj = \"mesh.obj\"",
    "count = 0",
    "resolution = 0",
];

/// One mutation: what, where (a fraction of the length) and which token or line.
#[derive(Clone, Debug)]
struct Mutation {
    kind: u8,
    at: u16,
    pick: u16,
    byte: u8,
}

fn mutate(input: &[u8], ms: &[Mutation], others: &[&[u8]]) -> Vec<u8> {
    let mut v = input.to_vec();
    for m in ms {
        let at = v.len() * m.at as usize / (u16::MAX as usize + 1);
        match m.kind % 6 {
            0 => {
                let t = TOKENS[m.pick as usize % TOKENS.len()].as_bytes();
                v.splice(at..at, t.iter().copied());
            }
            1 => v.insert(at, m.byte),
            2 => {
                let end = (at + 1 + m.pick as usize % 16).min(v.len());
                v.drain(at..end);
            }
            3 | 4 => {
                // Double a line of this input (3) or splice in a line of another corpus entry (4).
                let src: &[u8] = if m.kind % 6 == 3 {
                    &v.clone()
                } else {
                    others[m.pick as usize % others.len()]
                };
                let lines: Vec<&[u8]> = src.split(|&b| b == b'\n').collect();
                let line = lines[m.pick as usize % lines.len()];
                let mut ins = line.to_vec();
                ins.push(b'\n');
                let start = v[..at]
                    .iter()
                    .rposition(|&b| b == b'\n')
                    .map_or(0, |k| k + 1);
                v.splice(start..start, ins);
            }
            _ => {
                if let Some(b) = v.get_mut(at) {
                    *b = m.byte;
                }
            }
        }
    }
    v
}

#[derive(Clone)]
struct Case {
    toml: Vec<u8>,
    obj: Vec<u8>,
    mtl: Vec<u8>,
}

impl std::fmt::Debug for Case {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
        f.debug_struct("Case")
            .field("toml", &s(&self.toml))
            .field("obj", &s(&self.obj))
            .field("mtl", &s(&self.mtl))
            .finish()
    }
}

fn mutations() -> impl Strategy<Value = Vec<Mutation>> {
    proptest::collection::vec(
        (any::<u8>(), any::<u16>(), any::<u16>(), any::<u8>()).prop_map(
            |(kind, at, pick, byte)| Mutation {
                kind,
                at,
                pick,
                byte,
            },
        ),
        0..6,
    )
}

fn cases() -> impl Strategy<Value = Case> {
    // Mostly the first, valid scene file, mostly unmutated: a broken scene file stops the load
    // before the OBJ and MTL are read.
    (
        prop_oneof![3 => Just(0), 1 => 0..TOML_CORPUS.len()],
        0..OBJ_CORPUS.len(),
        0..MTL_CORPUS.len(),
        prop_oneof![3 => Just(Vec::new()), 1 => mutations()],
        mutations(),
        mutations(),
    )
        .prop_map(|(t, o, m, mt, mo, mm)| Case {
            toml: mutate(TOML_CORPUS[t], &mt, TOML_CORPUS),
            obj: mutate(OBJ_CORPUS[o], &mo, OBJ_CORPUS),
            mtl: mutate(MTL_CORPUS[m], &mm, MTL_CORPUS),
        })
}

type Loader = fn(&Path) -> Result<(Scene, LoadReport), SceneError>;

/// How the cases of a pass ended: loaded, or refused naming the scene file, the OBJ or the MTL.
#[derive(Debug, Default)]
struct Tally {
    loaded: usize,
    toml: usize,
    obj: usize,
    mtl: usize,
    /// Refused for another reason (a path the mutated scene file names).
    other: usize,
}

/// Writes a case into a fresh folder and loads it: Err(reason) on a panic or an amplified input.
fn check(case: &Case, load: Loader, tally: &Mutex<Tally>) -> Result<(), String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let d = dir.path();
    let write = |name: &str, bytes: &[u8]| std::fs::write(d.join(name), bytes).unwrap();
    write("scene.toml", &case.toml);
    write("mesh.obj", &case.obj);
    write("mirror.obj", b"v -1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write("lib.mtl", &case.mtl);
    let png = image::RgbaImage::from_raw(1, 1, vec![200, 100, 50, 255]).unwrap();
    png.save(d.join("tex.png")).unwrap();
    let path = d.join("scene.toml");
    let outcome = std::panic::catch_unwind(|| {
        load(&path).map(|(scene, _)| {
            let problems = cubetrace::placement::diagnose(&scene);
            (scene, problems)
        })
    });
    let scene = match outcome {
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            return Err(format!("the loader panicked: {msg}"));
        }
        Ok(Err(e)) => {
            let e = e.to_string();
            // tobj parses only what the loader's own pass has checked and normalised; tobj
            // refusing that text is a gap in the pass.
            if e.contains("tobj refused") {
                return Err(format!("the checked text reached tobj and failed: {e}"));
            }
            let mut t = tally.lock().unwrap();
            if e.contains("scene.toml") {
                t.toml += 1;
            } else if e.contains("mesh.obj") {
                t.obj += 1;
            } else if e.contains("lib.mtl") {
                t.mtl += 1;
            } else if e.trim().is_empty() {
                return Err("an empty error message".into());
            } else {
                t.other += 1;
            }
            return Ok(());
        }
        Ok(Ok((scene, _))) => {
            tally.lock().unwrap().loaded += 1;
            scene
        }
    };
    // Bounded memory: nothing grows faster than the input.
    let input = case.toml.len() + case.obj.len() + case.mtl.len() + 64;
    let held: usize = scene
        .meshes
        .iter()
        .flat_map(|m| &m.parts)
        .map(|p| p.positions.len() + p.triangles.len())
        .sum();
    if held > 2 * input {
        return Err(format!("{held} vertices and triangles from {input} bytes"));
    }
    Ok(())
}

/// Runs the fixed-seed pass with `load`; the first failure (shrunk by proptest) as Err, else
/// how the cases ended.
fn fuzz(load: Loader, count: u32) -> Result<Tally, String> {
    let config = Config {
        cases: count,
        failure_persistence: None,
        max_shrink_iters: 200,
        ..Config::default()
    };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::XorShift, &SEED));
    // A watchdog: each case reports back; one that takes a minute is a hang.
    let (tx, rx) = mpsc::channel::<()>();
    let tally = Arc::new(Mutex::new(Tally::default()));
    let t = tally.clone();
    let worker = std::thread::spawn(move || {
        runner
            .run(&cases(), |case| {
                let r = check(&case, load, &t);
                let _ = tx.send(());
                r.map_err(TestCaseError::fail)
            })
            .map_err(|e| e.to_string())
    });
    loop {
        match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(()) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                return Err("a case ran for over a minute (a hang)".into());
            }
        }
    }
    worker
        .join()
        .map_err(|_| "the fuzz worker panicked".to_string())??;
    let t = std::mem::take(&mut *tally.lock().unwrap());
    Ok(t)
}

#[test]
fn fuzz_scene_loader_fixed_seed() {
    let t = fuzz(scene::load_scene_file_report, CASES).unwrap();
    println!("{t:?}");
    // The corpus and mutations reach every part of the loader: a good share of the cases load,
    // and some are refused in each file.
    assert!(t.loaded >= CASES as usize / 10, "{t:?}");
    assert!(t.toml > 0 && t.obj > 0 && t.mtl > 0, "{t:?}");
}

/// Negative: the pass catches a loader that panics on one corpus feature (as tobj does on
/// `Kd 0.5`), one that amplifies its input, and tobj fed the raw MTL instead of the checked copy.
#[test]
fn fuzz_catches_panics_and_amplification() {
    fn panicky(path: &Path) -> Result<(Scene, LoadReport), SceneError> {
        let mtl = std::fs::read(path.with_file_name("lib.mtl")).unwrap();
        if mtl.windows(7).any(|w| w == b"Kd 0.5\n") {
            panic!("index out of bounds");
        }
        scene::load_scene_file_report(path)
    }
    let e = fuzz(panicky, 50).unwrap_err();
    assert!(e.contains("the loader panicked"), "{e}");

    fn amplifying(path: &Path) -> Result<(Scene, LoadReport), SceneError> {
        let (mut s, r) = scene::load_scene_file_report(path)?;
        let p = s.meshes[0].parts[0].clone();
        s.meshes[0].parts = vec![p; 1000];
        Ok((s, r))
    }
    let e = fuzz(amplifying, 50).unwrap_err();
    assert!(e.contains("from"), "{e}");

    // tobj given the raw MTL (not the loader's checked copy) panics or refuses it.
    fn raw_tobj(path: &Path) -> Result<(Scene, LoadReport), SceneError> {
        let mtl = std::fs::read(path.with_file_name("lib.mtl")).unwrap();
        tobj::load_mtl_buf(&mut mtl.as_slice()).map_err(|e| SceneError::Mtl {
            path: path.with_file_name("lib.mtl"),
            reason: format!("tobj refused it: {e}"),
        })?;
        scene::load_scene_file_report(path)
    }
    let e = fuzz(raw_tobj, 50).unwrap_err();
    assert!(e.contains("panicked") || e.contains("tobj"), "{e}");
}
