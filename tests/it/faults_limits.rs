//! Fault matrix, rows H10, H11 and H14 (see `tests/FAULTS.md`): a whole
//! (`--no-stream`) answer body and a line of `tasks.jsonl` have their
//! limits, each named when it stops a read, and memory stays bounded by
//! them. The real binary, against a local server that never stops sending.

use crate::agents_support::*;
use crate::faults_hostile::peak_rss;

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use mapvlm::agents::ProviderKind;
use mapvlm::limits::{MAX_BODY_BYTES, MAX_TASK_LINE_BYTES};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpListener;

/// What [`endless`] sends.
#[derive(Clone, Copy)]
enum Endless {
    /// A JSON body of spaces, with this `Content-Length`.
    Announced(u64),
    /// A JSON body of spaces, chunked.
    Chunked,
    /// An OpenAI stream of 512 KiB events that never finishes, chunked.
    Stream,
}

/// A server answering every request with status 200 and a body that never
/// ends (1 MiB a write, at most 1 GiB); its base URL and the bytes of body
/// it sent.
async fn endless(kind: Endless) -> (String, Arc<AtomicU64>) {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let base = format!("http://{}/v1", listener.local_addr().unwrap());
    let sent = Arc::new(AtomicU64::new(0));
    let counter = sent.clone();
    tokio::spawn(async move {
        while let Ok((mut socket, _)) = listener.accept().await {
            let counter = counter.clone();
            tokio::spawn(async move {
                // The request is small (a 60×40 scene): one read holds it.
                let mut request = vec![0u8; 1 << 20];
                let _ = socket.read(&mut request).await;
                let (head, piece) = match kind {
                    Endless::Announced(n) => (
                        format!("content-type: application/json\r\ncontent-length: {n}"),
                        vec![b' '; 1 << 20],
                    ),
                    Endless::Chunked => (
                        "content-type: application/json\r\ntransfer-encoding: chunked".to_string(),
                        vec![b' '; 1 << 20],
                    ),
                    Endless::Stream => {
                        let event = serde_json::json!({"choices": [{"index": 0,
                            "delta": {"content": "wash ".repeat((512 << 10) / 5)}}]});
                        let event = format!("data: {event}\n\n");
                        (
                            "content-type: text/event-stream\r\ntransfer-encoding: chunked"
                                .to_string(),
                            event.repeat(2).into_bytes(),
                        )
                    }
                };
                let head = format!("HTTP/1.1 200 OK\r\n{head}\r\n\r\n");
                if socket.write_all(head.as_bytes()).await.is_err() {
                    return;
                }
                let chunked = !matches!(kind, Endless::Announced(_));
                let mut chunk = Vec::new();
                if chunked {
                    chunk.extend(format!("{:x}\r\n", piece.len()).into_bytes());
                }
                chunk.extend_from_slice(&piece);
                if chunked {
                    chunk.extend_from_slice(b"\r\n");
                }
                // At most 1 GiB, should the client never hang up.
                while counter.load(Ordering::Relaxed) < 1 << 30 {
                    if socket.write_all(&chunk).await.is_err() {
                        return;
                    }
                    counter.fetch_add(piece.len() as u64, Ordering::Relaxed);
                }
            });
        }
    });
    (base, sent)
}

/// [`peak_rss`] of `command`, off the async runtime so the servers answer.
async fn measured(command: std::process::Command) -> (i64, std::process::ExitStatus, String) {
    tokio::task::spawn_blocking(move || peak_rss(command))
        .await
        .unwrap()
}

/// `plan --no-stream` of the single-image approach against `base`.
fn plan(home: &Path, base: &str) -> std::process::Command {
    let args = crate::faults_provider::plan_args(home, base, &["--no-stream", "--no-cache"]);
    mapvlm_command(&args, home)
}

#[tokio::test(flavor = "multi_thread")]
async fn a_whole_body_past_its_limit_is_refused_at_the_limit_in_bounded_memory() {
    let home = tempfile::tempdir().unwrap();
    let server = wiremock::MockServer::start().await;
    let provider = ProviderKind::Openai;
    answer(
        &server,
        provider,
        PLANNER_MARK,
        whole(provider, "1. Walk to the sink.\n2. Wash the mug."),
    )
    .await;
    let normal = plan(home.path(), &base_url(&server, provider));
    let (normal, status, err) = measured(normal).await;
    assert!(status.success(), "{err}");
    let limit_mib = MAX_BODY_BYTES >> 20;
    let named = format!("a body longer than the limit of {limit_mib} MiB");

    // Announced: refused from the header, before the body is read.
    let (base, sent) = endless(Endless::Announced(2 << 30)).await;
    let announced = plan(home.path(), &base);
    let (_, status, err) = measured(announced).await;
    assert!(!status.success(), "{err}");
    assert!(err.contains(&named), "{err}");
    assert!(
        sent.load(Ordering::Relaxed) < MAX_BODY_BYTES as u64,
        "read {} bytes of an announced 2 GiB",
        sent.load(Ordering::Relaxed)
    );

    // Not announced (chunked): reading stops at the limit.
    let (base, sent) = endless(Endless::Chunked).await;
    let chunked = plan(home.path(), &base);
    let (peak, status, err) = measured(chunked).await;
    assert!(!status.success(), "{err}");
    assert!(err.contains(&named), "{err}");
    let limit_kib = (MAX_BODY_BYTES >> 10) as i64;
    assert!(
        peak <= normal + 2 * limit_kib,
        "{peak} KiB against {normal} KiB for a normal answer"
    );
    let sent = sent.load(Ordering::Relaxed);
    assert!(
        sent < 3 * MAX_BODY_BYTES as u64,
        "the server sent {sent} bytes before the client hung up"
    );
}

