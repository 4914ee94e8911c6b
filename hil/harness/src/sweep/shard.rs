//! Which part of the grid one process runs: `--shard I/N`, `auto`, `auto/N` or `all`.
//! Shard `I` of `N` holds the points `i` with `i mod N = I`; the index is derived from
//! the job array, never taken as is:
//!
//! - Slurm: `I = (SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN) / SLURM_ARRAY_TASK_STEP`,
//!   `N = SLURM_ARRAY_TASK_COUNT` (`--array=0-3`, `1-4` and `1-7:2` are all shards `0..3`
//!   of 4); an array that is not one range with one step is refused.
//! - Kubernetes Indexed Jobs: `I = JOB_COMPLETION_INDEX`, `N` from `--shard auto/N`.
//!
//! Without `--shard`, a Slurm array task takes its shard from the array (an Indexed Job
//! is refused for want of `N`); a flag that disagrees with the array is refused, naming
//! both. `--shard all` runs every point whatever the environment.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// Shard `index` of `count`: the points `i` with `i mod count = index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// `I`, from 0.
    pub index: usize,
    /// `N`, at least 1.
    pub count: usize,
}

impl Shard {
    /// Whether grid point `i` is in this shard.
    #[must_use]
    pub fn holds(&self, i: usize) -> bool {
        i % self.count == self.index
    }

    /// The points of a grid of `points` in this shard, in index order.
    pub fn points(&self, points: usize) -> impl Iterator<Item = usize> {
        (self.index..points).step_by(self.count)
    }
}

impl FromStr for Shard {
    type Err = String;

    /// `I/N`, both whole numbers, `I < N`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parse = |x: &str, what: &str| {
            x.trim().parse::<usize>().map_err(|_| {
                format!("`{s}`: {what} `{x}` is not a whole number (expected I/N, e.g. 0/4)")
            })
        };
        let Some((i, n)) = s.split_once('/') else {
            return Err(format!(
                "`{s}`: expected I/N (shard I of N, from 0), e.g. 0/4"
            ));
        };
        let (index, count) = (parse(i, "I")?, parse(n, "N")?);
        if count == 0 {
            return Err(format!("`{s}`: N must be at least 1"));
        }
        if index >= count {
            return Err(format!(
                "`{s}`: I must be below N (the shards of {count} are 0..{})",
                count - 1
            ));
        }
        Ok(Shard { index, count })
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The value of `--shard`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardSpec {
    /// `I/N`.
    Fixed(Shard),
    /// `auto` (`count` None) or `auto/N`: the index from a job array's variables.
    Auto {
        /// `N` of `auto/N`.
        count: Option<usize>,
    },
    /// `all`: every point, whatever the environment.
    All,
}

impl FromStr for ShardSpec {
    type Err = String;

    /// `I/N`, `auto`, `auto/N` or `all`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        if t == "all" {
            return Ok(Self::All);
        }
        if t == "auto" {
            return Ok(Self::Auto { count: None });
        }
        if let Some(n) = t.strip_prefix("auto/") {
            let count = n.trim().parse::<usize>().map_err(|_| {
                format!("`{s}`: N `{n}` is not a whole number (expected auto/N, e.g. auto/8)")
            })?;
            if count == 0 {
                return Err(format!("`{s}`: N must be at least 1"));
            }
            return Ok(Self::Auto { count: Some(count) });
        }
        s.parse::<Shard>().map(Self::Fixed).map_err(|e| {
            if s.contains('/') {
                e
            } else {
                format!("`{s}`: expected I/N (e.g. 0/4), auto, auto/N or all")
            }
        })
    }
}

/// The shard a job array's variables give.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ArrayShard {
    /// The shard's index.
    pub index: usize,
    /// The number of shards, if the environment says (Slurm does, Kubernetes does not).
    pub count: Option<usize>,
    /// The variables it came from, for messages: `SLURM_ARRAY_TASK_ID=5 of the array
    /// 1-7:2 (SLURM_ARRAY_TASK_COUNT=4)` or `JOB_COMPLETION_INDEX=3`.
    pub source: String,
}

fn var(env: &dyn Fn(&str) -> Option<String>, name: &str) -> Option<String> {
    env(name).filter(|v| !v.trim().is_empty())
}

fn number(env: &dyn Fn(&str) -> Option<String>, name: &str, why: &str) -> Result<usize, String> {
    let Some(v) = var(env, name) else {
        return Err(format!(
            "SLURM_ARRAY_TASK_ID is set but {name} is not ({why}); is this a Slurm array task?"
        ));
    };
    whole(name, &v)
}

fn whole(name: &str, v: &str) -> Result<usize, String> {
    v.trim()
        .parse::<usize>()
        .map_err(|_| format!("{name}={v}: not a whole number"))
}

