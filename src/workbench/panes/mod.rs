//! The seven panes: their names, the frame they share, and each one's
//! state, keys and drawing in its own module.

pub mod description;
pub mod graph;
pub mod prompt;
pub mod scene;
pub mod scores;
pub mod steps;

use std::collections::BTreeMap;

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders};
use ratatui::Frame;

use crate::agents::{AgentRole, Approach, ProviderKind};
use crate::workbench::agents;
use crate::workbench::editing::Editing;
pub use crate::workbench::layout::Pane;
use crate::workbench::runs::{AgentStatus, AgentView, Runs};
use crate::workbench::scroll::{text_width, truncate};
use crate::workbench::session::RunRecord;
use crate::workbench::theme::Theme;
use crate::workbench::workspace::Workspace;
use graph::GraphPane;
use prompt::PromptPane;
use scene::ScenePane;
use steps::{StepList, StepUndo, Steps};

/// What every pane draws from beside its own state, read-only: the
/// session's data, the runs, the theme, the editor in use and the focus
/// (made by [`crate::workbench::app::App::shared`]). Drawing is a pure
/// function of it.
#[derive(Clone, Copy)]
pub struct Shared<'a> {
    /// The theme in use.
    pub theme: &'a Theme,
    /// The task, the approach, the sources of the plans and their scores.
    pub work: &'a Workspace,
    /// The agents and the runs.
    pub runs: &'a Runs,
    /// Every pane's own state.
    pub panes: &'a Panes,
    /// The editor in use, drawn where it edits.
    pub editing: &'a Editing,
    /// The focused pane.
    pub focus: Pane,
    /// Whether an overlay covers the panes (a picture is held back).
    pub overlay_open: bool,
}

impl Shared<'_> {
    /// The text of `agent`'s prompt template in the current approach, with
    /// the editor's text when it is being edited.
    pub fn prompt_of(&self, agent: AgentRole) -> String {
        let editing = matches!(self.editing, Editing::Prompt);
        self.panes
            .prompt
            .text_of(self.work.approach, agent, editing)
    }

    /// Whether an agent's prompt or settings differ from those its output
    /// was made with.
    pub fn agent_changed(&self, agent: AgentRole) -> bool {
        self.runs.agent_changed(agent, &self.prompt_of(agent))
    }

    /// The note shown when the selected agent's prompt was edited but only
    /// recorded outputs can be replayed.
    pub fn provider_note(&self) -> Option<String> {
        let agent = self.panes.prompt.agent;
        let view = self.runs.agents.get(&agent)?;
        let prompt = self.prompt_of(agent);
        let why = if self.work.approach != Approach::MultiImage {
            "the demo's recording has only the multi-image approach"
        } else {
            "this prompt was edited and the demo's recording has no answer for it"
        };
        (view.settings.provider == ProviderKind::Replay
            && !self
                .panes
                .prompt
                .is_recorded(self.work.approach, agent, &prompt))
        .then(|| agents::provider_needed(agent, why).to_string())
    }

    /// The run whose plan the Plan pane shows, when it shows a run's plan.
    pub fn shown_run(&self) -> Option<&RunRecord> {
        self.runs.shown(&self.work.plan_source)
    }

    /// The latest run when it did not finish and the Plan pane shows
    /// another plan: the panes say it failed and why.
    pub fn unfinished_latest(&self) -> Option<&RunRecord> {
        self.runs.unfinished_latest(&self.work.plan_source)
    }
}

/// The panes' own state: each pane's content and view.
pub struct Panes {
    /// Whether the focused pane fills the screen.
    pub zoom: bool,
    /// The Prompt pane: every template's text, and its editor.
    pub prompt: PromptPane,
    /// The plan steps.
    pub plan: Steps,
    /// The ground-truth steps.
    pub ground_truth: Steps,
    /// The Knowledge Graph pane.
    pub graph: GraphPane,
    /// The Scene pane.
    pub scene: ScenePane,
    /// Scroll offsets of the text panes.
    pub scroll: BTreeMap<Pane, u16>,
    /// The search, highlighted in every pane.
    pub search: String,
    /// The step edits `u` takes back on the source in use.
    pub undo: StepUndo,
    /// The step edits `u` can take back on each parked source, by task id
    /// (`None`: the demo); kept while the workbench runs, not saved.
    pub parked_undo: BTreeMap<Option<String>, StepUndo>,
}

impl Panes {
    /// The steps of a list.
    pub fn steps(&self, list: StepList) -> &Steps {
        match list {
            StepList::Plan => &self.plan,
            StepList::GroundTruth => &self.ground_truth,
        }
    }

    pub(crate) fn steps_mut(&mut self, list: StepList) -> &mut Steps {
        match list {
            StepList::Plan => &mut self.plan,
            StepList::GroundTruth => &mut self.ground_truth,
        }
    }
}

/// Draws one pane.
pub(crate) fn render_pane(frame: &mut Frame, app: &Shared, pane: Pane, area: Rect) {
    match pane {
        Pane::Scene => scene::draw(frame, app, area),
        Pane::Graph => graph::draw(frame, app, area),
        Pane::Description => description::draw(frame, app, area),
        Pane::Plan => steps::draw(frame, app, StepList::Plan, area),
        Pane::GroundTruth => steps::draw(frame, app, StepList::GroundTruth, area),
        Pane::Scores => scores::draw(frame, app, area),
        Pane::Prompt => prompt::draw(frame, app, area),
    }
}

/// How long a running agent may be silent before its pane says so.
const SILENCE_SHOWN: std::time::Duration = std::time::Duration::from_secs(2);

