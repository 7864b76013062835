//! The annotation screen's update function: a message in, the commands out.
//! Keys reach it through the one key table ([`crate::workbench::keymap`]),
//! as a [`Component`].

use crossterm::event::{KeyEvent, KeyEventKind};
use ratatui::layout::Rect;
use ratatui::Frame;
use ratatui_textarea::TextArea;

use super::state::{Cmd, Judging, Mode, Msg, Scene, Severity};
use super::view;
use crate::annotate::{Judgement, Preference, StepLabel, Verdict};
use crate::workbench::component::{self, Component};
use crate::workbench::keymap::{Action, Context};
use crate::workbench::theme::Theme;

impl Judging {
    /// Handles one message.
    pub fn update(&mut self, msg: Msg) -> Vec<Cmd> {
        match msg {
            Msg::Key(key) if key.kind == KeyEventKind::Release => vec![],
            Msg::Key(key) => component::dispatch(self, &key),
            Msg::Tick(clock) => {
                self.clock = clock;
                vec![]
            }
            Msg::NotSaved {
                subject,
                previous,
                error,
            } => {
                match previous {
                    Some(v) => self.current.insert(subject, v),
                    None => self.current.remove(&subject),
                };
                self.status = Some((format!("NOT SAVED: {error}"), Severity::Error));
                vec![]
            }
            Msg::Image(path, result) => {
                if matches!(&self.scene, Scene::Loading(p) if *p == path) {
                    self.scene = match result {
                        Ok(image) => Scene::Loaded(path, image),
                        Err(e) => Scene::Failed(e.to_string()),
                    };
                }
                vec![]
            }
            // An encoding finished after the user moved on is dropped.
            Msg::ImageReady(path, encoded) => {
                if matches!(&self.scene, Scene::Loaded(p, _) if *p == path) {
                    self.image = Some(encoded);
                }
                vec![]
            }
            Msg::ImageUndrawable(path, e) => {
                if matches!(&self.scene, Scene::Loaded(p, _) if *p == path) {
                    self.scene =
                        Scene::Failed(format!("the scene image cannot be drawn here: {e}"));
                }
                vec![]
            }
        }
    }
}

impl Component for Judging {
    type Outcome = Vec<Cmd>;

    fn contexts(&self) -> Vec<Context> {
        Judging::contexts(self)
    }

    fn on_action(&mut self, action: Action) -> Vec<Cmd> {
        match std::mem::replace(&mut self.mode, Mode::Judging) {
            Mode::Judging => self.act(action),
            Mode::Help if action == Action::Quit => self.act(action),
            Mode::Help => vec![],
            Mode::Note(editor) => {
                match action {
                    Action::Accept => {
                        self.draft.note = editor.lines().join(" ").trim().to_string();
                        self.status = Some((
                            "note kept; it is saved with the judgement".into(),
                            Severity::Info,
                        ));
                    }
                    Action::Quit => self.quit = true,
                    _ => {}
                }
                vec![]
            }
        }
    }

    fn on_other_key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        match &mut self.mode {
            Mode::Note(editor) => {
                editor.input(key);
            }
            Mode::Help => self.mode = Mode::Judging,
            Mode::Judging => {}
        }
        vec![]
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        view::draw(frame, area, self, theme);
    }
}

impl Judging {
    /// Carries out a judging action from the key table.
    fn act(&mut self, action: Action) -> Vec<Cmd> {
        let steps = self.plan().len();
        match action {
            Action::Rate(rating) => return self.judge(Some(rating), None),
            Action::Prefer(p) => return self.judge(None, Some(p)),
            Action::Label(label) if steps > 0 => {
                if self.draft.labels.get(&self.step) == Some(&label) {
                    self.draft.labels.remove(&self.step);
                } else {
                    self.draft.labels.insert(self.step, label);
                    self.step = (self.step + 1).min(steps - 1);
                }
            }
            Action::ClearLabel => {
                self.draft.labels.remove(&self.step);
            }
            Action::Move(delta) => {
                self.step = self
                    .step
                    .saturating_add_signed(delta)
                    .min(steps.saturating_sub(1));
            }
            Action::WriteNote => {
                let mut editor = TextArea::new(vec![self.draft.note.clone()]);
                editor.move_cursor(ratatui_textarea::CursorMove::End);
                self.mode = Mode::Note(Box::new(editor));
            }
            Action::NextItem if self.pos + 1 < self.units.len() => return self.go_to(self.pos + 1),
            Action::PreviousItem if self.pos > 0 => return self.go_to(self.pos - 1),
            Action::NextUnjudged => return self.advance(),
            Action::SkipItem => {
                self.skipped.insert(self.pos);
                return self.advance();
            }
            Action::Undo => return self.undo(),
            Action::Help => self.mode = Mode::Help,
            Action::Quit => self.quit = true,
            _ => {}
        }
        vec![]
    }

