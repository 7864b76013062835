//! The knowledge graph: SKM's output parsed into `(subject, relation,
//! object)` triples — from JSON when the provider produced it, else from
//! text, tolerant of numbering, quotes, brackets and stray prose — deduplicated,
//! with the lines that held no triple kept and counted.

use std::collections::{BTreeMap, HashSet};

use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

/// One fact: `subject --relation--> object`.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Triple {
    /// The thing the fact is about.
    pub subject: String,
    /// How it relates.
    pub relation: String,
    /// What it relates to.
    pub object: String,
}

impl Triple {
    fn key(&self) -> (String, String, String) {
        (
            normal(&self.subject),
            normal(&self.relation),
            normal(&self.object),
        )
    }
}

/// What parsing SKM's output gave.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ParsedTriples {
    /// The distinct triples, in order of first appearance.
    pub triples: Vec<Triple>,
    /// Non-blank lines that held no triple, as written.
    pub unparsed: Vec<String>,
    /// How many repeated triples were dropped.
    pub duplicates: usize,
    /// Whether the output was JSON.
    pub from_json: bool,
}

/// The JSON schema SKM is asked to follow where the provider supports it.
pub fn triples_schema() -> Value {
    json!({
        "type": "object",
        "properties": {
            "triples": {
                "type": "array",
                "items": {
                    "type": "object",
                    "properties": {
                        "subject": {"type": "string"},
                        "relation": {"type": "string"},
                        "object": {"type": "string"}
                    },
                    "required": ["subject", "relation", "object"],
                    "additionalProperties": false
                }
            }
        },
        "required": ["triples"],
        "additionalProperties": false
    })
}

/// Parses SKM's raw output into triples.
pub fn parse_triples(text: &str) -> ParsedTriples {
    let mut parsed = ParsedTriples::default();
    let found = match json_triples(text) {
        Some(triples) => {
            parsed.from_json = true;
            triples
        }
        None => text_triples(text, &mut parsed.unparsed),
    };
    let mut seen = HashSet::new();
    for triple in found {
        if seen.insert(triple.key()) {
            parsed.triples.push(triple);
        } else {
            parsed.duplicates += 1;
        }
    }
    parsed
}

fn json_triples(text: &str) -> Option<Vec<Triple>> {
    let body = text.trim();
    let body = body
        .strip_prefix("```json")
        .or_else(|| body.strip_prefix("```"))
        .map(|rest| rest.trim_end().trim_end_matches("```"))
        .unwrap_or(body);
    let value: Value = serde_json::from_str(body.trim()).ok()?;
    let items = match &value {
        Value::Array(items) => items,
        Value::Object(map) => map.get("triples")?.as_array()?,
        _ => return None,
    };
    let triple_of = |item: &Value| -> Option<Triple> {
        let parts: Vec<&str> = match item {
            Value::Array(parts) => parts.iter().map(Value::as_str).collect::<Option<_>>()?,
            Value::Object(map) => {
                let pick = |names: &[&str]| names.iter().find_map(|n| map.get(*n)?.as_str());
                vec![
                    pick(&["subject", "head", "s"])?,
                    pick(&["relation", "predicate", "p", "r"])?,
                    pick(&["object", "tail", "o"])?,
                ]
            }
            _ => return None,
        };
        make_triple(&parts)
    };
    Some(items.iter().filter_map(triple_of).collect())
}

fn text_triples(text: &str, unparsed: &mut Vec<String>) -> Vec<Triple> {
    let mut triples = Vec::new();
    for line in text.lines() {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with("```") {
            continue;
        }
        let mut found: Vec<Triple> = bracketed(trimmed)
            .into_iter()
            .filter_map(|group| make_triple(&split_parts(group)))
            .collect();
        if found.is_empty() {
            let bare = strip_marker(trimmed).trim_end_matches(['.', ';']);
            found.extend(make_triple(&split_parts(bare)));
        }
        if found.is_empty() {
            unparsed.push(trimmed.to_string());
        }
        triples.extend(found);
    }
    triples
}

