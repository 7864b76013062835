//! The form of an agent's provider, model, temperature and token limit.

use crossterm::event::KeyEvent;
use ratatui_textarea::TextArea;

use crate::agents::config::{check_max_tokens, check_temperature, AgentSettings};
use crate::agents::{AgentRole, ProviderKind};
use crate::workbench::app::{single_line_editor, App, Severity};
use crate::workbench::keymap::Action;
use crate::workbench::message::Cmd;
use crate::workbench::overlays::Overlay;

impl App {
    /// A key of the model form: other keys are typed into the field.
    pub(crate) fn on_model_form_key(
        &mut self,
        agent: AgentRole,
        mut fields: Vec<TextArea<'static>>,
        field: usize,
        action: Option<Action>,
        key: KeyEvent,
    ) -> Vec<Cmd> {
        let n = fields.len();
        let field = match action {
            Some(Action::Leave) => return Vec::new(),
            Some(Action::Accept) => {
                self.apply_model_form(agent, &fields);
                return Vec::new();
            }
            Some(Action::NextField) => (field + 1) % n,
            Some(Action::PreviousField) => (field + n - 1) % n,
            _ => {
                if let Some(f) = fields.get_mut(field) {
                    f.input(key);
                }
                field
            }
        };
        self.overlay = Some(Overlay::ModelForm {
            agent,
            fields,
            field,
        });
        Vec::new()
    }

    pub(crate) fn apply_model_form(&mut self, agent: AgentRole, fields: &[TextArea<'static>]) {
        let text = |i: usize| {
            fields
                .get(i)
                .map(|f| f.lines().join("").trim().to_string())
                .unwrap_or_default()
        };
        let label = agent.label();
        let before = self.runs.agents.get(&agent).map(|v| v.settings.clone());
        let checked = || -> Result<AgentSettings, String> {
            if text(0).is_empty() || text(1).is_empty() {
                return Err("provider and model must be set".into());
            }
            let provider = text(0).parse::<ProviderKind>()?;
            let temperature = text(2)
                .parse::<f64>()
                .map_err(|_| format!("temperature `{}` is not a number", text(2)))
                .and_then(|t| check_temperature("temperature", t).map_err(|e| e.to_string()))?;
            let max_tokens = text(3)
                .parse::<u64>()
                .map_err(|_| format!("token limit `{}` is not a whole number", text(3)))
                .and_then(|n| check_max_tokens("token limit", n).map_err(|e| e.to_string()))?;
            // The same provider keeps its resolved endpoint and switches;
            // another starts from its defaults until a run resolves it.
            let base = before
                .clone()
                .filter(|b| b.provider == provider)
                .unwrap_or_else(|| AgentSettings::new(provider, &text(1), temperature, max_tokens));
            Ok(AgentSettings {
                model: text(1),
                temperature,
                max_tokens,
                ..base
            })
        };
        match checked() {
            Ok(settings) => {
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.settings = settings;
                }
                self.session_dirty = true;
                self.set_status(
                    format!("{label}: {} / {} (r runs what changed)", text(0), text(1)),
                    Severity::Info,
                );
            }
            Err(why) => self.set_status(format!("{label}: not changed: {why}"), Severity::Warn),
        }
    }

    pub(crate) fn open_model_form(&mut self, agent: AgentRole) {
        let Some(v) = self.runs.agents.get(&agent) else {
            return;
        };
        let fields = vec![
            single_line_editor(v.settings.provider.name()),
            single_line_editor(&v.settings.model),
            single_line_editor(&v.settings.temperature.to_string()),
            single_line_editor(&v.settings.max_tokens.to_string()),
        ];
        self.overlay = Some(Overlay::ModelForm {
            agent,
            fields,
            field: 0,
        });
    }
}

#[cfg(test)]
mod tests {
    use crate::agents::AgentRole;
    use crate::workbench::app::{single_line_editor, App, AppInit, Severity};

    fn apply(app: &mut App, temperature: &str, max_tokens: &str) -> (String, Severity) {
        let fields = ["openai", "gpt-4o", temperature, max_tokens].map(single_line_editor);
        app.apply_model_form(AgentRole::Planner, &fields);
        app.status.clone().unwrap_or_else(|| panic!("no status"))
    }

    #[test]
    fn out_of_range_numbers_are_refused_naming_the_value_and_the_range() {
        let (mut app, _) = App::new(AppInit::demo((120, 40), "no models in this test"));
        let before = app.runs.agents[&AgentRole::Planner].settings.clone();
        for (temperature, max_tokens, why) in [
            ("1e300", "100", "temperature 1e300 is outside 0..=2"),
            ("NaN", "100", "temperature NaN is outside 0..=2"),
            ("-0.1", "100", "temperature -0.1 is outside 0..=2"),
            ("inf", "100", "temperature inf is outside 0..=2"),
            ("warm", "100", "temperature `warm` is not a number"),
            ("0.5", "0", "token limit 0 is outside 1..=1000000"),
            (
                "0.5",
                "5000000000",
                "token limit 5000000000 is outside 1..=1000000",
            ),
            ("0.5", "-3", "token limit `-3` is not a whole number"),
        ] {
            let (status, severity) = apply(&mut app, temperature, max_tokens);
            assert_eq!(severity, Severity::Warn, "{status}");
            assert!(status.contains(why), "{temperature} {max_tokens}: {status}");
            assert_eq!(app.runs.agents[&AgentRole::Planner].settings, before);
        }
        let (status, severity) = apply(&mut app, "2", "1000000");
        assert_eq!(severity, Severity::Info, "{status}");
        let set = &app.runs.agents[&AgentRole::Planner].settings;
        assert_eq!((set.temperature, set.max_tokens), (2.0, 1_000_000));
    }
}
