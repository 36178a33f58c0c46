#![forbid(unsafe_code)]
//! Keyframed animation of a scene: the cameras' and the meshes' keys, the frame rate and the
//! default frame range (the scene file's `[animation]`, see the `file` module for its form).
//!
//! Time is in seconds; frame `f` is at time `f / fps` (frame 0 at time 0). Each key sets some of
//! its track's fields (a camera's `eye`, `target`, `up`, `fov_y_deg`; a mesh's `translate`,
//! `rotate_deg`, `scale`); each field is animated by the keys that set it, independently of the
//! others:
//! - at a key's exact time the field is that key's value, bit for bit;
//! - between two keys it is interpolated linearly (`a * (1 - s) + b * s`, per component;
//!   rotations per Euler angle, in degrees);
//! - before its first key and after its last it holds that key's value;
//! - a field no key sets keeps the scene's value (the `[[camera]]`'s or the `[[mesh]]`'s).
//!
//! Keys of a track are in strictly increasing time (the file check refuses others), so the
//! evaluation needs no sorting. A scene without tracks is a still: [`Animation::apply`] gives
//! it back unchanged.

use glam::Vec3;

use super::Scene;

/// How values between two keys are found. Only linear interpolation exists.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Interpolation {
    #[default]
    Linear,
}

impl Interpolation {
    /// The scene file's names, in the order the error message lists them.
    pub const NAMES: &[&str] = &["linear"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "linear" => Some(Interpolation::Linear),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Linear => "linear",
        }
    }
}

/// The largest frame number (Blender's `MAXFRAME`).
pub const MAX_FRAME: i64 = 1_048_574;

/// The largest frame rate a scene may give.
pub const MAX_FPS: f64 = 1000.0;

/// Frames per second when the file gives none.
pub const DEFAULT_FPS: f64 = 24.0;

/// A scene's animation; the default is none (a still).
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// Frames per second (finite, > 0).
    pub fps: f64,
    /// The default frame range `[first, last]` (inclusive), used when `render --frames` is not
    /// given; `None`: a still (frame 1 alone).
    pub frames: Option<[i64; 2]>,
    pub interpolation: Interpolation,
    pub cameras: Vec<CameraTrack>,
    pub meshes: Vec<MeshTrack>,
}

impl Default for Animation {
    fn default() -> Self {
        Animation {
            fps: DEFAULT_FPS,
            frames: None,
            interpolation: Interpolation::Linear,
            cameras: Vec::new(),
            meshes: Vec::new(),
        }
    }
}

/// The keys of one camera ([`Scene::cameras`] index `camera`).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraTrack {
    pub camera: usize,
    pub keys: Vec<CameraKey>,
}

#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CameraKey {
    /// Seconds.
    pub time: f64,
    pub eye: Option<Vec3>,
    pub target: Option<Vec3>,
    pub up: Option<Vec3>,
    pub fov_y_deg: Option<f32>,
}

/// The keys of one mesh's transform ([`Scene::meshes`] index `mesh`).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshTrack {
    pub mesh: usize,
    pub keys: Vec<MeshKey>,
}

#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct MeshKey {
    /// Seconds.
    pub time: f64,
    pub translate: Option<Vec3>,
    pub rotate_deg: Option<Vec3>,
    pub scale: Option<Vec3>,
}

/// A value that can be interpolated linearly.
trait Lerp: Copy {
    fn lerp_to(self, other: Self, s: f32) -> Self;
}

impl Lerp for Vec3 {
    fn lerp_to(self, other: Self, s: f32) -> Self {
        self * (1.0 - s) + other * s
    }
}

impl Lerp for f32 {
    fn lerp_to(self, other: Self, s: f32) -> Self {
        self * (1.0 - s) + other * s
    }
}

/// The value at `time` of the keys `(time, value)` (in increasing time), `None` without keys.
fn sample<T: Lerp>(keys: impl Iterator<Item = (f64, T)>, time: f64) -> Option<T> {
    let mut before: Option<(f64, T)> = None;
    for (t, v) in keys {
        if t == time {
            return Some(v);
        }
        if t > time {
            return Some(match before {
                None => v,
                Some((t0, v0)) => v0.lerp_to(v, ((time - t0) / (t - t0)) as f32),
            });
        }
        before = Some((t, v));
    }
    before.map(|(_, v)| v)
}

