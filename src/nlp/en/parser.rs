//! The dependency parser: spaCy's greedy transition-based arc-eager parser
//! (eight state features, a precomputed maxout lower layer, a linear upper
//! layer), then pseudo-projective lifting undone as spaCy does.

use std::path::Path;

use serde_json::Value as Json;

use super::layers::{add_into, argmax, matmul_transposed, Linear};
use super::tok2vec::WIDTH;
use super::weights::{as_text, get, read_msgpack, ThincModel};
use super::EnError;

const N_FEATS: usize = 8;
const HIDDEN: usize = 64;
const PIECES: usize = 2;
const DELIMITER: &str = "||";

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Move {
    Shift,
    Reduce,
    Left,
    Right,
    Break,
}

impl Move {
    fn from_code(code: &str) -> Option<Self> {
        Some(match code {
            "0" => Self::Shift,
            "1" => Self::Reduce,
            "2" => Self::Left,
            "3" => Self::Right,
            "4" => Self::Break,
            _ => return None,
        })
    }
}

struct Action {
    kind: Move,
    label: usize,
    is_subtok: bool,
}

/// The parser component.
pub struct Parser {
    project: Linear,
    /// Lower-layer weights, (feature, hidden, piece) rows of width `HIDDEN`.
    lower: Vec<f32>,
    lower_bias: Vec<f32>,
    lower_pad: Vec<f32>,
    upper: Linear,
    actions: Vec<Action>,
    labels: Vec<String>,
    root_label: usize,
}

/// One token's analysis by the parser.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Arc {
    /// The head's index in the document (itself for a root).
    pub head: usize,
    /// The dependency label.
    pub dep: String,
}

impl Parser {
    /// Loads `parser/model` and `parser/moves` from the parser folder.
    pub fn load(dir: &Path) -> Result<Self, EnError> {
        let model_path = dir.join("model");
        let model = ThincModel::load(&model_path)?;
        let bad = |what: &str| EnError::corrupt(&model_path, what);
        let lower_node = model
            .named("precomputable_affine")
            .into_iter()
            .next()
            .ok_or_else(|| bad("no precomputable_affine layer"))?;
        let lower = model
            .param(lower_node, "W", &[N_FEATS, HIDDEN, PIECES, HIDDEN])?
            .data
            .clone();
        let lower_bias = model
            .param(lower_node, "b", &[HIDDEN, PIECES])?
            .data
            .clone();
        let lower_pad = model
            .param(lower_node, "pad", &[1, N_FEATS, HIDDEN, PIECES])?
            .data
            .clone();
        let linears = model.named("linear");
        let project_node = linears
            .iter()
            .find(|n| n.dims.get("nI") == Some(&(WIDTH as i64)))
            .ok_or_else(|| bad("no linear layer from the token vectors"))?;
        let upper_node = linears
            .iter()
            .find(|n| n.dims.get("nI") == Some(&(HIDDEN as i64)))
            .ok_or_else(|| bad("no upper linear layer"))?;
        let n_classes = upper_node
            .dims
            .get("nO")
            .copied()
            .ok_or_else(|| bad("the upper layer has no nO"))? as usize;
        let project = Linear::from_node(&model, project_node, HIDDEN, WIDTH)?;
        let upper = Linear::from_node(&model, upper_node, n_classes, HIDDEN)?;
        let (actions, labels) = load_moves(&dir.join("moves"))?;
        if actions.len() != n_classes {
            return Err(bad(&format!(
                "{} classes but {} moves",
                n_classes,
                actions.len()
            )));
        }
        let root_label = labels.iter().position(|l| l == "ROOT").unwrap_or(0);
        Ok(Self {
            project,
            lower,
            lower_bias,
            lower_pad,
            upper,
            actions,
            labels,
            root_label,
        })
    }

