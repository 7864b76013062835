//! The files under deploy/: the Slurm array script passes shellcheck and
//! runs as an array task and as the merge, and the Kubernetes manifests have
//! the shape an Indexed Job with a shared cache needs.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use yaml_rust2::{Yaml, YamlLoader};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn documents(path: &str) -> Vec<Yaml> {
    let text = std::fs::read_to_string(repo(path)).unwrap_or_else(|e| panic!("{path}: {e}"));
    YamlLoader::load_from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn of_kind<'a>(docs: &'a [Yaml], kind: &str) -> &'a Yaml {
    docs.iter()
        .find(|d| d["kind"].as_str() == Some(kind))
        .unwrap_or_else(|| panic!("no {kind}"))
}

fn strings(list: &Yaml) -> Vec<&str> {
    list.as_vec()
        .unwrap_or_else(|| panic!("not a list: {list:?}"))
        .iter()
        .map(|v| v.as_str().unwrap_or_else(|| panic!("not a string: {v:?}")))
        .collect()
}

/// The value of environment variable `name` of a container, when given as a value.
fn env<'a>(container: &'a Yaml, name: &str) -> Option<&'a Yaml> {
    container["env"]
        .as_vec()?
        .iter()
        .find(|e| e["name"].as_str() == Some(name))
}

#[test]
fn the_slurm_script_passes_shellcheck() {
    let script = repo("deploy/slurm/eval-array.sh");
    let run = Command::new("shellcheck").arg(&script).output();
    let run = run.unwrap_or_else(|e| {
        panic!("shellcheck is needed for this test ({e}): install it (apt-get install shellcheck; .ci/run does)")
    });
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stdout)
    );
}

/// Runs the Slurm script on `dataset` into `out` as one stage (an array
/// task, the merge) with `vars` and the binary `binary`.
fn slurm_stage(out: &Path, binary: &Path, vars: &[(&str, &str)]) -> std::process::Output {
    let dataset = common::shared().join("data/alfred30");
    let mut command = Command::new("bash");
    command
        .arg(repo("deploy/slurm/eval-array.sh"))
        .arg(&dataset)
        .arg(out)
        .args(["3", "--", "--from-dataset-plans", "--metrics", "kas"])
        .env("MAPVLM", binary)
        .env_remove("MAPVLM_SCRIPT")
        .env_remove("MAPVLM_STAGE")
        .env_remove("MAPVLM_SHARED_CACHE")
        .env_remove("MAPVLM_SHARD_COUNT")
        .env_remove("JOB_COMPLETION_INDEX");
    for name in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_COUNT",
    ] {
        command.env_remove(name);
    }
    command.envs(vars.iter().copied());
    command.output().unwrap_or_else(|e| panic!("bash: {e}"))
}

#[test]
fn the_slurm_script_runs_each_array_task_and_the_merge_and_reports_a_failed_shard() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let out = home.path().join("out");
    let mapvlm = Path::new(env!("CARGO_BIN_EXE_mapvlm"));
    let task = |id: &str, binary: &Path| {
        let vars = [
            ("SLURM_ARRAY_TASK_ID", id),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "1"),
        ];
        slurm_stage(&out, binary, &vars)
    };
    for id in ["1", "3"] {
        let run = task(id, mapvlm);
        assert!(run.status.success(), "{id}: {}", common::stderr(&run));
    }
    // Shard 2 fails: its binary is one that exits 1.
    let failing = task("2", Path::new("false"));
    assert!(!failing.status.success());
    let merge = slurm_stage(&out, mapvlm, &[("MAPVLM_STAGE", "merge")]);
    assert!(!merge.status.success());
    let said = common::stderr(&merge);
    assert!(said.contains("shard 2 (exit status 1)"), "{said}");
    assert!(
        !said.contains("shard 1") && !said.contains("shard 3 ("),
        "{said}"
    );
    assert!(said.contains("sbatch --array=K"), "{said}");
    assert!(!out.join("merged/table3.csv").exists(), "no table");

    let one = std::fs::read(out.join("shard-1/table3.csv")).unwrap_or_else(|e| panic!("{e}"));
    let rerun = task("2", mapvlm);
    assert!(rerun.status.success(), "{}", common::stderr(&rerun));
    assert_eq!(
        std::fs::read(out.join("shard-1/table3.csv")).ok(),
        Some(one),
        "shard 1 untouched"
    );
    let merge = slurm_stage(&out, mapvlm, &[("MAPVLM_STAGE", "merge")]);
    assert!(merge.status.success(), "{}", common::stderr(&merge));
    let csv =
        std::fs::read_to_string(out.join("merged/table3.csv")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(csv.lines().count(), 1 + 30 + 1, "{csv}");
    for shard in ["shard-1", "shard-2", "shard-3"] {
        assert!(out.join(shard).join("manifest.json").is_file(), "{shard}");
    }
    let merged = std::fs::read_dir(out.join("merged/tasks")).map(Iterator::count);
    assert_eq!(merged.ok(), Some(120));
}

