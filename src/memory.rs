#![forbid(unsafe_code)]
//! Memory a render needs, estimated before it starts, against the memory the machine has: a
//! render that cannot fit is refused with both figures instead of growing until the system
//! kills it. The estimates count the per-pixel data the render holds at its peak (the sizes of
//! the real types where they are in Rust). What does not grow with the frame is left out: the
//! scene and the program are already in the process when the machine's available memory is
//! read, and the reference's BVH is of the scene's size.
//!
//! The machine's limit: `MemAvailable` of `/proc/meminfo`, lowered by a cgroup v2 memory limit
//! (`memory.max` less `memory.current`) and by `CUBETRACE_MEMORY_LIMIT` (bytes, or with a `K`,
//! `M`, `G` or `T` suffix in powers of 1024), whichever are there. With none of them (not Linux)
//! nothing is refused. The GPU side is held against the device's largest device-local heap
//! ([`crate::vk::GpuContext::device_local_heap_bytes`]) and the same variable.

use std::path::Path;

use anyhow::{Result, bail};
use glam::Vec3;

use crate::metrics::PixelError;
use crate::output::Format;
use crate::reference::PathResult;

/// The environment variable that caps the memory a render may take (see the module docs).
pub const LIMIT_ENV: &str = "CUBETRACE_MEMORY_LIMIT";

/// Bytes per pixel of a [`crate::reference::Frame`]: colour, surface and hit positions, mask,
/// object, primitive and global triangle ids, bounces, the last hit's position and triangle.
pub const REFERENCE_FRAME_BYTES: u64 =
    3 * size_of::<Vec3>() as u64 + 1 + 4 + 4 + 4 + 1 + size_of::<Vec3>() as u64 + 4;

/// Bytes per pixel of writing an image: PNG: 8-bit RGB plus the encoded file (at most about the
/// same again); EXR: `channels` 32-bit channels, built and then encoded into memory before the
/// atomic write.
pub fn output_bytes_per_pixel(format: Format, channels: u64) -> u64 {
    match format {
        Format::Png => 3 + 3,
        Format::Exr => 2 * 4 * channels,
    }
}

/// Bytes of a reference render of `pixels` written as `format`: the frame, plus at once either
/// the rows of path results it is assembled from or the output encoding.
pub fn reference_bytes(pixels: u64, format: Format) -> u64 {
    let rows = size_of::<PathResult>() as u64;
    let output = output_bytes_per_pixel(format, 13);
    pixels * (REFERENCE_FRAME_BYTES + rows.max(output))
}

/// Host bytes of a GPU render of `pixels` written as `format`, and with `compare` the
/// reference and the per-pixel verdicts too. The read-back frame (colour, mask, surface
/// position, records) is held throughout; at its peak the read-back holds the raw colour,
/// records and position beside their staging buffer; then the [`crate::metrics::Traced`] copy
/// and the output encoding; with `compare` the reference's frame and rows and the verdicts.
pub fn gpu_host_bytes(pixels: u64, format: Format, compare: bool) -> u64 {
    let record = size_of::<crate::vk::frame::PixelRecord>() as u64;
    let frame = 2 * size_of::<Vec3>() as u64 + 1 + record;
    let readback = 16 + record + 16 + record;
    // Colour, hit position, mask, resolved, bounces.
    let traced = 2 * size_of::<Vec3>() as u64 + 2 + 4;
    let output = traced + output_bytes_per_pixel(format, 12);
    let reference = if compare {
        traced
            + REFERENCE_FRAME_BYTES
            + (size_of::<PathResult>() as u64).max(size_of::<PixelError>() as u64)
    } else {
        0
    };
    pixels * (frame + readback.max(output).max(reference))
}

/// Parses a memory size: bytes, or a number with a `K`, `M`, `G` or `T` suffix (powers of
/// 1024, an optional `B` or `iB` after it).
pub fn parse_size(text: &str) -> Option<u64> {
    let t = text.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (number, shift) = match t.chars().last()? {
        'K' | 'k' => (&t[..t.len() - 1], 10),
        'M' | 'm' => (&t[..t.len() - 1], 20),
        'G' | 'g' => (&t[..t.len() - 1], 30),
        'T' | 't' => (&t[..t.len() - 1], 40),
        _ => (t, 0),
    };
    let v: f64 = number.trim().parse().ok()?;
    (v.is_finite() && v >= 0.0).then(|| (v * (1u64 << shift) as f64) as u64)
}

