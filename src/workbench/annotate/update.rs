//! The annotation screen's update function: a message in, the commands out.
//! Keys reach it through the one key table ([`crate::workbench::keymap`]),
//! as a [`Component`].

use crossterm::event::{KeyEvent, KeyEventKind};
use ratatui::layout::Rect;
use ratatui::Frame;
use ratatui_textarea::TextArea;

use super::state::{Cmd, Focus, Judging, Mode, Msg, Scene, Severity};
use super::view::{self, Lists};
use crate::annotate::{Judgement, Preference, StepLabel, Subject, Verdict};
use crate::workbench::component::{self, Component};
use crate::workbench::keymap::{Action, Context};
use crate::workbench::scroll::Motion;
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
            Msg::SkipNotSaved(error) => {
                self.status = Some((
                    format!("the skip is not kept for the next sitting: {error}"),
                    Severity::Warn,
                ));
                vec![]
            }
            Msg::Resize(width, height) => {
                self.size = Some((width, height));
                self.keep_in_view();
                vec![]
            }
            Msg::Wheel(lines) => {
                match self.mode {
                    Mode::Help => self.scroll_help(Motion::Wheel(lines)),
                    Mode::Judging => self.move_by(Motion::Wheel(lines)),
                    Mode::Note(_) => {}
                }
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
            Mode::Help => {
                match action {
                    Action::Quit => self.quit = true,
                    Action::Move(delta) => {
                        self.mode = Mode::Help;
                        self.scroll_help(Motion::of_move(delta));
                    }
                    Action::HalfPage(delta) => {
                        self.mode = Mode::Help;
                        self.scroll_help(Motion::HalfPage(delta));
                    }
                    _ => {}
                }
                vec![]
            }
            Mode::Note(editor) => {
                match action {
                    Action::Accept => {
                        self.draft.note = editor.lines().join(" ").trim().to_string();
                        let saved = self.save_draft();
                        let said = if saved.is_empty() {
                            "note kept; it is saved with the judgement"
                        } else {
                            "note saved with the judgement"
                        };
                        self.status = Some((said.into(), Severity::Info));
                        return saved;
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
    /// The window the screen is drawn in, once its size is known.
    fn window(&self) -> Option<Rect> {
        self.size.map(|(w, h)| Rect::new(0, 0, w, h))
    }

    /// Whether a judgement can be given: the window is known and large
    /// enough to show what is judged.
    fn can_judge(&self) -> bool {
        self.window().is_some_and(|area| view::fits(area, self))
    }

    /// The screen's lists as the window shows them (wrapping does not
    /// depend on colours).
    fn lists(&self) -> Option<Lists> {
        self.window()
            .map(|area| view::lists(self, area, &Theme::no_color()))
    }

    /// Whether the selected step of the plan is on screen, so that a label
    /// goes only to a step the annotator can see.
    fn step_is_seen(&self) -> bool {
        if !self.can_judge() || self.focus != Focus::Plan {
            return false;
        }
        self.lists()
            .and_then(|l| l.plan)
            .is_some_and(|p| self.scrolls.plan.shows(&p.wrapped, self.step, p.viewport))
    }

    /// Brings every list's selected step into view (after a resize or a
    /// change of what is shown).
    pub(super) fn keep_in_view(&mut self) {
        let Some(lists) = self.lists() else { return };
        if let Some(p) = &lists.plan {
            self.scrolls.plan.follow(&p.wrapped, self.step, p.viewport);
        }
        if let Some([l, r]) = &lists.sides {
            let step = self.step;
            let at = |w: &crate::workbench::scroll::Wrapped| view::side_step(step, w.items());
            self.scrolls
                .left
                .follow(&l.wrapped, at(&l.wrapped), l.viewport);
            self.scrolls
                .right
                .follow(&r.wrapped, at(&r.wrapped), r.viewport);
        }
        if let Some(g) = &lists.reference {
            self.scrolls
                .reference
                .follow(&g.wrapped, self.reference_step, g.viewport);
        }
        if matches!(self.mode, Mode::Help) {
            self.scroll_help(Motion::Line(0));
        }
    }

    /// Scrolls the help.
    fn scroll_help(&mut self, motion: Motion) {
        if let Some(area) = self.window() {
            let (_, lines, viewport) = view::help_view(self, area, &Theme::no_color());
            self.scrolls.help.scroll(lines.len(), viewport, motion);
        }
    }

    /// Moves the selection of the list the movement keys move in: the
    /// plan, both plans of a pair together, or the reference plan.
    fn move_by(&mut self, motion: Motion) {
        let Some(lists) = self.lists() else { return };
        if self.focus == Focus::Reference {
            if let Some(g) = &lists.reference {
                self.reference_step = self.scrolls.reference.select(
                    &g.wrapped,
                    self.reference_step,
                    g.viewport,
                    motion,
                );
            }
            return;
        }
        if let Some(p) = &lists.plan {
            self.step = self
                .scrolls
                .plan
                .select(&p.wrapped, self.step, p.viewport, motion);
        }
        if let Some(sides) = &lists.sides {
            self.move_pair(sides, motion);
        }
    }

    /// Moves the selection shared by both plans of a pair: a line at a
    /// time (a page and the wheel are that many lines), each side
    /// scrolling inside its selected step first while it goes on out of
    /// view; Home and End go to the ends.
    fn move_pair(&mut self, sides: &[view::List; 2], motion: Motion) {
        let longest = sides.iter().map(|s| s.wrapped.items()).max().unwrap_or(0);
        let (times, d) = match motion {
            Motion::Home | Motion::End => {
                self.step = if motion == Motion::Home {
                    0
                } else {
                    longest.saturating_sub(1)
                };
                for (side, scroll) in sides
                    .iter()
                    .zip([&mut self.scrolls.left, &mut self.scrolls.right])
                {
                    let at = view::side_step(self.step, side.wrapped.items());
                    if motion == Motion::Home {
                        scroll.reset();
                    } else {
                        scroll.scroll(side.wrapped.total(), side.viewport, Motion::End);
                    }
                    scroll.follow(&side.wrapped, at, side.viewport);
                }
                return;
            }
            Motion::Line(d) => (1, d.signum()),
            Motion::Page(d) => (
                sides
                    .iter()
                    .map(|s| s.viewport)
                    .min()
                    .unwrap_or(1)
                    .saturating_sub(1)
                    .max(1),
                d.signum(),
            ),
            Motion::HalfPage(d) => (
                (sides.iter().map(|s| s.viewport).min().unwrap_or(1) / 2).max(1),
                d.signum(),
            ),
            Motion::Wheel(d) => (d.unsigned_abs(), d.signum()),
        };
        for _ in 0..times {
            let mut inside = false;
            for (side, scroll) in sides
                .iter()
                .zip([&mut self.scrolls.left, &mut self.scrolls.right])
            {
                let at = view::side_step(self.step, side.wrapped.items());
                let span = side.wrapped.span(at);
                let (top, bottom) = (scroll.offset(), scroll.offset() + side.viewport);
                let goes_on = if d > 0 {
                    span.end > bottom
                } else {
                    span.start < top
                };
                if goes_on && d != 0 {
                    scroll.scroll(side.wrapped.total(), side.viewport, Motion::Line(d));
                    inside = true;
                }
            }
            if inside || d == 0 {
                continue;
            }
            self.step = self
                .step
                .saturating_add_signed(d)
                .min(longest.saturating_sub(1));
            for (side, scroll) in sides
                .iter()
                .zip([&mut self.scrolls.left, &mut self.scrolls.right])
            {
                let at = view::side_step(self.step, side.wrapped.items());
                scroll.follow(&side.wrapped, at, side.viewport);
            }
        }
    }

    /// Carries out a judging action from the key table.
    fn act(&mut self, action: Action) -> Vec<Cmd> {
        let steps = self.plan().len();
        match action {
            Action::Rate(_) | Action::Prefer(_) | Action::Label(_) if !self.can_judge() => {}
            Action::Rate(rating) => return self.judge(Some(rating), None),
            Action::Prefer(p) => return self.judge(None, Some(p)),
            Action::Label(_) | Action::ClearLabel
                if !self.step_is_seen() && self.focus == Focus::Reference =>
            {
                self.status = Some((
                    "labels go on the plan's steps: g goes back to the plan".into(),
                    Severity::Info,
                ));
            }
            Action::Label(_) | Action::ClearLabel if !self.step_is_seen() => {}
            Action::Label(label) if steps > 0 => {
                if self.draft.labels.get(&self.step) == Some(&label) {
                    self.draft.labels.remove(&self.step);
                } else {
                    self.draft.labels.insert(self.step, label);
                    // Labelling moves on to the next step (the help says so).
                    self.step = (self.step + 1).min(steps - 1);
                }
                self.keep_in_view();
                return self.save_draft();
            }
            Action::ClearLabel => {
                self.draft.labels.remove(&self.step);
                self.keep_in_view();
                return self.save_draft();
            }
            Action::Move(delta) => self.move_by(Motion::of_move(delta)),
            Action::HalfPage(delta) => self.move_by(Motion::HalfPage(delta)),
            Action::NextPane if self.show_gt => {
                self.focus = match self.focus {
                    Focus::Plan => Focus::Reference,
                    Focus::Reference => Focus::Plan,
                };
                self.keep_in_view();
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
                let mut cmds = Vec::new();
                if let Some(subject) = self.subject(self.pos) {
                    if self.skipped.insert(self.pos) {
                        cmds.push(Cmd::Skip {
                            subject,
                            skipped: true,
                        });
                    }
                }
                cmds.extend(self.advance());
                return cmds;
            }
            Action::Undo => return self.undo(),
            Action::Help => {
                self.mode = Mode::Help;
                self.scrolls.help.reset();
            }
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

    /// The labels and note as drafted, as a judgement's fields.
    fn drafted_labels(&self) -> Vec<StepLabel> {
        self.draft
            .labels
            .iter()
            .map(|(&step, &label)| StepLabel { step, label })
            .collect()
    }

    /// Appends `verdict` as the judgement of `subject` now, current at
    /// once; undo brings back what it replaces.
    fn record(&mut self, subject: Subject, verdict: Option<Verdict>) -> Cmd {
        let previous = match &verdict {
            Some(v) => self.current.insert(subject.clone(), v.clone()),
            None => self.current.remove(&subject),
        };
        self.undo.push((subject.clone(), previous.clone()));
        Cmd::Append {
            judgement: Box::new(Judgement {
                subject,
                annotator: self.annotator.clone(),
                at: self.clock.unix,
                verdict,
            }),
            previous,
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
            step_labels: self.drafted_labels(),
            note: self.draft.note.clone(),
            seconds: self.seconds_here(),
            guidelines: self.guidelines.hash.clone(),
        };
        let mut cmds = vec![self.record(subject.clone(), Some(verdict))];
        if self.skipped.remove(&self.pos) {
            cmds.push(Cmd::Skip {
                subject,
                skipped: false,
            });
        }
        self.spent.remove(&self.pos);
        self.shown_at = self.clock.elapsed;
        self.status = None;
        cmds.extend(self.advance());
        cmds
    }

    /// Labels or a note changed on a unit already judged: saved at once
    /// with its current rating or preference (one line), so that nothing
    /// the annotator added is lost by moving on without judging again.
    /// Nothing happens on a unit not judged yet (the draft goes with its
    /// judgement) or when nothing changed.
    fn save_draft(&mut self) -> Vec<Cmd> {
        let Some(subject) = self.subject(self.pos) else {
            return vec![];
        };
        let Some(now) = self.current.get(&subject) else {
            return vec![];
        };
        let labels = self.drafted_labels();
        let judged = now.rating.is_some() || now.preference.is_some();
        if !judged || (now.step_labels == labels && now.note == self.draft.note) {
            return vec![];
        }
        let verdict = Verdict {
            step_labels: labels,
            note: self.draft.note.clone(),
            seconds: now.seconds + self.seconds_here(),
            ..now.clone()
        };
        self.spent.remove(&self.pos);
        self.shown_at = self.clock.elapsed;
        vec![self.record(subject, Some(verdict))]
    }

    /// Undoes the last judgement line: appends a whole copy of the
    /// judgement it replaced (with the time now), or a withdrawal when
    /// there was none, and shows its unit.
    fn undo(&mut self) -> Vec<Cmd> {
        let Some((subject, earlier)) = self.undo.pop() else {
            self.status = Some(("nothing to undo".into(), Severity::Info));
            return vec![];
        };
        let said = match &earlier {
            Some(v) => match (v.rating, v.preference) {
                (Some(r), _) => format!("undone: back to the earlier judgement, {r}"),
                (None, Some(p)) => {
                    format!("undone: back to the earlier judgement, {}", p.as_str())
                }
                (None, None) => "undone: back to the earlier judgement".to_string(),
            },
            None => "undone: the judgement is withdrawn; judge it again".to_string(),
        };
        let mut cmds = vec![self.record(subject.clone(), earlier)];
        // Undoing is not itself undone by the next `u`: that goes further back.
        self.undo.pop();
        let pos = (0..self.units.len()).find(|&p| self.subject(p).as_ref() == Some(&subject));
        if let Some(p) = pos {
            cmds.extend(self.go_to(p));
        }
        self.status = Some((said, Severity::Info));
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
                None,
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
    fn undo_after_a_change_of_rating_brings_the_earlier_rating_back() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        let first = s.subject(0);
        let mut lines = appended(&press(&mut s, '3'));
        press(&mut s, 'p');
        s.update(Msg::Tick(Clock {
            elapsed: Duration::from_secs(5),
            unix: 1_700_000_005,
        }));
        lines.extend(appended(&press(&mut s, '4')));
        s.update(Msg::Tick(Clock {
            elapsed: Duration::from_secs(9),
            unix: 1_700_000_009,
        }));
        lines.extend(appended(&press(&mut s, 'u')));
        assert_eq!(lines.len(), 3);
        assert_eq!(s.pos, 0);
        let back = &lines[2];
        assert_eq!(Some(&back.subject), first.as_ref());
        assert_eq!(back.at, 1_700_000_009, "the copy has the time of the undo");
        assert_eq!(
            back.verdict, lines[0].verdict,
            "a whole copy of the earlier line"
        );
        assert_eq!(s.verdict().and_then(|v| v.rating), Some(3));
        // Read back as agree reads it: the item is rated 3.
        let current = crate::annotate::Current::of(&lines);
        let ratings: Vec<_> = current.ratings().map(|(_, _, r)| r).collect();
        assert_eq!(ratings, [3]);
        // A second undo goes further back: the first judgement is withdrawn.
        let more = appended(&press(&mut s, 'u'));
        assert_eq!(more.len(), 1);
        assert_eq!(more[0].verdict, None);
        assert_eq!(s.judged(), 0);
    }

    #[test]
    fn labels_and_a_note_added_after_the_rating_are_saved_with_it() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        let first = s.subject(0);
        press(&mut s, '4');
        press(&mut s, 'p');
        let lines = appended(&press(&mut s, 'w'));
        assert_eq!(lines.len(), 1, "one line for the new label");
        let v = lines[0]
            .verdict
            .clone()
            .unwrap_or_else(|| panic!("withdrawn"));
        assert_eq!(Some(&lines[0].subject), first.as_ref());
        assert_eq!(v.rating, Some(4), "saved with the current rating");
        assert_eq!(
            v.step_labels,
            [StepLabel {
                step: 0,
                label: StepLabelKind::WrongObject
            }]
        );
        press(&mut s, 'e');
        for c in "=1+1".chars() {
            press(&mut s, c);
        }
        let noted =
            appended(&s.update(Msg::Key(KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE))));
        assert_eq!(noted.len(), 1);
        assert_eq!(
            noted[0].verdict.as_ref().map(|v| v.note.as_str()),
            Some("=1+1")
        );
        assert_eq!(noted[0].verdict.as_ref().and_then(|v| v.rating), Some(4));
        // Moving on saves nothing more; an unrated item's label waits for
        // its rating.
        assert!(appended(&press(&mut s, 'n')).is_empty());
        assert!(appended(&press(&mut s, 'w')).is_empty());
    }

    #[test]
    fn a_skip_is_recorded_and_an_earlier_skip_is_left_for_last() {
        let (mut s, _) = open(setup(false, Annotations::default()));
        let first = s.subject(0).unwrap_or_else(|| panic!("no items"));
        let cmds = press(&mut s, 's');
        assert!(cmds.contains(&Cmd::Skip {
            subject: first.clone(),
            skipped: true
        }));
        let mut init = setup(false, Annotations::default());
        init.skipped = [first.clone()].into();
        let (mut again, _) = open(init);
        assert_eq!(again.pos, 1, "the skipped item is left for last");
        assert_eq!(again.skipped.len(), 1);
        for _ in 0..5 {
            press(&mut again, '3');
        }
        assert_eq!(again.pos, 0);
        let cmds = press(&mut again, '3');
        assert!(cmds.contains(&Cmd::Skip {
            subject: first,
            skipped: false
        }));
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
