//! Prompt sets from the workbench: `S` in the Prompt pane names the set the
//! prompts are saved as ([`SetName`]), `L` chooses a saved set to load
//! ([`SetPicker`]). The files are read and written by tasks of the runtime
//! ([`Cmd::SavePromptSet`], [`Cmd::ListPromptSets`], [`Cmd::LoadPromptSet`]);
//! their layout is [`crate::agents::prompt_sets`]'.

use crossterm::event::{KeyEvent, MouseEvent};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Clear, Paragraph};
use ratatui::Frame;
use ratatui_textarea::TextArea;

use crate::agents::prompt_sets::check_name;
use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::overlays::{centred, list_box, list_mouse, moved, themed_box, Picked};
use crate::workbench::shared::single_line_editor;
use crate::workbench::theme::Theme;

/// What a key in a prompt-set overlay asks of the workbench: the set's
/// name when one is chosen.
pub type SetOutcome = Picked<String>;

/// The name to save the prompts under, being typed.
#[derive(Debug, Clone)]
pub struct SetName {
    editor: TextArea<'static>,
    problem: Option<String>,
}

impl SetName {
    /// The prompt, filled with `name` (e.g. the set loaded last).
    pub fn new(name: &str) -> SetName {
        SetName {
            editor: single_line_editor(name),
            problem: None,
        }
    }
}

impl Component for SetName {
    type Outcome = SetOutcome;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::SetName]
    }

    fn on_action(&mut self, action: Action) -> SetOutcome {
        match action {
            Action::Leave => SetOutcome::Cancelled,
            Action::Accept => {
                let name = self.editor.lines().join("").trim().to_string();
                match check_name(&name) {
                    Ok(()) => SetOutcome::Chosen(name),
                    Err(e) => {
                        self.problem = Some(e.to_string());
                        SetOutcome::Open
                    }
                }
            }
            _ => SetOutcome::Open,
        }
    }

    fn on_other_key(&mut self, key: KeyEvent) -> SetOutcome {
        self.editor.input(key);
        self.problem = None;
        SetOutcome::Open
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let rect = centred(area, 80, 4);
        frame.render_widget(Clear, rect);
        let title = format!(
            "Save the prompts as the set ({})",
            keymap::hints(Context::SetName)
        );
        let block = themed_box(theme, &title);
        let inner = block.inner(rect);
        frame.render_widget(block, rect);
        let [field, problem] = Layout::vertical([Constraint::Length(1); 2]).areas(inner);
        frame.render_widget(&self.editor, field);
        if let Some(text) = &self.problem {
            let line = Paragraph::new(Span::styled(text.as_str(), theme.warn));
            frame.render_widget(line, problem);
        }
    }
}

/// The saved sets to choose one from.
#[derive(Debug, Clone)]
pub struct SetPicker {
    names: Vec<String>,
    selected: usize,
    /// The set chosen once over unsaved prompt edits: choosing it again
    /// discards them.
    armed: Option<String>,
}

impl SetPicker {
    /// A picker over `names` (at least one), on the first.
    pub fn new(names: Vec<String>) -> SetPicker {
        SetPicker {
            names,
            selected: 0,
            armed: None,
        }
    }

    /// How wide its box is: wider while it asks about unsaved edits.
    fn width(&self) -> u16 {
        if self.armed.is_some() {
            80
        } else {
            60
        }
    }

    /// Whether choosing `name` loads it now: at once when no prompt edit
    /// is unsaved (`unsaved`), else when it is chosen a second time (the
    /// first arms it, and the picker asks before the edits are lost).
    pub fn confirmed(&mut self, name: &str, unsaved: bool) -> bool {
        if unsaved && self.armed.as_deref() != Some(name) {
            self.armed = Some(name.to_string());
            return false;
        }
        true
    }
}

