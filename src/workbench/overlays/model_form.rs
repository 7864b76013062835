//! The model form: an agent's provider, base URL, model, temperature and
//! token limit, as a [`Component`] with its own state; it shows where the
//! requests will go as the fields are typed. It opens for the agent in
//! question (the one the status message names, e.g. "SKM needs a
//! provider"), and can save its settings for every agent at once.

use crossterm::event::KeyEvent;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Clear, Paragraph};
use ratatui::Frame;
use ratatui_textarea::TextArea;

use crate::agents::config::{check_base_url, check_max_tokens, check_temperature, AgentSettings};
use crate::agents::provider::endpoint_url;
use crate::agents::{AgentRole, ProviderKind};
use crate::sanitize::{for_terminal, redact_url_credentials};
use crate::workbench::component::Component;
use crate::workbench::keymap::{Action, Context};
use crate::workbench::overlays::{centred, themed_box};
use crate::workbench::panes::Pane;
use crate::workbench::shared::single_line_editor;
use crate::workbench::theme::Theme;
use crate::workbench::workspace::Messages;

/// The form's fields, in order.
const LABELS: [&str; 5] = ["provider", "base URL", "model", "temperature", "max tokens"];

/// The fields by position in [`LABELS`].
const PROVIDER: usize = 0;
const BASE_URL: usize = 1;
const MODEL: usize = 2;
const TEMPERATURE: usize = 3;
const MAX_TOKENS: usize = 4;

/// The model form's state: one editor per field, the field with focus,
/// whether saving applies to every agent, and why the last save was refused.
#[derive(Debug, Clone)]
pub struct ModelForm {
    agent: AgentRole,
    fields: Vec<TextArea<'static>>,
    focus: usize,
    every_agent: bool,
    problem: Option<String>,
    /// The settings it opened with: a save on the same provider keeps
    /// their endpoint and switches.
    opened_with: AgentSettings,
}

/// What a key in the form asks of the workbench.
#[derive(Debug, Clone, PartialEq)]
pub enum FormOutcome {
    /// The form stays open.
    Open,
    /// The form was closed without saving.
    Cancelled,
    /// The form was saved: give these agents these settings.
    Saved {
        /// The agents to set: the form's agent, or every agent.
        agents: Vec<AgentRole>,
        /// The checked settings.
        settings: AgentSettings,
    },
}

impl ModelForm {
    /// The form for `agent`, filled with its current `settings`.
    pub fn new(agent: AgentRole, settings: &AgentSettings) -> ModelForm {
        let values = [
            settings.provider.to_string(),
            redact_url_credentials(&settings.base_url),
            settings.model.clone(),
            settings.temperature.to_string(),
            settings.max_tokens.to_string(),
        ];
        ModelForm {
            agent,
            fields: values.iter().map(|v| single_line_editor(v)).collect(),
            focus: 0,
            every_agent: false,
            problem: None,
            opened_with: settings.clone(),
        }
    }

    /// The agent the form was opened for.
    pub fn agent(&self) -> AgentRole {
        self.agent
    }

    /// Whether saving sets every agent, not just [`ModelForm::agent`].
    pub fn every_agent(&self) -> bool {
        self.every_agent
    }

    fn text(&self, i: usize) -> String {
        self.fields
            .get(i)
            .map(|f| f.lines().join("").trim().to_string())
            .unwrap_or_default()
    }

    /// The base URL the typed fields give: the one typed, or, when the
    /// field was left as it opened and the provider was changed, the new
    /// provider's default (an OpenAI URL never goes to Anthropic); the
    /// opened one itself (credentials and all) when nothing was changed.
    fn base_url(&self, provider: ProviderKind) -> String {
        let typed = self.text(BASE_URL);
        let untouched = typed == redact_url_credentials(&self.opened_with.base_url);
        match (untouched, provider == self.opened_with.provider) {
            (true, true) => self.opened_with.base_url.clone(),
            (true, false) => provider.default_base_url().to_string(),
            (false, _) => typed,
        }
    }

    /// [`ModelForm::base_url`], checked when it is not the one the agent
    /// already had (a URL from the config file is the config file's to
    /// check; one typed here must be a URL without credentials).
    fn checked_url(&self, provider: ProviderKind) -> Result<String, String> {
        let base_url = self.base_url(provider);
        if base_url != self.opened_with.base_url {
            check_form_url(self.agent, &base_url)?;
        }
        Ok(base_url)
    }