    /// Goes to the next unjudged unit after this one, or says all are done.
    fn advance(&mut self) -> Vec<Cmd> {
        let from = (self.pos + 1) % self.units.len().max(1);
        match self.next_unjudged_from(from) {
            Some(p) => self.go_to(p),
            None => {
                self.status = Some((
                    format!(
                        "all {} judged; ← → to look back, u to undo, q to quit",
                        self.units.len()
                    ),
                    Severity::Info,
                ));
                vec![]
            }
        }
    }

    /// Saves a judgement of the unit on screen and moves on.
    fn judge(&mut self, rating: Option<u8>, preference: Option<Preference>) -> Vec<Cmd> {
        let Some(subject) = self.subject(self.pos) else {
            return vec![];
        };
        let verdict = Verdict {
            rating,
            preference,
            step_labels: self
                .draft
                .labels
                .iter()
                .map(|(&step, &label)| StepLabel { step, label })
                .collect(),
            note: self.draft.note.clone(),
            seconds: self.seconds_here(),
            guidelines: self.guidelines.hash.clone(),
        };
        let previous = self.current.insert(subject.clone(), verdict.clone());
        self.undo.retain(|s| *s != subject);
        self.undo.push(subject.clone());
        self.skipped.remove(&self.pos);
        self.spent.remove(&self.pos);
        self.shown_at = self.clock.elapsed;
        self.status = None;
        let mut cmds = vec![Cmd::Append {
            judgement: Box::new(Judgement {
                subject,
                annotator: self.annotator.clone(),
                at: self.clock.unix,
                verdict: Some(verdict),
            }),
            previous,
        }];
        cmds.extend(self.advance());
        cmds
    }

    /// Withdraws the last judgement still current and shows its unit.
    fn undo(&mut self) -> Vec<Cmd> {
        let Some(subject) = self.undo.pop() else {
            self.status = Some(("nothing to undo".into(), Severity::Info));
            return vec![];
        };
        let previous = self.current.remove(&subject);
        let pos = (0..self.units.len()).find(|&p| self.subject(p).as_ref() == Some(&subject));
        let mut cmds = vec![Cmd::Append {
            judgement: Box::new(Judgement {
                subject,
                annotator: self.annotator.clone(),
                at: self.clock.unix,
                verdict: None,
            }),
            previous,
        }];
        self.status = Some((
            "the last judgement is withdrawn; judge it again".into(),
            Severity::Info,
        ));
        if let Some(p) = pos {
            cmds.extend(self.go_to(p));
        }
        cmds
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

    use super::super::fixtures::{appended, open, press, setup};
    use super::super::state::{Clock, Cmd, Draft, Msg, Severity};
    use crate::annotate::guidelines::Guidelines;
    use crate::annotate::{Annotations, Preference, StepLabel, StepLabelKind, Subject};

    #[test]
    fn an_image_encoded_after_the_user_moved_on_is_dropped() {
        use std::path::PathBuf;
        use std::sync::Arc;

        use image::DynamicImage;
        use ratatui::layout::Rect;

        use super::super::state::Scene;
        use crate::workbench::scene_image;

        let (mut s, _) = open(setup(false, Annotations::default()));
        let (here, gone) = (
            PathBuf::from("/nowhere/here.png"),
            PathBuf::from("/nowhere/gone.png"),
        );
        let image = Arc::new(DynamicImage::new_rgb8(4, 4));
        s.scene = Scene::Loaded(here.clone(), image.clone());
        let area = Rect::new(0, 0, 4, 2);
        let encoded = || {
            scene_image::encode(
                &crate::workbench::graphics::Graphics::halfblocks(),
                &image,
                area,
            )
            .unwrap()
        };
        s.update(Msg::ImageReady(gone.clone(), encoded()));
        assert!(s.image.is_none(), "the image of an item left behind");
        s.update(Msg::ImageUndrawable(gone, "no protocol".into()));
        assert!(matches!(s.scene, Scene::Loaded(..)));
        s.update(Msg::ImageReady(here, encoded()));
        assert_eq!(s.image.as_ref().map(|(at, _)| *at), Some(area));
    }

    #[test]
    fn the_first_key_rates_the_first_item_and_moves_on() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        assert_eq!(s.pos, 0);
        let first = s.subject(0);
        s.update(Msg::Tick(Clock {
            elapsed: Duration::from_secs(7),
            unix: 1_700_000_007,
        }));
        let lines = appended(&press(&mut s, '4'));
        assert_eq!(lines.len(), 1);
        assert_eq!(Some(&lines[0].subject), first.as_ref());
        let v = lines[0]
            .verdict
            .clone()
            .unwrap_or_else(|| panic!("withdrawn"));
        assert_eq!(
            (v.rating, v.seconds, lines[0].at),
            (Some(4), 7, 1_700_000_007)
        );
        assert_eq!(v.guidelines, Guidelines::built_in().hash);
        assert_eq!(s.pos, 1);
        assert_eq!(s.judged(), 1);
    }

