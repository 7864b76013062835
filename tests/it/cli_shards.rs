//! `--shard` on `score --pairs` and `eval`, and `mapvlm merge`: the shards of
//! a run hold exactly its lines and files, and merged they give its tables
//! byte for byte.

use crate::common;

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Output;

use common::{assert_one_line_failure, stderr};

/// The scheduler variables `--shard auto` reads, removed from every run so
/// that the machine the tests run on cannot change them.
const SCHEDULER_VARS: [&str; 5] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_COUNT",
    "JOB_COMPLETION_INDEX",
    "MAPVLM_SHARD_COUNT",
];

fn run(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = common::mapvlm_command();
    command.args(args);
    for var in SCHEDULER_VARS {
        command.env_remove(var);
    }
    command.envs(env.iter().copied());
    command
        .output()
        .unwrap_or_else(|e| panic!("running mapvlm: {e}"))
}

/// The KAS lines of the golden pairs, with extra arguments and environment.
fn score(extra: &[&str], env: &[(&str, &str)]) -> Vec<String> {
    let pairs = common::shared().join("golden/pairs.dev.jsonl");
    let mut args = vec!["--metrics", "kas"];
    args.extend_from_slice(extra);
    score_lines(&pairs, &args, env)
}

/// The JSON lines of `score --pairs PAIRS --json` with extra arguments.
fn score_lines(pairs: &Path, extra: &[&str], env: &[(&str, &str)]) -> Vec<String> {
    let pairs = pairs.to_string_lossy();
    let mut args = vec!["score", "--pairs", &pairs, "--json"];
    args.extend_from_slice(extra);
    let out = run(&args, env);
    assert!(out.status.success(), "{:?}: {}", extra, stderr(&out));
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect()
}

#[test]
fn three_score_shards_hold_exactly_the_lines_of_the_single_run() {
    let whole = score(&[], &[]);
    assert!(whole.len() > 100, "{} pairs", whole.len());
    let shards: Vec<Vec<String>> = (1..=3)
        .map(|i| score(&["--shard", &format!("{i}/3")], &[]))
        .collect();
    for (i, shard) in shards.iter().enumerate() {
        assert!(
            shard.len() > 20,
            "shard {} has {} pairs",
            i + 1,
            shard.len()
        );
    }
    assert_partition(&whole, &shards);

    let slurm = score(
        &["--shard", "auto"],
        &[
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ],
    );
    assert_eq!(slurm, shards[1], "Slurm task 5 of 4..=6 is shard 2/3");
    let indexed = [("JOB_COMPLETION_INDEX", "2"), ("MAPVLM_SHARD_COUNT", "3")];
    assert_eq!(
        score(&["--shard", "auto"], &indexed),
        shards[2],
        "Indexed Job completion 2 of 3 is shard 3/3"
    );
    assert_eq!(
        score(
            &["--shard", "auto", "--shard-count", "3"],
            &[("JOB_COMPLETION_INDEX", "0")]
        ),
        shards[0]
    );
}

/// Asserts that `shards` hold exactly the lines of `whole`, each in one
/// shard, in the order of the file.
fn assert_partition(whole: &[String], shards: &[Vec<String>]) {
    for (i, shard) in shards.iter().enumerate() {
        let mut rest = whole.iter();
        assert!(
            shard.iter().all(|line| rest.any(|l| l == line)),
            "shard {}: every line is one of the single run's, in its order",
            i + 1
        );
    }
    let mut joined: Vec<String> = shards.concat();
    let mut expected = whole.to_vec();
    joined.sort();
    expected.sort();
    assert_eq!(joined, expected, "every pair in exactly one shard");
}

#[test]
fn cold_pg2s_shards_hold_the_single_runs_lines_bit_for_bit() {
    // Each run embeds its own sentences from scratch: a sentence's cosines
    // are the same bits whichever sentences share its shard. (With padded
    // batches, 8 of these 12 lines differed in a last digit.)
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let golden = std::fs::read_to_string(common::shared().join("golden/pairs.dev.jsonl"))
        .unwrap_or_else(|e| panic!("golden pairs: {e}"));
    let subset = dir.path().join("pairs.jsonl");
    let first: Vec<&str> = golden.lines().take(12).collect();
    std::fs::write(&subset, first.join("\n") + "\n").unwrap_or_else(|e| panic!("{e}"));
    let whole = score_lines(&subset, &["--no-cache"], &[]);
    assert_eq!(whole.len(), 12);
    assert!(whole
        .iter()
        .all(|line| line.contains("\"sentence_matches\":[[")));
    let shards: Vec<Vec<String>> = (1..=3)
        .map(|i| score_lines(&subset, &["--no-cache", "--shard", &format!("{i}/3")], &[]))
        .collect();
    assert!(shards.iter().all(|shard| !shard.is_empty()));
    assert_partition(&whole, &shards);
}

