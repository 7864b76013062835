//! spaCy's rule-based tokenizer, configured from the model's `tokenizer`
//! file: whitespace splitting, special cases, prefix/suffix/infix patterns,
//! the URL matcher, and the special-case pass over the finished tokens.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Mutex;

use fancy_regex::Regex;
use rmpv::Value;

use super::lexeme::py_isspace;
use super::weights::{as_text, get, read_msgpack};
use super::EnError;

/// spaCy's attribute id for ORTH in special-case rules.
const ORTH: u64 = 65;
/// spaCy's attribute id for NORM in special-case rules.
const NORM: u64 = 67;

/// A token as the tokenizer makes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawToken {
    /// The token's text.
    pub text: String,
    /// Whether one space follows it.
    pub spacy: bool,
    /// The norm a special case gave it, if any.
    pub norm: Option<String>,
}

impl RawToken {
    fn plain(text: &str) -> Self {
        Self {
            text: text.to_string(),
            spacy: false,
            norm: None,
        }
    }
}

/// One special case: the tokens a string becomes.
type Special = Vec<RawToken>;

/// How many space-separated chunks the tokenizer remembers, as spaCy.
const MAX_CACHE: usize = 10_000;

/// The tokenizer of the English pipeline.
pub struct Tokenizer {
    prefix: Option<Regex>,
    suffix: Option<Regex>,
    infix: Option<Regex>,
    token_match: Option<Regex>,
    url_match: Option<Regex>,
    specials: HashMap<String, Special>,
    /// Special cases re-applied after tokenization, keyed by their first
    /// token: (the affix tokenization of the string, the string).
    phrase_patterns: HashMap<String, Vec<(Vec<String>, String)>>,
    /// The tokens of recently seen space-separated chunks.
    cache: Mutex<HashMap<String, Vec<RawToken>>>,
}

impl Tokenizer {
    /// Loads the tokenizer from the model's `tokenizer` file.
    pub fn load(path: &Path) -> Result<Self, EnError> {
        let root = read_msgpack(path)?;
        let pattern = |key: &str, anchored: bool| -> Result<Option<Regex>, EnError> {
            match get(&root, key) {
                None | Some(Value::Nil) => Ok(None),
                Some(v) => {
                    let text = as_text(v)
                        .ok_or_else(|| EnError::corrupt(path, &format!("{key} is not text")))?;
                    let text = if anchored {
                        format!(r"\A(?:{text})")
                    } else {
                        text.to_string()
                    };
                    Regex::new(&text).map(Some).map_err(|e| {
                        EnError::corrupt(path, &format!("{key} is not a usable pattern: {e}"))
                    })
                }
            }
        };
        let mut tokenizer = Self {
            prefix: pattern("prefix_search", false)?,
            suffix: pattern("suffix_search", false)?,
            infix: pattern("infix_finditer", false)?,
            token_match: pattern("token_match", true)?,
            url_match: pattern("url_match", true)?,
            specials: HashMap::new(),
            phrase_patterns: HashMap::new(),
            cache: Mutex::new(HashMap::new()),
        };
        let faster_heuristics = get(&root, "faster_heuristics")
            .and_then(Value::as_bool)
            .unwrap_or(true);
        let exceptions = get(&root, "exceptions")
            .and_then(Value::as_map)
            .ok_or_else(|| EnError::corrupt(path, "no exceptions"))?;
        for (key, tokens) in exceptions {
            let key = as_text(key).ok_or_else(|| EnError::corrupt(path, "bad exception key"))?;
            let special = parse_special(tokens)
                .ok_or_else(|| EnError::corrupt(path, &format!("bad exception {key:?}")))?;
            tokenizer.specials.insert(key.to_string(), special);
        }
        let mut keys: Vec<String> = tokenizer.specials.keys().cloned().collect();
        keys.sort();
        for key in keys {
            let needs_matcher = !faster_heuristics
                || tokenizer.find_prefix(&key) > 0
                || tokenizer.find_suffix(&key) > 0
                || !tokenizer.find_infix(&key).is_empty()
                || key.contains(' ');
            if needs_matcher {
                let orths: Vec<String> = tokenizer
                    .tokenize_affixes(&key, false)
                    .into_iter()
                    .map(|t| t.text)
                    .collect();
                if let Some(first) = orths.first() {
                    tokenizer
                        .phrase_patterns
                        .entry(first.clone())
                        .or_default()
                        .push((orths, key));
                }
            }
        }
        Ok(tokenizer)
    }

