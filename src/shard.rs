//! Shards: one machine's share of a pairs file or a dataset, so that a
//! scheduler's job array (Slurm) or Indexed Job (Kubernetes) can split the
//! work and `mapvlm merge` put it back together.
//!
//! The split is a pure function of the item's id: the item with id `x` is in
//! shard `1 + (u64::from_be_bytes(SHA-256(x)[0..8]) mod N)`. Any machine, any
//! version and any order of the input computes the same split, and every item
//! is in exactly one shard.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// One shard of a split into `count` shards: `index` counts from 1 to `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Which shard, from 1 to `count`.
    pub index: u64,
    /// How many shards the work is split into.
    pub count: u64,
}

/// A `--shard` value: a given shard, or `auto` (read from the scheduler).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardSpec {
    /// `I/N`.
    Given(Shard),
    /// `auto`: a Slurm job array's or a Kubernetes Indexed Job's variables.
    Auto,
}

/// Why a shard could not be known.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// The value is not `I/N` or `auto`.
    #[error("`{0}` is not a shard: write I/N (e.g. 2/3, I from 1 to N) or auto")]
    Syntax(String),
    /// N is zero.
    #[error("`{0}`: the shard count N must be at least 1")]
    NoShards(String),
    /// I is outside 1..=N.
    #[error("`{value}`: the shard I counts from 1 to N, here 1 to {count}")]
    OutOfRange {
        /// The value as given.
        value: String,
        /// Its N.
        count: u64,
    },
    /// A scheduler variable is not a number.
    #[error("auto: {name}={value} is not a whole number; is this a job array?")]
    NotANumber {
        /// The variable.
        name: &'static str,
        /// Its value.
        value: String,
    },
    /// A Slurm array whose task ids do not run 1..=N once shifted, e.g. a step.
    #[error("auto: Slurm array task {id} (from {min}, {count} tasks) is not shard 1..={count}; use a contiguous array without a step, e.g. --array=0-{last}", last = count.saturating_sub(1))]
    SlurmRange {
        /// SLURM_ARRAY_TASK_ID.
        id: u64,
        /// SLURM_ARRAY_TASK_MIN.
        min: u64,
        /// SLURM_ARRAY_TASK_COUNT.
        count: u64,
    },
    /// `SLURM_ARRAY_TASK_ID` without the `SLURM_ARRAY_TASK_COUNT` Slurm
    /// sets beside it in a job array.
    #[error("auto: SLURM_ARRAY_TASK_ID is {id} but SLURM_ARRAY_TASK_COUNT is not set, as Slurm sets both in a job array (sbatch --array); run it as one, or give --shard I/N")]
    SlurmNoCount {
        /// SLURM_ARRAY_TASK_ID.
        id: u64,
    },
    /// An Indexed Job without the count of its completions.
    #[error("auto: JOB_COMPLETION_INDEX is set but not the shard count; give --shard-count N or set MAPVLM_SHARD_COUNT to the Job's completions")]
    NoCount,
    /// `auto` outside any job array.
    #[error("auto: neither a Slurm job array (SLURM_ARRAY_TASK_ID) nor a Kubernetes Indexed Job (JOB_COMPLETION_INDEX) is in the environment; give --shard I/N")]
    NoScheduler,
}

impl Shard {
    /// The whole work as one shard.
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// Shard `index` of `count`, checked.
    pub fn new(index: u64, count: u64) -> Result<Shard, ShardError> {
        let value = format!("{index}/{count}");
        if count == 0 {
            return Err(ShardError::NoShards(value));
        }
        if !(1..=count).contains(&index) {
            return Err(ShardError::OutOfRange { value, count });
        }
        Ok(Shard { index, count })
    }

    /// The shard (1..=`count`) the item with id `id` belongs to.
    pub fn of(id: &str, count: u64) -> u64 {
        let digest = Sha256::digest(id.as_bytes());
        let mut head = [0u8; 8];
        head.copy_from_slice(&digest[..8]);
        u64::from_be_bytes(head) % count.max(1) + 1
    }

    /// Whether the item with id `id` is in this shard.
    pub fn contains(&self, id: &str) -> bool {
        Self::of(id, self.count) == self.index
    }

