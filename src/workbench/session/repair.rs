//! Numbers in a session file that its types cannot hold (a temperature of
//! 1e300, a negative token count, a `null` where an older mapvlm wrote an
//! infinity) are put back to their defaults, each with a notice, before the
//! file is read: one bad value must not set aside the whole run history.

use serde_json::{Map, Value};

use crate::agents::config::{DEFAULT_MAX_TOKENS, MAX_TOKENS_RANGE, TEMPERATURE_RANGE};
use crate::agents::pipeline::MAX_SAMPLES;

/// What a numeric field of a session holds, and its default.
#[derive(Clone, Copy)]
enum Kind {
    /// A sampling temperature in [`TEMPERATURE_RANGE`]; default 0.
    Temperature,
    /// A token limit in [`MAX_TOKENS_RANGE`]; default [`DEFAULT_MAX_TOKENS`].
    TokenLimit,
    /// A count, an id or a time: a whole number 0 or more; default 0.
    Count,
    /// An optional score: a finite number or `null`; default `null`.
    Score,
    /// How many samples a run asks for: 1 to [`MAX_SAMPLES`]; default 1.
    Samples,
}

impl Kind {
    /// Whether `value` is one of this kind.
    fn holds(self, value: &Value) -> bool {
        match self {
            Kind::Temperature => value
                .as_f64()
                .is_some_and(|t| TEMPERATURE_RANGE.contains(&t)),
            Kind::TokenLimit => value
                .as_u64()
                .and_then(|n| u32::try_from(n).ok())
                .is_some_and(|n| MAX_TOKENS_RANGE.contains(&n)),
            Kind::Count => value.is_u64(),
            Kind::Score => value.is_null() || value.as_f64().is_some_and(f64::is_finite),
            Kind::Samples => value
                .as_u64()
                .is_some_and(|n| (1..=u64::from(MAX_SAMPLES)).contains(&n)),
        }
    }

    /// What a value of this kind must be, for the notice.
    fn expected(self) -> String {
        match self {
            Kind::Temperature => format!(
                "a temperature in {}..={}",
                TEMPERATURE_RANGE.start(),
                TEMPERATURE_RANGE.end()
            ),
            Kind::TokenLimit => format!(
                "a token limit in {}..={}",
                MAX_TOKENS_RANGE.start(),
                MAX_TOKENS_RANGE.end()
            ),
            Kind::Count => "a whole number, 0 or more".to_string(),
            Kind::Score => "a finite number or null".to_string(),
            Kind::Samples => format!("a number of samples in 1..={MAX_SAMPLES}"),
        }
    }

    /// The value put in place of a bad one.
    fn default(self) -> Value {
        match self {
            Kind::Temperature => 0.into(),
            Kind::TokenLimit => DEFAULT_MAX_TOKENS.into(),
            Kind::Count => 0.into(),
            Kind::Score => Value::Null,
            Kind::Samples => 1.into(),
        }
    }
}

/// Puts every numeric field of the session JSON `session` that its type
/// cannot hold back to its default; returns one notice per value replaced,
/// naming where it was, what it was and what it became. Fields that are
/// missing are left for the reader to report.
pub(super) fn repair_numbers(session: &mut Value) -> Vec<String> {
    let mut notices = Vec::new();
    if let Some(object) = session.as_object_mut() {
        fix_field(object, "", "samples", Kind::Samples, &mut notices);
    }
    fix(
        session.get_mut("draft"),
        "draft",
        &[("index", Kind::Count)],
        &mut notices,
    );
    repair_source(session, "", &mut notices);
    let parked = session.get_mut("parked").and_then(Value::as_array_mut);
    for (i, source) in parked.into_iter().flatten().enumerate() {
        repair_source(source, &format!("parked[{i}]."), &mut notices);
    }
    notices
}

/// [`repair_numbers`] over the fields of one source (see
/// [`super::SourceState`]), named with `prefix` in the notices.
fn repair_source(source: &mut Value, prefix: &str, notices: &mut Vec<String>) {
    let settings = [
        ("temperature", Kind::Temperature),
        ("max_tokens", Kind::TokenLimit),
    ];
    for (role, agent) in entries(source.get_mut("settings")) {
        fix(
            Some(agent),
            &format!("{prefix}settings.{role}"),
            &settings,
            notices,
        );
    }
    for (role, pair) in entries(source.get_mut("ran_with")) {
        fix(
            pair.get_mut(1),
            &format!("{prefix}ran_with.{role}"),
            &settings,
            notices,
        );
    }
    fix(
        source.get_mut("ground_truth_source"),
        &format!("{prefix}ground_truth_source"),
        &[("index", Kind::Count)],
        notices,
    );
    fix(
        source.get_mut("plan_source"),
        &format!("{prefix}plan_source"),
        &[("run", Kind::Count)],
        notices,
    );
    let runs = source.get_mut("runs").and_then(Value::as_array_mut);
    for (i, run) in runs.into_iter().flatten().enumerate() {
        let at = format!("{prefix}runs[{i}]");
        fix(
            Some(run),
            &at,
            &[("id", Kind::Count), ("started_unix", Kind::Count)],
            notices,
        );
        let scores = ["kas", "s_plan", "s_goal", "pg2s"].map(|name| (name, Kind::Score));
        fix(
            run.get_mut("scores"),
            &format!("{at}.scores"),
            &scores,
            notices,
        );
        let samples = run.get_mut("samples").and_then(Value::as_array_mut);
        for (j, sample) in samples.into_iter().flatten().enumerate() {
            let at = format!("{at}.samples[{j}]");
            fix(
                sample.get_mut("scores"),
                &format!("{at}.scores"),
                &scores,
                notices,
            );
        }
        let agents = run.get_mut("agents").and_then(Value::as_array_mut);
        for (j, agent) in agents.into_iter().flatten().enumerate() {
            let at = format!("{at}.agents[{j}]");
            fix(
                Some(&mut *agent),
                &at,
                &[("elapsed_ms", Kind::Count)],
                notices,
            );
            fix(Some(&mut *agent), &at, &settings, notices);
            let usage = [
                ("input_tokens", Kind::Count),
                ("output_tokens", Kind::Count),
            ];
            fix(
                agent.get_mut("usage"),
                &format!("{at}.usage"),
                &usage,
                notices,
            );
        }
    }
}