    /// Splits a text into tokens exactly as spaCy's tokenizer does.
    pub fn tokenize(&self, text: &str) -> Vec<RawToken> {
        let tokens = self.tokenize_affixes(text, true);
        self.apply_special_cases(tokens)
    }

    fn tokenize_affixes(&self, text: &str, with_specials: bool) -> Vec<RawToken> {
        let mut tokens = Vec::new();
        let Some(first) = text.chars().next() else {
            return tokens;
        };
        let mut in_ws = py_isspace(first);
        let mut start = 0;
        for (i, c) in text.char_indices() {
            if py_isspace(c) == in_ws {
                continue;
            }
            if start < i {
                self.tokenize_span(&text[start..i], with_specials, &mut tokens);
            }
            if c == ' ' {
                if let Some(last) = tokens.last_mut() {
                    last.spacy = true;
                }
                start = i + 1;
            } else {
                start = i;
            }
            in_ws = !in_ws;
        }
        if start < text.len() {
            self.tokenize_span(&text[start..], with_specials, &mut tokens);
            if let Some(last) = tokens.last_mut() {
                last.spacy = text.ends_with(' ') && !in_ws;
            }
        }
        tokens
    }

    fn tokenize_span(&self, span: &str, with_specials: bool, out: &mut Vec<RawToken>) {
        if !with_specials {
            self.split_span(span, false, out);
            return;
        }
        if let Some(special) = self.specials.get(span) {
            out.extend(special.iter().cloned());
            return;
        }
        if let Ok(cache) = self.cache.lock() {
            if let Some(tokens) = cache.get(span) {
                out.extend(tokens.iter().cloned());
                return;
            }
        }
        let start = out.len();
        self.split_span(span, true, out);
        if let Ok(mut cache) = self.cache.lock() {
            if cache.len() >= MAX_CACHE {
                cache.clear();
            }
            cache.insert(span.to_string(), out[start..].to_vec());
        }
    }

    fn split_span(&self, span: &str, with_specials: bool, out: &mut Vec<RawToken>) {
        let (prefixes, core, suffixes) = self.split_affixes(span, with_specials);
        out.extend(prefixes.into_iter().map(RawToken::plain));
        if !core.is_empty() {
            self.attach_core(core, with_specials, out);
        }
        out.extend(suffixes.into_iter().rev().map(RawToken::plain));
    }

    fn is_special(&self, text: &str, with_specials: bool) -> bool {
        with_specials && self.specials.contains_key(text)
    }