#[test]
fn the_slurm_script_says_how_to_call_it_when_arguments_are_missing() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    for args in [
        &[][..],
        &["data"][..],
        &["data", "out"][..],
        &["data", "out", "x"][..],
    ] {
        let run = Command::new("bash")
            .arg(repo("deploy/slurm/eval-array.sh"))
            .args(args)
            .current_dir(home.path())
            .output()
            .unwrap_or_else(|e| panic!("bash: {e}"));
        assert_eq!(run.status.code(), Some(2), "{args:?}");
        let said = common::stderr(&run);
        assert!(said.contains("usage: eval-array.sh"), "{args:?}: {said}");
        assert!(!said.contains("unbound variable"), "{args:?}: {said}");
    }
}

#[test]
fn the_indexed_job_shards_by_completion_index_over_a_shared_volume() {
    let docs = documents("deploy/kubernetes/eval-indexed-job.yaml");
    let claim = of_kind(&docs, "PersistentVolumeClaim");
    let claim_name = claim["metadata"]["name"].as_str().unwrap_or_default();
    assert!(strings(&claim["spec"]["accessModes"]).contains(&"ReadWriteMany"));

    let job = of_kind(&docs, "Job");
    let spec = &job["spec"];
    assert_eq!(spec["completionMode"].as_str(), Some("Indexed"));
    let completions = spec["completions"].as_i64().unwrap_or_default();
    assert!(completions > 1, "{completions}");
    assert_eq!(spec["parallelism"].as_i64(), Some(completions));

    let pod = &spec["template"]["spec"];
    let container = &pod["containers"][0];
    let args = strings(&container["args"]);
    assert_eq!(args[0], "eval");
    assert!(
        args.windows(2).any(|w| w == ["--shard", "auto"]),
        "{args:?}"
    );
    let count = env(container, "MAPVLM_SHARD_COUNT").unwrap_or_else(|| panic!("no count"));
    assert_eq!(
        count["value"].as_str(),
        Some(completions.to_string().as_str())
    );

    let volume = &pod["volumes"][0];
    assert_eq!(
        volume["persistentVolumeClaim"]["claimName"].as_str(),
        Some(claim_name)
    );
    let mount = &container["volumeMounts"][0];
    assert_eq!(mount["name"].as_str(), volume["name"].as_str());
    let mount_path = mount["mountPath"].as_str().unwrap_or_default();
    let cache = env(container, "XDG_CACHE_HOME").unwrap_or_else(|| panic!("no cache"));
    let cache = cache["value"].as_str().unwrap_or_default();
    assert!(cache.starts_with(mount_path), "{cache} on {mount_path}");
    let out = args[args.iter().position(|a| *a == "--out").unwrap_or_default() + 1];
    assert!(out.starts_with(mount_path), "{out}");
    assert!(
        out.contains("$(JOB_COMPLETION_INDEX)"),
        "{out}: one folder per index"
    );

    let merge = documents("deploy/kubernetes/merge-job.yaml");
    let merge = of_kind(&merge, "Job");
    let merge_pod = &merge["spec"]["template"]["spec"];
    let merge_args = strings(&merge_pod["containers"][0]["args"]);
    assert_eq!(merge_args[0], "merge");
    let shards: Vec<String> = (0..completions)
        .map(|i| out.replace("$(JOB_COMPLETION_INDEX)", &i.to_string()))
        .collect();
    assert_eq!(merge_args[1..=shards.len()], shards, "every index merged");
    assert_eq!(
        merge_pod["volumes"][0]["persistentVolumeClaim"]["claimName"].as_str(),
        Some(claim_name)
    );
}
