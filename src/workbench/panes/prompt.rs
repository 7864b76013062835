//! The Prompt pane: the selected agent's template and its editor.

use std::cell::RefCell;
use std::collections::BTreeMap;

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};
use ratatui::Frame;
use ratatui_textarea::TextArea;

use super::Shared;
use crate::agents::prompts::template_name;
use crate::agents::{AgentRole, Approach};
use crate::workbench::agents;
use crate::workbench::editing::Editing;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::panes::{agent_badge, draw_scrolled, highlighted, pane_block, Pane};
use crate::workbench::runs::AgentStatus;
use crate::workbench::scroll;

/// The Prompt pane's state: every template's text, the agent shown and
/// its editor.
pub struct PromptPane {
    /// Every prompt template's text by name, as edited.
    pub texts: BTreeMap<String, String>,
    /// The templates' texts the workbench started with.
    pub defaults: BTreeMap<String, String>,
    /// The texts as last saved in or loaded from a prompt set (at start,
    /// the templates): loading a set over others asks first.
    pub kept: BTreeMap<String, String>,
    /// The agent whose prompt the pane shows.
    pub agent: AgentRole,
    /// The editor, holding the shown agent's prompt.
    pub editor: TextArea<'static>,
    /// Whether each agent's template text is the one the demo recorded,
    /// with the text that answer is for: the pane asks every frame, and a
    /// template is parsed again only when its text changed.
    recorded: RefCell<BTreeMap<(Approach, AgentRole), (String, bool)>>,
}

impl PromptPane {
    /// Whether a prompt was edited since the last prompt set was saved or
    /// loaded (or since the start): what loading a set would discard.
    pub fn has_unsaved_edits(&self) -> bool {
        self.texts != self.kept
    }

    /// The pane on the SKM's prompt, `texts` being the templates as started.
    pub fn new(texts: BTreeMap<String, String>) -> Self {
        PromptPane {
            defaults: texts.clone(),
            kept: texts.clone(),
            texts,
            agent: AgentRole::Skm,
            editor: TextArea::default(),
            recorded: RefCell::default(),
        }
    }

    /// Whether `text` is `agent`'s template as the demo's recording has it
    /// in `approach` ([`agents::is_recorded_prompt`]), parsed once a text.
    pub fn is_recorded(&self, approach: Approach, agent: AgentRole, text: &str) -> bool {
        let Ok(mut cache) = self.recorded.try_borrow_mut() else {
            return agents::is_recorded_prompt(approach, agent, text);
        };
        match cache.get(&(approach, agent)) {
            Some((seen, answer)) if seen == text => *answer,
            _ => {
                let answer = agents::is_recorded_prompt(approach, agent, text);
                cache.insert((approach, agent), (text.to_string(), answer));
                answer
            }
        }
    }
}

impl PromptPane {
    /// The editor's text.
    pub fn editor_text(&self) -> String {
        self.editor.lines().join("\n")
    }

    /// The text of `agent`'s template in `approach`, the editor's text when
    /// `editing` it.
    pub fn text_of(&self, approach: Approach, agent: AgentRole, editing: bool) -> String {
        if agent == self.agent && editing {
            return self.editor_text();
        }
        self.texts
            .get(&template_name(approach, agent))
            .cloned()
            .unwrap_or_default()
    }

    /// Puts the shown agent's template of `approach` in the editor.
    pub fn load_editor(&mut self, approach: Approach) {
        let text = self
            .texts
            .get(&template_name(approach, self.agent))
            .cloned()
            .unwrap_or_default();
        self.editor = TextArea::new(text.lines().map(str::to_string).collect());
        self.editor.set_wrap_mode(ratatui_textarea::WrapMode::Word);
    }

    /// Keeps the editor's text as the shown agent's template of `approach`.
    pub fn store_editor(&mut self, approach: Approach) {
        let text = self.editor_text();
        self.texts.insert(template_name(approach, self.agent), text);
    }
}

pub(crate) fn draw(frame: &mut Frame, app: &Shared, area: Rect) {
    let t = app.theme;
    let block = pane_block(
        app,
        Pane::Prompt,
        Some(agent_badge(app, app.panes.prompt.agent)),
        area.width,
    );
    let inner = block.inner(area);
    let mut tabs = Vec::new();
    for (i, agent) in app.work.approach.roles().iter().enumerate() {
        let style = if *agent == app.panes.prompt.agent {
            t.selection
        } else {
            t.base
        };
        tabs.push(Span::styled(agent_tab(i, *agent), style));
    }
    if let Some(v) = app.runs.agents.get(&app.panes.prompt.agent) {
        tabs.push(Span::styled(
            format!(
                "  {}/{} · t={} · max {}",
                v.settings.provider,
                v.settings.model,
                v.settings.temperature,
                v.settings.max_tokens
            ),
            t.muted,
        ));
    }
    let note = app.provider_note();
    let [tab_row, body, footer] = parts(app, inner);
    if matches!(app.editing, Editing::Prompt) {
        frame.render_widget(block, area);
        frame.render_widget(&app.panes.prompt.editor, body);
    } else {
        // The prompt wrapped to the body and scrolled by the pane's keys,
        // its markers on the pane's frame.
        let lines = body_lines(app, body);
        draw_scrolled(frame, app, Pane::Prompt, block, area, body, lines);
    }
    frame.render_widget(Paragraph::new(Line::from(tabs)), tab_row);
    let (state, warn) = if matches!(app.editing, Editing::Prompt) {
        (
            format!("editing · {}", keymap::hints(Context::PromptEditor)),
            false,
        )
    } else {
        run_state(app)
    };
    let mut footer_lines = vec![Line::from(Span::styled(
        state,
        if warn { t.warn } else { t.muted },
    ))];
    if let Some(note) = note {
        footer_lines.push(Line::from(Span::styled(note, t.warn)));
    }
    frame.render_widget(
        Paragraph::new(footer_lines).wrap(Wrap { trim: true }),
        footer,
    );
}