    fn split_affixes<'a>(
        &self,
        span: &'a str,
        with_specials: bool,
    ) -> (Vec<&'a str>, &'a str, Vec<&'a str>) {
        let mut prefixes = Vec::new();
        let mut suffixes = Vec::new();
        let mut string = span;
        let mut last_size = usize::MAX;
        while !string.is_empty() && string.len() != last_size {
            if self.matches_token(string) || self.is_special(string, with_specials) {
                break;
            }
            last_size = string.len();
            let pre_len = self.find_prefix(string);
            if pre_len != 0 {
                let minus_pre = &string[pre_len..];
                if !minus_pre.is_empty() && self.is_special(minus_pre, with_specials) {
                    prefixes.push(&string[..pre_len]);
                    string = minus_pre;
                    break;
                }
            }
            let suf_len = self.find_suffix(&string[pre_len..]);
            if suf_len != 0 {
                let minus_suf = &string[..string.len() - suf_len];
                if !minus_suf.is_empty() && self.is_special(minus_suf, with_specials) {
                    suffixes.push(&string[string.len() - suf_len..]);
                    string = minus_suf;
                    break;
                }
            }
            if pre_len != 0 && suf_len != 0 && pre_len + suf_len <= string.len() {
                prefixes.push(&string[..pre_len]);
                suffixes.push(&string[string.len() - suf_len..]);
                string = &string[pre_len..string.len() - suf_len];
            } else if pre_len != 0 {
                prefixes.push(&string[..pre_len]);
                string = &string[pre_len..];
            } else if suf_len != 0 {
                suffixes.push(&string[string.len() - suf_len..]);
                string = &string[..string.len() - suf_len];
            }
        }
        (prefixes, string, suffixes)
    }

    fn attach_core(&self, core: &str, with_specials: bool, out: &mut Vec<RawToken>) {
        if with_specials {
            if let Some(special) = self.specials.get(core) {
                out.extend(special.iter().cloned());
                return;
            }
        }
        if self.matches_token(core) || matches_start(&self.url_match, core) {
            out.push(RawToken::plain(core));
            return;
        }
        let infixes = self.find_infix(core);
        if infixes.is_empty() {
            out.push(RawToken::plain(core));
            return;
        }
        let mut start = 0;
        for (infix_start, infix_end) in infixes {
            if infix_start == 0 {
                continue;
            }
            if infix_start != start {
                out.push(RawToken::plain(&core[start..infix_start]));
            }
            if infix_start != infix_end {
                out.push(RawToken::plain(&core[infix_start..infix_end]));
            }
            start = infix_end;
        }
        if start < core.len() {
            out.push(RawToken::plain(&core[start..]));
        }
    }

    fn matches_token(&self, text: &str) -> bool {
        matches_start(&self.token_match, text)
    }

    fn find_prefix(&self, text: &str) -> usize {
        search_len(&self.prefix, text)
    }

    fn find_suffix(&self, text: &str) -> usize {
        search_len(&self.suffix, text)
    }

    fn find_infix(&self, text: &str) -> Vec<(usize, usize)> {
        let Some(infix) = &self.infix else {
            return Vec::new();
        };
        infix
            .find_iter(text)
            .map_while(Result::ok)
            .map(|m| (m.start(), m.end()))
            .collect()
    }

    /// spaCy's second pass: special cases whose strings the affix rules
    /// split are found again among the tokens (longest first) and merged.
    fn apply_special_cases(&self, tokens: Vec<RawToken>) -> Vec<RawToken> {
        if self.phrase_patterns.is_empty() {
            return tokens;
        }
        let mut matches: Vec<(usize, usize)> = Vec::new();
        for (start, token) in tokens.iter().enumerate() {
            let Some(candidates) = self.phrase_patterns.get(&token.text) else {
                continue;
            };
            for (orths, _) in candidates {
                let end = start + orths.len();
                if end <= tokens.len()
                    && tokens[start..end]
                        .iter()
                        .zip(orths)
                        .all(|(t, o)| &t.text == o)
                {
                    matches.push((start, end));
                }
            }
        }
        if matches.is_empty() {
            return tokens;
        }
        matches.sort_by(|a, b| (a.1 - a.0).cmp(&(b.1 - b.0)).then(b.0.cmp(&a.0)));
        let mut seen = vec![false; tokens.len()];
        let mut kept = Vec::new();
        for &(start, end) in matches.iter().rev() {
            if !seen[start] && !seen[end - 1] {
                kept.push((start, end));
            }
            seen[start..end].iter_mut().for_each(|s| *s = true);
        }
        kept.sort();
        let mut out = Vec::with_capacity(tokens.len());
        let mut i = 0;
        let mut kept = kept.into_iter().peekable();
        while i < tokens.len() {
            match kept.peek() {
                Some(&(start, end)) if start == i => {
                    kept.next();
                    let text = span_text(&tokens[start..end]);
                    match self.specials.get(&text) {
                        Some(special) => {
                            out.extend(special.iter().cloned());
                            if let Some(last) = out.last_mut() {
                                last.spacy = tokens[end - 1].spacy;
                            }
                        }
                        None => out.extend(tokens[start..end].iter().cloned()),
                    }
                    i = end;
                }
                _ => {
                    out.push(tokens[i].clone());
                    i += 1;
                }
            }
        }
        out
    }
}

fn span_text(tokens: &[RawToken]) -> String {
    let mut text = String::new();
    for (i, token) in tokens.iter().enumerate() {
        text.push_str(&token.text);
        if token.spacy && i + 1 < tokens.len() {
            text.push(' ');
        }
    }
    text
}

fn search_len(regex: &Option<Regex>, text: &str) -> usize {
    match regex {
        Some(regex) => match regex.find(text) {
            Ok(Some(m)) => m.end() - m.start(),
            _ => 0,
        },
        None => 0,
    }
}

fn matches_start(regex: &Option<Regex>, text: &str) -> bool {
    match regex {
        Some(regex) => matches!(regex.find(text), Ok(Some(_))),
        None => false,
    }
}

fn parse_special(tokens: &Value) -> Option<Special> {
    let mut out = Vec::new();
    for token in tokens.as_array()? {
        let mut orth = None;
        let mut norm = None;
        for (k, v) in token.as_map()? {
            match k.as_u64()? {
                ORTH => orth = Some(as_text(v)?.to_string()),
                NORM => norm = Some(as_text(v)?.to_string()),
                _ => {}
            }
        }
        out.push(RawToken {
            text: orth?,
            spacy: false,
            norm,
        });
    }
    Some(out)
}
