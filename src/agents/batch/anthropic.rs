//! Anthropic's Message Batches: the requests posted to
//! `/v1/messages/batches` as `requests: [{custom_id, params}]`, polled at
//! `/v1/messages/batches/{id}` until `processing_status` is `ended`, and the
//! results read as JSONL from the batch's `results_url`, each line matched
//! by `custom_id`.

use serde_json::{json, Value};
use tokio_util::sync::CancellationToken;

use super::{
    completion, get_json, read_outcomes, request_count, string_field, BatchStatus, Outcome,
};
use crate::agents::anthropic::{answer_of, request_body, API_VERSION};
use crate::agents::pipeline::PendingRequest;
use crate::agents::provider::HttpEndpoint;
use crate::agents::AgentError;

fn authorised(
    endpoint: &HttpEndpoint,
    builder: reqwest::RequestBuilder,
) -> reqwest::RequestBuilder {
    let builder = builder.header("anthropic-version", API_VERSION);
    match &endpoint.key {
        Some(key) => builder.header("x-api-key", key.expose()),
        None => builder,
    }
}

/// The body that creates a batch of `requests`: each Messages request (never
/// streamed) under its `custom_id`. No key is part of it.
pub fn create_body(requests: &[&PendingRequest]) -> Value {
    let requests: Vec<Value> = requests
        .iter()
        .map(|pending| {
            let mut request = pending.request.clone();
            request.stream = false;
            let mut params = request_body(&request);
            if let Some(params) = params.as_object_mut() {
                params.remove("stream");
            }
            json!({"custom_id": pending.key, "params": params})
        })
        .collect();
    json!({ "requests": requests })
}

/// Creates the batch; returns its id.
pub async fn submit(
    endpoint: &HttpEndpoint,
    requests: &[&PendingRequest],
    cancel: &CancellationToken,
) -> Result<String, AgentError> {
    let body = create_body(requests);
    let url = endpoint.url("v1/messages/batches");
    let create = || authorised(endpoint, endpoint.client.post(&url).json(&body));
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
    let url = endpoint.url(&format!("v1/messages/batches/{id}"));
    let value = get_json(endpoint, &url, authorised, cancel).await?;
    let state = string_field(endpoint, &value, "processing_status", "the batch")?;
    let count = |field: &str| request_count(&value, field);
    let done = ["succeeded", "errored", "canceled", "expired"]
        .iter()
        .map(|field| count(field))
        .sum::<u64>();
    let results = value
        .get("results_url")
        .and_then(Value::as_str)
        .map(str::to_string)
        .into_iter()
        .collect();
    Ok(BatchStatus {
        ended: state == "ended",
        state,
        done,
        total: done + count("processing"),
        results,
        error: None,
    })
}

/// The lines of the batch's results: each request's answer or why it
/// failed, by `custom_id`. The results URL must lie under the base URL: the
/// key is sent to no other server.
pub async fn results(
    endpoint: &HttpEndpoint,
    status: &BatchStatus,
    model: &str,
    cancel: &CancellationToken,
) -> Result<Vec<(String, Outcome)>, AgentError> {
    let mut outcomes = Vec::new();
    for url in &status.results {
        if !url.starts_with(&format!("{}/", endpoint.base_url)) {
            return Err(endpoint.invalid(format!(
                "the results URL {url} is not under the base URL {}; the key is not sent elsewhere",
                endpoint.shown_url()
            )));
        }
        let get = || authorised(endpoint, endpoint.client.get(url));
        let response = endpoint.send(get, cancel).await?;
        outcomes.extend(read_outcomes(endpoint, response, model, outcome, cancel).await?);
    }
    Ok(outcomes)
}

/// One line of the results as an answer or a failure.
fn outcome(endpoint: &HttpEndpoint, line: &Value, model: &str) -> Outcome {
    let result = line.get("result").unwrap_or(&Value::Null);
    match result.get("type").and_then(Value::as_str) {
        Some("succeeded") => match result.get("message").and_then(answer_of) {
            Some((text, usage)) => completion(endpoint, &text, usage, model),
            None => Outcome::Failed("no `content` in the answer".into()),
        },
        Some("errored") => {
            let error = result
                .pointer("/error/error")
                .or_else(|| result.get("error"));
            let kind = error
                .and_then(|e| e.get("type"))
                .and_then(Value::as_str)
                .unwrap_or("error");
            let message = error
                .and_then(|e| e.get("message"))
                .and_then(Value::as_str)
                .unwrap_or("");
            Outcome::Failed(endpoint.redact(&format!("{kind}: {message}")))
        }
        Some(other) => Outcome::Failed(format!("{other} before it was answered")),
        None => Outcome::Failed("no `result.type` in its line of the results".into()),
    }
}