#[tokio::test(flavor = "multi_thread")]
async fn a_stream_past_its_total_is_refused_at_the_limit_in_bounded_memory() {
    let home = tempfile::tempdir().unwrap();
    // The largest token limit: 8 MB of answer allowed.
    let max_tokens = "1000000";
    let limit = mapvlm::limits::answer_bytes(1_000_000);
    let server = crate::faults_provider::planning_server().await;
    let streamed = |base: &str| {
        let args = crate::faults_provider::plan_args(
            home.path(),
            base,
            &["--no-cache", "--max-tokens", max_tokens],
        );
        mapvlm_command(&args, home.path())
    };
    let (normal, status, err) = measured(streamed(&base_url(&server, ProviderKind::Openai))).await;
    assert!(status.success(), "{err}");
    let (base, sent) = endless(Endless::Stream).await;
    let (peak, status, err) = measured(streamed(&base)).await;
    assert!(!status.success(), "{err}");
    assert!(
        err.contains(&format!("an answer longer than the limit of {limit} bytes")),
        "{err}"
    );
    // Bounded by the limit, not by what the server sends (600 MB once cost
    // 2.26 GB): at most twice the limit over a normal answer's peak.
    let limit_kib = (limit >> 10) as i64;
    eprintln!("peak {peak} KiB, normal {normal} KiB, limit {limit_kib} KiB");
    assert!(
        peak <= normal + 2 * limit_kib,
        "{peak} KiB against {normal} KiB for a normal answer"
    );
    let sent = sent.load(Ordering::Relaxed);
    assert!(sent < 4 * limit as u64, "the server sent {sent} bytes");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_tasks_line_past_its_limit_is_refused_with_its_number_and_the_others_run() {
    let home = tempfile::tempdir().unwrap();
    let data = home.path().join("data");
    std::fs::create_dir(&data).unwrap();
    scene(&data);
    let task = |id: &str, text: &str| {
        serde_json::json!({"id": id, "task": text, "image": "scene.png",
            "ground_truth": ["Walk to the sink.", "Wash the mug."]})
        .to_string()
    };
    let (first, last) = (task("t-1", "Wash the mug"), task("t-3", "Dry it"));
    let server = crate::faults_provider::planning_server().await;
    let base = base_url(&server, ProviderKind::Openai);
    let eval = |out: &Path| {
        let args = crate::faults_provider::eval_args(&data, out, &base);
        mapvlm_command(&args, home.path())
    };
    std::fs::write(data.join("tasks.jsonl"), format!("{first}\n{last}\n")).unwrap();
    let normal = eval(&home.path().join("normal"));
    let (normal, status, err) = measured(normal).await;
    assert!(status.success(), "{err}");
    server.reset().await;
    crate::faults_provider::answer_plans(&server).await;

    {
        // Ten times the limit: reading it whole would show. Dropped before
        // the run, since a child's peak counts its parent's pages before
        // `exec`.
        let huge = "wash ".repeat(2 * MAX_TASK_LINE_BYTES);
        let lines = [first, task("t-2", &huge), last];
        std::fs::write(data.join("tasks.jsonl"), lines.join("\n")).unwrap();
    }
    let out = home.path().join("out");
    let command = eval(&out);
    let (peak, status, err) = measured(command).await;
    assert!(!status.success(), "{err}");
    let limit = MAX_TASK_LINE_BYTES;
    assert!(
        err.contains("tasks.jsonl:2")
            && err.contains(&format!("is longer than the limit of {limit}")),
        "{err}"
    );
    for id in ["t-1", "t-3"] {
        assert!(
            out.join(format!("tasks/{id}.single-image.json")).is_file(),
            "{id} was planned: {err}"
        );
    }
    assert!(!out.join("tasks/t-2.single-image.json").exists());
    assert_eq!(server.received_requests().await.unwrap().len(), 2);
    // The line was skipped unread: at most twice the limit more memory.
    let line_kib = (limit >> 10) as i64;
    assert!(
        peak <= normal + 2 * line_kib,
        "{peak} KiB against {normal} KiB without the line: {err}"
    );
}
