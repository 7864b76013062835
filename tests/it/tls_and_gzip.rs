//! A provider behind TLS with a private CA (trusted through `SSL_CERT_FILE`
//! and refused without it, with a message saying how to trust it) and a
//! gzip-encoded answer (decoded as any well-kept client does).

use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use crate::agents_support::*;
use crate::faults_provider::{plan_args, planning_server};
use mapvlm::agents::ProviderKind;
use tokio::net::{TcpListener, TcpStream};
use tokio_rustls::rustls::pki_types::{CertificateDer, PrivateKeyDer, PrivatePkcs8KeyDer};
use tokio_rustls::rustls::ServerConfig;
use tokio_rustls::TlsAcceptor;
use wiremock::{Mock, MockServer, ResponseTemplate};

/// A private CA and a certificate it signed for `localhost`: the CA's PEM
/// (what a user puts in `SSL_CERT_FILE`) and the server's TLS settings.
pub(crate) fn private_ca() -> (String, ServerConfig) {
    let ca_key = rcgen::KeyPair::generate().unwrap();
    let mut ca_params = rcgen::CertificateParams::new(Vec::<String>::new()).unwrap();
    ca_params.is_ca = rcgen::IsCa::Ca(rcgen::BasicConstraints::Unconstrained);
    ca_params
        .distinguished_name
        .push(rcgen::DnType::CommonName, "mapvlm test CA");
    let ca = ca_params.self_signed(&ca_key).unwrap();
    let server_key = rcgen::KeyPair::generate().unwrap();
    let server = rcgen::CertificateParams::new(vec!["localhost".to_string()])
        .unwrap()
        .signed_by(&server_key, &ca, &ca_key)
        .unwrap();
    let key = PrivateKeyDer::Pkcs8(PrivatePkcs8KeyDer::from(server_key.serialize_der()));
    let config = ServerConfig::builder()
        .with_no_client_auth()
        .with_single_cert(vec![CertificateDer::from(server.der().to_vec())], key)
        .unwrap();
    (ca.pem(), config)
}

/// Ends TLS on a local port and passes each connection on to `backend`
/// (a plain-HTTP mock server); the `https://localhost:PORT` it serves.
pub(crate) async fn tls_front(config: ServerConfig, backend: &MockServer) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let port = listener.local_addr().unwrap().port();
    let acceptor = TlsAcceptor::from(Arc::new(config));
    let backend = *backend.address();
    tokio::spawn(async move {
        while let Ok((client, _)) = listener.accept().await {
            let acceptor = acceptor.clone();
            tokio::spawn(async move {
                // A refused handshake (the client does not trust the CA)
                // simply ends the connection.
                let Ok(mut client) = acceptor.accept(client).await else {
                    return;
                };
                let mut server = TcpStream::connect(backend).await.unwrap();
                let _ = tokio::io::copy_bidirectional(&mut client, &mut server).await;
            });
        }
    });
    format!("https://localhost:{port}")
}

async fn plan(args: Vec<String>, home: &Path, ca_file: Option<&Path>) -> std::process::Output {
    let home = home.to_path_buf();
    let ca_file = ca_file.map(Path::to_path_buf);
    tokio::task::spawn_blocking(move || {
        let mut command = mapvlm_command(&args, &home);
        command
            .env_remove("SSL_CERT_FILE")
            .env_remove("SSL_CERT_DIR");
        if let Some(file) = ca_file {
            command.env("SSL_CERT_FILE", file);
        }
        command.output().unwrap()
    })
    .await
    .unwrap()
}

/// The run succeeded and printed the served plan's two steps.
fn assert_planned(run: &std::process::Output) {
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    let out = String::from_utf8_lossy(&run.stdout);
    assert!(
        out.contains("Walk to the sink.") && out.contains("Wash the mug."),
        "{out}"
    );
}

#[tokio::test(flavor = "multi_thread")]
async fn a_server_of_a_private_ca_is_reached_through_ssl_cert_file_and_refused_with_a_hint_without_it(
) {
    let home = tempfile::tempdir().unwrap();
    let server = planning_server().await;
    let (ca_pem, config) = private_ca();
    let base = format!("{}/v1", tls_front(config, &server).await);
    let args = plan_args(home.path(), &base, &["--no-cache"]);

    let refused = plan(args.clone(), home.path(), None).await;
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success(), "{err}");
    assert!(
        err.contains("certificate")
            && err.contains("SSL_CERT_FILE")
            && err.contains("SSL_CERT_DIR"),
        "{err}"
    );
    assert_eq!(
        server.received_requests().await.unwrap().len(),
        0,
        "nothing passed an untrusted handshake"
    );

    let ca_file = home.path().join("private-ca.pem");
    std::fs::write(&ca_file, ca_pem).unwrap();
    assert_planned(&plan(args, home.path(), Some(&ca_file)).await);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_gzip_encoded_answer_is_decoded() {
    let home = tempfile::tempdir().unwrap();
    let server = MockServer::start().await;
    let provider = ProviderKind::Openai;
    let body = serde_json::json!({
        "id": "cmpl-1", "object": "chat.completion",
        "choices": [{"index": 0, "finish_reason": "stop",
            "message": {"role": "assistant", "content": "1. Walk to the sink.\n2. Wash the mug."}}],
        "usage": {"prompt_tokens": 10, "completion_tokens": 5}
    });
    let mut gzip = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gzip.write_all(body.to_string().as_bytes()).unwrap();
    let gzipped = gzip.finish().unwrap();
    let response = ResponseTemplate::new(200)
        .insert_header("content-encoding", "gzip")
        .set_body_raw(gzipped, "application/json");
    Mock::given(wiremock::matchers::body_string_contains(PLANNER_MARK))
        .respond_with(response)
        .mount(&server)
        .await;
    let base = base_url(&server, provider);
    let args = plan_args(home.path(), &base, &["--no-cache", "--no-stream"]);
    assert_planned(&plan(args, home.path(), None).await);
    let request = &server.received_requests().await.unwrap()[0];
    let accepted = request
        .headers
        .get("accept-encoding")
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    assert!(accepted.contains("gzip"), "asked for gzip: {accepted:?}");
}