/// A size for a message: `1.50 GiB`, `12.0 MiB`, `512 bytes`.
pub fn human(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= (1u64 << 30) as f64 {
        format!("{:.2} GiB", b / (1u64 << 30) as f64)
    } else if b >= (1u64 << 20) as f64 {
        format!("{:.1} MiB", b / (1u64 << 20) as f64)
    } else if b >= 1024.0 {
        format!("{:.1} KiB", b / 1024.0)
    } else {
        format!("{bytes} bytes")
    }
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
pub fn mem_available(meminfo: &str) -> Option<u64> {
    meminfo.lines().find_map(|l| {
        let rest = l.strip_prefix("MemAvailable:")?;
        let kib: u64 = rest.trim().strip_suffix("kB")?.trim().parse().ok()?;
        Some(kib * 1024)
    })
}

/// The cap set by [`LIMIT_ENV`], if set; an error names the variable when it is malformed.
pub fn env_limit() -> Result<Option<u64>> {
    match std::env::var(LIMIT_ENV) {
        Ok(v) => match parse_size(&v) {
            Some(b) => Ok(Some(b)),
            None => {
                bail!("{LIMIT_ENV}={v}: not a memory size (bytes, or a number with K, M, G or T)")
            }
        },
        Err(_) => Ok(None),
    }
}

/// The host memory a render may take now, with where the figure comes from; `None` where
/// nothing tells (see the module docs).
pub fn host_available() -> Result<Option<(u64, String)>> {
    let mut best: Option<(u64, String)> = None;
    let mut take = |bytes: u64, from: String| {
        if best.as_ref().is_none_or(|(b, _)| bytes < *b) {
            best = Some((bytes, from));
        }
    };
    if let Some(b) = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .as_deref()
        .and_then(mem_available)
    {
        take(b, "available memory (MemAvailable)".into());
    }
    let cgroup = Path::new("/sys/fs/cgroup");
    let read = |name: &str| {
        std::fs::read_to_string(cgroup.join(name))
            .ok()
            .and_then(|s| s.trim().parse::<u64>().ok())
    };
    if let (Some(max), Some(current)) = (read("memory.max"), read("memory.current")) {
        take(
            max.saturating_sub(current),
            "the cgroup's memory limit less its use".into(),
        );
    }
    if let Some(b) = env_limit()? {
        take(b, LIMIT_ENV.into());
    }
    Ok(best)
}

/// The device memory a render may take: the device's largest device-local heap (`heap`), or
/// [`LIMIT_ENV`] where it is lower; with where the figure comes from.
pub fn device_available(heap: u64) -> Result<(u64, String)> {
    Ok(match env_limit()? {
        Some(b) if b < heap => (b, LIMIT_ENV.to_string()),
        _ => (heap, "the device's largest device-local heap".to_string()),
    })
}

/// What a render may take: the host's and the device's memory, each with where the figure comes
/// from. Render and bench hold their needs against one value of this, so that a test can set
/// both figures without the machine's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limits {
    /// [`host_available`]: `None` where nothing tells (nothing is refused on the host).
    pub host: Option<(u64, String)>,
    /// [`device_available`].
    pub device: (u64, String),
    /// The device's memory is the host's (a CPU driver such as lavapipe): the device's bytes
    /// count against the host's limit too.
    pub device_is_host: bool,
}

impl Limits {
    /// The limits of this machine for a device whose largest device-local heap has `heap` bytes;
    /// `device_is_cpu` as [`crate::vk::GpuContext::device_is_cpu`].
    pub fn of_device(heap: u64, device_is_cpu: bool) -> Result<Self> {
        Ok(Limits {
            host: host_available()?,
            device: device_available(heap)?,
            device_is_host: device_is_cpu,
        })
    }
}

/// What [`check`] suggests: the frame's and the CMOs' knobs.
pub const FRAME_ADVICE: &str = "use a smaller --width/--height (or --cube-size, fewer CMOs)";

/// Refuses `need` bytes for `what` when they exceed `available` (bytes and where the figure
/// comes from); `None` available refuses nothing. The message ends in [`FRAME_ADVICE`].
pub fn check(what: &str, need: u64, available: Option<(u64, String)>) -> Result<()> {
    check_with(what, need, available, FRAME_ADVICE)
}

/// [`check`] with the refusal's own `advice` (what takes the memory and what would fix it).
pub fn check_with(
    what: &str,
    need: u64,
    available: Option<(u64, String)>,
    advice: &str,
) -> Result<()> {
    match available {
        Some((have, from)) if need > have => bail!(
            "{what} needs about {} of memory, more than the {} this machine can give ({from}); \
             {advice}",
            human(need),
            human(have)
        ),
        _ => Ok(()),
    }
}

