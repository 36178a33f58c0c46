//! `self_reflections` per reflector: the scene file's override (`"auto"`, `true`, `false`), and
//! what each built-in scene gets under auto.

use std::path::{Path, PathBuf};

use cubetrace::reference::{self, Tracer};
use cubetrace::scene::{self, SelfReflections, builtin, export};

/// The torus exported to `dir`, its `self_reflections` line replaced by `line` (removed when
/// empty).
fn torus_with(dir: &Path, line: &str) -> PathBuf {
    let mut torus = builtin::torus();
    torus.self_reflections = SelfReflections::Auto;
    let path = export::export(&torus, dir).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let old = text
        .lines()
        .find(|l| l.starts_with("self_reflections"))
        .expect("exported")
        .to_string();
    assert_eq!(old, "self_reflections = \"auto\"");
    std::fs::write(&path, text.replacen(&old, line, 1)).unwrap();
    path
}

#[test]
fn override_parses_auto_true_false_and_default() {
    let dir = tempfile::tempdir().unwrap();
    for (line, want) in [
        ("self_reflections = \"auto\"", SelfReflections::Auto),
        ("", SelfReflections::Auto),
        ("self_reflections = true", SelfReflections::On),
        ("self_reflections = false", SelfReflections::Off),
    ] {
        let s = scene::load_scene_file(&torus_with(dir.path(), line)).unwrap();
        assert_eq!(s.self_reflections, want, "{line}");
        // The torus sees itself under auto and on, not when forced off.
        assert_eq!(
            s.captures_reflectors(),
            want != SelfReflections::Off,
            "{line}"
        );
    }
}

#[test]
fn bad_override_is_named_by_line() {
    let dir = tempfile::tempdir().unwrap();
    for bad in ["\"yes\"", "\"Auto\"", "1", "[true]"] {
        let path = torus_with(dir.path(), &format!("self_reflections = {bad}"));
        let text = std::fs::read_to_string(&path).unwrap();
        let line = 1 + text
            .lines()
            .position(|l| l.starts_with("self_reflections"))
            .unwrap();
        let e = scene::load_scene_file(&path).unwrap_err().to_string();
        assert!(e.contains("self_reflections"), "{bad}: {e}");
        assert!(
            e.contains(&format!("{line}")),
            "{bad}: no line {line} in {e}"
        );
        assert!(
            e.contains("scene.toml") || e.contains(".toml"),
            "{bad}: {e}"
        );
    }
}

/// What auto decides on each built-in scene. The torus and the bowl are built with self-capture
/// pinned off (see `builtin.rs`: from their one CMO the captured mirror hides the room).
#[test]
fn builtins_under_auto() {
    for (name, want, pinned_off) in [
        ("default", false, false),
        ("sphere-room", false, false),
        ("teapot", true, false),
        ("torus", true, true),
        ("bowl", true, true),
    ] {
        let mut s = builtin::by_name(name).unwrap();
        let built = if pinned_off {
            SelfReflections::Off
        } else {
            SelfReflections::Auto
        };
        assert_eq!(s.self_reflections, built, "{name}");
        assert!(!pinned_off || !s.captures_reflectors(), "{name}");
        s.self_reflections = SelfReflections::Auto;
        assert_eq!(s.captures_reflectors(), want, "{name}");
        let world = s.world();
        for o in &world.objects {
            assert_eq!(o.captured, !o.reflector || want, "{name} {}", o.name);
        }
    }
}

/// The CPU capture of the torus under auto holds torus texels (it sees itself through the
/// capture); forced off, none. Negative: the same count on the sphere room is zero under auto.
#[test]
fn torus_captures_itself_under_auto() {
    let reflector_texels = |s: &scene::Scene| {
        let tracer = Tracer::new(s);
        let centre = s.cmo_centres()[0];
        let cube = cubetrace::cpu::capture::capture(s, &tracer, centre, 16);
        cube.triangle
            .iter()
            .filter(|&&t| t != reference::NO_ID && tracer.is_reflector(t))
            .count()
    };
    let mut torus = builtin::torus();
    torus.self_reflections = SelfReflections::Auto;
    assert!(reflector_texels(&torus) > 0);
    let mut off = torus.clone();
    off.self_reflections = SelfReflections::Off;
    assert_eq!(reflector_texels(&off), 0);
    assert_eq!(reflector_texels(&builtin::sphere_room()), 0);
}
