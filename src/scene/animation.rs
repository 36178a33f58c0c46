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
//!   rotations per Euler angle, in degrees), or, with `interpolation = "catmull-rom"`, a camera's
//!   fields follow a Catmull-Rom spline through the keys (below);
//! - before its first key and after its last it holds that key's value;
//! - a field no key sets keeps the scene's value (the `[[camera]]`'s or the `[[mesh]]`'s).
//!
//! Catmull-Rom (camera fields only): between keys `i` and `i + 1` the field is the cubic Hermite
//! curve through the two values with the tangents `m_i = (p_{i+1} - p_{i-1}) / (t_{i+1} -
//! t_{i-1})` (Catmull-Rom's, for keys at uneven times), and at the first and last key the one-sided
//! difference. The path passes through every key, with a continuous velocity; with two keys it is
//! the straight line. A spline overshoots between keys where the path turns, so `fov_y_deg` is
//! clamped into (0, 180) degrees; mesh transforms stay linear, since an overshooting `scale`
//! could pass through zero and turn a mesh inside out.
//!
//! Keys of a track are in strictly increasing time (the file check refuses others), so the
//! evaluation needs no sorting. A scene without tracks is a still: [`Animation::apply`] gives
//! it back unchanged.

use glam::Vec3;

use super::Scene;

/// How values between two keys are found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Interpolation {
    /// Straight lines between keys, for every field.
    #[default]
    Linear,
    /// A Catmull-Rom spline through a camera's keys (module docs); meshes stay linear.
    CatmullRom,
}

impl Interpolation {
    /// The scene file's names, in the order the error message lists them.
    pub const NAMES: &[&str] = &["linear", "catmull-rom"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "linear" => Some(Interpolation::Linear),
            "catmull-rom" => Some(Interpolation::CatmullRom),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Linear => "linear",
            Interpolation::CatmullRom => "catmull-rom",
        }
    }
}

/// The largest frame number (Blender's `MAXFRAME`).
pub const MAX_FRAME: i64 = 1_048_574;

/// The largest frame rate a scene may give.
pub const MAX_FPS: f64 = 1000.0;

/// The narrowest field of view a Catmull-Rom camera path gives (degrees), and 180 less it the
/// widest: an overshoot between keys stays a camera.
pub const MIN_FOV_DEG: f32 = 0.01;

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

/// A value that can be interpolated linearly, or along a spline (a weighted sum of values).
trait Lerp: Copy {
    fn lerp_to(self, other: Self, s: f32) -> Self;
    /// `Σ w_i v_i`.
    fn weighted(terms: [(f32, Self); 4]) -> Self;
}

impl Lerp for Vec3 {
    fn lerp_to(self, other: Self, s: f32) -> Self {
        self * (1.0 - s) + other * s
    }
    fn weighted(terms: [(f32, Self); 4]) -> Self {
        terms.iter().fold(Vec3::ZERO, |acc, &(w, v)| acc + v * w)
    }
}

impl Lerp for f32 {
    fn lerp_to(self, other: Self, s: f32) -> Self {
        self * (1.0 - s) + other * s
    }
    fn weighted(terms: [(f32, Self); 4]) -> Self {
        terms.iter().fold(0.0, |acc, &(w, v)| acc + v * w)
    }
}

/// The value at `time` of the keys `(time, value)` (in increasing time) on their Catmull-Rom
/// spline (module docs); `None` without keys. At a key's time, and before the first or after the
/// last, it is [`sample`]'s value.
fn sample_spline<T: Lerp>(keys: impl Iterator<Item = (f64, T)>, time: f64) -> Option<T> {
    let k: Vec<(f64, T)> = keys.collect();
    let Some(i) = k.windows(2).position(|w| w[0].0 < time && time < w[1].0) else {
        return sample(k.into_iter(), time);
    };
    let (t0, p0) = k[i];
    let (t1, p1) = k[i + 1];
    let (ta, pa) = k[i.saturating_sub(1)];
    let (tb, pb) = k[(i + 2).min(k.len() - 1)];
    let h = t1 - t0;
    let s = (time - t0) / h;
    let (s2, s3) = (s * s, s * s * s);
    let (h00, h10) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s);
    let (h01, h11) = (-2.0 * s3 + 3.0 * s2, s3 - s2);
    // The tangents `(p_next - p_prev) / (t_next - t_prev)`, scaled by the interval `h`, enter
    // the sum as weights on the neighbours' values.
    let (w0, w1) = (h * h10 / (t1 - ta), h * h11 / (tb - t0));
    Some(T::weighted([
        ((h00 - w1) as f32, p0),
        ((h01 + w0) as f32, p1),
        (-w0 as f32, pa),
        (w1 as f32, pb),
    ]))
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
            let spline = self.interpolation == Interpolation::CatmullRom;
            let it = |f: fn(&CameraKey) -> Option<Vec3>| {
                let keys = k.iter().filter_map(move |key| Some((key.time, f(key)?)));
                if spline {
                    sample_spline(keys, time)
                } else {
                    sample(keys, time)
                }
            };
            c.eye = it(|k| k.eye).unwrap_or(c.eye);
            c.target = it(|k| k.target).unwrap_or(c.target);
            c.up = it(|k| k.up).unwrap_or(c.up);
            let fov = k.iter().filter_map(|key| Some((key.time, key.fov_y_deg?)));
            let fov = if spline {
                // An overshoot stays a valid field of view (module docs).
                sample_spline(fov, time).map(|f| f.clamp(MIN_FOV_DEG, 180.0 - MIN_FOV_DEG))
            } else {
                sample(fov, time)
            };
            c.fov_y_deg = fov.unwrap_or(c.fov_y_deg);
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
    /// else frame 1 alone for a scene with keys; `None` for a still, which renders one frame.
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

    #[test]
    fn the_spline_passes_through_the_keys_with_catmull_rom_tangents() {
        let k = keys(&[(0.0, 0.0), (1.0, 1.0), (3.0, -1.0), (4.0, 2.0)]);
        // Through every key, bit for bit; held outside.
        for &(t, v) in &k {
            assert_eq!(sample_spline(k.iter().copied(), t), Some(v));
        }
        assert_eq!(sample_spline(k.iter().copied(), -1.0), Some(0.0));
        assert_eq!(sample_spline(k.iter().copied(), 5.0), Some(2.0));
        // The slope just after key 1 is the Catmull-Rom tangent (p2 - p0) / (t2 - t0) = -1/3,
        // not the chord's -1 that linear gives.
        let e = 1e-3;
        let after = sample_spline(k.iter().copied(), 1.0 + e).unwrap();
        let slope = (after - 1.0) / e as f32;
        assert!((slope - (-1.0 / 3.0)).abs() < 0.01, "{slope}");
        let linear = (sample(k.iter().copied(), 1.0 + e).unwrap() - 1.0) / e as f32;
        assert!((linear - (-1.0)).abs() < 0.01, "{linear}");
        // The velocity is continuous at a key: the slope just before key 1 is the same.
        let before = (1.0 - sample_spline(k.iter().copied(), 1.0 - e).unwrap()) / e as f32;
        assert!((before - slope).abs() < 0.01, "{before} {slope}");
        // Two keys: the straight line.
        let two = keys(&[(0.0, 2.0), (2.0, 6.0)]);
        let mid = sample_spline(two.iter().copied(), 0.5).unwrap();
        assert!((mid - 3.0).abs() < 1e-5, "{mid}");
        assert_eq!(sample_spline(std::iter::empty::<(f64, f32)>(), 0.5), None);
    }
}
