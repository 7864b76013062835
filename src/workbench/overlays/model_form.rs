//! The form of an agent's provider, model, temperature and token limit.

use crossterm::event::KeyEvent;
use ratatui_textarea::TextArea;

use crate::agents::AgentRole;
use crate::workbench::app::{single_line_editor, App, Severity};
use crate::workbench::keymap::Action;
use crate::workbench::message::Cmd;
use crate::workbench::overlays::Overlay;
use crate::workbench::session::AgentSettings;

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
        let temperature = text(2).parse::<f32>();
        let max_tokens = text(3).parse::<u32>();
        match (temperature, max_tokens) {
            (Ok(temperature), Ok(max_tokens)) if !text(0).is_empty() && !text(1).is_empty() => {
                if let Some(v) = self.runs.agents.get_mut(&agent) {
                    v.settings = AgentSettings {
                        provider: text(0),
                        model: text(1),
                        temperature,
                        max_tokens,
                    };
                }
                self.session_dirty = true;
                self.set_status(
                    format!("{}: {} / {} (r runs what changed)", agent.label(), text(0), text(1)),
                    Severity::Info,
                );
            }
            _ => self.set_status(
                format!("{}: not changed: provider and model must be set, the temperature a number, the token limit a whole number", agent.label()),
                Severity::Warn,
            ),
        }
    }

    pub(crate) fn open_model_form(&mut self, agent: AgentRole) {
        let Some(v) = self.runs.agents.get(&agent) else {
            return;
        };
        let fields = vec![
            single_line_editor(&v.settings.provider),
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
