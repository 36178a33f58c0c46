#![forbid(unsafe_code)]
//! View-independent shading, shared by the cubemap capture and the CPU reference.
//!
//! A surface point's colour depends only on the point (its material, texture coordinate and
//! normal), never on where it is seen from. So a cubemap texel that sees a point stores the same
//! colour the reference computes when a reflected ray hits it, and any difference between a
//! traced reflection and the reference is tracing error, not shading error.
//!
//! `colour = albedo` (unlit), or `albedo * (ambient + intensity * max(0, n . l))` (Lambert, one
//! fixed directional light; `l` points *towards* the light, `n` is the interpolated normal as
//! stored, not flipped towards the viewer).
//!
//! Textures are sampled bilinearly with repeat addressing, in linear space after sRGB decoding,
//! at `(u, 1 - v)` with texel centres at +0.5: what a Vulkan `LINEAR`/`REPEAT` sampler on an
//! `R8G8B8A8_SRGB` image without mipmaps returns (up to its fixed-point filter weights).
//!
//! A leaf module: the scene holds [`Material`]s and [`Texture`]s (defined here, as the data this
//! arithmetic reads), and nothing here reads a scene.

use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shading {
    Unlit,
    Lambert {
        ambient: f32,
        /// Unit vector towards the light.
        light_direction: Vec3,
        light_intensity: f32,
    },
}

impl Default for Shading {
    fn default() -> Self {
        Shading::Lambert {
            ambient: 0.35,
            light_direction: Vec3::new(0.3, 0.9, 0.4).normalize(),
            light_intensity: 0.65,
        }
    }
}

impl Shading {
    /// The shaded colour of a surface point with the given albedo and unit normal.
    pub fn shade(&self, albedo: Vec3, normal: Vec3) -> Vec3 {
        match *self {
            Shading::Unlit => albedo,
            Shading::Lambert {
                ambient,
                light_direction,
                light_intensity,
            } => albedo * (ambient + light_intensity * normal.dot(light_direction).max(0.0)),
        }
    }
}

/// sRGB transfer function, decode (8-bit value to linear).
pub fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer function, decode, of an encoded value `c` in [0, 1] as a float (an OBJ
/// vertex colour); below 0 is 0, 1 is 1 exactly, above 1 follows the curve.
pub fn srgb_decode(c: f32) -> f32 {
    if c <= 0.0 {
        0.0
    } else if c == 1.0 {
        1.0
    } else if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer function, encode, as a float: the inverse of [`srgb_decode`] up to rounding
/// (0 and 1 exactly).
pub fn srgb_encode(c: f32) -> f32 {
    if c <= 0.0 {
        0.0
    } else if c == 1.0 {
        1.0
    } else if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB transfer function, encode (linear to 8-bit, clamped, rounded to nearest).
pub fn linear_to_srgb(c: f32) -> u8 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    let s = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGB diffuse colour (`Kd`).
    pub diffuse: Vec3,
    /// Index into the scene's texture list (`map_Kd`), multiplied with `diffuse`.
    pub texture: Option<u32>,
    /// The Phong specular power a reflector of this material reflects with (MTL `Ns` where the
    /// mesh honours it, or the scene file's `specular_power`): `None`, or at least
    /// [`crate::lobe::MIRROR_POWER`], is a perfect mirror. Ignored on non-reflectors.
    pub specular_power: Option<f32>,
}

/// An sRGB-encoded RGBA8 image, row 0 at the top.
#[derive(Clone, PartialEq)]
pub struct Texture {
    /// File name used when the scene is exported (`NAME.png`).
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<u8>,
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Texture({} {}x{})", self.name, self.width, self.height)
    }
}

impl Texture {
    fn texel_linear(&self, x: i64, y: i64) -> Vec3 {
        let x = x.rem_euclid(self.width as i64) as usize;
        let y = y.rem_euclid(self.height as i64) as usize;
        let o = 4 * (y * self.width as usize + x);
        Vec3::new(
            srgb_to_linear(self.rgba8[o]),
            srgb_to_linear(self.rgba8[o + 1]),
            srgb_to_linear(self.rgba8[o + 2]),
        )
    }

    /// Bilinear, repeat-addressed lookup in linear space at OBJ coordinates `uv`.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let fx = uv.x * self.width as f32 - 0.5;
        let fy = (1.0 - uv.y) * self.height as f32 - 0.5;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (ax, ay) = (fx - x0, fy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self
            .texel_linear(x0, y0)
            .lerp(self.texel_linear(x0 + 1, y0), ax);
        let bottom = self
            .texel_linear(x0, y0 + 1)
            .lerp(self.texel_linear(x0 + 1, y0 + 1), ax);
        top.lerp(bottom, ay)
    }
}

/// The albedo of a material at texture coordinate `uv` (ignored without a texture).
pub fn albedo(material: &Material, textures: &[Texture], uv: Vec2) -> Vec3 {
    match material.texture {
        Some(t) => material.diffuse * textures[t as usize].sample(uv),
        None => material.diffuse,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip() {
        for v in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(v)), v);
        }
        assert_eq!(linear_to_srgb(f32::NAN), 0);
        assert_eq!(linear_to_srgb(2.0), 255);
    }

    #[test]
    fn bilinear_at_texel_centres_and_between() {
        // 2x1 texture: black, white. Row 0 is the top, v is up.
        let t = Texture {
            name: "t".into(),
            width: 2,
            height: 1,
            rgba8: vec![0, 0, 0, 255, 255, 255, 255, 255],
        };
        assert_eq!(t.sample(Vec2::new(0.25, 0.5)), Vec3::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.5)), Vec3::ONE);
        let mid = t.sample(Vec2::new(0.5, 0.5));
        assert!((mid - Vec3::splat(0.5)).abs().max_element() < 1e-6);
        // Repeat addressing: u = 0 sits between the last and the first texel.
        let wrap = t.sample(Vec2::new(0.0, 0.5));
        assert!((wrap - Vec3::splat(0.5)).abs().max_element() < 1e-6);
    }

    #[test]
    fn lambert_is_view_independent_and_clamped() {
        let s = Shading::Lambert {
            ambient: 0.2,
            light_direction: Vec3::Y,
            light_intensity: 0.8,
        };
        assert_eq!(s.shade(Vec3::ONE, Vec3::Y), Vec3::ONE);
        assert_eq!(s.shade(Vec3::ONE, -Vec3::Y), Vec3::splat(0.2));
        assert_eq!(Shading::Unlit.shade(Vec3::X, -Vec3::Y), Vec3::X);
    }
}