impl Animation {
    /// Whether any camera or mesh has keys (else every frame is the same still).
    pub fn is_animated(&self) -> bool {
        !self.cameras.is_empty() || !self.meshes.is_empty()
    }

    /// The time of `frame`, in seconds.
    pub fn time(&self, frame: i64) -> f64 {
        frame as f64 / self.fps
    }

    /// `scene` at `frame`: its cameras and mesh transforms replaced by the tracks' values at
    /// the frame's time. A still scene (no tracks) comes back unchanged.
    pub fn apply(&self, scene: &Scene, frame: i64) -> Scene {
        let mut out = scene.clone();
        if !self.is_animated() {
            return out;
        }
        let time = self.time(frame);
        for track in &self.cameras {
            let Some(c) = out.cameras.get_mut(track.camera) else {
                continue;
            };
            let k = &track.keys;
            let it = |f: fn(&CameraKey) -> Option<Vec3>| {
                sample(
                    k.iter().filter_map(move |key| Some((key.time, f(key)?))),
                    time,
                )
            };
            c.eye = it(|k| k.eye).unwrap_or(c.eye);
            c.target = it(|k| k.target).unwrap_or(c.target);
            c.up = it(|k| k.up).unwrap_or(c.up);
            let fov = k.iter().filter_map(|key| Some((key.time, key.fov_y_deg?)));
            c.fov_y_deg = sample(fov, time).unwrap_or(c.fov_y_deg);
        }
        for track in &self.meshes {
            let Some(m) = out.meshes.get_mut(track.mesh) else {
                continue;
            };
            let k = &track.keys;
            let it = |f: fn(&MeshKey) -> Option<Vec3>| {
                sample(
                    k.iter().filter_map(move |key| Some((key.time, f(key)?))),
                    time,
                )
            };
            let t = &mut m.transform;
            t.translate = it(|k| k.translate).unwrap_or(t.translate);
            t.rotate_deg = it(|k| k.rotate_deg).unwrap_or(t.rotate_deg);
            t.scale = it(|k| k.scale).unwrap_or(t.scale);
        }
        out
    }
}

impl Scene {
    /// The scene at `frame` ([`Animation::apply`]): cameras and mesh transforms at time
    /// `frame / fps`; a still scene is returned unchanged.
    pub fn at_frame(&self, frame: i64) -> Scene {
        self.animation.apply(self, frame)
    }

    /// The frames `render` renders when `--frames` is not given: the animation's `frames`,
    /// else frame 1 alone for a scene with keys; `None` for a still (one frame, as before).
    pub fn default_frames(&self) -> Option<[i64; 2]> {
        let a = &self.animation;
        a.frames.or(a.is_animated().then_some([1, 1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(values: &[(f64, f32)]) -> Vec<(f64, f32)> {
        values.to_vec()
    }

    #[test]
    fn a_key_time_gives_the_key_value_and_the_midpoint_is_linear() {
        // Values whose linear blend at the ends would round: the key's own value must come back.
        let k = keys(&[(0.0, 0.1), (1.0 / 3.0, 0.7), (1.0, -2.3)]);
        assert_eq!(sample(k.iter().copied(), 1.0 / 3.0), Some(0.7));
        assert_eq!(sample(k.iter().copied(), 1.0), Some(-2.3));
        assert_eq!(sample(k.iter().copied(), 0.0), Some(0.1));
        let mid = sample(k.iter().copied(), (1.0 / 3.0 + 1.0) / 2.0).unwrap();
        assert!((mid - (0.7 + -2.3) / 2.0).abs() < 1e-6, "{mid}");
        // Negative: a quarter of the way is not the midpoint.
        let quarter = sample(k.iter().copied(), 1.0 / 3.0 + (2.0 / 3.0) / 4.0).unwrap();
        assert!((quarter - (0.7 + -2.3) / 2.0).abs() > 0.1, "{quarter}");
        // Held before the first key and after the last.
        assert_eq!(sample(k.iter().copied(), -5.0), Some(0.1));
        assert_eq!(sample(k.iter().copied(), 9.0), Some(-2.3));
        assert_eq!(sample(std::iter::empty::<(f64, f32)>(), 0.5), None);
    }
}
