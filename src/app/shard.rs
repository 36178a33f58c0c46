#![forbid(unsafe_code)]
//! Which part of a frame range this run renders: `--shard I/N`, or the array index a scheduler
//! hands each task (Slurm job arrays, Kubernetes Indexed Jobs).
//!
//! - [`resolve`] settles the shard, in this order: `--shard I/N` (0-based `I`); else Slurm's
//!   `SLURM_ARRAY_TASK_ID` with `SLURM_ARRAY_TASK_COUNT` and `SLURM_ARRAY_TASK_MIN` (and
//!   `_MAX`/`_STEP` when set); else Kubernetes' `JOB_COMPLETION_INDEX` with the completion count
//!   given as `--shard-count N`; `None` (the whole range) when none applies. The environment is
//!   passed in, so tests inject it.
//! - [`select`] cuts the frame list into `N` contiguous chunks whose sizes differ by at most one
//!   and returns chunk `I`: the chunks cover every frame exactly once, in order, so frames
//!   rendered over any `N` are the frames of one run.
//!
//! A Slurm array is read as one contiguous range of ids (`--array=0-7`, `--array=1-8`,
//! `--array=0-14:2`); an array with gaps (`--array=3,7`, as a rerun of failed tasks is
//! submitted) has no chunk numbering of its own and is refused with a message naming the
//! variables: such a job passes its chunk explicitly, `--shard $SLURM_ARRAY_TASK_ID/N`, as the
//! scripts of `cubetrace farm` do.

use std::fmt;

use anyhow::{Result, bail};

/// One task's share of a frame range: chunk `index` (0-based) of `count`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
    /// Where the shard came from, for the log and messages.
    pub source: ShardSource,
}

/// Where a [`Shard`] came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShardSource {
    /// `--shard I/N`.
    Flag,
    /// A Slurm job array: `SLURM_ARRAY_TASK_ID` and the array's min, step and count.
    Slurm { id: u64, min: u64, step: u64 },
    /// A Kubernetes Indexed Job: `JOB_COMPLETION_INDEX`, the count from `--shard-count`.
    Kubernetes,
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (i, n) = (self.index, self.count);
        match &self.source {
            ShardSource::Flag => write!(f, "shard {i}/{n} (--shard {i}/{n})"),
            ShardSource::Slurm { id, min, step } => write!(
                f,
                "shard {i}/{n} (SLURM_ARRAY_TASK_ID={id}, SLURM_ARRAY_TASK_MIN={min}, \
                 step {step}, SLURM_ARRAY_TASK_COUNT={n})"
            ),
            ShardSource::Kubernetes => {
                write!(
                    f,
                    "shard {i}/{n} (JOB_COMPLETION_INDEX={i}, --shard-count {n})"
                )
            }
        }
    }
}

/// The shard flags of `cubetrace render`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ShardArgs {
    /// Render only chunk I of N of the frames (0-based: `--shard 0/4` .. `--shard 3/4`): the
    /// range is cut into N contiguous chunks whose sizes differ by at most one, so the N runs
    /// together render every frame once. Without it, the chunk comes from the scheduler: a Slurm
    /// job array (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN, SLURM_ARRAY_TASK_COUNT; one
    /// contiguous range of ids) or a Kubernetes Indexed Job (JOB_COMPLETION_INDEX with
    /// --shard-count). `--shard 0/1` renders the whole range whatever the environment says.
    #[arg(long, value_name = "I/N", conflicts_with = "shard_count")]
    pub shard: Option<String>,
    /// The number of chunks of a Kubernetes Indexed Job (its `completions`): the chunk index is
    /// read from JOB_COMPLETION_INDEX.
    #[arg(long, value_name = "N")]
    pub shard_count: Option<u32>,
}

impl ShardArgs {
    /// [`resolve`] with the process's environment.
    pub fn resolve(&self) -> Result<Option<Shard>> {
        resolve(self.shard.as_deref(), self.shard_count, &|k| {
            std::env::var(k).ok()
        })
    }
}

const SLURM_ID: &str = "SLURM_ARRAY_TASK_ID";
const SLURM_COUNT: &str = "SLURM_ARRAY_TASK_COUNT";
const SLURM_MIN: &str = "SLURM_ARRAY_TASK_MIN";
const SLURM_MAX: &str = "SLURM_ARRAY_TASK_MAX";
const SLURM_STEP: &str = "SLURM_ARRAY_TASK_STEP";
const K8S_INDEX: &str = "JOB_COMPLETION_INDEX";

