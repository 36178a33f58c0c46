//! The scene file's `[animation]` table: its check into an [`Animation`] ([`animation`]); its
//! form ([`AnimationFile`], the tracks and their keys) is with the rest of the file's in `form`.

use glam::Vec3;
use toml::Spanned;

use super::form::{AnimationFile, CameraKeyFile, MeshKeyFile, ScaleFile};
use crate::scene::animation::{
    Animation, CameraKey, CameraTrack, Interpolation, MAX_FPS, MAX_FRAME, MeshKey, MeshTrack,
};
use crate::scene::source::Source;
use crate::scene::{Scene, SceneError};

/// `[animation]`: `fps` finite and positive, `frames` an ordered range of frame numbers,
/// `interpolation` a known name, then each track (a known camera or mesh, animated once, its
/// keys in strictly increasing time). A mesh `split` in two (its mirror parts' mesh, its other
/// parts') moves as one: a track of the first moves both.
pub(super) fn animation(
    src: &Source,
    a: &AnimationFile,
    scene: &Scene,
    split: &[(usize, usize)],
) -> Result<Animation, SceneError> {
    let mut out = Animation::default();
    if let Some(fps) = &a.fps {
        let v = *fps.get_ref();
        if !(v.is_finite() && v > 0.0 && v <= MAX_FPS) {
            return Err(src.invalid(
                fps,
                "animation.fps",
                format!("{v} is out of range (frames per second above 0, at most {MAX_FPS})"),
            ));
        }
        out.fps = v;
    }
    if let Some(frames) = &a.frames {
        let [first, last] = *frames.get_ref();
        if first < 0 || last > MAX_FRAME || first > last {
            return Err(src.invalid(
                frames,
                "animation.frames",
                format!(
                    "[{first}, {last}] is not a range [first, last] with 0 <= first <= last <= \
                     {MAX_FRAME}"
                ),
            ));
        }
        out.frames = Some([first, last]);
    }
    if let Some(i) = &a.interpolation {
        out.interpolation = Interpolation::from_name(i.get_ref()).ok_or_else(|| {
            src.invalid(
                i,
                "animation.interpolation",
                format!(
                    "'{}' is not one of {}",
                    i.get_ref(),
                    Interpolation::NAMES
                        .iter()
                        .map(|n| format!("\"{n}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })?;
    }
    for (t, track) in a.cameras.iter().enumerate() {
        let field = format!("animation.camera[{t}]");
        let camera = match &track.get_ref().camera {
            None => 0,
            Some(name) => (scene.cameras.iter())
                .position(|c| c.name == *name.get_ref())
                .ok_or_else(|| {
                    src.invalid(
                        name,
                        &format!("{field}.camera"),
                        format!("no [[camera]] named '{}'", name.get_ref()),
                    )
                })?,
        };
        if out.cameras.iter().any(|c| c.camera == camera) {
            return Err(src.invalid(
                track,
                &field,
                format!("camera '{}' is animated twice", scene.cameras[camera].name),
            ));
        }
        let keys = keys(src, &track.get_ref().keys, track, &field, camera_key)?;
        out.cameras.push(CameraTrack { camera, keys });
    }
    for (t, track) in a.meshes.iter().enumerate() {
        let field = format!("animation.mesh[{t}]");
        let name = &track.get_ref().mesh;
        let mesh = (scene.meshes.iter())
            .position(|m| m.name == *name.get_ref())
            .ok_or_else(|| {
                src.invalid(
                    name,
                    &format!("{field}.mesh"),
                    format!("no [[mesh]] named '{}'", name.get_ref()),
                )
            })?;
        if out.meshes.iter().any(|m| m.mesh == mesh) {
            return Err(src.invalid(
                track,
                &field,
                format!("mesh '{}' is animated twice", name.get_ref()),
            ));
        }
        let keys = keys(src, &track.get_ref().keys, track, &field, mesh_key)?;
        // A mesh split in two (some of its parts mirrors) moves as one.
        if let Some(&(_, rest)) = split.iter().find(|s| s.0 == mesh) {
            if out.meshes.iter().any(|m| m.mesh == rest) {
                return Err(src.invalid(
                    track,
                    &field,
                    format!(
                        "mesh '{}' is animated twice (its mirrors' mesh moves it)",
                        scene.meshes[rest].name
                    ),
                ));
            }
            out.meshes.push(MeshTrack {
                mesh: rest,
                keys: keys.clone(),
            });
        }
        out.meshes.push(MeshTrack { mesh, keys });
    }
    Ok(out)
}

/// A track's keys: at least one, each with a finite `time` after the previous key's, each
/// value checked by `one` (given the key's field name and its time).
fn keys<F, K, T>(
    src: &Source,
    keys: &[Spanned<F>],
    track: &Spanned<T>,
    field: &str,
    one: impl Fn(&Source, &Spanned<F>, &str, f64) -> Result<K, SceneError>,
) -> Result<Vec<K>, SceneError>
where
    F: KeyTime,
{
    if keys.is_empty() {
        return Err(src.invalid(track, field, "has no keys (add [[...key]] tables)"));
    }
    let mut out = Vec::new();
    let mut previous: Option<f64> = None;
    for (k, key) in keys.iter().enumerate() {
        let kf = format!("{field}.key[{k}]");
        let Some(time) = key.get_ref().time() else {
            return Err(src.invalid(
                key,
                &format!("{kf}.time"),
                "missing: every key needs a time (seconds)",
            ));
        };
        let t = *time.get_ref();
        if !t.is_finite() {
            return Err(src.invalid(
                time,
                &format!("{kf}.time"),
                format!("{t} is not a finite number"),
            ));
        }
        if let Some(p) = previous
            && t <= p
        {
            return Err(src.invalid(
                time,
                &format!("{kf}.time"),
                format!("{t} is not after the previous key's {p} (keys are in increasing time)"),
            ));
        }
        previous = Some(t);
        out.push(one(src, key, &kf, t)?);
    }
    Ok(out)
}

/// A key table's `time`.
trait KeyTime {
    fn time(&self) -> Option<&Spanned<f64>>;
}

impl KeyTime for CameraKeyFile {
    fn time(&self) -> Option<&Spanned<f64>> {
        self.time.as_ref()
    }
}

impl KeyTime for MeshKeyFile {
    fn time(&self) -> Option<&Spanned<f64>> {
        self.time.as_ref()
    }
}

/// A camera key: `eye` and `target` points, `up` finite and not zero, `fov_y_deg` in (0, 180);
/// at least one of them.
fn camera_key(
    src: &Source,
    key: &Spanned<CameraKeyFile>,
    kf: &str,
    time: f64,
) -> Result<CameraKey, SceneError> {
    let k = key.get_ref();
    let f = |s: &str| format!("{kf}.{s}");
    let point = |v: &Option<Spanned<[f32; 3]>>, name: &str| {
        v.as_ref().map(|v| src.point(v, &f(name))).transpose()
    };
    let up = match &k.up {
        Some(u) => {
            let v = src.finite(u, &f("up"))?;
            if v == Vec3::ZERO {
                return Err(src.invalid(u, &f("up"), "must not be zero"));
            }
            Some(v)
        }
        None => None,
    };
    let fov_y_deg = match &k.fov_y_deg {
        Some(v) => {
            let x = src.scalar(v, &f("fov_y_deg"))?;
            if !(x > 0.0 && x < 180.0) {
                return Err(src.invalid(v, &f("fov_y_deg"), "must be in (0, 180) degrees"));
            }
            Some(x)
        }
        None => None,
    };
    let out = CameraKey {
        time,
        eye: point(&k.eye, "eye")?,
        target: point(&k.target, "target")?,
        up,
        fov_y_deg,
    };
    if out.eye.is_none() && out.target.is_none() && out.up.is_none() && out.fov_y_deg.is_none() {
        return Err(src.invalid(key, kf, "sets none of eye, target, up, fov_y_deg"));
    }
    Ok(out)
}

/// A mesh key: `translate` a point, `rotate_deg` in [-360, 360], `scale` finite and non-zero;
/// at least one of them.
fn mesh_key(
    src: &Source,
    key: &Spanned<MeshKeyFile>,
    kf: &str,
    time: f64,
) -> Result<MeshKey, SceneError> {
    let k = key.get_ref();
    let f = |s: &str| format!("{kf}.{s}");
    let rotate_deg = match &k.rotate_deg {
        Some(r) => {
            let v = src.finite(r, &f("rotate_deg"))?;
            if let Some(c) = (0..3).find(|&c| v[c].abs() > 360.0) {
                return Err(src.invalid(
                    r,
                    &f("rotate_deg"),
                    format!(
                        "component {c} is {} (angles lie in [-360, 360] degrees)",
                        v[c]
                    ),
                ));
            }
            Some(v)
        }
        None => None,
    };
    let scale = match &k.scale {
        Some(s) => {
            let v = match *s.get_ref() {
                ScaleFile::Uniform(x) => Vec3::splat(x),
                ScaleFile::PerAxis(x) => Vec3::from_array(x),
            };
            if !v.is_finite() || v.cmpeq(Vec3::ZERO).any() {
                return Err(src.invalid(s, &f("scale"), "scale must be finite and non-zero"));
            }
            Some(v)
        }
        None => None,
    };
    let out = MeshKey {
        time,
        translate: (k.translate.as_ref())
            .map(|v| src.point(v, &f("translate")))
            .transpose()?,
        rotate_deg,
        scale,
    };
    if out.translate.is_none() && out.rotate_deg.is_none() && out.scale.is_none() {
        return Err(src.invalid(key, kf, "sets none of translate, rotate_deg, scale"));
    }
    Ok(out)
}
