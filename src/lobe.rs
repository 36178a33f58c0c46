#![forbid(unsafe_code)]
//! Glossy reflection: the Phong specular lobe, its cap, and the per-sample directions that the
//! CPU reference and `--method bvh` draw from it, identically (`spirv/shared/lobe.wgsl` is this
//! module operation for operation).
//!
//! - **Glossiness** is the Phong specular power `n` (MTL `Ns`), as the Hi-Z chapter uses it
//!   (`../shared/papers/hiz-screen-space-cone-traced-reflections.md`, 4.4.5). The lobe around the
//!   mirror direction `r` has density proportional to `cos^n(theta)`, `theta` the angle to `r`.
//! - **The cap.** At and above [`MIRROR_POWER`] (1024, the low end of the chapter's 1024-2048
//!   range, where the lobe no longer changes visibly) a reflector is a perfect mirror: nothing is
//!   sampled, and every method's output is the mirror's, bit for bit. [`glossy`] is the one test.
//! - **Sampling** (Eq. 4.1, the inverse CDF of the Phong distribution): `cos(theta) =
//!   xi^(1 / (n + 1))`, `phi = 2 pi v`, with `xi = 1 - u` so that `u` in `[0, 1)` never takes
//!   the logarithm of 0 (the same distribution). The power is computed as `exp2(log2(xi) /
//!   (n + 1))` on both sides. The lobe is placed around `r` with the branchless orthonormal basis
//!   of Duff et al. (JCGT 2017), and the direction is normalised (glam's `normalize`).
//! - **Below the surface.** A sampled direction on the other side of the surface than `r`
//!   (`(d . n) (r . n) <= 0`, `n` the shading normal) is absorbed, as pbrt's Phong and Blinn
//!   lobes give such a direction a zero BRDF: the sample counts with zero radiance (black, no
//!   hit). The estimator is then the mean over samples of the radiance along each direction, the
//!   absorbed ones counting zero: at grazing angles a glossy reflector is darker than its mirror,
//!   as the lobe's cut-off part is lost energy.
//! - **Randomness** is a hash, not a generator with state: the two uniforms of pixel `(x, y)`,
//!   sample key `key` ([`sample_key`]: the film's sample index and count) and bounce `b` are
//!   [`uniforms`], PCG's output permutation (`pcg_hash`, Jarzynski and Olano, "Hash Functions for
//!   GPU Rendering", JCGT 2020) chained over the inputs from a fixed seed, the top 24 bits of each
//!   word scaled by `2^-24` (exact in f32). The same pixel, sample and bounce give the same
//!   direction every run, on every thread count and on both devices (up to the last bits of the
//!   transcendental functions, which the device computes its own way).
//! - **Samples per pixel.** At `--spp N` each of the film's `N` samples (its own sub-pixel
//!   offset, [`crate::film`]) reflects along one lobe direction, keyed by `(N, s)`, so that the
//!   sample sets of different `N` are independent (an error-against-spp table measures real
//!   error). The pixel is the film's filter over its samples: the box filter's mean is the Monte
//!   Carlo estimate of the lobe integral (with the pixel's footprint).

use glam::Vec3;

/// The specular power at and above which a reflector is a perfect mirror.
pub const MIRROR_POWER: f32 = 1024.0;

/// The hash chain's seed.
pub const SEED: u32 = 0x9e37_79b9;

/// Whether a reflector of specular power `power` (`None`: no power given) is glossy: a power
/// below [`MIRROR_POWER`]. Everything else is a perfect mirror.
pub fn glossy(power: Option<f32>) -> Option<f32> {
    power.filter(|&p| p < MIRROR_POWER)
}

/// PCG's hash (`pcg_hash`): one LCG step, then the RXS-M-XS output permutation.
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The key of sample `sample` of a frame of `spp` samples per pixel: `spp << 16 | sample`
/// (`spp` at most [`crate::film::MAX_SPP`], `sample` below it).
pub fn sample_key(spp: u32, sample: u32) -> u32 {
    (spp << 16) | (sample & 0xffff)
}

