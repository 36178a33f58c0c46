#![forbid(unsafe_code)]
//! The statistics of a run's frames: median, min and max ([`Stats`]), per pass ([`PassStats`],
//! [`pass_stats`], [`frame_stats`]) and the pixel records' mean counters ([`Counters`]).

use serde::Serialize;

use crate::vk::PassTime;
use crate::vk::frame::GpuFrame;

/// Median, min and max of a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Stats {
    /// `None` for an empty sample. NaNs sort last (`total_cmp`).
    pub fn of(values: &[f64]) -> Option<Stats> {
        if values.is_empty() {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Some(Stats {
            median,
            min: v[0],
            max: v[n - 1],
        })
    }
}

/// GPU time of one pass over the timed frames, nanoseconds.
#[derive(Clone, Debug, Serialize)]
pub struct PassStats {
    pub pass: String,
    pub ns: Stats,
}

/// Mean per-ray counters of the pixel records, over mirror pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Counters {
    pub cells: f64,
    pub texels: f64,
    /// CMO traces per ray (1 + handoffs to further CMOs).
    pub traces: f64,
    /// Reflection-point method: search steps per searched vertex in the frame, mean and max
    /// (the paper's Table 1); 0 for the other methods.
    pub search_mean: f64,
    pub search_max: u32,
}

impl Counters {
    /// Means over mirror pixels of `frame`.
    pub fn of(frame: &GpuFrame) -> Counters {
        let (mut c, mut n) = (Counters::default(), 0usize);
        for (r, _) in frame
            .records
            .iter()
            .zip(&frame.mask)
            .filter(|(_, m)| **m != 0)
        {
            c.cells += f64::from(r.cells);
            c.texels += f64::from(r.texels);
            c.traces += f64::from(r.traces);
            n += 1;
        }
        let n = n.max(1) as f64;
        Counters {
            cells: c.cells / n,
            texels: c.texels / n,
            traces: c.traces / n,
            search_mean: frame.search.map_or(0.0, |s| s.mean_iterations),
            search_max: frame.search.map_or(0, |s| s.max_iterations),
        }
    }
}

/// Statistics over frames of one pass's time (`Some(name)`) or of the sum of all passes.
pub fn frame_stats(pass_ns: &[Vec<PassTime>], pass: Option<&str>) -> Stats {
    let per_frame: Vec<f64> = pass_ns
        .iter()
        .map(|f| {
            f.iter()
                .filter(|(n, _)| pass.is_none_or(|p| p == n))
                .map(|(_, t)| t)
                .sum()
        })
        .collect();
    Stats::of(&per_frame).unwrap_or_default()
}

/// Per-pass statistics over frames, in the first frame's pass order; passes of one name (a
/// glossy frame's two captures under `--criterion bounded`: the colour's and the lists') are
/// summed into one row.
pub fn pass_stats(pass_ns: &[Vec<PassTime>]) -> Vec<PassStats> {
    let Some(first) = pass_ns.first() else {
        return Vec::new();
    };
    let mut seen = std::collections::HashSet::new();
    first
        .iter()
        .filter(|(name, _)| seen.insert(name.as_str()))
        .filter_map(|(name, _)| {
            let v: Vec<f64> = pass_ns
                .iter()
                .map(|f| f.iter().filter(|(n, _)| n == name).map(|(_, t)| t).sum())
                .collect();
            Some(PassStats {
                pass: name.clone(),
                ns: Stats::of(&v)?,
            })
        })
        .collect()
}

/// [`frame_stats`] of the pass `name` where it ran (it is in `passes`), else zero.
pub(super) fn optional_pass(pass_ns: &[Vec<PassTime>], passes: &[PassStats], name: &str) -> Stats {
    if passes.iter().any(|p| p.pass == name) {
        frame_stats(pass_ns, Some(name))
    } else {
        Stats::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_median_min_max() {
        let s = Stats::of(&[3.0, 1.0, 2.0]).unwrap();
        assert_eq!((s.median, s.min, s.max), (2.0, 1.0, 3.0));
        let s = Stats::of(&[4.0, 1.0, 2.0, 3.0]).unwrap();
        assert_eq!(s.median, 2.5);
        assert!(Stats::of(&[]).is_none());
    }

    #[test]
    fn pass_stats_per_pass() {
        let f = |a: f64, b: f64| vec![("capture".to_string(), a), ("envmap".to_string(), b)];
        let s = pass_stats(&[f(1.0, 10.0), f(3.0, 30.0), f(2.0, 20.0)]);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].pass, "capture");
        assert_eq!((s[0].ns.median, s[0].ns.min, s[0].ns.max), (2.0, 1.0, 3.0));
        assert_eq!(s[1].ns.median, 20.0);
        // Two passes of one name: one row, their sum.
        let g = |a: f64, b: f64| vec![("capture".to_string(), a), ("capture".to_string(), b)];
        let s = pass_stats(&[g(1.0, 10.0), g(3.0, 30.0)]);
        assert_eq!(s.len(), 1);
        assert_eq!((s[0].ns.min, s[0].ns.max), (11.0, 33.0));
    }
}
