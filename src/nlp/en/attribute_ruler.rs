//! The attribute ruler: token patterns (spaCy Matcher patterns without
//! operators) that set POS, TAG and DEP, applied in the order they were added.

use std::path::Path;

use regex::Regex;
use rmpv::Value;

use super::weights::{as_text, get, read_msgpack};
use super::EnError;

/// The token fields the ruler reads and writes.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TokenAttrs {
    /// The text.
    pub text: String,
    /// Fine-grained tag.
    pub tag: String,
    /// Coarse part of speech.
    pub pos: String,
    /// Dependency label.
    pub dep: String,
    /// Whether the token is whitespace.
    pub is_space: bool,
}

#[derive(Debug, Clone, Copy)]
enum Field {
    Orth,
    Lower,
    Tag,
    Pos,
    Dep,
    IsSpace,
}

enum Test {
    Equals(String),
    Bool(bool),
    In(Vec<String>),
    NotIn(Vec<String>),
    Regex(Regex),
}

struct Rule {
    /// Alternative token sequences; each token is a list of field tests.
    patterns: Vec<Vec<Vec<(Field, Test)>>>,
    pos: Option<String>,
    tag: Option<String>,
    dep: Option<String>,
    index: i64,
}

/// The attribute ruler component.
pub struct AttributeRuler {
    rules: Vec<Rule>,
}

impl AttributeRuler {
    /// Loads `attribute_ruler/patterns`.
    pub fn load(path: &Path) -> Result<Self, EnError> {
        let root = read_msgpack(path)?;
        let entries = root
            .as_array()
            .ok_or_else(|| EnError::corrupt(path, "patterns is not a list"))?;
        let rules = entries
            .iter()
            .enumerate()
            .map(|(i, entry)| {
                parse_rule(entry).map_err(|e| EnError::corrupt(path, &format!("pattern {i}: {e}")))
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { rules })
    }

    /// Matches every rule on the original tokens, then applies the matches
    /// in rule order (later rules win).
    pub fn apply(&self, tokens: &mut [TokenAttrs]) {
        let lowers: Vec<String> = tokens.iter().map(|t| t.text.to_lowercase()).collect();
        let mut matches: Vec<(usize, usize, usize)> = Vec::new();
        for (r, rule) in self.rules.iter().enumerate() {
            for pattern in &rule.patterns {
                if pattern.is_empty() || pattern.len() > tokens.len() {
                    continue;
                }
                for start in 0..=tokens.len() - pattern.len() {
                    let all = pattern.iter().enumerate().all(|(k, tests)| {
                        tests
                            .iter()
                            .all(|(f, t)| passes(&tokens[start + k], &lowers[start + k], *f, t))
                    });
                    if all {
                        matches.push((r, start, start + pattern.len()));
                    }
                }
            }
        }
        matches.sort();
        for (r, start, end) in matches {
            let rule = &self.rules[r];
            let len = (end - start) as i64;
            let offset = if rule.index < 0 {
                len + rule.index
            } else {
                rule.index
            };
            if offset < 0 || offset >= len {
                continue;
            }
            let token = &mut tokens[start + offset as usize];
            if let Some(pos) = &rule.pos {
                token.pos.clone_from(pos);
            }
            if let Some(tag) = &rule.tag {
                token.tag.clone_from(tag);
            }
            if let Some(dep) = &rule.dep {
                token.dep.clone_from(dep);
            }
        }
    }
}

fn passes(token: &TokenAttrs, lower: &str, field: Field, test: &Test) -> bool {
    let value = match field {
        Field::Orth => token.text.as_str(),
        Field::Lower => lower,
        Field::Tag => token.tag.as_str(),
        Field::Pos => token.pos.as_str(),
        Field::Dep => token.dep.as_str(),
        Field::IsSpace => {
            return match test {
                Test::Bool(b) => *b == token.is_space,
                _ => false,
            }
        }
    };
    match test {
        Test::Equals(s) => s == value,
        Test::Bool(_) => false,
        Test::In(set) => set.iter().any(|s| s == value),
        Test::NotIn(set) => !set.iter().any(|s| s == value),
        Test::Regex(re) => re.is_match(value),
    }
}

fn parse_rule(entry: &Value) -> Result<Rule, String> {
    let mut patterns = Vec::new();
    for pattern in get(entry, "patterns")
        .and_then(Value::as_array)
        .ok_or("no patterns")?
    {
        let mut tokens = Vec::new();
        for token in pattern.as_array().ok_or("a pattern is not a list")? {
            let mut tests = Vec::new();
            for (key, value) in token.as_map().ok_or("a token pattern is not a map")? {
                let field = match as_text(key).ok_or("bad key")? {
                    "ORTH" | "TEXT" => Field::Orth,
                    "LOWER" => Field::Lower,
                    "TAG" => Field::Tag,
                    "POS" => Field::Pos,
                    "DEP" => Field::Dep,
                    "IS_SPACE" => Field::IsSpace,
                    other => return Err(format!("unsupported token attribute {other}")),
                };
                tests.push((field, parse_test(value)?));
            }
            tokens.push(tests);
        }
        patterns.push(tokens);
    }
    let attrs = get(entry, "attrs").ok_or("no attrs")?;
    let text_attr = |name: &str| get(attrs, name).and_then(as_text).map(str::to_string);
    Ok(Rule {
        patterns,
        pos: text_attr("POS"),
        tag: text_attr("TAG"),
        dep: text_attr("DEP"),
        index: get(entry, "index").and_then(Value::as_i64).unwrap_or(0),
    })
}

fn parse_test(value: &Value) -> Result<Test, String> {
    if let Some(b) = value.as_bool() {
        return Ok(Test::Bool(b));
    }
    if let Some(s) = as_text(value) {
        return Ok(Test::Equals(s.to_string()));
    }
    let map = value.as_map().ok_or("unsupported token test")?;
    let [(op, arg)] = map.as_slice() else {
        return Err("a token test has more than one operator".to_string());
    };
    let strings = || -> Result<Vec<String>, String> {
        arg.as_array()
            .ok_or("IN/NOT_IN needs a list")?
            .iter()
            .map(|v| {
                as_text(v)
                    .map(str::to_string)
                    .ok_or("a non-text list item".to_string())
            })
            .collect()
    };
    match as_text(op).ok_or("bad operator")? {
        "IN" => Ok(Test::In(strings()?)),
        "NOT_IN" => Ok(Test::NotIn(strings()?)),
        "REGEX" => {
            let pattern = as_text(arg).ok_or("REGEX needs text")?;
            Regex::new(pattern)
                .map(Test::Regex)
                .map_err(|e| format!("bad REGEX: {e}"))
        }
        other => Err(format!("unsupported operator {other}")),
    }
}
