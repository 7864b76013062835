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

/// Copies the folder `from` to `to` (files and subfolders).
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap_or_else(|e| panic!("{e}"));
    for entry in std::fs::read_dir(from).unwrap_or_else(|e| panic!("{e}")) {
        let entry = entry.unwrap_or_else(|e| panic!("{e}"));
        let target = to.join(entry.file_name());
        if entry.path().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap_or_else(|e| panic!("{e}"));
        }
    }
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&read(path)).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn write_json(path: &Path, value: &serde_json::Value) {
    let text = serde_json::to_string_pretty(value).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(path, text).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn merge_refuses_shards_that_differ_in_any_provenance_field_naming_it() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let shards: Vec<_> = (1..=3)
        .map(|i| home.path().join(format!("shard{i}")))
        .collect();
    for (i, dir) in shards.iter().enumerate() {
        eval(dir, Some(&format!("{}/3", i + 1)));
    }
    let manifest = read_json(&shards[1].join("manifest.json"));
    let provenance = &manifest["provenance"];
    assert_eq!(
        provenance["metrics"],
        serde_json::json!(["kas"]),
        "{manifest}"
    );
    assert_eq!(
        provenance["mapvlm_version"].as_str(),
        Some(env!("CARGO_PKG_VERSION"))
    );
    assert_eq!(
        provenance["dataset_hash"].as_str().map(str::len),
        Some(64),
        "{manifest}"
    );
    assert!(provenance["prompts"]
        .as_object()
        .is_some_and(|p| !p.is_empty()));
    let settings =
        serde_json::json!({"sentence_threshold": 0.675, "word_threshold": 0.708, "alpha": 0.5});
    let table: [(&str, &str, serde_json::Value); 10] = [
        ("provenance", "mapvlm_version", serde_json::json!("0.0.1")),
        (
            "provenance",
            "dataset_hash",
            serde_json::json!("0".repeat(64)),
        ),
        ("provenance", "metrics", serde_json::json!(["kas", "pg2s"])),
        ("provenance", "pg2s_settings", settings),
        (
            "provenance",
            "encoder",
            serde_json::json!("all-mpnet-base-v2: other"),
        ),
        (
            "provenance",
            "word_vectors",
            serde_json::json!("glove: other"),
        ),
        (
            "provenance",
            "prompts",
            serde_json::json!({"single-image": {"hash": "0123456789abcdef", "source": "built-in"}}),
        ),
        ("", "dataset_tasks", serde_json::json!(["only-one"])),
        ("", "approaches", serde_json::json!(["single-image"])),
        ("shard", "count", serde_json::json!(4)),
    ];
    for (parent, field, value) in table {
        let changed = home.path().join(format!("changed-{field}"));
        copy_dir(&shards[1], &changed);
        let mut manifest = read_json(&changed.join("manifest.json"));
        match parent {
            "" => manifest[field] = value,
            parent => manifest[parent][field] = value,
        }
        write_json(&changed.join("manifest.json"), &manifest);
        let out = home.path().join(format!("merged-{field}"));
        let refused = merge(&[&shards[0], &changed, &shards[2]], &out);
        let name = if parent == "shard" {
            "`shard.count`".to_string()
        } else {
            format!("`{field}`")
        };
        assert_one_line_failure(&refused, &name);
        let said = stderr(&refused);
        assert!(
            said.contains(&shards[0].display().to_string())
                && said.contains(&changed.display().to_string()),
            "names both shards: {said}"
        );
        assert!(!out.join("table3.csv").exists(), "{field}: no table");
        assert!(!out.join("tasks").exists(), "{field}: no result copied");
    }

    // A result scored otherwise than its shard's manifest says is refused too.
    let changed = home.path().join("changed-result");
    copy_dir(&shards[1], &changed);
    let name = read_json(&changed.join("manifest.json"))["results"][0]
        .as_str()
        .map(str::to_string)
        .unwrap_or_default();
    let file = changed.join("tasks").join(&name);
    let mut result = read_json(&file);
    result["provenance"]["metrics"] = serde_json::json!(["kas", "pg2s"]);
    write_json(&file, &result);
    let refused = merge(&[&shards[0], &changed, &shards[2]], &home.path().join("m"));
    assert_one_line_failure(&refused, "`metrics`");
    assert!(stderr(&refused).contains(&name), "{}", stderr(&refused));

    // Costs are the sum of the shards'.
    for (dir, usd) in shards.iter().zip([0.25, 0.5, 1.0]) {
        let mut manifest = read_json(&dir.join("manifest.json"));
        manifest["cost"] =
            serde_json::json!({"plans": 2, "input_tokens": 100, "output_tokens": 10, "usd": usd});
        write_json(&dir.join("manifest.json"), &manifest);
    }
    let merged = home.path().join("merged");
    let shard_dirs: Vec<&Path> = shards.iter().map(|p| p.as_path()).collect();
    let done = merge(&shard_dirs, &merged);
    assert!(done.status.success(), "{}", stderr(&done));
    assert_eq!(
        read_json(&merged.join("manifest.json"))["cost"],
        serde_json::json!({"plans": 6, "input_tokens": 300, "output_tokens": 30, "usd": 1.75})
    );
}