#[test]
fn bad_shards_and_auto_without_a_scheduler_fail_with_one_line() {
    let pairs = common::shared().join("golden/pairs.dev.jsonl");
    let pairs = pairs.to_string_lossy();
    let score_shard = |shard: &str, env: &[(&str, &str)]| {
        let args = [
            "score",
            "--pairs",
            &pairs,
            "--metrics",
            "kas",
            "--shard",
            shard,
        ];
        run(&args, env)
    };
    for (shard, needle) in [
        ("0/3", "from 1 to N, here 1 to 3"),
        ("4/3", "from 1 to N, here 1 to 3"),
        ("1/0", "at least 1"),
        ("half", "write I/N"),
    ] {
        assert_one_line_failure(&score_shard(shard, &[]), needle);
    }
    assert_one_line_failure(&score_shard("auto", &[]), "neither a Slurm job array");
    assert_one_line_failure(
        &score_shard("auto", &[("JOB_COMPLETION_INDEX", "1")]),
        "MAPVLM_SHARD_COUNT",
    );
}

/// `eval` of the published plans of alfred30 (KAS, no model) into `out`.
fn eval(out: &Path, shard: Option<&str>) {
    let dataset = common::shared().join("data/alfred30");
    let (dataset, out) = (dataset.to_string_lossy(), out.to_string_lossy());
    let mut args = vec![
        "eval",
        "--dataset",
        &dataset,
        "--from-dataset-plans",
        "--metrics",
        "kas",
        "--out",
        &out,
    ];
    if let Some(shard) = shard {
        args.extend(["--shard", shard]);
    }
    let done = run(&args, &[]);
    assert!(done.status.success(), "{shard:?}: {}", stderr(&done));
}

fn merge(shards: &[&Path], out: &Path) -> Output {
    let mut args: Vec<String> = vec!["merge".into()];
    args.extend(shards.iter().map(|p| p.to_string_lossy().into_owned()));
    args.extend(["--out".into(), out.to_string_lossy().into_owned()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    run(&args, &[])
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The task ids of the result files in `dir/tasks`.
fn task_ids(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir.join("tasks"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| {
            let name = entry.unwrap_or_else(|e| panic!("{e}")).file_name();
            let name = name.to_string_lossy();
            name.split('.').next().unwrap_or_default().to_string()
        })
        .collect()
}

#[test]
fn three_eval_shards_merge_into_the_single_runs_table_byte_for_byte() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let whole = home.path().join("whole");
    eval(&whole, None);
    let shards: Vec<_> = (1..=3)
        .map(|i| home.path().join(format!("shard{i}")))
        .collect();
    for (i, dir) in shards.iter().enumerate() {
        eval(dir, Some(&format!("{}/3", i + 1)));
    }
    let ids: Vec<BTreeSet<String>> = shards.iter().map(|d| task_ids(d)).collect();
    assert!(ids.iter().all(|s| !s.is_empty()), "{ids:?}");
    assert_eq!(ids.iter().map(BTreeSet::len).sum::<usize>(), 30, "{ids:?}");

    let merged = home.path().join("merged");
    let shard_dirs: Vec<&Path> = shards.iter().map(|p| p.as_path()).collect();
    for attempt in ["first", "again"] {
        let done = merge(&shard_dirs, &merged);
        assert!(done.status.success(), "{attempt}: {}", stderr(&done));
        for table in ["table3.csv", "table3.md"] {
            assert_eq!(
                read(&merged.join(table)),
                read(&whole.join(table)),
                "{attempt}: {table}"
            );
        }
        let files = std::fs::read_dir(whole.join("tasks")).unwrap_or_else(|e| panic!("{e}"));
        let mut compared = 0;
        for file in files {
            let name = file.unwrap_or_else(|e| panic!("{e}")).file_name();
            let name = Path::new("tasks").join(name);
            assert_eq!(
                read(&merged.join(&name)),
                read(&whole.join(&name)),
                "{name:?}"
            );
            compared += 1;
        }
        assert_eq!(compared, 120);
        assert_eq!(task_ids(&merged).len(), 30);
    }

    let partial = home.path().join("partial");
    let failed = merge(&shard_dirs[..2], &partial);
    assert_one_line_failure(&failed, "shard 3/3 missing");
    let err = stderr(&failed);
    let named: BTreeSet<String> = ids[2]
        .iter()
        .filter(|id| err.contains(*id))
        .cloned()
        .collect();
    assert_eq!(
        named, ids[2],
        "names every task of the missing shard: {err}"
    );
    assert!(
        ids[0].iter().chain(&ids[1]).all(|id| !err.contains(id)),
        "names only the missing tasks: {err}"
    );
    assert!(!partial.join("table3.csv").exists(), "writes nothing");
}