    /// Where a run with the typed fields sends its requests, or why the
    /// fields name no place yet.
    fn destination(&self) -> Result<String, String> {
        let provider = self.text(PROVIDER).parse::<ProviderKind>()?;
        let base_url = self.checked_url(provider)?;
        Ok(match provider.request_path() {
            Some(path) => endpoint_url(&redact_url_credentials(&base_url), path),
            None => "nowhere: the demo's recording answers".to_string(),
        })
    }

    /// The settings typed, checked: a known provider (or the recording), a
    /// base URL without credentials, a model, and numbers in range; else
    /// why not, naming the value.
    fn checked(&self) -> Result<AgentSettings, String> {
        let (provider, model) = (self.text(PROVIDER), self.text(MODEL));
        if provider.is_empty() || model.is_empty() {
            return Err("provider and model must be set".into());
        }
        let provider = provider.parse::<ProviderKind>()?;
        let base_url = self.checked_url(provider)?;
        let temperature = self
            .text(TEMPERATURE)
            .parse::<f64>()
            .map_err(|_| format!("temperature `{}` is not a number", self.text(TEMPERATURE)))
            .and_then(|t| check_temperature("temperature", t).map_err(|e| e.to_string()))?;
        let max_tokens = self
            .text(MAX_TOKENS)
            .parse::<u64>()
            .map_err(|_| {
                format!(
                    "token limit `{}` is not a whole number",
                    self.text(MAX_TOKENS)
                )
            })
            .and_then(|n| check_max_tokens("token limit", n).map_err(|e| e.to_string()))?;
        // Another provider starts from its defaults until a run resolves it.
        let base = Some(&self.opened_with)
            .filter(|b| b.provider == provider)
            .cloned()
            .unwrap_or_else(|| AgentSettings::new(provider, &model, temperature, max_tokens));
        Ok(AgentSettings {
            model,
            temperature,
            max_tokens,
            base_url,
            ..base
        })
    }
}

/// Refuses a base URL typed in the form that is not one, or that holds
/// credentials (`user:key@host`): a key belongs in the key variable or the
/// config file, never in a URL the session keeps.
fn check_form_url(agent: AgentRole, base_url: &str) -> Result<(), String> {
    check_base_url(agent, base_url).map_err(|e| e.to_string())?;
    let with_credentials = reqwest::Url::parse(base_url.trim())
        .is_ok_and(|url| !url.username().is_empty() || url.password().is_some());
    if with_credentials {
        return Err(
            "the base URL holds credentials: set the key in OPENAI_API_KEY or ANTHROPIC_API_KEY (or api_key in the config file) instead"
                .to_string(),
        );
    }
    Ok(())
}