/// A word's top 24 bits as a number in `[0, 1)`, exactly.
fn unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The two uniforms in `[0, 1)` of pixel `(x, y)`, sample key `key` and bounce `bounce` (0 for
/// the first reflection).
pub fn uniforms(x: u32, y: u32, key: u32, bounce: u32) -> (f32, f32) {
    let h = pcg(pcg(pcg(pcg(SEED ^ bounce) ^ key) ^ x) ^ y);
    let a = pcg(h);
    let b = pcg(a);
    (unit(a), unit(b))
}

/// The orthonormal basis `(t, b)` with `t x b = r` of the unit vector `r` (Duff et al. 2017).
pub fn basis(r: Vec3) -> (Vec3, Vec3) {
    let sign = if r.z >= 0.0 { 1.0f32 } else { -1.0 };
    let a = -1.0 / (sign + r.z);
    let b = r.x * r.y * a;
    (
        Vec3::new(1.0 + sign * (r.x * r.x) * a, sign * b, -sign * r.x),
        Vec3::new(b, sign + (r.y * r.y) * a, -r.y),
    )
}

/// `cos(theta)` of Eq. 4.1 for the uniform `u` and power `power`: `(1 - u)^(1 / (power + 1))`.
pub fn cos_theta(u: f32, power: f32) -> f32 {
    ((1.0 - u).log2() / (power + 1.0)).exp2()
}

/// The direction of the Phong lobe of power `power` around the unit vector `axis` for the
/// uniforms `(u, v)`: `theta` from Eq. 4.1, `phi = 2 pi v`.
pub fn sample_around(axis: Vec3, power: f32, (u, v): (f32, f32)) -> Vec3 {
    let c = cos_theta(u, power);
    let s = (1.0 - c * c).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * v;
    let (t, b) = basis(axis);
    let (sp, cp) = (phi.sin(), phi.cos());
    (t * (s * cp) + b * (s * sp) + axis * c).normalize()
}

/// One lobe sample at a glossy reflector: the direction around the mirror direction `mirror`
/// (unit), or `None` where it lies below the surface of shading normal `normal` (absorbed, see
/// the module docs).
pub fn sample(mirror: Vec3, normal: Vec3, power: f32, u: (f32, f32)) -> Option<Vec3> {
    let d = sample_around(mirror, power, u);
    (d.dot(normal) * mirror.dot(normal) > 0.0).then_some(d)
}

/// The Hi-Z chapter's `xi` for the cone angle (Eq. 4.1 at a fixed uniform, 4.4.5): "0.244 seems
/// to be a good number for covering a decent range of cone-angle extents".
pub const CONE_XI: f32 = 0.244;

/// The half-angle (radians) of the cone that stands in for the lobe of power `power` in cone
/// tracing: Eq. 4.1 at `xi` = [`CONE_XI`], `theta = acos(xi^(1 / (power + 1)))` (the chapter
/// prints `cos`; the angle whose cosine Eq. 4.1 gives is meant), and 0 for a mirror
/// ([`glossy`]). Computed as `acos(exp2(log2(xi) / (power + 1)))`, as `lobe_cone_angle` in
/// `spirv/shared/lobe.wgsl`. About 23.0 degrees at power 16, 11.9 at 64, 6.0 at 256.
pub fn cone_half_angle(power: f32) -> f32 {
    if power >= MIRROR_POWER {
        return 0.0;
    }
    (CONE_XI.log2() / (power.max(0.0) + 1.0)).exp2().acos()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference values of `pcg_hash` from Jarzynski and Olano's code, computed by hand
    /// from its definition here once more; the uniforms lie in [0, 1) and are spread.
    #[test]
    fn hash_and_uniforms() {
        // pcg_hash(0): state = 2891336453, word = ((state >> ((state >> 28) + 4)) ^ state) *
        // 277803737, then (word >> 22) ^ word, all mod 2^32, evaluated in u64 here.
        let state: u64 = 2_891_336_453;
        let word = (((state >> ((state >> 28) + 4)) ^ state) * 277_803_737) & 0xffff_ffff;
        assert_eq!(u64::from(pcg(0)), (word >> 22) ^ word);
        assert_ne!(pcg(0), pcg(1));
        let mut mean = 0.0f64;
        for k in 0..4096u32 {
            let (a, b) = uniforms(k % 64, k / 64, 7, 0);
            assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
            mean += f64::from(a);
        }
        mean /= 4096.0;
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
        // The inputs all count.
        assert_ne!(uniforms(1, 2, 3, 0), uniforms(1, 2, 3, 1));
        assert_ne!(uniforms(1, 2, 3, 0), uniforms(1, 2, 4, 0));
        assert_ne!(uniforms(1, 2, 3, 0), uniforms(2, 1, 3, 0));
        assert_eq!(sample_key(16, 5), (16 << 16) | 5);
    }

    /// The sampled cosines follow the cos^n lobe: E[cos theta] = (n + 1) / (n + 2). Negative:
    /// the same samples read as a lobe of power 2n do not.
    #[test]
    fn lobe_moments() {
        let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
        for n in [0.0f32, 1.0, 10.0, 100.0] {
            let mut sum = 0.0f64;
            let count = 20000;
            for k in 0..count {
                let d = sample_around(axis, n, uniforms(k, 0, 1, 0));
                assert!((d.length() - 1.0).abs() < 1e-5);
                sum += f64::from(d.dot(axis));
            }
            let mean = sum / f64::from(count);
            let want = f64::from(n + 1.0) / f64::from(n + 2.0);
            let wrong = f64::from(2.0 * n + 1.0) / f64::from(2.0 * n + 2.0);
            assert!(
                (mean - want).abs() < 0.01 * (1.0 - want) + 1e-4,
                "{n}: {mean} {want}"
            );
            if n > 0.0 {
                assert!((mean - wrong).abs() > 3.0 * (mean - want).abs(), "{n}");
            }
        }
        let (t, b) = basis(axis);
        assert!(t.dot(axis).abs() < 1e-6 && b.dot(axis).abs() < 1e-6 && t.dot(b).abs() < 1e-6);
        assert!((t.cross(b) - axis).length() < 1e-5);
    }

    /// The cap: 1024 and above (and no power) is a mirror; below it glossy. Directions below
    /// the surface are absorbed.
    #[test]
    fn cap_and_horizon() {
        assert_eq!(glossy(None), None);
        assert_eq!(glossy(Some(1024.0)), None);
        assert_eq!(glossy(Some(5000.0)), None);
        assert_eq!(glossy(Some(1023.5)), Some(1023.5));
        let n = Vec3::Y;
        // A grazing mirror direction: about half its power-0 lobe lies below.
        let r = Vec3::new(1.0, 0.01, 0.0).normalize();
        let below = (0..2000)
            .filter(|&k| sample(r, n, 0.0, uniforms(k, 0, 0, 0)).is_none())
            .count();
        assert!((700..1300).contains(&below), "{below}");
        // Straight up, a sharp lobe never goes below.
        assert!((0..2000).all(|k| sample(Vec3::Y, n, 50.0, uniforms(k, 0, 0, 0)).is_some()));
    }

    /// The cone half-angle: Eq. 4.1 at xi = 0.244 (the fraction of the lobe's samples inside the
    /// cone is 1 - 0.244 by the inverse CDF), narrowing with the power, 0 at the mirror cap.
    #[test]
    fn cone_angle() {
        for n in [1.0f32, 16.0, 64.0, 256.0] {
            let theta = cone_half_angle(n);
            let inside = (0..20000)
                .filter(|&k| sample_around(Vec3::Z, n, uniforms(k, 1, 2, 0)).z >= theta.cos())
                .count();
            let share = inside as f64 / 20000.0;
            assert!(
                (share - (1.0 - f64::from(CONE_XI))).abs() < 0.01,
                "{n}: {share}"
            );
        }
        assert!((cone_half_angle(64.0).to_degrees() - 11.9).abs() < 0.05);
        assert!(cone_half_angle(16.0) > cone_half_angle(64.0));
        assert_eq!(cone_half_angle(MIRROR_POWER), 0.0);
        assert_eq!(cone_half_angle(4096.0), 0.0);
    }
}