/// The advice of a refusal from what takes the memory, largest first (`(name, bytes)`, as
/// `vk::budget::largest_items` lists them): the three largest with their sizes, then what
/// would shrink the largest (a texture: a smaller image; CMO data: --cube-size or fewer CMOs;
/// the frame: --width/--height; geometry: fewer triangles).
pub fn advice(items: &[(String, u64)]) -> String {
    let Some((first, _)) = items.first() else {
        return FRAME_ADVICE.to_string();
    };
    let listed: Vec<String> = items
        .iter()
        .take(3)
        .map(|(name, bytes)| format!("{name}: {}", human(*bytes)))
        .collect();
    let fix = if first.starts_with("texture") {
        "scale that texture down (each halving of its sides takes 3/4 off)"
    } else if first.starts_with("CMO") && first.contains("--list-size") {
        "use a smaller --list-size or fewer CMOs (--cmos)"
    } else if first.starts_with("CMO") {
        "use a smaller --cube-size or fewer CMOs (--cmos)"
    } else if first.starts_with("frame") {
        "use a smaller --width/--height"
    } else {
        "use a mesh with fewer triangles"
    };
    format!("the largest items: {}; to fit, {fix}", listed.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_issue_s_reference_frame_is_large() {
        // `--method reference --width 16384 --height 16384` grew past 14 GB in the issue's run
        // (and had not finished): the estimate must be above that.
        let need = reference_bytes(16384 * 16384, Format::Png);
        assert!(need > 14_000_000_000, "{}", human(need));
        assert!(need < 64_000_000_000, "{}", human(need));
        // Negative: a small frame is small, and EXR costs more than PNG.
        assert!(reference_bytes(160 * 120, Format::Png) < 4 << 20);
        assert!(reference_bytes(1000, Format::Exr) > reference_bytes(1000, Format::Png));
        // The comparison's data comes after the read-back's peak is freed: no more, no less.
        assert!(
            gpu_host_bytes(1000, Format::Png, true) >= gpu_host_bytes(1000, Format::Png, false)
        );
        assert_eq!(
            gpu_host_bytes(2000, Format::Exr, true),
            2 * gpu_host_bytes(1000, Format::Exr, true)
        );
    }

    #[test]
    fn check_refuses_with_both_figures() {
        let e = check("a frame", 3 << 30, Some((1 << 30, "test".into())))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("3.00 GiB") && e.contains("1.00 GiB") && e.contains("test"),
            "{e}"
        );
        // Negative: what fits, or where nothing is known, passes.
        check("a frame", 1 << 30, Some((1 << 30, "test".into()))).unwrap();
        check("a frame", u64::MAX, None).unwrap();
    }

    #[test]
    fn advice_names_the_largest_item_and_its_fix() {
        let items = vec![
            ("texture 'floor' 8192x8192".to_string(), 256u64 << 20),
            (
                "CMO data (2 CMOs of 256^2 texels per face)".to_string(),
                30 << 20,
            ),
            (
                "frame buffers (64x48, --method compute)".to_string(),
                1 << 20,
            ),
            ("scene geometry (12 triangles)".to_string(), 2 << 10),
        ];
        let a = advice(&items);
        assert!(a.contains("texture 'floor' 8192x8192: 256.0 MiB"), "{a}");
        assert!(a.contains("scale that texture down"), "{a}");
        assert!(!a.contains("scene geometry"), "three items only: {a}");
        // Negative: with the CMOs first, the advice is theirs, not the texture's.
        let a = advice(&items[1..]);
        assert!(a.contains("--cube-size") && !a.contains("texture"), "{a}");
        // The bounded criterion's lists at a size of their own: that size is the fix.
        let lists = [(
            "CMO data (2 CMOs, their lists of 4096^2 texels per face: --list-size)".to_string(),
            10 << 30,
        )];
        let a = advice(&lists);
        assert!(
            a.contains("a smaller --list-size") && !a.contains("--cube-size"),
            "{a}"
        );
        assert_eq!(advice(&[]), FRAME_ADVICE);
    }

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("1024"), Some(1024));
        assert_eq!(parse_size("64M"), Some(64 << 20));
        assert_eq!(parse_size("1.5GiB"), Some(3 << 29));
        assert_eq!(parse_size("2 G"), Some(2 << 30));
        assert_eq!(parse_size("10KB"), Some(10 << 10));
        // Negative: not sizes.
        for bad in ["", "G", "-1M", "ten", "1X", "nan"] {
            assert_eq!(parse_size(bad), None, "{bad}");
        }
        let meminfo = "MemTotal:       24000000 kB\nMemFree: 100 kB\nMemAvailable:   21000000 kB\n";
        assert_eq!(mem_available(meminfo), Some(21_000_000 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
    }
}