impl Component for ModelForm {
    type Outcome = FormOutcome;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::ModelForm]
    }

    fn on_action(&mut self, action: Action) -> FormOutcome {
        let n = self.fields.len();
        match action {
            Action::Leave => return FormOutcome::Cancelled,
            Action::Accept => match self.checked() {
                Ok(settings) => {
                    let agents = if self.every_agent {
                        AgentRole::ALL.to_vec()
                    } else {
                        vec![self.agent]
                    };
                    return FormOutcome::Saved { agents, settings };
                }
                Err(why) => self.problem = Some(why),
            },
            Action::NextField => self.focus = (self.focus + 1) % n,
            Action::PreviousField => self.focus = (self.focus + n - 1) % n,
            Action::EveryAgent => self.every_agent = !self.every_agent,
            _ => {}
        }
        FormOutcome::Open
    }

    fn on_other_key(&mut self, key: KeyEvent) -> FormOutcome {
        if let Some(field) = self.fields.get_mut(self.focus) {
            field.input(key);
            self.problem = None;
        }
        FormOutcome::Open
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let rect = centred(area, 86, 10);
        frame.render_widget(Clear, rect);
        // The keys are on the status line: every one is a hint there.
        let title = format!("{}: provider, base URL and model", self.agent.label());
        let block = themed_box(theme, &title);
        let inner = block.inner(rect);
        frame.render_widget(block, rect);
        let rows = Layout::vertical([Constraint::Length(1); 8]).split(inner);
        for (i, (label, editor)) in LABELS.iter().zip(&self.fields).enumerate() {
            let [l, r] =
                Layout::horizontal([Constraint::Length(14), Constraint::Min(1)]).areas(rows[i]);
            let style = if i == self.focus {
                theme.accent
            } else {
                theme.muted
            };
            frame.render_widget(Paragraph::new(Span::styled(*label, style)), l);
            frame.render_widget(editor, r);
        }
        let scope = if self.every_agent {
            Line::from(vec![
                Span::styled("saves for     ", theme.muted),
                Span::styled("every agent", theme.accent),
                Span::styled(" (Ctrl-A: this agent only)", theme.muted),
            ])
        } else {
            Line::from(vec![
                Span::styled("saves for     ", theme.muted),
                Span::styled(self.agent.label(), theme.accent),
                Span::styled(" only (Ctrl-A: every agent)", theme.muted),
            ])
        };
        let destination = match self.destination() {
            Ok(url) => Line::from(vec![
                Span::styled("sends to      ", theme.muted),
                Span::styled(for_terminal(&url), theme.base),
            ]),
            Err(why) => Line::from(vec![
                Span::styled("sends to      ", theme.muted),
                Span::styled(for_terminal(&why), theme.warn),
            ]),
        };
        frame.render_widget(Paragraph::new(destination), rows[5]);
        frame.render_widget(Paragraph::new(scope), rows[6]);
        if let Some(problem) = &self.problem {
            let line = Span::styled(format!("not saved: {}", for_terminal(problem)), theme.warn);
            frame.render_widget(Paragraph::new(line), rows[7]);
        }
    }
}