impl Component for SetPicker {
    type Outcome = SetOutcome;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::Picker]
    }

    fn on_action(&mut self, action: Action) -> SetOutcome {
        match action {
            Action::Leave => SetOutcome::Cancelled,
            Action::Move(delta) => {
                self.selected = moved(self.selected, delta, self.names.len());
                self.armed = None;
                SetOutcome::Open
            }
            Action::Accept => self
                .names
                .get(self.selected)
                .map_or(SetOutcome::Cancelled, |n| SetOutcome::Chosen(n.clone())),
            _ => SetOutcome::Open,
        }
    }

    fn on_other_key(&mut self, _key: KeyEvent) -> SetOutcome {
        SetOutcome::Open
    }

    /// A click selects a row, a click on the selected row chooses it, the
    /// wheel moves the selection.
    fn on_mouse(&mut self, mouse: MouseEvent, area: Rect) -> Self::Outcome {
        let (selected, action) =
            list_mouse(&mouse, area, self.width(), self.names.len(), self.selected);
        self.selected = selected;
        self.on_action(action)
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let (accept, leave) = (
            keymap::key_of(Context::Picker, Action::Accept),
            keymap::key_of(Context::Picker, Action::Leave),
        );
        let title = match &self.armed {
            Some(_) => format!(
                "The prompts have unsaved edits: {accept} again discards them, {leave} keeps them"
            ),
            None => format!("Load a prompt set ({accept} loads)"),
        };
        let (rect, first, count) = list_box(area, self.width(), self.names.len(), self.selected);
        frame.render_widget(Clear, rect);
        let block = themed_box(theme, &title);
        let inner = block.inner(rect);
        frame.render_widget(block, rect);
        let lines: Vec<Line> = self
            .names
            .iter()
            .enumerate()
            .skip(first)
            .take(count)
            .map(|(i, name)| {
                let style = if i == self.selected {
                    theme.selection
                } else {
                    theme.base
                };
                Line::from(Span::styled(name.as_str(), style))
            })
            .collect();
        frame.render_widget(Paragraph::new(lines), inner);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::replay::Pace;
    use crate::workbench::agents::AgentsPipeline;
    use crate::workbench::app::{App, AppInit};
    use crate::workbench::headless::Headless;
    use crate::workbench::message::Msg;
    use crate::workbench::overlays::Overlay;
    use crate::workbench::panes::Pane;
    use crate::workbench::scoring::ModelSlot;
    use crossterm::event::{KeyCode, KeyModifiers};

    struct Bench {
        app: App,
        pipeline: AgentsPipeline,
    }

    impl Bench {
        fn new(root: &std::path::Path) -> Bench {
            let (app, _) = App::new(AppInit {
                prompt_sets: Some(root.to_path_buf()),
                ..AppInit::demo((160, 50), "no models in this test")
            });
            let pipeline = AgentsPipeline::offline(Pace::Instant).unwrap();
            Bench { app, pipeline }
        }

        fn key(&mut self, code: KeyCode) {
            let cmds = self
                .app
                .update(Msg::Key(KeyEvent::new(code, KeyModifiers::NONE)));
            let models = ModelSlot::Unavailable("none".into());
            Headless::new(&self.pipeline, models).run(&mut self.app, cmds, &mut |_| {});
        }

        fn keys(&mut self, text: &str) {
            text.chars().for_each(|c| self.key(KeyCode::Char(c)));
        }

        fn status(&self) -> String {
            self.app
                .messages
                .status
                .clone()
                .map(|(s, _)| s)
                .unwrap_or_default()
        }
    }

    const SKM: &str = "multi-image-skm";

    #[test]
    fn prompts_saved_as_a_set_load_back_from_the_picker() {
        let root = tempfile::tempdir().unwrap();
        let mut b = Bench::new(root.path());
        while b.app.focus != Pane::Prompt {
            b.key(KeyCode::Tab);
        }
        b.key(KeyCode::Char('L'));
        assert!(
            b.status().starts_with("no prompt set in "),
            "{}",
            b.status()
        );
        let shipped = b.app.panes.prompt.texts[SKM].clone();
        b.key(KeyCode::Enter);
        b.key(KeyCode::End);
        b.keys(" Name every towel.");
        b.key(KeyCode::Esc);
        let edited = b.app.panes.prompt.texts[SKM].clone();
        assert!(edited.ends_with("Name every towel."), "{edited}");

        b.key(KeyCode::Char('S'));
        b.keys("my/x");
        b.key(KeyCode::Enter);
        let Some(Overlay::PromptSetName(prompt)) = &b.app.overlay else {
            panic!("a bad name keeps the prompt open");
        };
        assert!(prompt
            .problem
            .as_deref()
            .is_some_and(|p| p.contains("`my/x` has a character")));
        for _ in 0..4 {
            b.key(KeyCode::Backspace);
        }
        b.keys("towels");
        b.key(KeyCode::Enter);
        assert!(b.app.overlay.is_none());
        let dir = root.path().join("towels");
        assert!(
            b.status().contains(&format!("saved in {}", dir.display())),
            "{}",
            b.status()
        );
        let file = std::fs::read_to_string(dir.join(format!("{SKM}.txt"))).unwrap();
        assert!(file.trim_end().ends_with("Name every towel."), "{file}");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            8,
            "every template"
        );

        b.app.panes.prompt.texts.insert(SKM.into(), shipped.clone());
        b.key(KeyCode::Char('L'));
        assert!(matches!(b.app.overlay, Some(Overlay::PromptSetPicker(_))));
        b.key(KeyCode::Enter);
        assert!(
            matches!(&b.app.overlay, Some(Overlay::PromptSetPicker(p)) if p.armed.is_some()),
            "an edit not in a set: the first Enter asks"
        );
        assert_eq!(
            b.app.panes.prompt.texts[SKM], shipped,
            "nothing discarded yet"
        );
        b.key(KeyCode::Esc);
        assert!(b.app.overlay.is_none());
        assert_eq!(
            b.app.panes.prompt.texts[SKM], shipped,
            "Esc keeps the edits"
        );
        b.key(KeyCode::Char('L'));
        b.key(KeyCode::Enter);
        b.key(KeyCode::Enter);
        assert_eq!(b.status(), "prompt set towels loaded (r runs what changed)");
        assert_eq!(b.app.panes.prompt.texts[SKM], edited);
        assert_eq!(
            b.app.agents_to_run(false).first(),
            Some(&crate::agents::AgentRole::Skm)
        );

        std::fs::write(dir.join(format!("{SKM}.txt")), "no sections").unwrap();
        b.key(KeyCode::Char('L'));
        b.key(KeyCode::Enter);
        let status = b.status();
        assert!(
            status.starts_with("prompt set towels not loaded: ")
                && status.contains(&format!("{SKM}.txt"))
                && !status.contains('\n'),
            "{status}"
        );
        assert_eq!(b.app.panes.prompt.texts[SKM], edited, "nothing lost");
    }
}
