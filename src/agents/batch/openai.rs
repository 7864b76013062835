//! The OpenAI Batch API: the requests as a JSONL file uploaded to `/files`
//! with purpose `batch`, a batch created over it at `/batches` with a 24-hour
//! completion window, polled at `/batches/{id}`, and its output and error
//! files read from `/files/{id}/content`, each line matched by `custom_id`.

use serde_json::{json, Value};
use tokio_util::sync::CancellationToken;

use super::{
    completion, get_json, read_outcomes, request_count, string_field, BatchStatus, Outcome,
};
use crate::agents::openai::{answer_of, request_body};
use crate::agents::pipeline::PendingRequest;
use crate::agents::provider::HttpEndpoint;
use crate::agents::AgentError;

/// The endpoint every request of a batch goes to.
const ENDPOINT: &str = "/v1/chat/completions";

/// Statuses after which a batch changes no more.
const ENDED: [&str; 4] = ["completed", "failed", "expired", "cancelled"];

fn authorised(
    endpoint: &HttpEndpoint,
    builder: reqwest::RequestBuilder,
) -> reqwest::RequestBuilder {
    match &endpoint.key {
        Some(key) => builder.bearer_auth(key.expose()),
        None => builder,
    }
}

/// The JSONL input file of `requests`, built in memory: one line each with
/// its `custom_id`, method, endpoint and the Chat Completions body (never
/// streamed). No key is part of it.
pub fn input_file(requests: &[&PendingRequest]) -> Vec<u8> {
    let mut file = Vec::new();
    for pending in requests {
        let mut request = pending.request.clone();
        request.stream = false;
        let line = json!({
            "custom_id": pending.key,
            "method": "POST",
            "url": ENDPOINT,
            "body": request_body(&request, request.json_schema.is_some()),
        });
        file.extend_from_slice(line.to_string().as_bytes());
        file.push(b'\n');
    }
    file
}

/// Uploads the input file and creates the batch; returns the batch's id.
pub async fn submit(
    endpoint: &HttpEndpoint,
    requests: &[&PendingRequest],
    cancel: &CancellationToken,
) -> Result<String, AgentError> {
    let file = input_file(requests);
    let upload_url = endpoint.url("files");
    let upload = || {
        let part = reqwest::multipart::Part::bytes(file.clone()).file_name("mapvlm-batch.jsonl");
        let form = reqwest::multipart::Form::new()
            .text("purpose", "batch")
            .part("file", part);
        authorised(endpoint, endpoint.client.post(&upload_url).multipart(form))
    };
    let uploaded = endpoint
        .read_json(endpoint.send(upload, cancel).await?, cancel)
        .await?;
    let file_id = string_field(endpoint, &uploaded, "id", "the uploaded file")?;
    let body = json!({
        "input_file_id": file_id,
        "endpoint": ENDPOINT,
        "completion_window": "24h",
    });
    let create_url = endpoint.url("batches");
    let create = || authorised(endpoint, endpoint.client.post(&create_url).json(&body));
    let created = endpoint
        .read_json(endpoint.send(create, cancel).await?, cancel)
        .await?;
    string_field(endpoint, &created, "id", "the created batch")
}

/// The batch's status.
pub async fn status(
    endpoint: &HttpEndpoint,
    id: &str,
    cancel: &CancellationToken,
) -> Result<BatchStatus, AgentError> {
    let url = endpoint.url(&format!("batches/{id}"));
    let value = get_json(endpoint, &url, authorised, cancel).await?;
    let state = string_field(endpoint, &value, "status", "the batch")?;
    let count = |field: &str| request_count(&value, field);
    let results = ["output_file_id", "error_file_id"]
        .iter()
        .filter_map(|field| value.get(*field).and_then(Value::as_str))
        .map(str::to_string)
        .collect();
    let error = value
        .pointer("/errors/data")
        .and_then(Value::as_array)
        .map(|errors| {
            errors
                .iter()
                .filter_map(|e| e.get("message").and_then(Value::as_str))
                .collect::<Vec<_>>()
                .join("; ")
        })
        .filter(|message| !message.is_empty())
        .map(|message| endpoint.redact(&message));
    Ok(BatchStatus {
        ended: ENDED.contains(&state.as_str()),
        state,
        done: count("completed") + count("failed"),
        total: count("total"),
        results,
        error,
    })
}

/// Every line of the batch's output and error files: each request's answer
/// or why it failed, by `custom_id`.
pub async fn results(
    endpoint: &HttpEndpoint,
    status: &BatchStatus,
    model: &str,
    cancel: &CancellationToken,
) -> Result<Vec<(String, Outcome)>, AgentError> {
    let mut outcomes = Vec::new();
    for file_id in &status.results {
        let url = endpoint.url(&format!("files/{file_id}/content"));
        let get = || authorised(endpoint, endpoint.client.get(&url));
        let response = endpoint.send(get, cancel).await?;
        outcomes.extend(read_outcomes(endpoint, response, model, outcome, cancel).await?);
    }
    Ok(outcomes)
}

/// One line of an output or error file as an answer or a failure.
fn outcome(endpoint: &HttpEndpoint, line: &Value, model: &str) -> Outcome {
    if let Some(error) = line.get("error").filter(|e| !e.is_null()) {
        let code = error.get("code").and_then(Value::as_str).unwrap_or("error");
        let message = error.get("message").and_then(Value::as_str).unwrap_or("");
        return Outcome::Failed(endpoint.redact(&format!("{code}: {message}")));
    }
    let status = line
        .pointer("/response/status_code")
        .and_then(Value::as_u64)
        .unwrap_or(0);
    let body = line.pointer("/response/body").unwrap_or(&Value::Null);
    if status != 200 {
        let message = body
            .pointer("/error/message")
            .and_then(Value::as_str)
            .unwrap_or("no message");
        return Outcome::Failed(endpoint.redact(&format!("HTTP {status}: {message}")));
    }
    match answer_of(body) {
        Some((text, usage)) => completion(endpoint, text, usage, model),
        None => Outcome::Failed("no choices[0].message in the answer".into()),
    }
}