    /// The shard a scheduler gave this process, from its environment
    /// (`var` looks a variable up): a Slurm job array (I =
    /// `SLURM_ARRAY_TASK_ID` − `SLURM_ARRAY_TASK_MIN` + 1, N =
    /// `SLURM_ARRAY_TASK_COUNT`) or a Kubernetes Indexed Job (I =
    /// `JOB_COMPLETION_INDEX` + 1, N = `count`).
    pub fn from_scheduler(
        var: impl Fn(&str) -> Option<String>,
        count: Option<u64>,
    ) -> Result<Shard, ShardError> {
        let number = |name: &'static str| -> Result<Option<u64>, ShardError> {
            var(name)
                .map(|value| {
                    value
                        .trim()
                        .parse()
                        .map_err(|_| ShardError::NotANumber { name, value })
                })
                .transpose()
        };
        if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
            let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let total = number("SLURM_ARRAY_TASK_COUNT")?.ok_or(ShardError::SlurmNoCount { id })?;
            let slurm = ShardError::SlurmRange {
                id,
                min,
                count: total,
            };
            let index = id.checked_sub(min).ok_or_else(|| slurm.clone())? + 1;
            return Shard::new(index, total).map_err(|_| slurm);
        }
        if let Some(index) = number("JOB_COMPLETION_INDEX")? {
            let count = count.ok_or(ShardError::NoCount)?;
            return Shard::new(index.saturating_add(1), count);
        }
        Err(ShardError::NoScheduler)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for ShardSpec {
    type Err = ShardError;

    fn from_str(value: &str) -> Result<Self, Self::Err> {
        if value == "auto" {
            return Ok(ShardSpec::Auto);
        }
        let syntax = || ShardError::Syntax(value.to_string());
        let (index, count) = value.split_once('/').ok_or_else(syntax)?;
        let index: u64 = index.trim().parse().map_err(|_| syntax())?;
        let count: u64 = count.trim().parse().map_err(|_| syntax())?;
        Shard::new(index, count).map(ShardSpec::Given)
    }
}

impl ShardSpec {
    /// The shard this process works on; `auto` reads the process's
    /// environment, with `count` for a Kubernetes Indexed Job.
    pub fn resolve(&self, count: Option<u64>) -> Result<Shard, ShardError> {
        match self {
            ShardSpec::Given(shard) => Ok(*shard),
            ShardSpec::Auto => Shard::from_scheduler(|name| std::env::var(name).ok(), count),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            vars.iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn the_split_is_the_documented_hash() {
        // SHA-256("a") starts ca978112ca1bbdca.
        assert_eq!(
            Shard::of("a", 1 << 20),
            0xca97_8112_ca1b_bdca % (1 << 20) + 1
        );
        assert_eq!(Shard::of("a", 1), 1);
        let ids: Vec<String> = (0..300).map(|i| format!("task-{i}")).collect();
        let mut sizes = [0; 3];
        for id in &ids {
            let owners: Vec<u64> = (1..=3)
                .filter(|&i| Shard::new(i, 3).is_ok_and(|s| s.contains(id)))
                .collect();
            assert_eq!(owners.len(), 1, "{id} is in exactly one shard");
            sizes[(owners[0] - 1) as usize] += 1;
        }
        assert!(sizes.iter().all(|&n| n > 70), "a fair split: {sizes:?}");
    }

    #[test]
    fn bad_shards_say_what_is_wrong() {
        let message = |v: &str| match v.parse::<ShardSpec>() {
            Err(e) => e.to_string(),
            Ok(s) => format!("accepted {s:?}"),
        };
        assert!(message("0/3").contains("from 1 to N, here 1 to 3"));
        assert!(message("4/3").contains("from 1 to N, here 1 to 3"));
        assert!(message("1/0").contains("at least 1"));
        assert!(message("two").contains("write I/N"));
        assert!(message("-1/3").contains("write I/N"));
        assert_eq!(
            "2/3".parse::<ShardSpec>(),
            Ok(ShardSpec::Given(Shard { index: 2, count: 3 }))
        );
        assert_eq!("auto".parse::<ShardSpec>(), Ok(ShardSpec::Auto));
    }

    #[test]
    fn slurm_arrays_count_from_their_minimum() {
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "12"),
            ("SLURM_ARRAY_TASK_MIN", "10"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert_eq!(
            Shard::from_scheduler(env(&vars), Some(9)),
            Ok(Shard { index: 3, count: 4 })
        );
        let stepped = [
            ("SLURM_ARRAY_TASK_ID", "8"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_COUNT", "5"),
        ];
        let err = Shard::from_scheduler(env(&stepped), None);
        assert!(
            matches!(err, Err(ShardError::SlurmRange { id: 8, .. })),
            "{err:?}"
        );
        let alone = [("SLURM_ARRAY_TASK_ID", "2")];
        let err = Shard::from_scheduler(env(&alone), None).unwrap_err();
        assert_eq!(err, ShardError::SlurmNoCount { id: 2 });
        assert!(err
            .to_string()
            .contains("SLURM_ARRAY_TASK_COUNT is not set"));
    }

    #[test]
    fn indexed_jobs_count_from_zero_and_need_the_count() {
        let vars = [("JOB_COMPLETION_INDEX", "0")];
        assert_eq!(
            Shard::from_scheduler(env(&vars), Some(3)),
            Ok(Shard { index: 1, count: 3 })
        );
        assert_eq!(
            Shard::from_scheduler(env(&vars), None),
            Err(ShardError::NoCount)
        );
        let last = [("JOB_COMPLETION_INDEX", "3")];
        assert!(Shard::from_scheduler(env(&last), Some(3)).is_err());
        let junk = [("JOB_COMPLETION_INDEX", "x")];
        assert!(matches!(
            Shard::from_scheduler(env(&junk), Some(3)),
            Err(ShardError::NotANumber { .. })
        ));
        assert_eq!(
            Shard::from_scheduler(env(&[]), Some(3)),
            Err(ShardError::NoScheduler)
        );
    }
}