/// The agent the model form is for: the one the status message or the
/// start notice names as needing a provider or a key (e.g. "SKM needs a
/// provider"), else the agent of the focused pane (Knowledge Graph: SKM,
/// Grounded Description: GKM), else the Prompt pane's agent (`shown`).
pub fn agent_in_question(messages: &Messages, focus: Pane, shown: AgentRole) -> AgentRole {
    let named = [&messages.status, &messages.notice]
        .into_iter()
        .filter_map(|m| m.as_ref())
        .find_map(|(text, _)| {
            AgentRole::ALL.into_iter().find(|role| {
                let label = role.label();
                text.contains(&format!("{label} needs a provider"))
                    || text.contains(&format!("{label} uses "))
                    || text.starts_with(&format!("{label} failed"))
            })
        });
    named.unwrap_or(match focus {
        Pane::Graph => AgentRole::Skm,
        Pane::Description => AgentRole::Gkm,
        _ => shown,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workbench::app::{App, AppInit};
    use crate::workbench::component::Input;
    use crate::workbench::overlays::Overlay;
    use crate::workbench::shared::Severity;
    use crossterm::event::{KeyCode, KeyModifiers};
    use ratatui::backend::TestBackend;
    use ratatui::Terminal;

    fn demo() -> App {
        App::new(AppInit::demo((120, 40), "no models in this test")).0
    }

    fn press(app: &mut App, code: KeyCode, modifiers: KeyModifiers) {
        let Some(Overlay::ModelForm(form)) = app.overlay.take() else {
            panic!("the model form is not open");
        };
        app.on_model_form_input(form, &Input::Key(KeyEvent::new(code, modifiers)));
    }

    /// Replaces the text of field `index` with `text`.
    fn type_into(app: &mut App, index: usize, text: &str) {
        for _ in 0..index {
            press(app, KeyCode::Tab, KeyModifiers::NONE);
        }
        press(app, KeyCode::End, KeyModifiers::NONE);
        for _ in 0..40 {
            press(app, KeyCode::Backspace, KeyModifiers::NONE);
        }
        for c in text.chars() {
            press(app, KeyCode::Char(c), KeyModifiers::NONE);
        }
        for _ in 0..index {
            press(app, KeyCode::BackTab, KeyModifiers::NONE);
        }
    }

    /// Types the provider, model, temperature and token limit (the base
    /// URL is left as it opened).
    fn fill(app: &mut App, values: [&str; 4]) {
        for (i, value) in [PROVIDER, MODEL, TEMPERATURE, MAX_TOKENS]
            .into_iter()
            .zip(values)
        {
            type_into(app, i, value);
        }
    }

    fn provider(app: &App, role: AgentRole) -> String {
        let settings = &app.runs.agents[&role].settings;
        format!("{}/{}", settings.provider, settings.model)
    }

    #[test]
    fn out_of_range_numbers_are_refused_naming_the_value_and_the_range() {
        let mut app = demo();
        let before = app.runs.agents[&AgentRole::Planner].settings.clone();
        for (provider, temperature, max_tokens, why) in [
            (
                "openai",
                "1e300",
                "100",
                "temperature 1e300 is outside 0..=2",
            ),
            ("openai", "NaN", "100", "temperature NaN is outside 0..=2"),
            ("openai", "-0.1", "100", "temperature -0.1 is outside 0..=2"),
            ("openai", "inf", "100", "temperature inf is outside 0..=2"),
            (
                "openai",
                "warm",
                "100",
                "temperature `warm` is not a number",
            ),
            ("openai", "0.5", "0", "token limit 0 is outside 1..=1000000"),
            (
                "openai",
                "0.5",
                "5000000000",
                "token limit 5000000000 is outside 1..=1000000",
            ),
            (
                "openai",
                "0.5",
                "-3",
                "token limit `-3` is not a whole number",
            ),
            ("opnai", "0.5", "100", "unknown provider `opnai`"),
        ] {
            app.panes.prompt.agent = AgentRole::Planner;
            app.open_model_form();
            fill(&mut app, [provider, "gpt-4o", temperature, max_tokens]);
            press(&mut app, KeyCode::Enter, KeyModifiers::NONE);
            let Some(Overlay::ModelForm(form)) = &app.overlay else {
                panic!("a refused form stays open with what was typed");
            };
            let problem = form.problem.clone().unwrap_or_default();
            assert!(
                problem.contains(why),
                "{temperature} {max_tokens}: {problem}"
            );
            assert_eq!(form.text(TEMPERATURE), temperature);
            assert_eq!(app.runs.agents[&AgentRole::Planner].settings, before);
            press(&mut app, KeyCode::Esc, KeyModifiers::NONE);
            assert!(app.overlay.is_none());
        }
        app.open_model_form();
        fill(&mut app, ["openai", "gpt-4o", "2", "1000000"]);
        press(&mut app, KeyCode::Enter, KeyModifiers::NONE);
        assert!(app.overlay.is_none());
        let set = &app.runs.agents[&AgentRole::Planner].settings;
        assert_eq!((set.temperature, set.max_tokens), (2.0, 1_000_000));
        assert_eq!(provider(&app, AgentRole::Skm), "replay/demo-recording");
    }

    #[test]
    fn the_form_opens_for_the_agent_a_message_names_and_saves_for_every_agent() {
        let mut app = demo();
        app.panes.prompt.agent = AgentRole::Planner;
        app.set_status(
            "the replay provider only has the demo's recording, not this task: GKM needs a provider. Press m …",
            Severity::Warn,
        );
        app.open_model_form();
        let Some(Overlay::ModelForm(form)) = &app.overlay else {
            panic!("not open");
        };
        assert_eq!(form.agent(), AgentRole::Gkm);
        fill(&mut app, ["openai", "local", "0", "512"]);
        press(&mut app, KeyCode::Char('a'), KeyModifiers::CONTROL);
        press(&mut app, KeyCode::Enter, KeyModifiers::NONE);
        for role in AgentRole::ALL {
            assert_eq!(provider(&app, role), "openai/local", "{role:?}");
        }
        assert!(app
            .messages
            .status
            .as_ref()
            .is_some_and(|(s, _)| s.starts_with("every agent: openai / local")));

        app.messages.status = None;
        app.focus = Pane::Graph;
        assert_eq!(
            agent_in_question(&app.messages, app.focus, app.panes.prompt.agent),
            AgentRole::Skm
        );
        app.focus = Pane::Plan;
        assert_eq!(
            agent_in_question(&app.messages, app.focus, app.panes.prompt.agent),
            AgentRole::Planner
        );
        app.set_status(
            "Planner uses openai but no API key is set: …",
            Severity::Warn,
        );
        app.focus = Pane::Graph;
        assert_eq!(
            agent_in_question(&app.messages, app.focus, app.panes.prompt.agent),
            AgentRole::Planner
        );
    }

    #[test]
    fn the_form_draws_its_fields_scope_and_problem() {
        let mut form = ModelForm::new(AgentRole::Skm, &AgentSettings::demo_recording());
        form.on_action(Action::EveryAgent);
        for _ in 0..TEMPERATURE {
            form.on_action(Action::NextField);
        }
        form.on_other_key(KeyEvent::new(KeyCode::Char('x'), KeyModifiers::NONE));
        assert_eq!(form.on_action(Action::Accept), FormOutcome::Open);
        let mut terminal = Terminal::new(TestBackend::new(90, 12)).unwrap();
        terminal
            .draw(|f| form.draw(f, f.area(), &Theme::no_color()))
            .unwrap();
        insta::assert_snapshot!(terminal.backend());
    }

    /// The form edits the base URL and shows where requests go: another
    /// provider with the URL left alone gets that provider's default (an
    /// OpenAI URL never reaches Anthropic), a typed URL is kept, and a URL
    /// with credentials is refused, pointing to the key variables.
    #[test]
    fn the_base_url_is_edited_shown_and_never_holds_credentials() {
        let mut app = demo();
        app.panes.prompt.agent = AgentRole::Planner;
        app.open_model_form();
        fill(&mut app, ["openai", "gpt-4o", "0", "512"]);
        type_into(&mut app, BASE_URL, "http://127.0.0.1:8000/v1?api-version=2");
        let Some(Overlay::ModelForm(form)) = &app.overlay else {
            panic!("not open");
        };
        assert_eq!(
            form.destination(),
            Ok("http://127.0.0.1:8000/v1/chat/completions?api-version=2".to_string())
        );
        press(&mut app, KeyCode::Enter, KeyModifiers::NONE);
        let planner = &app.runs.agents[&AgentRole::Planner].settings;
        assert_eq!(planner.base_url, "http://127.0.0.1:8000/v1?api-version=2");

        app.open_model_form();
        type_into(&mut app, PROVIDER, "anthropic");
        let Some(Overlay::ModelForm(form)) = &app.overlay else {
            panic!("not open");
        };
        assert_eq!(
            form.destination(),
            Ok("https://api.anthropic.com/v1/messages".to_string()),
            "the OpenAI-style URL left as it was does not go to Anthropic"
        );
        press(&mut app, KeyCode::Enter, KeyModifiers::NONE);
        let planner = &app.runs.agents[&AgentRole::Planner].settings;
        assert_eq!(planner.provider, ProviderKind::Anthropic);
        assert_eq!(planner.base_url, "https://api.anthropic.com");

        app.open_model_form();
        type_into(&mut app, BASE_URL, "http://user:sk-secret@127.0.0.1:8000");
        press(&mut app, KeyCode::Enter, KeyModifiers::NONE);
        let Some(Overlay::ModelForm(form)) = &app.overlay else {
            panic!("a URL with credentials is not saved");
        };
        let problem = form.problem.clone().unwrap_or_default();
        assert!(problem.contains("ANTHROPIC_API_KEY"), "{problem}");
        assert!(!problem.contains("sk-secret"), "{problem}");
        assert_eq!(planner_url(&app), "https://api.anthropic.com");
        press(&mut app, KeyCode::Esc, KeyModifiers::NONE);

        // A URL with credentials from the config file is shown redacted and
        // kept as it is when the form saves without touching it.
        let configured = AgentSettings {
            base_url: "http://user:sk-secret@127.0.0.1:8000/v1".into(),
            ..AgentSettings::new(ProviderKind::Openai, "gpt-4o", 0.0, 512)
        };
        app.runs
            .agents
            .get_mut(&AgentRole::Planner)
            .unwrap()
            .settings = configured.clone();
        app.open_model_form();
        let Some(Overlay::ModelForm(form)) = &app.overlay else {
            panic!("not open");
        };
        assert_eq!(form.text(BASE_URL), "http://***@127.0.0.1:8000/v1");
        assert_eq!(
            form.destination(),
            Ok("http://***@127.0.0.1:8000/v1/chat/completions".to_string())
        );
        press(&mut app, KeyCode::Enter, KeyModifiers::NONE);
        assert!(app.overlay.is_none(), "saved");
        assert_eq!(planner_url(&app), configured.base_url);
    }

    fn planner_url(app: &App) -> String {
        app.runs.agents[&AgentRole::Planner]
            .settings
            .base_url
            .clone()
    }
}