/// The shard of this run: `--shard I/N` (`arg`), else a Slurm array task, else a Kubernetes
/// Indexed Job (`count` is its `--shard-count`); `None` when none applies. `env` reads an
/// environment variable. An explicit `--shard` wins over the environment; the source used is
/// logged (info). Every refusal names the flag or variable and its value.
pub fn resolve(
    arg: Option<&str>,
    count: Option<u32>,
    env: &dyn Fn(&str) -> Option<String>,
) -> Result<Option<Shard>> {
    let shard = if let Some(arg) = arg {
        if let Some(n) = count {
            bail!(
                "--shard {arg} carries its own count; --shard-count {n} is for \
                 JOB_COMPLETION_INDEX (Kubernetes): give one of them"
            );
        }
        let shard = parse_flag(arg)?;
        for var in [SLURM_ID, K8S_INDEX] {
            if let Some(v) = env(var) {
                log::info!("--shard {arg} given: {var}={v} is not read");
            }
        }
        Some(shard)
    } else if let Some(n) = count {
        Some(kubernetes(env, n)?)
    } else if env(SLURM_ID).is_some() {
        Some(slurm(env)?)
    } else if let Some(v) = env(K8S_INDEX) {
        bail!(
            "{K8S_INDEX}={v} is set (a Kubernetes Indexed Job) but --shard-count is not: pass \
             the Job's completions, e.g. --shard-count 8 (or --shard 0/1 to render every frame)"
        );
    } else {
        None
    };
    if let Some(s) = &shard {
        log::info!("rendering {s}");
    }
    Ok(shard)
}

/// `I/N` of `--shard`.
fn parse_flag(arg: &str) -> Result<Shard> {
    let bad = || {
        anyhow::anyhow!(
            "--shard {arg:?}: expected I/N, chunk I of N with I counted from 0 (e.g. --shard 0/4 \
             .. --shard 3/4)"
        )
    };
    let (i, n) = arg.split_once('/').ok_or_else(bad)?;
    let index: u32 = i.trim().parse().map_err(|_| bad())?;
    let count: u32 = n.trim().parse().map_err(|_| bad())?;
    if count == 0 {
        bail!("--shard {arg}: the count N must be at least 1");
    }
    if index >= count {
        bail!(
            "--shard {arg}: the index must be below the count; indices are 0-based (0..{} for \
             {count} shards)",
            count - 1
        );
    }
    Ok(Shard {
        index,
        count,
        source: ShardSource::Flag,
    })
}

/// A variable holding a whole number, `None` when unset; a refusal naming it otherwise.
fn number(env: &dyn Fn(&str) -> Option<String>, var: &str) -> Result<Option<u64>> {
    match env(var) {
        None => Ok(None),
        Some(v) => match v.trim().parse::<u64>() {
            Ok(x) => Ok(Some(x)),
            Err(_) => bail!("{var}={v:?} is not a whole number"),
        },
    }
}

/// The chunk of a Kubernetes Indexed Job: `JOB_COMPLETION_INDEX` of `--shard-count`.
fn kubernetes(env: &dyn Fn(&str) -> Option<String>, count: u32) -> Result<Shard> {
    if count == 0 {
        bail!("--shard-count 0: the count must be at least 1");
    }
    let Some(index) = number(env, K8S_INDEX)? else {
        bail!(
            "--shard-count {count} needs {K8S_INDEX} (set in each pod of a Kubernetes Indexed \
             Job), which is not set; to render one chunk by hand use --shard I/{count}"
        );
    };
    if index >= u64::from(count) {
        bail!(
            "{K8S_INDEX}={index} is not below --shard-count {count} (indices are 0-based): \
             --shard-count must be the Job's completions"
        );
    }
    Ok(Shard {
        index: index as u32,
        count,
        source: ShardSource::Kubernetes,
    })
}