/// What a running agent is waiting for, for its pane's title: the wait
/// before a retry, counting down (`HTTP 503 · retry 3 of 4 in 2 s
/// (Retry-After)`), or a silence of [`SILENCE_SHOWN`] or more since its
/// last token (`no answer yet · 5 s`, `5 s since the last token`); `None`
/// while the answer flows.
pub(crate) fn waiting_text(v: &AgentView) -> Option<String> {
    let now = std::time::Instant::now();
    let Some((notice, until)) = v.retry.as_ref() else {
        let silent = now.saturating_duration_since(v.heard?);
        return (silent >= SILENCE_SHOWN).then(|| match v.output.is_empty() {
            true => format!("no answer yet · {} s", silent.as_secs()),
            false => format!("{} s since the last token", silent.as_secs()),
        });
    };
    let left = until.saturating_duration_since(now);
    Some(format!(
        "HTTP {} · retry {} of {} in {} s{}",
        notice.status,
        notice.retry,
        notice.of,
        left.as_secs_f64().ceil(),
        if notice.asked { " (Retry-After)" } else { "" }
    ))
}

/// A short word for an agent's state, with its style.
pub(crate) fn agent_badge<'a>(app: &Shared, agent: AgentRole) -> Span<'a> {
    let t = &app.theme;
    let Some(v) = app.runs.agents.get(&agent) else {
        return Span::raw("");
    };
    match &v.status {
        AgentStatus::Idle => Span::styled("idle", t.muted),
        AgentStatus::Waiting => Span::styled("waiting", t.warn),
        AgentStatus::Running => Span::styled(
            waiting_text(v).unwrap_or_else(|| "writing…".to_string()),
            t.warn,
        ),
        AgentStatus::Done => Span::styled(
            format!(
                "{} ms · {} tok",
                v.duration_ms,
                v.usage.input_tokens + v.usage.output_tokens
            ),
            t.good,
        ),
        AgentStatus::Failed(_) => Span::styled("failed", t.bad),
        AgentStatus::Cancelled => Span::styled("cancelled", t.bad),
    }
}

/// The visible window of a list of items `item_height` rows tall that keeps
/// `selected` in view: (first item shown, number of items shown).
pub fn list_window(
    selected: usize,
    len: usize,
    item_height: usize,
    height: usize,
) -> (usize, usize) {
    let fits = (height / item_height.max(1)).max(1);
    let first = if selected >= fits {
        selected + 1 - fits
    } else {
        0
    };
    (first, fits.min(len.saturating_sub(first)))
}

/// Splits `text` into spans, with every case-insensitive occurrence of
/// `needle` in the highlight style.
pub(crate) fn highlighted<'a>(
    text: &'a str,
    needle: &str,
    base: Style,
    hit: Style,
) -> Vec<Span<'a>> {
    if needle.is_empty() {
        return vec![Span::styled(text, base)];
    }
    let lower = text.to_lowercase();
    let needle = needle.to_lowercase();
    if lower.len() != text.len() {
        return vec![Span::styled(text, base)];
    }
    let mut spans = Vec::new();
    let mut at = 0;
    while let Some(found) = lower[at..].find(&needle) {
        let start = at + found;
        let end = start + needle.len();
        if start > at {
            spans.push(Span::styled(&text[at..start], base));
        }
        spans.push(Span::styled(&text[start..end], hit));
        at = end;
    }
    if at < text.len() {
        spans.push(Span::styled(&text[at..], base));
    }
    spans
}

/// The bordered block of a pane, with its title and the focus border.
/// Draws `block` over `area` and `lines` in `body` from `pane`'s scroll
/// offset (kept inside them), with `↑ N more` / `↓ N more` on the block's
/// frame: for a pane whose scrolled text is only part of what it draws.
pub(crate) fn draw_scrolled(
    frame: &mut Frame,
    app: &Shared,
    pane: Pane,
    block: Block<'_>,
    area: Rect,
    body: Rect,
    lines: Vec<Line<'static>>,
) {
    let viewport = usize::from(body.height);
    let wanted = app.panes.scroll.get(&pane).copied().unwrap_or(0);
    let offset = usize::from(wanted).min(lines.len().saturating_sub(viewport));
    let block =
        crate::workbench::scroll::framed(block, offset, lines.len(), viewport, app.theme.accent);
    frame.render_widget(block, area);
    let shown: Vec<Line> = lines.into_iter().skip(offset).take(viewport).collect();
    frame.render_widget(ratatui::widgets::Paragraph::new(shown), body);
}

/// The frame of `pane`, `width` columns wide: its name, then `extra` (the
/// agent's state, the plan's source, a run's failure) cut with `…` where
/// the top border is too short for it, never cut silently.
pub(crate) fn pane_block<'a>(
    app: &Shared,
    pane: Pane,
    extra: Option<Span<'a>>,
    width: u16,
) -> Block<'a> {
    let focused = app.focus == pane;
    let name = format!(" {} ", pane.title());
    // Within the corners (the space after `extra` may go).
    let room = usize::from(width)
        .saturating_sub(2)
        .saturating_sub(text_width(&name));
    let mut title = vec![Span::styled(name, app.theme.title)];
    if let Some(extra) = extra {
        let cut = truncate(&extra.content, room);
        title.push(Span::styled(cut, extra.style));
        title.push(Span::styled(" ", app.theme.title));
    }
    Block::default()
        .borders(Borders::ALL)
        .border_type(if focused {
            ratatui::widgets::BorderType::Thick
        } else {
            ratatui::widgets::BorderType::Plain
        })
        .border_style(if focused {
            app.theme.focus
        } else {
            app.theme.border
        })
        .style(app.theme.base)
        .title(Line::from(title))
}