    /// Parses one document from its token vectors (n × 96); `is_space`
    /// marks whitespace tokens.
    pub fn parse(&self, tokvecs: &[f32], is_space: &[bool]) -> Vec<Arc> {
        let n = is_space.len();
        if n == 0 {
            return Vec::new();
        }
        let cached = self.precompute(tokvecs, n);
        let width = HIDDEN * PIECES;
        let mut state = State::new(n);
        let mut unmaxed = vec![0f32; width];
        let mut hidden = vec![0f32; HIDDEN];
        let mut scores = vec![0f32; self.actions.len()];
        let mut ids = [-1i64; N_FEATS];
        while !state.is_final() {
            state.context(&mut ids);
            unmaxed.fill(0.0);
            for (f, &id) in ids.iter().enumerate() {
                let feature = if id < 0 {
                    &self.lower_pad[f * width..(f + 1) * width]
                } else {
                    let start = (id as usize * N_FEATS + f) * width;
                    &cached[start..start + width]
                };
                add_into(&mut unmaxed, feature);
            }
            add_into(&mut unmaxed, &self.lower_bias);
            for (h, pieces) in hidden.iter_mut().zip(unmaxed.chunks_exact(PIECES)) {
                *h = pieces[argmax(pieces)];
            }
            self.upper.apply(&hidden, &mut scores);
            let valid = state.valid_moves();
            let mut best: Option<usize> = None;
            for (i, action) in self.actions.iter().enumerate() {
                let ok = if action.is_subtok {
                    state.is_valid(action.kind, true)
                } else {
                    valid[action.kind as usize]
                };
                if ok && best.is_none_or(|b| scores[i] > scores[b]) {
                    best = Some(i);
                }
            }
            match best {
                Some(i) => state.apply(self.actions[i].kind, self.actions[i].label),
                None => state.force_final(),
            }
        }
        self.annotate(&state, is_space)
    }

    /// The lower layer applied to every token for every feature slot:
    /// n × 8 × (64 × 2).
    fn precompute(&self, tokvecs: &[f32], n: usize) -> Vec<f32> {
        let width = N_FEATS * HIDDEN * PIECES;
        let mut x = vec![0f32; n * HIDDEN];
        self.project.apply_rows(tokvecs, n, &mut x);
        let mut cached = vec![0f32; n * width];
        matmul_transposed(&x, &self.lower, n, HIDDEN, width, &mut cached);
        cached
    }

    fn annotate(&self, state: &State, is_space: &[bool]) -> Vec<Arc> {
        let n = is_space.len();
        let mut heads: Vec<usize> = (0..n)
            .map(|i| usize::try_from(state.heads[i]).unwrap_or(i))
            .collect();
        let mut deps: Vec<String> = (0..n)
            .map(|i| {
                if heads[i] == i {
                    self.labels[self.root_label].clone()
                } else {
                    self.labels[state.labels[i]].clone()
                }
            })
            .collect();
        deprojectivize(&mut heads, &mut deps, is_space);
        heads
            .into_iter()
            .zip(deps)
            .map(|(head, dep)| Arc { head, dep })
            .collect()
    }
}

fn load_moves(path: &Path) -> Result<(Vec<Action>, Vec<String>), EnError> {
    let root = read_msgpack(path)?;
    let bad = |what: &str| EnError::corrupt(path, what);
    let moves_json = get(&root, "moves")
        .and_then(as_text)
        .ok_or_else(|| bad("no moves"))?;
    let moves: Json = serde_json::from_str(moves_json).map_err(|e| bad(&e.to_string()))?;
    let moves = moves.as_object().ok_or_else(|| bad("moves is not a map"))?;
    let mut codes: Vec<&String> = moves.keys().collect();
    codes.sort();
    let mut labels: Vec<String> = Vec::new();
    let mut actions = Vec::new();
    let mut added: Vec<(i64, String, Move)> = Vec::new();
    let label_index = |label: &str, labels: &mut Vec<String>| -> usize {
        match labels.iter().position(|l| l == label) {
            Some(i) => i,
            None => {
                labels.push(label.to_string());
                labels.len() - 1
            }
        }
    };
    for code in codes {
        let kind = Move::from_code(code).ok_or_else(|| bad("unknown move"))?;
        let freqs = moves[code]
            .as_object()
            .ok_or_else(|| bad("bad move labels"))?;
        let mut sorted: Vec<(i64, &String)> = freqs
            .iter()
            .map(|(label, f)| (f.as_i64().unwrap_or(0), label))
            .collect();
        sorted.sort();
        sorted.reverse();
        for (freq, label) in sorted {
            if freq < 0 {
                added.push((freq, label.clone(), kind));
            } else {
                let label = label_index(label, &mut labels);
                push_action(&mut actions, kind, label, &labels);
            }
        }
    }
    added.sort_by(|a, b| (b.0, &b.1).cmp(&(a.0, &a.1)));
    for (_, label, kind) in added {
        let label = label_index(&label, &mut labels);
        push_action(&mut actions, kind, label, &labels);
    }
    if !labels.iter().any(|l| l == "ROOT") {
        labels.push("ROOT".to_string());
    }
    Ok((actions, labels))
}

