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

/// A private one-node Slurm cluster (tests/it/slurm/cluster.sh), stopped
/// when dropped.
struct Cluster {
    dir: PathBuf,
    conf: String,
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        let started = Command::new("bash")
            .arg(repo("tests/it/slurm/cluster.sh"))
            .arg("start")
            .arg(dir)
            .output()
            .unwrap_or_else(|e| panic!("bash: {e}"));
        assert!(
            started.status.success(),
            "the private Slurm cluster did not start (it needs slurm-wlm and munge: apt-get install slurm-wlm munge; .ci/run does): {}",
            common::stderr(&started)
        );
        let conf = String::from_utf8_lossy(&started.stdout).trim().to_string();
        Cluster {
            dir: dir.to_path_buf(),
            conf,
        }
    }

    /// A command of the cluster's (`sbatch`, `squeue`, `bash SCRIPT`...).
    fn command(&self, program: &str) -> Command {
        let mut command = Command::new(program);
        command.env("SLURM_CONF", &self.conf);
        for name in [
            "MAPVLM_SCRIPT",
            "MAPVLM_STAGE",
            "MAPVLM_SHARED_CACHE",
            "MAPVLM_SHARD_COUNT",
            "JOB_COMPLETION_INDEX",
        ] {
            command.env_remove(name);
        }
        command
    }

    /// Waits until no job is queued or running (at most 20 minutes).
    fn drain(&self) {
        let start = std::time::Instant::now();
        loop {
            let queue = self
                .command("squeue")
                .args(["-h", "-o", "%i %T %r"])
                .output()
                .unwrap_or_else(|e| panic!("squeue: {e}"));
            let queue = String::from_utf8_lossy(&queue.stdout).to_string();
            if queue.trim().is_empty() {
                return;
            }
            assert!(
                start.elapsed() < std::time::Duration::from_secs(1200),
                "jobs still queued: {queue}"
            );
            std::thread::sleep(std::time::Duration::from_millis(500));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(repo("tests/it/slurm/cluster.sh"))
            .arg("stop")
            .arg(&self.dir)
            .status();
    }
}

/// Every file under `dir`, by path relative to it, with its bytes.
fn tree(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    let mut files = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap_or_else(|e| panic!("{e}")) {
            let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
                let name = path.strip_prefix(dir).unwrap_or(&path).to_path_buf();
                files.insert(name, bytes);
            }
        }
    }
    files
}

/// The tables and result files of an eval or merge folder.
fn outputs(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    let mut files = tree(&dir.join("tasks"));
    for table in ["table3.csv", "table3.md"] {
        let bytes = std::fs::read(dir.join(table)).unwrap_or_else(|e| panic!("{table}: {e}"));
        files.insert(PathBuf::from(table), bytes);
    }
    files
}