/// The innermost `(…)`, `[…]` or `{…}` groups of `line`, without brackets.
fn bracketed(line: &str) -> Vec<&str> {
    let mut groups = Vec::new();
    let mut open = None;
    for (at, c) in line.char_indices() {
        match c {
            '(' | '[' | '{' => open = Some(at + 1),
            ')' | ']' | '}' => {
                if let Some(start) = open.take() {
                    groups.push(&line[start..at]);
                }
            }
            _ => {}
        }
    }
    groups
}

/// `line` without a leading bullet, number (`1.`, `2)`) or label (`Triple 3:`).
fn strip_marker(line: &str) -> &str {
    let rest = line.trim_start_matches(['-', '*', '•', '>']).trim_start();
    let lower = rest.to_ascii_lowercase();
    let label = ["triple", "fact"]
        .iter()
        .find(|word| lower.starts_with(**word))
        .map_or(0, |word| word.len());
    let after_label = rest[label..].trim_start();
    let digits = after_label.len()
        - after_label
            .trim_start_matches(|c: char| c.is_ascii_digit())
            .len();
    let after_number = after_label[digits..].trim_start();
    match after_number.chars().next() {
        Some(mark @ ('.' | ')' | ':' | '-')) if label > 0 || digits > 0 => {
            after_number[mark.len_utf8()..].trim_start()
        }
        _ => rest,
    }
}

fn split_parts(text: &str) -> Vec<&str> {
    for separator in [",", "|", "->", ";"] {
        let parts: Vec<&str> = text.split(separator).collect();
        if parts.len() == 3 {
            return parts;
        }
    }
    Vec::new()
}

fn make_triple(parts: &[&str]) -> Option<Triple> {
    let [subject, relation, object] = parts else {
        return None;
    };
    let clean = |part: &str| {
        let stripped = part.trim().trim_matches(|c: char| {
            matches!(c, '"' | '\'' | '`' | '‘' | '’' | '“' | '”' | '*' | '.') || c.is_whitespace()
        });
        stripped.split_whitespace().collect::<Vec<_>>().join(" ")
    };
    let triple = Triple {
        subject: clean(subject),
        relation: clean(relation),
        object: clean(object),
    };
    let words = |s: &str| s.split_whitespace().count();
    let sensible = !triple.subject.is_empty()
        && !triple.relation.is_empty()
        && !triple.object.is_empty()
        && [&triple.subject, &triple.relation, &triple.object]
            .iter()
            .all(|part| words(part) <= 8);
    sensible.then_some(triple)
}

fn normal(text: &str) -> String {
    text.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_lowercase()
}

/// A labelled edge between two nodes (indices into [`KnowledgeGraph::nodes`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Edge {
    /// The subject's node.
    pub from: usize,
    /// The relation.
    pub label: String,
    /// The object's node.
    pub to: usize,
}

/// The scene as a graph: objects as nodes, relations as labelled edges.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct KnowledgeGraph {
    /// Node names, in order of first appearance (case-insensitively distinct).
    pub nodes: Vec<String>,
    /// The edges.
    pub edges: Vec<Edge>,
}

impl KnowledgeGraph {
    /// The graph of `triples`.
    pub fn from_triples(triples: &[Triple]) -> Self {
        let mut graph = Self::default();
        let mut index: BTreeMap<String, usize> = BTreeMap::new();
        let mut node = |graph: &mut Self, name: &str| {
            *index.entry(normal(name)).or_insert_with(|| {
                graph.nodes.push(name.to_string());
                graph.nodes.len() - 1
            })
        };
        for triple in triples {
            let from = node(&mut graph, &triple.subject);
            let to = node(&mut graph, &triple.object);
            graph.edges.push(Edge {
                from,
                label: triple.relation.clone(),
                to,
            });
        }
        graph
    }

    /// The node called `name` (case and spacing ignored).
    pub fn find(&self, name: &str) -> Option<usize> {
        let wanted = normal(name);
        self.nodes.iter().position(|n| normal(n) == wanted)
    }