fn push_action(actions: &mut Vec<Action>, kind: Move, label: usize, labels: &[String]) {
    if actions.iter().any(|a| a.kind == kind && a.label == label) {
        return;
    }
    actions.push(Action {
        kind,
        label,
        is_subtok: labels[label] == "subtok",
    });
}

/// An arc in the state's per-head lists.
#[derive(Clone, Copy)]
struct StateArc {
    head: i64,
    child: i64,
}

/// The arc-eager parse state (spaCy's `StateC`).
struct State {
    length: i64,
    heads: Vec<i64>,
    labels: Vec<usize>,
    stack: Vec<i64>,
    rebuffer: Vec<i64>,
    b_i: i64,
    left_arcs: Vec<Vec<StateArc>>,
    right_arcs: Vec<Vec<StateArc>>,
    unshiftable: Vec<bool>,
    sent_starts: Vec<bool>,
}

impl State {
    fn new(n: usize) -> Self {
        let mut sent_starts = vec![false; n];
        sent_starts[0] = true;
        Self {
            length: n as i64,
            heads: vec![-1; n],
            labels: vec![0; n],
            stack: Vec::new(),
            rebuffer: Vec::new(),
            b_i: 0,
            left_arcs: vec![Vec::new(); n],
            right_arcs: vec![Vec::new(); n],
            unshiftable: vec![false; n],
            sent_starts,
        }
    }

    fn s(&self, i: usize) -> i64 {
        if i >= self.stack.len() {
            -1
        } else {
            self.stack[self.stack.len() - 1 - i]
        }
    }

    fn b(&self, i: usize) -> i64 {
        if i < self.rebuffer.len() {
            return self.rebuffer[self.rebuffer.len() - 1 - i];
        }
        let b_i = self.b_i + (i - self.rebuffer.len()) as i64;
        if b_i >= self.length {
            -1
        } else {
            b_i
        }
    }

    /// The `idx`-th most recently added child among the head's arcs.
    fn nth_child(arcs: &[Vec<StateArc>], head: i64, idx: usize) -> i64 {
        if head < 0 {
            return -1;
        }
        arcs[head as usize]
            .iter()
            .rev()
            .filter(|a| a.child != -1)
            .nth(idx - 1)
            .map_or(-1, |a| a.child)
    }

    fn context(&self, ids: &mut [i64; N_FEATS]) {
        ids[0] = self.b(0);
        ids[1] = self.b(1);
        ids[2] = self.s(0);
        ids[3] = self.s(1);
        ids[4] = self.s(2);
        ids[5] = Self::nth_child(&self.left_arcs, self.b(0), 1);
        ids[6] = Self::nth_child(&self.left_arcs, self.s(0), 1);
        ids[7] = Self::nth_child(&self.right_arcs, self.s(0), 1);
    }

    fn buffer_length(&self) -> i64 {
        (self.length - self.b_i) + self.rebuffer.len() as i64
    }

    fn is_final(&self) -> bool {
        self.stack.is_empty() && self.buffer_length() == 0
    }

    fn is_sent_start(&self, word: i64) -> bool {
        word >= 0 && word < self.length && self.sent_starts[word as usize]
    }

    fn has_head(&self, word: i64) -> bool {
        self.heads[word as usize] >= 0
    }

    fn valid_moves(&self) -> [bool; 5] {
        [
            self.is_valid(Move::Shift, false),
            self.is_valid(Move::Reduce, false),
            self.is_valid(Move::Left, false),
            self.is_valid(Move::Right, false),
            self.is_valid(Move::Break, false),
        ]
    }

    fn is_valid(&self, kind: Move, subtok: bool) -> bool {
        let depth = self.stack.len();
        match kind {
            Move::Shift => {
                depth == 0
                    || (self.buffer_length() >= 2
                        && !self.is_sent_start(self.b(0))
                        && !self
                            .unshiftable
                            .get(self.b(0) as usize)
                            .copied()
                            .unwrap_or(false))
            }
            Move::Reduce => depth > 0,
            Move::Left | Move::Right => {
                depth > 0
                    && self.buffer_length() > 0
                    && !self.is_sent_start(self.b(0))
                    && !(subtok && self.s(0) != self.b(0) - 1)
            }
            Move::Break => {
                self.buffer_length() >= 2
                    && self.b(1) == self.b(0) + 1
                    && !self.is_sent_start(self.b(1))
            }
        }
    }

    fn push(&mut self) {
        let b0 = match self.rebuffer.pop() {
            Some(b0) => b0,
            None => {
                self.b_i += 1;
                self.b_i - 1
            }
        };
        self.stack.push(b0);
    }