#[test]
fn eval_resuming_into_an_out_of_another_run_refuses_naming_the_field() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let out = home.path().join("out");
    eval(&out, Some("1/3"));
    let before = read(&out.join("manifest.json"));
    let dataset = common::shared().join("data/alfred30");
    let (dataset, out_arg) = (dataset.to_string_lossy(), out.to_string_lossy());
    let again = |extra: &[&str]| {
        let mut args = vec![
            "eval",
            "--dataset",
            &dataset,
            "--from-dataset-plans",
            "--out",
            &out_arg,
        ];
        args.extend_from_slice(extra);
        run(&args, &[])
    };
    // The whole dataset (shard 1/1, the mistake of a lone `sbatch --array=1`).
    assert_one_line_failure(&again(&["--metrics", "kas"]), "`shard.count`");
    assert_one_line_failure(&again(&["--metrics", "kas", "--shard", "2/3"]), "`shard`");
    assert_one_line_failure(
        &again(&["--metrics", "kas,pg2s", "--shard", "1/3"]),
        "`metrics`",
    );
    assert_eq!(
        read(&out.join("manifest.json")),
        before,
        "nothing rewritten"
    );
    let same = again(&["--metrics", "kas", "--shard", "1/3"]);
    assert!(same.status.success(), "{}", stderr(&same));
}

#[test]
fn a_bad_tasks_line_fails_only_its_shard_and_one_without_an_id_fails_every_shard() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let data = home.path().join("data");
    std::fs::create_dir_all(&data).unwrap_or_else(|e| panic!("{e}"));
    let good = |i: usize| {
        format!(
            r#"{{"id": "t-{i}", "task": "Wash mug {i}", "ground_truth": ["Walk to the sink.", "Wash the mug."], "single_agent_image": ["Go to the sink.", "Wash the mug."]}}"#
        )
    };
    let mut lines: Vec<String> = (1..=6).map(good).collect();
    // Line 7: task "bad" has no instruction.
    lines.push(r#"{"id": "bad", "ground_truth": ["Walk."]}"#.to_string());
    std::fs::write(data.join("tasks.jsonl"), lines.join("\n") + "\n")
        .unwrap_or_else(|e| panic!("{e}"));
    let owner = mapvlm::shard::Shard::of("bad", 3);
    let eval_shard = |i: u64, out: &Path| {
        let (d, o) = (data.to_string_lossy(), out.to_string_lossy());
        let shard = format!("{i}/3");
        let args = [
            "eval",
            "--dataset",
            &d,
            "--from-dataset-plans",
            "--metrics",
            "kas",
            "--out",
            &o,
            "--shard",
            &shard,
        ];
        run(&args, &[])
    };
    let dirs: Vec<_> = (1..=3).map(|i| home.path().join(format!("s{i}"))).collect();
    for (i, dir) in (1..=3).zip(&dirs) {
        let done = eval_shard(i, dir);
        let said = stderr(&done);
        if i == owner {
            assert!(!done.status.success(), "shard {i}: {said}");
            assert!(
                said.contains("tasks.jsonl:7") && said.contains("bad"),
                "{said}"
            );
        } else {
            assert!(done.status.success(), "shard {i}: {said}");
            assert!(!said.contains("tasks.jsonl:7"), "shard {i}: {said}");
        }
    }
    let shard_dirs: Vec<&Path> = dirs.iter().map(|p| p.as_path()).collect();
    let refused = merge(&shard_dirs, &home.path().join("m1"));
    assert_one_line_failure(&refused, "bad (line 7 of the tasks file)");

    // No readable id: every shard reports the line, and merge names it.
    lines[6] = "{not json".to_string();
    std::fs::write(data.join("tasks.jsonl"), lines.join("\n") + "\n")
        .unwrap_or_else(|e| panic!("{e}"));
    let fresh: Vec<_> = (1..=3).map(|i| home.path().join(format!("n{i}"))).collect();
    for (i, dir) in (1..=3).zip(&fresh) {
        let done = eval_shard(i, dir);
        assert!(!done.status.success(), "shard {i}");
        assert!(
            stderr(&done).contains("tasks.jsonl:7"),
            "shard {i}: {}",
            stderr(&done)
        );
    }
    let shard_dirs: Vec<&Path> = fresh.iter().map(|p| p.as_path()).collect();
    let refused = merge(&shard_dirs, &home.path().join("m2"));
    assert_one_line_failure(&refused, "line 7 of the tasks file (no readable id)");
}