/// Slurm's array variables, if `SLURM_ARRAY_TASK_ID` is set.
fn slurm(env: &dyn Fn(&str) -> Option<String>) -> Result<Option<ArrayShard>, String> {
    let Some(id_text) = var(env, "SLURM_ARRAY_TASK_ID") else {
        return Ok(None);
    };
    let id = whole("SLURM_ARRAY_TASK_ID", &id_text)?;
    let min = number(env, "SLURM_ARRAY_TASK_MIN", "the first task's ID")?;
    let step = number(env, "SLURM_ARRAY_TASK_STEP", "the step between task IDs")?;
    let count = number(env, "SLURM_ARRAY_TASK_COUNT", "the number of shards")?;
    if step == 0 || count == 0 {
        return Err(format!(
            "SLURM_ARRAY_TASK_STEP={step}, SLURM_ARRAY_TASK_COUNT={count}: both must be at least 1"
        ));
    }
    let last = (count - 1)
        .checked_mul(step)
        .and_then(|x| x.checked_add(min))
        .ok_or_else(|| {
            format!("SLURM_ARRAY_TASK_MIN={min}, _STEP={step}, _COUNT={count}: out of range")
        })?;
    let shape = format!(
        "{min}-{last}{}",
        if step > 1 {
            format!(":{step}")
        } else {
            String::new()
        }
    );
    // MAX is absent from some launchers' environments; where it is set it must close
    // the range, or the IDs are a list (`--array=1,2,5`) rather than FIRST-LAST:STEP.
    if let Some(max_text) = var(env, "SLURM_ARRAY_TASK_MAX") {
        let max = whole("SLURM_ARRAY_TASK_MAX", &max_text)?;
        if max != last {
            return Err(format!(
                "the Slurm array (SLURM_ARRAY_TASK_MIN={min}, SLURM_ARRAY_TASK_MAX={max}, \
                 SLURM_ARRAY_TASK_STEP={step}, SLURM_ARRAY_TASK_COUNT={count}) is not one range \
                 with one step, so its tasks cannot be numbered as shards 0..{}: submit \
                 --array=0-{} (or FIRST-LAST:STEP with {count} tasks)",
                count - 1,
                count - 1
            ));
        }
    }
    if id < min || (id - min) % step != 0 || (id - min) / step >= count {
        return Err(format!(
            "SLURM_ARRAY_TASK_ID={id} is not a task of the array {shape} \
             (SLURM_ARRAY_TASK_MIN={min}, SLURM_ARRAY_TASK_STEP={step}, \
             SLURM_ARRAY_TASK_COUNT={count})"
        ));
    }
    Ok(Some(ArrayShard {
        index: (id - min) / step,
        count: Some(count),
        source: format!(
            "SLURM_ARRAY_TASK_ID={id} of the array {shape} (SLURM_ARRAY_TASK_COUNT={count})"
        ),
    }))
}

/// The shard of a job array's environment (`env` looks a variable up): Slurm's array
/// variables or Kubernetes' `JOB_COMPLETION_INDEX`; None outside an array. The error
/// names the variables and why they cannot be a shard.
pub fn array_shard(env: &dyn Fn(&str) -> Option<String>) -> Result<Option<ArrayShard>, String> {
    let s = slurm(env)?;
    let k = match var(env, "JOB_COMPLETION_INDEX") {
        None => None,
        Some(v) => Some(ArrayShard {
            index: whole("JOB_COMPLETION_INDEX", &v)?,
            count: None,
            source: format!("JOB_COMPLETION_INDEX={}", v.trim()),
        }),
    };
    match (s, k) {
        (Some(s), Some(k)) if s.index != k.index => Err(format!(
            "{} and {} give different shards ({} and {}); unset one",
            s.source, k.source, s.index, k.index
        )),
        (Some(s), _) => Ok(Some(s)),
        (None, k) => Ok(k),
    }
}

/// The shard to run: `--shard` (`flag`) checked against the job array's variables
/// (`env`), or taken from them. None: every point. The error names the flag and the
/// variable that disagree.
pub fn resolve(
    flag: Option<ShardSpec>,
    env: &dyn Fn(&str) -> Option<String>,
) -> Result<Option<Shard>, String> {
    if flag == Some(ShardSpec::All) {
        return Ok(None);
    }
    let arr = array_shard(env).map_err(|e| format!("--shard: {e}"))?;
    match (flag, arr) {
        (None, None) | (Some(ShardSpec::All), _) => Ok(None),
        (Some(ShardSpec::Fixed(s)), None) => Ok(Some(s)),
        (Some(ShardSpec::Auto { .. }), None) => Err(
            "--shard auto: not in a job array (neither SLURM_ARRAY_TASK_ID nor \
             JOB_COMPLETION_INDEX is set); give --shard I/N"
                .into(),
        ),
        (None | Some(ShardSpec::Auto { count: None }), Some(a)) => match a.count {
            Some(count) => Ok(Some(Shard {
                index: a.index,
                count,
            })),
            None => Err(format!(
                "--shard: {} gives the shard's index but not the number of shards; give \
                 --shard auto/N (N: the Indexed Job's completions)",
                a.source
            )),
        },
        (Some(ShardSpec::Auto { count: Some(n) }), Some(a)) => {
            if let Some(c) = a.count.filter(|&c| c != n) {
                return Err(format!(
                    "--shard auto/{n} conflicts with {}: the array has {c} tasks; drop the /{n} \
                     or submit {n} tasks",
                    a.source
                ));
            }
            if a.index >= n {
                return Err(format!(
                    "--shard auto/{n}: {} is not below N = {n} (the Job's completions?)",
                    a.source
                ));
            }
            Ok(Some(Shard {
                index: a.index,
                count: n,
            }))
        }
        (Some(ShardSpec::Fixed(s)), Some(a)) => {
            if s.index == a.index && a.count.is_none_or(|c| c == s.count) {
                Ok(Some(s))
            } else {
                Err(format!(
                    "--shard {s} conflicts with {}, which is shard {}{}: give one of \
                     them, or --shard all for the whole grid",
                    a.source,
                    a.index,
                    a.count.map_or(String::new(), |c| format!("/{c}"))
                ))
            }
        }
    }
}