    fn add_arc(&mut self, head: i64, child: i64, label: usize) {
        if self.has_head(child) {
            let old = self.heads[child as usize];
            let arcs = if old > child {
                &mut self.left_arcs[old as usize]
            } else {
                &mut self.right_arcs[old as usize]
            };
            // spaCy removes the arc only when it is the newest of its head;
            // otherwise its loop edits a copy and the arc stays.
            if arcs
                .last()
                .is_some_and(|a| a.head == old && a.child == child)
            {
                arcs.pop();
            }
        }
        let arc = StateArc { head, child };
        if head > child {
            self.left_arcs[head as usize].push(arc);
        } else {
            self.right_arcs[head as usize].push(arc);
        }
        self.heads[child as usize] = head;
        self.labels[child as usize] = label;
    }

    fn apply(&mut self, kind: Move, label: usize) {
        match kind {
            Move::Shift => self.push(),
            Move::Reduce => {
                let s0 = self.s(0);
                if self.has_head(s0) || self.stack.len() == 1 {
                    self.stack.pop();
                } else {
                    self.unshiftable[s0 as usize] = true;
                    self.rebuffer.push(s0);
                    self.stack.pop();
                }
            }
            Move::Left => {
                let (b0, s0) = (self.b(0), self.s(0));
                self.add_arc(b0, s0, label);
                if let Some(u) = self.unshiftable.get_mut(b0 as usize) {
                    *u = false;
                }
                self.stack.pop();
            }
            Move::Right => {
                let (s0, b0) = (self.s(0), self.b(0));
                self.add_arc(s0, b0, label);
                self.push();
            }
            Move::Break => {
                let b1 = self.b(1);
                self.sent_starts[b1 as usize] = true;
            }
        }
    }

    fn force_final(&mut self) {
        self.stack.clear();
        self.b_i = self.length;
        self.rebuffer.clear();
    }
}

/// Left and right edges of each token's subtree, as spaCy's
/// `set_children_from_heads` computes them.
fn edges(heads: &[usize]) -> (Vec<usize>, Vec<usize>) {
    let n = heads.len();
    let mut l_edge: Vec<usize> = (0..n).collect();
    let mut r_edge: Vec<usize> = (0..n).collect();
    for _ in 0..12 {
        for i in 0..n {
            let h = heads[i];
            l_edge[h] = l_edge[h].min(l_edge[i]);
            r_edge[h] = r_edge[h].max(r_edge[i]);
        }
        for i in (0..n).rev() {
            let h = heads[i];
            r_edge[h] = r_edge[h].max(r_edge[i]);
            l_edge[h] = l_edge[h].min(l_edge[i]);
        }
        if heads_within_sentences(heads, &l_edge) {
            break;
        }
    }
    (l_edge, r_edge)
}

fn heads_within_sentences(heads: &[usize], l_edge: &[usize]) -> bool {
    let n = heads.len();
    let mut starts = vec![false; n];
    for i in 0..n {
        if heads[i] == i {
            starts[l_edge[i]] = true;
        }
    }
    let mut sent_start = 0;
    for (i, &starts_here) in starts.iter().enumerate() {
        if (i > 0 && starts_here) || i == n - 1 {
            for &h in heads.iter().take(i).skip(sent_start) {
                if h < sent_start || h > i {
                    return false;
                }
            }
            sent_start = i;
        }
    }
    true
}

/// Reattaches arcs whose labels are decorated `X||Y`: the new head is the
/// first token labelled `Y` found breadth-first below the current head.
fn deprojectivize(heads: &mut [usize], deps: &mut [String], is_space: &[bool]) {
    if !deps.iter().any(|d| d.contains(DELIMITER)) {
        return;
    }
    let (l_edge, r_edge) = edges(heads);
    for i in 0..heads.len() {
        let Some((new_label, head_label)) = deps[i].split_once(DELIMITER) else {
            continue;
        };
        let (new_label, head_label) = (new_label.to_string(), head_label.to_string());
        let mut new_head = heads[i];
        let mut queue = vec![heads[i]];
        let mut visits = 0;
        'search: while !queue.is_empty() && visits <= heads.len() {
            let mut next = Vec::new();
            for q in queue {
                visits += 1;
                for child in l_edge[q]..=r_edge[q] {
                    if child == q || heads[child] != q || is_space[child] || child == i {
                        continue;
                    }
                    if deps[child] == head_label {
                        new_head = child;
                        break 'search;
                    }
                    next.push(child);
                }
            }
            queue = next;
        }
        heads[i] = new_head;
        deps[i] = new_label;
    }
}