/// The chunk of a Slurm array task: `(ID - MIN) / STEP` of `COUNT`, the array one contiguous
/// range of ids (checked against `MAX` when set).
fn slurm(env: &dyn Fn(&str) -> Option<String>) -> Result<Shard> {
    let need = |var: &str| -> Result<u64> {
        number(env, var)?.ok_or_else(|| {
            anyhow::anyhow!(
                "{SLURM_ID} is set but {var} is not; pass the chunk explicitly: --shard \
                 $SLURM_ARRAY_TASK_ID/N"
            )
        })
    };
    let id = need(SLURM_ID)?;
    let count = need(SLURM_COUNT)?;
    let min = need(SLURM_MIN)?;
    let step = number(env, SLURM_STEP)?.unwrap_or(1);
    let explicit = "pass the chunk explicitly: --shard $SLURM_ARRAY_TASK_ID/N with N the \
                    original array's size";
    if count == 0 || count > u64::from(u32::MAX) {
        bail!("{SLURM_COUNT}={count} is not a usable number of array tasks");
    }
    if step == 0 {
        bail!("{SLURM_STEP}=0 is not a step");
    }
    if id < min || (id - min) % step != 0 {
        bail!("{SLURM_ID}={id} is not in the array {SLURM_MIN}={min} with step {step}; {explicit}");
    }
    let index = (id - min) / step;
    if let Some(max) = number(env, SLURM_MAX)? {
        let span = max.checked_sub(min).map(|d| d / step + 1);
        if span != Some(count) {
            bail!(
                "the job array is not one contiguous range: {SLURM_MIN}={min}, \
                 {SLURM_MAX}={max} (step {step}) but {SLURM_COUNT}={count} (a rerun of some \
                 tasks, e.g. --array=3,7?); {explicit}"
            );
        }
    }
    if index >= count {
        bail!(
            "{SLURM_ID}={id} is beyond the array ({SLURM_MIN}={min}, step {step}, \
             {SLURM_COUNT}={count}); {explicit}"
        );
    }
    Ok(Shard {
        index: index as u32,
        count: count as u32,
        source: ShardSource::Slurm { id, min, step },
    })
}

/// The range `[start, end)` of positions of chunk `index` of `count` over `len` items: chunk `i`
/// starts at `floor(i * len / count)`, so the chunks are contiguous, in order, cover every item
/// once, and their sizes differ by at most one.
pub fn chunk(len: usize, index: u32, count: u32) -> std::ops::Range<usize> {
    let at = |i: u32| (len as u128 * u128::from(i) / u128::from(count.max(1))) as usize;
    at(index.min(count))..at((index + 1).min(count))
}

