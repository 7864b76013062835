//! Fault matrix, rows H20–H27 (see `tests/FAULTS.md`): paths that are not
//! UTF-8 or hold a line break, a stream answering a `--no-stream` request,
//! and flags a hostile or hurried user gives (an agent the approach does not
//! run, empty names, negative numbers without `=`, a Slurm array variable
//! alone, zero resamples). The real binary, against a local server.

use crate::agents_support::*;

use std::ffi::OsString;
use std::os::unix::ffi::OsStringExt;
use std::path::Path;
use std::process::Output;

use mapvlm::agents::ProviderKind;
use wiremock::MockServer;

/// Runs mapvlm with `args` off the async runtime.
async fn run<S: AsRef<std::ffi::OsStr> + Send + 'static>(args: Vec<S>, home: &Path) -> Output {
    let home = home.to_path_buf();
    tokio::task::spawn_blocking(move || mapvlm_command(&args, &home).output().unwrap())
        .await
        .unwrap()
}

fn stderr(out: &Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// The one line a refused run prints: it failed, and stderr is that line.
fn refusal(out: &Output) -> String {
    let err = stderr(out);
    assert!(!out.status.success(), "{err}");
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    err
}

async fn asked(server: &MockServer) -> usize {
    server.received_requests().await.unwrap().len()
}

/// `name` with a byte that is not UTF-8 in it (Latin-1 `é`, as an old
/// archive or a Windows share may leave).
fn not_utf8(dir: &Path, name: &str) -> std::path::PathBuf {
    let mut bytes = name.as_bytes().to_vec();
    bytes.push(0xe9);
    dir.join(OsString::from_vec(bytes))
}

fn os(args: &[&str]) -> Vec<OsString> {
    args.iter().map(OsString::from).collect()
}

#[tokio::test(flavor = "multi_thread")]
async fn a_path_that_is_not_utf8_is_refused_naming_it_before_any_request() {
    let home = tempfile::tempdir().unwrap();
    let server = crate::faults_provider::planning_server().await;
    let base = base_url(&server, ProviderKind::Openai);
    let image = not_utf8(home.path(), "scene");
    std::fs::copy(scene(home.path()), &image).unwrap();
    let table = not_utf8(home.path(), "table");
    std::fs::write(&table, "| object | place |\n| mug | sink |\n").unwrap();

    for (flag, path, approach) in [
        ("--image", &image, "single-image"),
        ("--table", &table, "single-table"),
    ] {
        for json in [true, false] {
            let mut args = os(&["plan", "--task", "Wash the mug", "--approach", approach]);
            args.extend(os(&["--base-url", &base, "--no-cache"]));
            args.extend([OsString::from(flag), path.clone().into_os_string()]);
            if json {
                args.push("--json".into());
            }
            let out = run(args, home.path()).await;
            let err = refusal(&out);
            assert!(
                err.contains(&format!("{flag} {}", path.to_string_lossy()))
                    && err.contains("not UTF-8"),
                "{err}"
            );
            assert!(out.stdout.is_empty(), "no document, not even a cut one");
        }
    }

    // A dataset folder or an output folder of such a name: refused before
    // any task is planned.
    let data = not_utf8(home.path(), "data");
    std::fs::create_dir(&data).unwrap();
    scene(&data);
    let task = serde_json::json!({"id": "t-1", "task": "Wash the mug", "image": "scene.png",
        "ground_truth": ["Walk to the sink.", "Wash the mug."]});
    std::fs::write(data.join("tasks.jsonl"), task.to_string()).unwrap();
    let good = home.path().join("good-data");
    std::fs::create_dir(&good).unwrap();
    scene(&good);
    std::fs::write(good.join("tasks.jsonl"), task.to_string()).unwrap();
    let out_dir = not_utf8(home.path(), "out");
    for (flag, dataset, out) in [
        ("--dataset", &data, home.path().join("out")),
        ("--out", &good, out_dir.clone()),
    ] {
        let mut args = os(&["eval", "--approaches", "single-image", "--metrics", "kas"]);
        args.extend(os(&["--base-url", &base, "--no-cache"]));
        args.extend([
            "--dataset".into(),
            dataset.clone().into_os_string(),
            "--out".into(),
            out.into_os_string(),
        ]);
        let err = refusal(&run(args, home.path()).await);
        assert!(err.contains(flag) && err.contains("not UTF-8"), "{err}");
    }
    assert!(!out_dir.exists(), "nothing was written");
    assert_eq!(asked(&server).await, 0, "no provider was paid");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_line_break_in_a_path_or_a_streamed_body_never_splits_the_error_line() {
    let home = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    let base = base_url(&server, ProviderKind::Openai);

    // A path that would fake a second `mapvlm:` line.
    let fake = home.path().join("a\nmapvlm: all is well.png");
    let out = run(
        os(&[
            "plan",
            "--task",
            "Wash the mug",
            "--approach",
            "single-image",
        ])
        .into_iter()
        .chain(os(&["--base-url", &base, "--no-cache", "--image"]))
        .chain([fake.into_os_string()])
        .collect::<Vec<_>>(),
        home.path(),
    )
    .await;
    let err = refusal(&out);
    assert!(err.contains("a\\nmapvlm: all is well.png"), "{err}");
    let out = run(
        os(&["score", "--gt", "no\nsuch", "--pred", "file"]),
        home.path(),
    )
    .await;
    let err = refusal(&out);
    assert!(err.contains("no\\nsuch"), "{err}");

    // A server that answers a request for a whole answer with a stream.
    let stream = "data: {\"choices\":[{\"delta\":{\"content\":\"1. Walk.\"}}]}\n\ndata: [DONE]\n\n";
    for content_type in ["text/event-stream", "text/plain"] {
        server.reset().await;
        answer(
            &server,
            ProviderKind::Openai,
            PLANNER_MARK,
            wiremock::ResponseTemplate::new(200).set_body_raw(stream, content_type),
        )
        .await;
        let mut args = crate::faults_provider::plan_args(home.path(), &base, &["--no-stream"]);
        args.push("--no-cache".into());
        let out = run(args, home.path()).await;
        let err = stderr(&out);
        assert!(!out.status.success(), "{err}");
        let last = err.lines().last().unwrap_or_default();
        assert!(
            last.starts_with("mapvlm: ")
                && last.contains("event stream")
                && last.contains("leave out --no-stream")
                && last.contains("data: {"),
            "{err}"
        );
        assert!(
            !err.lines().any(|l| l.starts_with("data:")),
            "no line of the body stands alone: {err}"
        );
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn an_agent_setting_the_approach_does_not_use_is_named_and_empty_names_are_refused() {
    let home = tempfile::tempdir().unwrap();
    let server = crate::faults_provider::planning_server().await;
    let base = base_url(&server, ProviderKind::Openai);

    let mut args = crate::faults_provider::plan_args(home.path(), &base, &["--no-cache"]);
    args.extend(["--agent".into(), "skm.model=x".into()]);
    let out = run(args, home.path()).await;
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains(
            "--agent skm.model=x: single-image runs no skm agent, so this setting is not used"
        ),
        "{err}"
    );
    let mut args = crate::faults_provider::plan_args(home.path(), &base, &["--no-cache"]);
    args.extend(["--agent".into(), "single.model=y".into()]);
    let err = stderr(&run(args, home.path()).await);
    assert!(!err.contains("not used"), "{err}");
    let asked_so_far = asked(&server).await;

    let config = home.path().join("config.toml");
    std::fs::write(&config, "[defaults]\nmodel = \" \"\n").unwrap();
    let config = config.to_str().unwrap().to_string();
    for (extra, named) in [
        (vec!["--model", ""], "the model name is empty"),
        (
            vec!["--agent", "single.model="],
            "single: the model name is empty",
        ),
        (vec!["--config", config.as_str()], "the model name is empty"),
        (vec!["--task", ""], "--task is empty"),
        (vec!["--task", " \t "], "--task is empty"),
    ] {
        let mut args = crate::faults_provider::plan_args(home.path(), &base, &["--no-cache"]);
        if extra[0] == "--task" {
            let at = args.iter().position(|a| a == "--task").unwrap();
            args[at + 1] = extra[1].to_string();
        } else {
            args.extend(extra.iter().map(|s| s.to_string()));
        }
        let err = refusal(&run(args, home.path()).await);
        assert!(err.contains(named), "{extra:?}: {err}");
    }
    assert_eq!(asked(&server).await, asked_so_far, "nothing sent");
}

#[tokio::test(flavor = "multi_thread")]
async fn negative_numbers_zero_resamples_and_a_lone_slurm_variable_get_their_own_message() {
    let home = tempfile::tempdir().unwrap();
    let server = crate::faults_provider::planning_server().await;
    let base = base_url(&server, ProviderKind::Openai);
    let data = home.path().join("data");
    std::fs::create_dir(&data).unwrap();
    let out = home.path().join("out");

    // `--flag -1` says what `--flag=-1` says: never "unexpected argument".
    for (flag, value) in [("--samples", "-1"), ("--concurrency", "-2")] {
        let spaced = crate::faults_provider::plan_args(home.path(), &base, &[flag, value]);
        let joined =
            crate::faults_provider::plan_args(home.path(), &base, &[&format!("{flag}={value}")]);
        let spaced = stderr(&run(spaced, home.path()).await);
        let joined = stderr(&run(joined, home.path()).await);
        assert!(!spaced.contains("unexpected argument"), "{spaced}");
        assert_eq!(spaced, joined);
        assert!(spaced.contains(value), "{spaced}");
    }
    let eval = |extra: &[&str]| {
        let mut args = crate::faults_provider::eval_args(&data, &out, &base);
        args.extend(extra.iter().map(|s| s.to_string()));
        args
    };
    for shard in ["-1/3", "-2"] {
        let spaced = refusal(&run(eval(&["--shard", shard]), home.path()).await);
        let joined = refusal(&run(eval(&[&format!("--shard={shard}")]), home.path()).await);
        assert_eq!(spaced, joined);
        assert!(
            spaced.contains(&format!("--shard `{shard}` is not a shard")),
            "{spaced}"
        );
    }

    // Slurm sets SLURM_ARRAY_TASK_COUNT beside SLURM_ARRAY_TASK_ID in an array.
    let home_path = home.path().to_path_buf();
    let args = eval(&["--shard", "auto"]);
    let lone = tokio::task::spawn_blocking(move || {
        mapvlm_command(&args, &home_path)
            .env("SLURM_ARRAY_TASK_ID", "2")
            .env_remove("SLURM_ARRAY_TASK_COUNT")
            .env_remove("SLURM_ARRAY_TASK_MIN")
            .env_remove("JOB_COMPLETION_INDEX")
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    let err = refusal(&lone);
    assert!(
        err.contains("SLURM_ARRAY_TASK_ID is 2 but SLURM_ARRAY_TASK_COUNT is not set"),
        "{err}"
    );
    assert_eq!(asked(&server).await, 0);

    // Zero resamples would leave every interval undefined.
    for flag in ["--bootstrap", "--permutations"] {
        let out = tokio::task::spawn_blocking(move || crate::cli_agree::agree_golden(&[flag, "0"]))
            .await
            .unwrap();
        let err = refusal(&out);
        assert!(
            err.contains(&format!("{flag} 0: ")) && err.contains("at least 1"),
            "{err}"
        );
    }
}

#[test]
fn annotate_names_once_each_image_outside_the_items_folder() {
    let home = tempfile::tempdir().unwrap();
    let items = home.path().join("items");
    let other = home.path().join("other");
    std::fs::create_dir_all(&items).unwrap();
    std::fs::create_dir_all(&other).unwrap();
    scene(&items);
    let absolute = scene(&other);
    let item = |id: &str, image: &str| {
        serde_json::json!({"id": id, "gt": ["Walk to the sink."], "pred": ["Walk to the sink."], "image": image})
            .to_string()
    };
    let lines = [
        item("i1", "../other/scene.png"),
        item("i2", absolute.to_str().unwrap()),
        item("i3", "../other/scene.png"),
        item("i4", "scene.png"),
    ];
    let file = items.join("items.jsonl");
    std::fs::write(&file, lines.join("\n")).unwrap();
    let args = ["annotate", file.to_str().unwrap(), "--annotator", "ana"];
    let out = mapvlm_command(&args, home.path()).output().unwrap();
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    for (image, id) in [
        ("../other/scene.png", "i1"),
        (absolute.to_str().unwrap(), "i2"),
    ] {
        assert_eq!(
            err.matches(&format!("image {image} (item ")).count(),
            1,
            "{image} named once: {err}"
        );
        assert!(
            err.contains(&format!("(item {id}) is outside the items' folder")),
            "{err}"
        );
    }
    assert!(
        !err.contains("(item i4)"),
        "an image inside is not named: {err}"
    );
    assert!(err.contains("annotate needs a terminal"), "{err}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_recording_onto_a_full_disk_still_prints_the_plan_and_says_so() {
    let home = tempfile::tempdir().unwrap();
    let server = crate::faults_provider::planning_server().await;
    let base = base_url(&server, ProviderKind::Openai);
    let disk = home.path().join("disk");
    std::fs::create_dir_all(&disk).unwrap();
    let record = disk.join("rec.json");
    let args = crate::faults_provider::plan_args(
        home.path(),
        &base,
        &["--no-cache", "--record", record.to_str().unwrap()],
    );
    // A 16 KiB tmpfs, filled, in a mount namespace of its own (`unshare`:
    // nothing is left mounted when the run ends). The probe still passes:
    // an empty file needs no block.
    let script = r#"mount -t tmpfs -o size=16k tmpfs "$DISK" || exit 99
head -c 16384 /dev/zero > "$DISK/filler" 2>/dev/null
exec "$@""#;
    let home_path = home.path().to_path_buf();
    let run = tokio::task::spawn_blocking(move || {
        crate::common::in_own_mounts(&mapvlm_command(&args, &home_path), script, &disk)
    })
    .await
    .unwrap();
    let err = stderr(&run);
    assert_ne!(run.status.code(), Some(99), "mount failed: {err}");
    assert!(!run.status.success(), "{err}");
    let out = String::from_utf8_lossy(&run.stdout);
    assert!(
        out.contains("1. Walk to the sink.") && out.contains("2. Wash the mug."),
        "the paid plan is printed: {out}\n{err}"
    );
    let last = err.lines().last().unwrap_or_default();
    assert!(
        last.contains(&format!("--record {}", record.display())) && last.contains("No space left"),
        "{err}"
    );
    assert_eq!(asked(&server).await, 1);
}

#[tokio::test(flavor = "multi_thread")]
async fn cache_clear_removes_only_entries_of_the_cache() {
    let home = tempfile::tempdir().unwrap();
    let server = crate::faults_provider::planning_server().await;
    let base = base_url(&server, ProviderKind::Openai);
    // A real entry: an answer cached by a run.
    let args = crate::faults_provider::plan_args(home.path(), &base, &[]);
    let planned = run(args, home.path()).await;
    assert!(planned.status.success(), "{}", stderr(&planned));
    let cache = home.path().join("cache/mapvlm/responses");
    let entries = |dir: &Path| -> Vec<std::path::PathBuf> {
        crate::common::files_under(dir)
            .into_iter()
            .map(|(path, _)| path)
            .filter(|path| {
                // 64 hex digits, as `SHARD/KEY.json`.
                path.extension().is_some_and(|e| e == "json")
                    && path.file_stem().is_some_and(|n| {
                        n.len() == 64 && n.to_string_lossy().bytes().all(|b| b.is_ascii_hexdigit())
                    })
            })
            .collect()
    };
    let cached = entries(&cache);
    assert_eq!(cached.len(), 1, "{cached:?}");
    let entry = &cached[0];
    let name = entry.file_name().unwrap().to_owned();
    let elsewhere = home.path().join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("a.bin"), b"keep").unwrap();
    std::os::unix::fs::symlink(&elsewhere, cache.join("linked")).unwrap();
    let theirs = [
        cache.join("sub/a.bin"),
        entry.with_file_name("notes.txt"),
        cache.join("zz").join(&name),
        elsewhere.join("a.bin"),
    ];
    for file in &theirs {
        std::fs::create_dir_all(file.parent().unwrap()).unwrap();
        std::fs::write(file, b"keep").unwrap();
    }

    let cleared = run(os(&["cache", "clear", "responses"]), home.path()).await;
    assert!(cleared.status.success(), "{}", stderr(&cleared));
    assert!(!entry.exists(), "the entry is removed");
    for file in &theirs {
        assert!(file.exists(), "{} is kept", file.display());
    }
}