/// [`fix_field`] over each of `fields` of `object`, when it is an object.
fn fix(object: Option<&mut Value>, path: &str, fields: &[(&str, Kind)], notices: &mut Vec<String>) {
    let Some(object) = object.and_then(Value::as_object_mut) else {
        return;
    };
    for &(field, kind) in fields {
        fix_field(object, path, field, kind, notices);
    }
}

/// The entries of a JSON object (none when `value` is not one).
fn entries(value: Option<&mut Value>) -> impl Iterator<Item = (&String, &mut Value)> {
    value.and_then(Value::as_object_mut).into_iter().flatten()
}

/// Replaces `object[field]` by its kind's default when it is present and
/// not of its kind, noting it.
fn fix_field(
    object: &mut Map<String, Value>,
    path: &str,
    field: &str,
    kind: Kind,
    notices: &mut Vec<String>,
) {
    let Some(value) = object.get_mut(field) else {
        return;
    };
    if kind.holds(value) {
        return;
    }
    let default = kind.default();
    let at = if path.is_empty() {
        field.to_string()
    } else {
        format!("{path}.{field}")
    };
    notices.push(format!(
        "session value {at} = {value} is not {}; {default} used instead",
        kind.expected()
    ));
    *value = default;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn good_values_are_left_as_they_are() {
        let mut session = serde_json::json!({
            "settings": {"planner": {"temperature": 2.0, "max_tokens": 1_000_000}},
            "runs": [{"id": 3, "started_unix": 0, "scores": {"kas": null, "pg2s": -0.5},
                      "agents": [{"elapsed_ms": 7, "usage": {"input_tokens": 1, "output_tokens": 0}}]}],
        });
        let before = session.clone();
        assert!(repair_numbers(&mut session).is_empty());
        assert_eq!(session, before);
    }

    #[test]
    fn each_bad_number_falls_back_to_its_default_with_a_notice() {
        let mut session = serde_json::json!({
            "settings": {"planner": {"temperature": 1e300, "max_tokens": 0},
                         "skm": {"temperature": null, "max_tokens": 4_294_967_296_u64}},
            "ran_with": {"gkm": ["prompt", {"temperature": -0.5, "max_tokens": "many"}]},
            "draft": {"index": -1},
            "samples": 0,
            "plan_source": {"kind": "run", "run": 1.5},
            "runs": [{"id": -2, "started_unix": 1e300, "scores": {"kas": "high"},
                      "samples": [{"scores": {"pg2s": "low"}}],
                      "agents": [{"elapsed_ms": null, "temperature": 3, "max_tokens": 5,
                                  "usage": {"input_tokens": -1, "output_tokens": 2}}]}],
        });
        let notices = repair_numbers(&mut session);
        assert_eq!(notices.len(), 16, "{notices:#?}");
        assert!(
            notices.contains(
                &"session value samples = 0 is not a number of samples in 1..=100; 1 used instead"
                    .to_string()
            ),
            "{notices:#?}"
        );
        assert_eq!(
            session["runs"][0]["samples"][0]["scores"]["pg2s"],
            Value::Null
        );
        assert!(notices.contains(
            &"session value settings.planner.temperature = 1e+300 is not a temperature in 0..=2; 0 used instead".to_string()
        ), "{notices:#?}");
        assert!(notices.iter().any(|n| n.starts_with(
            "session value runs[0].agents[0].usage.input_tokens = -1 is not a whole number"
        )));
        assert_eq!(session["settings"]["planner"]["temperature"], 0);
        assert_eq!(session["settings"]["skm"]["max_tokens"], DEFAULT_MAX_TOKENS);
        assert_eq!(
            session["ran_with"]["gkm"][1]["max_tokens"],
            DEFAULT_MAX_TOKENS
        );
        assert_eq!(session["runs"][0]["scores"]["kas"], Value::Null);
        assert_eq!(session["runs"][0]["agents"][0]["max_tokens"], 5);
        assert_eq!(session["runs"][0]["agents"][0]["usage"]["output_tokens"], 2);
        assert!(
            repair_numbers(&mut session).is_empty(),
            "repaired once for all"
        );
    }
}