    /// Edges leaving `node`.
    pub fn outgoing(&self, node: usize) -> impl Iterator<Item = &Edge> {
        self.edges.iter().filter(move |e| e.from == node)
    }

    /// Edges reaching `node`.
    pub fn incoming(&self, node: usize) -> impl Iterator<Item = &Edge> {
        self.edges.iter().filter(move |e| e.to == node)
    }

    /// The nodes joined to `node` by an edge either way, without repeats.
    pub fn neighbours(&self, node: usize) -> Vec<usize> {
        let mut found = Vec::new();
        for edge in &self.edges {
            let other = match (edge.from == node, edge.to == node) {
                (true, _) => edge.to,
                (_, true) => edge.from,
                _ => continue,
            };
            if !found.contains(&other) {
                found.push(other);
            }
        }
        found
    }

    /// How many edges touch `node`.
    pub fn degree(&self, node: usize) -> usize {
        self.edges
            .iter()
            .filter(|e| e.from == node || e.to == node)
            .count()
    }

    /// The distinct relation labels, sorted.
    pub fn relations(&self) -> Vec<&str> {
        let mut labels: Vec<&str> = self.edges.iter().map(|e| e.label.as_str()).collect();
        labels.sort_unstable();
        labels.dedup();
        labels
    }

    /// The edges as `(subject, relation, object)` lines, for a prompt or a view.
    pub fn to_lines(&self) -> String {
        self.edges
            .iter()
            .map(|e| {
                format!(
                    "({}, {}, {})",
                    self.nodes[e.from], e.label, self.nodes[e.to]
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_with_numbering_quotes_brackets_and_prose() {
        let text = "Here are the triples:\n\
            1. (sponge, on, bathtub)\n\
            2) [\"Towel\", 'hangs on', rack]\n\
            - (Sponge,  ON, Bathtub)\n\
            * sink | next to | toilet\n\
            Triple 5: mirror, above, sink.\n\
            (a, b) and nothing else\n\
            (cup, in, sink), (cup, near, soap)\n\n";
        let parsed = parse_triples(text);
        let got: Vec<String> = parsed
            .triples
            .iter()
            .map(|t| format!("{}|{}|{}", t.subject, t.relation, t.object))
            .collect();
        assert_eq!(
            got,
            [
                "sponge|on|bathtub",
                "Towel|hangs on|rack",
                "sink|next to|toilet",
                "mirror|above|sink",
                "cup|in|sink",
                "cup|near|soap"
            ]
        );
        assert_eq!(parsed.duplicates, 1);
        assert_eq!(
            parsed.unparsed,
            ["Here are the triples:", "(a, b) and nothing else"]
        );
        assert!(!parsed.from_json);
    }

    #[test]
    fn json_output_in_either_shape() {
        let parsed = parse_triples(
            "```json\n{\"triples\": [{\"subject\": \"mug\", \"relation\": \"on\", \"object\": \"table\"}, [\"mug\", \"left of\", \"lamp\"]]}\n```",
        );
        assert!(parsed.from_json);
        assert_eq!(parsed.triples.len(), 2);
        assert_eq!(parsed.triples[1].relation, "left of");
    }

    #[test]
    fn graph_queries() {
        let parsed = parse_triples("(mug, on, table)\n(lamp, on, Table)\n(mug, left of, lamp)");
        let graph = KnowledgeGraph::from_triples(&parsed.triples);
        assert_eq!(graph.nodes, ["mug", "table", "lamp"]);
        let table = graph.find("TABLE").unwrap();
        assert_eq!(graph.incoming(table).count(), 2);
        assert_eq!(graph.degree(graph.find("mug").unwrap()), 2);
        assert_eq!(graph.neighbours(table), [0, 2]);
        assert_eq!(graph.relations(), ["left of", "on"]);
        assert_eq!(graph.to_lines().lines().nth(1), Some("(lamp, on, table)"));
    }
}