#[test]
fn on_a_private_slurm_cluster_the_array_merges_like_one_machine_and_a_failed_shard_reruns_alone() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let cluster = Cluster::start(&home.path().join("cluster"));
    let dataset = common::shared().join("data/alfred30");
    let single = home.path().join("single");
    let whole = common::mapvlm_command()
        .arg("eval")
        .arg("--dataset")
        .arg(&dataset)
        .arg("--from-dataset-plans")
        .arg("--out")
        .arg(&single)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(whole.status.success(), "{}", common::stderr(&whole));

    // The binary through a wrapper that gives array task 2 an empty model
    // pack while the file `fail-2` exists.
    let empty = home.path().join("no-models");
    std::fs::create_dir_all(&empty).unwrap_or_else(|e| panic!("{e}"));
    let flag = home.path().join("fail-2");
    let wrapper = home.path().join("mapvlm-wrapper");
    std::fs::write(
        &wrapper,
        format!(
            "#!/bin/sh\nif [ \"${{SLURM_ARRAY_TASK_ID:-}}\" = 2 ] && [ -e '{}' ]; then\n    export MAPVLM_MODELS='{}' HF_HUB_OFFLINE=1 PATH=/nonexistent\nfi\nexec '{}' \"$@\"\n",
            flag.display(),
            empty.display(),
            env!("CARGO_BIN_EXE_mapvlm")
        ),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let chmod = Command::new("chmod").arg("+x").arg(&wrapper).status();
    assert!(chmod.is_ok_and(|s| s.success()));
    let script = repo("deploy/slurm/eval-array.sh");
    let resources = ["--cpus-per-task=1", "--mem=1G"];
    // `program` (bash or sbatch) with `options`, the script, its own
    // options, DATASET OUT 3 and `eval_options`, through the wrapper.
    let job = |program: &str, options: &[&str], own: &[&str], out: &Path, eval_options: &[&str]| {
        let run = cluster
            .command(program)
            .args(options)
            .arg(&script)
            .args(own)
            .arg(&dataset)
            .arg(out)
            .arg("3")
            .args(eval_options)
            .env("MAPVLM", &wrapper)
            .env("XDG_CACHE_HOME", common::test_cache_home())
            .env("MAPVLM_MODELS", common::pack_dir())
            .output()
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(run.status.success(), "{}", common::stderr(&run));
    };
    let eval_options = ["--", "--from-dataset-plans"];
    let submit = |out: &Path| job("bash", &[], &resources, out, &eval_options);
    let merge_log = |out: &Path| -> String {
        tree(&out.join("logs"))
            .into_iter()
            .filter(|(name, _)| name.to_string_lossy().starts_with("merge-"))
            .map(|(_, bytes)| String::from_utf8_lossy(&bytes).into_owned())
            .collect()
    };

    let clean = home.path().join("clean");
    submit(&clean);
    cluster.drain();
    assert_eq!(
        outputs(&clean.join("merged")),
        outputs(&single),
        "{}",
        merge_log(&clean)
    );

    let out = home.path().join("out");
    std::fs::write(&flag, "").unwrap_or_else(|e| panic!("{e}"));
    submit(&out);
    cluster.drain();
    let said = merge_log(&out);
    assert!(said.contains("shard 2 (exit status 1)"), "{said}");
    assert!(
        !said.contains("shard 1 (") && !said.contains("shard 3 ("),
        "{said}"
    );
    assert!(!out.join("merged/table3.csv").exists(), "no table: {said}");
    let shard_2_log: String = tree(&out.join("logs"))
        .into_iter()
        .filter(|(name, _)| name.to_string_lossy().starts_with("shard-2-"))
        .map(|(_, bytes)| String::from_utf8_lossy(&bytes).into_owned())
        .collect();
    assert!(
        shard_2_log.contains("PG2S could not be loaded"),
        "{shard_2_log}"
    );

    // The documented reruns: shard 2 alone, then the merge alone.
    std::fs::remove_file(&flag).unwrap_or_else(|e| panic!("{e}"));
    let others = (tree(&out.join("shard-1")), tree(&out.join("shard-3")));
    let logs = out.join("logs");
    let shard_log = format!("--output={}/shard-%a-%A.out", logs.display());
    let rerun = [
        &resources[..],
        &["--array=2", &shard_log, "--open-mode=append"],
    ]
    .concat();
    job("sbatch", &rerun, &[], &out, &eval_options);
    cluster.drain();
    let merge_output = format!("--output={}/merge-%j.out", logs.display());
    let merge = [
        &resources[..],
        &["--export=ALL,MAPVLM_STAGE=merge", &merge_output],
    ]
    .concat();
    job("sbatch", &merge, &[], &out, &[]);
    cluster.drain();
    assert_eq!(
        (tree(&out.join("shard-1")), tree(&out.join("shard-3"))),
        others,
        "the other shards' files untouched"
    );
    assert_eq!(
        outputs(&out.join("merged")),
        outputs(&single),
        "{}",
        merge_log(&out)
    );
}