/// What the footer says of the selected agent's last run on this task, and
/// whether it is a warning: a prompt that never ran is not "changed", and a
/// failed or cancelled run is not an output the prompt made.
fn run_state(app: &Shared) -> (String, bool) {
    let agent = app.panes.prompt.agent;
    let run = keymap::key_of(Context::Panes, Action::Run);
    let edit = format!(
        "{} edits",
        keymap::key_of(Context::Prompt, Action::EditPrompt)
    );
    let Some(view) = app.runs.agents.get(&agent) else {
        return (idle_hints(&edit), false);
    };
    match view.status {
        AgentStatus::Waiting | AgentStatus::Running => {
            let cancel = keymap::key_of(Context::Panes, Action::CancelRun);
            (format!("running · {cancel} cancels · {edit}"), false)
        }
        AgentStatus::Failed(_) => (
            format!("its last run failed · {run} runs it again · {edit}"),
            true,
        ),
        AgentStatus::Cancelled => (
            format!("its last run was cancelled · {run} runs it · {edit}"),
            true,
        ),
        AgentStatus::Idle => (
            format!("not run yet on this task · {run} runs it · {edit}"),
            false,
        ),
        AgentStatus::Done if app.agent_changed(agent) => (
            format!("changed since its last run · {run} runs what changed · {edit}"),
            true,
        ),
        AgentStatus::Done => (idle_hints(&edit), false),
    }
}

/// The footer of an agent whose output is its prompt's: the pane's keys
/// (`edit`: the key that edits, with its word).
fn idle_hints(edit: &str) -> String {
    format!(
        "{edit} · {}/{} agent · {} provider and model",
        keymap::key_of(Context::Prompt, Action::PromptStep(-1)),
        keymap::key_of(Context::Prompt, Action::PromptStep(1)),
        keymap::key_of(Context::Panes, Action::ModelForm)
    )
}

/// The tab of the agent at `position` of the approach.
fn agent_tab(position: usize, agent: AgentRole) -> String {
    format!(" {} {} ", position + 1, agent.label())
}

/// The agent whose tab a click at (`column`, `row`) lands on, in the
/// Prompt pane drawn in `area`.
pub(crate) fn agent_at(app: &Shared, area: Rect, column: u16, row: u16) -> Option<AgentRole> {
    let inner = pane_block(app, Pane::Prompt, None, area.width).inner(area);
    let [tab_row, _, _] = parts(app, inner);
    if row != tab_row.y {
        return None;
    }
    let mut at = usize::from(tab_row.x);
    for (i, &agent) in app.work.approach.roles().iter().enumerate() {
        let end = at + agent_tab(i, agent).len();
        if (at..end).contains(&usize::from(column)) {
            return Some(agent);
        }
        at = end;
    }
    None
}

/// The pane's inside cut into the agent tabs, the prompt's body and the
/// footer (three lines when there is a provider note).
fn parts(app: &Shared, inner: Rect) -> [Rect; 3] {
    let footer_height = if app.provider_note().is_some() { 3 } else { 1 };
    Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(1),
        Constraint::Length(footer_height),
    ])
    .areas(inner)
}

/// The prompt shown, wrapped to `body`'s width, search hits highlighted.
fn body_lines(app: &Shared, body: Rect) -> Vec<Line<'static>> {
    let t = app.theme;
    let text: Vec<Line> = app
        .panes
        .prompt
        .editor
        .lines()
        .iter()
        .map(|l| Line::from(highlighted(l, &app.panes.search, t.base, t.highlight)))
        .collect();
    scroll::wrap_text(&text, body.width.into())
}

/// The furthest the prompt scrolls in a pane drawn in `area`: its last
/// line at the bottom of the body, never a blank page past it.
pub(crate) fn scroll_limit(app: &Shared, area: Rect) -> usize {
    let inner = pane_block(app, Pane::Prompt, None, area.width).inner(area);
    let [_, body, _] = parts(app, inner);
    body_lines(app, body)
        .len()
        .saturating_sub(usize::from(body.height))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::prompts::PromptSet;

    #[test]
    fn the_recorded_answer_follows_the_text_it_was_worked_out_for() {
        let set = PromptSet::load(None).unwrap();
        let texts = agents::prompt_texts(&set);
        let pane = PromptPane::new(texts.clone());
        let (approach, agent) = (Approach::MultiImage, AgentRole::Planner);
        let built_in = &texts[&template_name(approach, agent)];
        assert!(pane.is_recorded(approach, agent, built_in));
        assert!(pane.is_recorded(approach, agent, built_in), "asked again");
        let edited = format!("{built_in} Be brief.");
        assert!(!pane.is_recorded(approach, agent, &edited));
        assert!(pane.is_recorded(approach, agent, built_in), "edited back");
        assert!(!pane.is_recorded(Approach::SingleImage, AgentRole::Single, built_in));
    }
}