/// The shard's contiguous chunk of `frames` (all of them without a shard); see [`chunk`].
pub fn select(frames: &[i64], shard: Option<&Shard>) -> Vec<i64> {
    match shard {
        None => frames.to_vec(),
        Some(s) => frames[chunk(frames.len(), s.index, s.count)].to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env_of(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> + use<> {
        let map: HashMap<String, String> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k: &str| map.get(k).cloned()
    }

    fn ok(arg: Option<&str>, count: Option<u32>, vars: &[(&str, &str)]) -> Option<(u32, u32)> {
        resolve(arg, count, &env_of(vars))
            .unwrap_or_else(|e| panic!("{arg:?} {count:?} {vars:?}: {e:#}"))
            .map(|s| (s.index, s.count))
    }

    fn err(arg: Option<&str>, count: Option<u32>, vars: &[(&str, &str)]) -> String {
        match resolve(arg, count, &env_of(vars)) {
            Ok(s) => panic!("{arg:?} {count:?} {vars:?} accepted as {s:?}"),
            Err(e) => format!("{e:#}"),
        }
    }

    /// What is wrong with cutting `frames` into `n` chunks with `cut` (a [`chunk`]-like
    /// function): frames lost, doubled or out of order, or sizes more than one apart.
    fn partition_problem(
        frames: &[i64],
        n: u32,
        cut: impl Fn(usize, u32, u32) -> std::ops::Range<usize>,
    ) -> Option<String> {
        let parts: Vec<Vec<i64>> = (0..n)
            .map(|i| frames[cut(frames.len(), i, n)].to_vec())
            .collect();
        if parts.concat() != frames {
            return Some(format!(
                "{n} chunks {parts:?} are not the frames {frames:?}"
            ));
        }
        let sizes: Vec<usize> = parts.iter().map(Vec::len).collect();
        let (lo, hi) = (sizes.iter().min()?, sizes.iter().max()?);
        (hi - lo > 1).then(|| format!("{n} chunks of sizes {sizes:?}"))
    }

    /// Frames that are not positions (a step and an offset), so a chunk of positions mistaken
    /// for one of frame numbers would show.
    fn frames(len: usize) -> Vec<i64> {
        (0..len as i64).map(|i| 7 + 3 * i).collect()
    }

    #[test]
    fn chunks_cover_every_frame_once_in_order_and_balanced() {
        for len in 0..=30usize {
            for n in 1..=10u32 {
                assert_eq!(partition_problem(&frames(len), n, chunk), None);
                // select is chunk applied to the list.
                let s = Shard {
                    index: n / 2,
                    count: n,
                    source: ShardSource::Flag,
                };
                let f = frames(len);
                assert_eq!(select(&f, Some(&s)), f[chunk(len, n / 2, n)].to_vec());
            }
        }
        assert_eq!(select(&[1, 2, 3], None), vec![1, 2, 3]);
    }

    #[test]
    fn the_partition_check_catches_wrong_chunkings() {
        // Negatives: chunks of ceil(len / n) (10 over 4: 3, 3, 3, 1) are unbalanced; an end one
        // past the chunk's doubles frames; chunks that skip the last frame lose it.
        let ceil = |len: usize, i: u32, n: u32| {
            let c = len.div_ceil(n as usize);
            (i as usize * c).min(len)..((i as usize + 1) * c).min(len)
        };
        assert!(partition_problem(&frames(10), 4, ceil).is_some());
        let long = |len: usize, i: u32, n: u32| {
            let r = chunk(len, i, n);
            r.start..(r.end + 1).min(len)
        };
        assert!(partition_problem(&frames(10), 4, long).is_some());
        let short = |len: usize, i: u32, n: u32| chunk(len.saturating_sub(1), i, n);
        assert!(partition_problem(&frames(10), 4, short).is_some());
    }

    #[test]
    fn the_flag_is_parsed_and_wins_over_the_environment() {
        assert_eq!(ok(None, None, &[]), None);
        assert_eq!(ok(Some("0/1"), None, &[]), Some((0, 1)));
        assert_eq!(ok(Some("3/4"), None, &[]), Some((3, 4)));
        assert_eq!(ok(Some(" 2 / 5 "), None, &[]), Some((2, 5)));
        let slurm = [
            ("SLURM_ARRAY_TASK_ID", "1"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("JOB_COMPLETION_INDEX", "2"),
        ];
        assert_eq!(ok(Some("0/1"), None, &slurm), Some((0, 1)));
        let s = resolve(Some("1/2"), None, &env_of(&slurm))
            .unwrap()
            .unwrap();
        assert_eq!(s.source, ShardSource::Flag);
        assert_eq!(s.to_string(), "shard 1/2 (--shard 1/2)");
    }

    #[test]
    fn a_wrong_flag_is_refused_by_name() {
        let e = err(Some("4/4"), None, &[]);
        assert!(e.contains("--shard 4/4") && e.contains("0-based"), "{e}");
        assert!(e.contains("0..3"), "{e}");
        let e = err(Some("0/0"), None, &[]);
        assert!(e.contains("--shard 0/0") && e.contains("at least 1"), "{e}");
        for bad in [
            "", "3", "1/", "/4", "a/4", "1/b", "-1/4", "1/4/5", "1.5/4", "1:4",
        ] {
            let e = err(Some(bad), None, &[]);
            assert!(e.contains("--shard") && e.contains("I/N"), "{bad:?}: {e}");
            assert!(e.contains("from 0"), "{bad:?}: {e}");
        }
        let e = err(Some("0/2"), Some(2), &[]);
        assert!(e.contains("--shard-count"), "{e}");
    }

    #[test]
    fn slurm_arrays_give_the_chunk() {
        let task = |id: u32| id.to_string();
        // --array=0-3
        for id in 0..4 {
            let id_s = task(id);
            let vars = [
                ("SLURM_ARRAY_TASK_ID", id_s.as_str()),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
            ];
            assert_eq!(ok(None, None, &vars), Some((id, 4)));
        }
        // --array=1-8 (1-based ids): the index is ID - MIN, with or without MAX.
        let mut vars = vec![
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ];
        assert_eq!(ok(None, None, &vars), Some((4, 8)));
        vars.push(("SLURM_ARRAY_TASK_MAX", "8"));
        assert_eq!(ok(None, None, &vars), Some((4, 8)));
        // --array=0-14:2 (ids 0, 2, .., 14: eight tasks).
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "6"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "14"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ];
        assert_eq!(ok(None, None, &vars), Some((3, 8)));
        let s = resolve(None, None, &env_of(&vars)).unwrap().unwrap();
        assert_eq!(
            s.source,
            ShardSource::Slurm {
                id: 6,
                min: 0,
                step: 2
            }
        );
        assert!(s.to_string().contains("SLURM_ARRAY_TASK_ID=6"), "{s}");
    }

    #[test]
    fn slurm_arrays_that_do_not_number_chunks_are_refused() {
        // --array=3,7 (a rerun of two failed tasks): MIN 3, MAX 7, COUNT 2.
        let gaps = [
            ("SLURM_ARRAY_TASK_ID", "7"),
            ("SLURM_ARRAY_TASK_MIN", "3"),
            ("SLURM_ARRAY_TASK_MAX", "7"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
        ];
        let e = err(None, None, &gaps);
        assert!(e.contains("not one contiguous range"), "{e}");
        assert!(
            e.contains("SLURM_ARRAY_TASK_MAX=7") && e.contains("--shard"),
            "{e}"
        );
        // ... and the explicit flag makes the same task work.
        assert_eq!(ok(Some("7/8"), None, &gaps), Some((7, 8)));
        // Missing count or min.
        let e = err(None, None, &[("SLURM_ARRAY_TASK_ID", "1")]);
        assert!(e.contains("SLURM_ARRAY_TASK_COUNT"), "{e}");
        let e = err(
            None,
            None,
            &[
                ("SLURM_ARRAY_TASK_ID", "1"),
                ("SLURM_ARRAY_TASK_COUNT", "2"),
            ],
        );
        assert!(e.contains("SLURM_ARRAY_TASK_MIN"), "{e}");
        // Not a number.
        let e = err(
            None,
            None,
            &[
                ("SLURM_ARRAY_TASK_ID", "x"),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "2"),
            ],
        );
        assert!(e.contains("SLURM_ARRAY_TASK_ID=\"x\""), "{e}");
        // An id below the min, off the step, beyond the count; a zero count or step.
        for (id, min, count, step) in [
            ("0", "1", "4", "1"),
            ("3", "0", "4", "2"),
            ("4", "0", "4", "1"),
            ("0", "0", "0", "1"),
            ("0", "0", "4", "0"),
        ] {
            let vars = [
                ("SLURM_ARRAY_TASK_ID", id),
                ("SLURM_ARRAY_TASK_MIN", min),
                ("SLURM_ARRAY_TASK_COUNT", count),
                ("SLURM_ARRAY_TASK_STEP", step),
            ];
            let e = err(None, None, &vars);
            assert!(e.contains("SLURM_ARRAY_TASK_"), "{vars:?}: {e}");
        }
    }

    #[test]
    fn kubernetes_indexed_jobs_need_the_count() {
        let k = [("JOB_COMPLETION_INDEX", "2")];
        assert_eq!(ok(None, Some(3), &k), Some((2, 3)));
        let s = resolve(None, Some(3), &env_of(&k)).unwrap().unwrap();
        assert_eq!(s.source, ShardSource::Kubernetes);
        let e = err(None, None, &k);
        assert!(
            e.contains("JOB_COMPLETION_INDEX=2") && e.contains("--shard-count"),
            "{e}"
        );
        let e = err(None, Some(2), &k);
        assert!(
            e.contains("JOB_COMPLETION_INDEX=2") && e.contains("0-based"),
            "{e}"
        );
        let e = err(None, Some(0), &k);
        assert!(e.contains("--shard-count 0"), "{e}");
        let e = err(None, Some(4), &[]);
        assert!(
            e.contains("--shard-count 4 needs JOB_COMPLETION_INDEX"),
            "{e}"
        );
        let e = err(None, Some(4), &[("JOB_COMPLETION_INDEX", "-1")]);
        assert!(e.contains("JOB_COMPLETION_INDEX=\"-1\""), "{e}");
        // --shard-count names the Kubernetes source even inside a Slurm task.
        let both = [
            ("JOB_COMPLETION_INDEX", "1"),
            ("SLURM_ARRAY_TASK_ID", "0"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert_eq!(ok(None, Some(2), &both), Some((1, 2)));
        assert_eq!(ok(None, None, &both), Some((0, 4)));
    }
}