    #[test]
    fn labels_and_note_go_with_the_rating() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        press(&mut s, 'j');
        press(&mut s, 'w');
        assert_eq!(s.step, 2, "a label moves to the next step");
        press(&mut s, '!');
        assert_eq!(s.step, 2, "the last step stays selected");
        for c in ['k', 'k', 'o', 'w'] {
            press(&mut s, c);
        }
        press(&mut s, 'e');
        for c in "too short".chars() {
            press(&mut s, c);
        }
        s.update(Msg::Key(KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE)));
        let lines = appended(&press(&mut s, '2'));
        let v = lines[0]
            .verdict
            .clone()
            .unwrap_or_else(|| panic!("withdrawn"));
        assert_eq!(
            v.step_labels,
            [
                StepLabel {
                    step: 0,
                    label: StepLabelKind::Ok
                },
                StepLabel {
                    step: 2,
                    label: StepLabelKind::Unsafe
                }
            ]
        );
        assert_eq!(v.note, "too short");
        assert_eq!(s.draft, Draft::default(), "the next item starts clean");
    }

    #[test]
    fn undo_withdraws_the_last_and_reopening_resumes_there() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        let mut lines = Vec::new();
        for c in ['3', '4', '5'] {
            lines.extend(appended(&press(&mut s, c)));
        }
        let third = s.subject(2);
        lines.extend(appended(&press(&mut s, 'u')));
        assert_eq!(lines.len(), 4);
        assert_eq!(lines[3].verdict, None);
        assert_eq!(Some(&lines[3].subject), third.as_ref());
        assert_eq!(s.pos, 2);
        let existing = Annotations {
            lines: lines.into_iter().enumerate().collect(),
            errors: vec![],
        };
        let (again, _) = open(setup(false, existing));
        assert_eq!(again.pos, 2);
        assert_eq!(again.judged(), 2);
    }

    #[test]
    fn skip_next_previous_and_next_unjudged_move_as_said() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        press(&mut s, 's');
        assert_eq!(s.pos, 1);
        press(&mut s, '1');
        assert_eq!(s.pos, 2, "rating goes to the next unjudged");
        press(&mut s, 'p');
        press(&mut s, 'p');
        assert_eq!(s.pos, 0);
        press(&mut s, 'n');
        assert_eq!(s.pos, 1);
        s.update(Msg::Key(KeyEvent::new(KeyCode::Tab, KeyModifiers::NONE)));
        assert_eq!(s.pos, 2);
        for c in ['1', '1', '1', '1'] {
            press(&mut s, c);
        }
        assert_eq!(s.pos, 0, "the skipped one comes back last");
        press(&mut s, '2');
        assert_eq!(s.judged(), 6);
        assert!(s
            .status
            .as_ref()
            .is_some_and(|(t, _)| t.starts_with("all 6 judged")));
    }

    #[test]
    fn pairwise_prefers_sides_of_one_task() {
        let (mut s, _) = open(setup(true, Annotations::default()));
        assert_eq!(s.units.len(), 3);
        assert_eq!(
            press(&mut s, '3'),
            vec![],
            "no rating on the pairwise screen"
        );
        let lines = appended(&press(&mut s, '0'));
        let Subject::Pair(l, r) = &lines[0].subject else {
            panic!("not a pair")
        };
        assert_eq!(l.split('~').next(), r.split('~').next());
        assert_eq!(
            lines[0].verdict.as_ref().and_then(|v| v.preference),
            Some(Preference::Neither)
        );
    }

    #[test]
    fn a_failed_write_leaves_the_item_unjudged_and_says_so() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        let cmds = press(&mut s, '4');
        let Some(Cmd::Append {
            judgement,
            previous,
        }) = cmds.first().cloned()
        else {
            panic!("no append")
        };
        s.update(Msg::NotSaved {
            subject: judgement.subject,
            previous,
            error: "disk full".into(),
        });
        assert_eq!(s.judged(), 0);
        assert!(s
            .status
            .as_ref()
            .is_some_and(|(t, sev)| t.contains("disk full") && *sev == Severity::Error));
    }
}
