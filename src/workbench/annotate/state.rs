//! The annotation screen's state and its update function (the Elm
//! architecture): keys and finished tasks come in as [`Msg`], the work to do
//! goes out as [`Cmd`]; nothing here reads or writes a file.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind};
use image::DynamicImage;
use ratatui::layout::Rect;
use ratatui_image::protocol::Protocol;
use ratatui_textarea::TextArea;

use super::keys::{action_of, Action};
use crate::annotate::guidelines::Guidelines;
use crate::annotate::order::{pairwise_units, single_units, Unit};
use crate::annotate::{
    Annotations, Judgement, Preference, StepLabel, StepLabelKind, Subject, Verdict,
};
use crate::dataset::Pair;

/// The clock as the screen knows it: time since start (for the seconds
/// spent on an item) and the wall clock (for `at`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Clock {
    /// Time since the screen opened.
    pub elapsed: Duration,
    /// Unix seconds now.
    pub unix: u64,
}

/// How bad a status line is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// For information.
    Info,
    /// Something needs the user.
    Warn,
    /// Something failed; the user must act.
    Error,
}

/// What comes in.
pub enum Msg {
    /// A key was pressed.
    Key(KeyEvent),
    /// Time passed.
    Tick(Clock),
    /// A judgement could not be written; `previous` is what was current.
    NotSaved {
        /// The item or pair.
        subject: Subject,
        /// The judgement current before the failed line.
        previous: Option<Verdict>,
        /// Why (file and cause).
        error: String,
    },
    /// A scene image was read, or could not be.
    Image(PathBuf, Result<Arc<DynamicImage>, String>),
    /// The scene image is encoded for this area.
    ImageReady(Rect, Box<Protocol>),
    /// The scene image cannot be drawn on this terminal.
    ImageUndrawable(String),
}

/// What goes out.
#[derive(Debug, Clone, PartialEq)]
pub enum Cmd {
    /// Append this line to the annotations file; `previous` is restored if
    /// it fails.
    Append {
        /// The line.
        judgement: Box<Judgement>,
        /// The judgement it supersedes, if any.
        previous: Option<Verdict>,
    },
    /// Read this scene image.
    LoadImage(PathBuf),
}

/// The scene image of the unit on screen.
pub enum Scene {
    /// The unit has no image.
    None,
    /// Being read.
    Loading(PathBuf),
    /// Read.
    Loaded(PathBuf, Arc<DynamicImage>),
    /// Missing or unreadable: one line saying which and why.
    Failed(String),
}

/// What the screen is doing besides showing the unit.
pub enum Mode {
    /// Judging: keys act from the key table.
    Judging,
    /// Writing the note.
    Note(Box<TextArea<'static>>),
    /// The key list is open; any key closes it.
    Help,
}

/// The labels and note being made for the unit on screen.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Draft {
    /// One label per step at most, by 0-based step.
    pub labels: BTreeMap<usize, StepLabelKind>,
    /// The note.
    pub note: String,
}

/// What the screen starts from.
pub struct Setup {
    /// The items, in file order.
    pub items: Vec<Pair>,
    /// The folder relative image paths are read from.
    pub items_dir: PathBuf,
    /// Who is judging.
    pub annotator: String,
    /// Compare two plans instead of rating one.
    pub pairwise: bool,
    /// Show the ground-truth plan.
    pub show_gt: bool,
    /// The guidelines.
    pub guidelines: Guidelines,
    /// The annotations file as it was when the screen opened.
    pub existing: Annotations,
    /// One-line notices to show at start.
    pub notices: Vec<String>,
}

/// The annotation screen.
pub struct Judging {
    /// The items, in file order.
    pub items: Vec<Pair>,
    items_dir: PathBuf,
    /// Who is judging.
    pub annotator: String,
    /// Comparing pairs instead of rating single plans.
    pub pairwise: bool,
    /// The ground truth is shown.
    pub show_gt: bool,
    /// The guidelines.
    pub guidelines: Guidelines,
    /// What is judged, in this annotator's order.
    pub units: Vec<Unit>,
    /// The position on screen, in `units`.
    pub pos: usize,
    /// This annotator's current judgements.
    pub current: HashMap<Subject, Verdict>,
    /// Positions skipped in this sitting.
    pub skipped: HashSet<usize>,
    /// The judgements that `u` withdraws, last on top.
    undo: Vec<Subject>,
    /// The labels and note being made.
    pub draft: Draft,
    /// The selected step.
    pub step: usize,
    /// Help, note editing or judging.
    pub mode: Mode,
    /// The clock.
    pub clock: Clock,
    /// When the unit on screen was shown.
    shown_at: Duration,
    /// Time spent earlier on each position in this sitting.
    spent: HashMap<usize, Duration>,
    /// The status line.
    pub status: Option<(String, Severity)>,
    /// The scene image of the unit on screen.
    pub scene: Scene,
    /// The image encoded for an area of the screen.
    pub image: Option<(Rect, Box<Protocol>)>,
    /// Set when the user quits.
    pub quit: bool,
}

impl Judging {
    /// Builds the screen at the first unjudged position; the command reads
    /// its scene image.
    pub fn new(setup: Setup, clock: Clock) -> (Judging, Vec<Cmd>) {
        let units = if setup.pairwise {
            pairwise_units(&setup.items, &setup.annotator)
        } else {
            single_units(&setup.items, &setup.annotator)
        };
        let mine: Vec<&Judgement> = setup
            .existing
            .lines
            .iter()
            .map(|(_, j)| j)
            .filter(|j| j.annotator == setup.annotator)
            .collect();
        let resolved = crate::annotate::Current::of(mine);
        let mut current = HashMap::new();
        let mut undo = Vec::new();
        for j in resolved.judgements() {
            if let Some(v) = &j.verdict {
                current.insert(j.subject.clone(), v.clone());
                undo.push(j.subject.clone());
            }
        }
        let mut screen = Judging {
            items: setup.items,
            items_dir: setup.items_dir,
            annotator: setup.annotator,
            pairwise: setup.pairwise,
            show_gt: setup.show_gt,
            guidelines: setup.guidelines,
            units,
            pos: 0,
            current,
            skipped: HashSet::new(),
            undo,
            draft: Draft::default(),
            step: 0,
            mode: Mode::Judging,
            clock,
            shown_at: clock.elapsed,
            spent: HashMap::new(),
            status: setup
                .notices
                .into_iter()
                .next()
                .map(|n| (n, Severity::Warn)),
            scene: Scene::None,
            image: None,
            quit: false,
        };
        let first = screen.next_unjudged_from(0).unwrap_or(0);
        let cmds = screen.go_to(first);
        if screen.status.is_none() && screen.judged() == screen.units.len() {
            screen.status = Some((
                "every item is judged; ← → to look back, q to quit".into(),
                Severity::Info,
            ));
        }
        (screen, cmds)
    }

    /// The subject of the unit at `pos`.
    pub fn subject(&self, pos: usize) -> Option<Subject> {
        Some(match *self.units.get(pos)? {
            Unit::Single(i) => Subject::Item(self.items[i].id.clone()),
            Unit::Pair(l, r) => Subject::Pair(self.items[l].id.clone(), self.items[r].id.clone()),
        })
    }

    /// Whether the unit at `pos` has a current judgement (a rating, or a
    /// preference).
    pub fn is_judged(&self, pos: usize) -> bool {
        self.subject(pos)
            .and_then(|s| self.current.get(&s))
            .is_some_and(|v| v.rating.is_some() || v.preference.is_some())
    }

    /// How many units are judged.
    pub fn judged(&self) -> usize {
        (0..self.units.len()).filter(|&p| self.is_judged(p)).count()
    }

    /// The current judgement of the unit on screen.
    pub fn verdict(&self) -> Option<&Verdict> {
        self.subject(self.pos).and_then(|s| self.current.get(&s))
    }

    /// Seconds spent on the unit on screen, in this sitting.
    pub fn seconds_here(&self) -> u64 {
        let earlier = self.spent.get(&self.pos).copied().unwrap_or_default();
        (earlier + self.clock.elapsed.saturating_sub(self.shown_at)).as_secs()
    }

    /// The mean seconds per judged unit, over this annotator's current
    /// judgements.
    pub fn mean_seconds(&self) -> Option<u64> {
        let judged: Vec<u64> = self
            .current
            .values()
            .filter(|v| v.rating.is_some() || v.preference.is_some())
            .map(|v| v.seconds)
            .collect();
        (!judged.is_empty()).then(|| judged.iter().sum::<u64>() / judged.len() as u64)
    }

    /// The steps of the plan being labelled (the single item's plan).
    pub fn plan(&self) -> &[String] {
        match self.units.get(self.pos) {
            Some(Unit::Single(i)) => &self.items[*i].pred,
            _ => &[],
        }
    }

    /// The item whose task, image and ground truth are shown.
    pub fn shown_item(&self) -> Option<&Pair> {
        match *self.units.get(self.pos)? {
            Unit::Single(i) | Unit::Pair(i, _) => self.items.get(i),
        }
    }

    fn image_path(&self) -> Option<PathBuf> {
        let image = self.shown_item()?.image.as_ref()?;
        Some(self.items_dir.join(image))
    }

    /// The first unjudged, unskipped position at or after `from`, wrapping
    /// around; skipped ones when nothing else is left.
    fn next_unjudged_from(&self, from: usize) -> Option<usize> {
        let n = self.units.len();
        let ring = (0..n).map(|k| (from + k) % n);
        ring.clone()
            .find(|&p| !self.is_judged(p) && !self.skipped.contains(&p))
            .or_else(|| ring.into_iter().find(|&p| !self.is_judged(p)))
    }

    /// Shows the unit at `pos`: keeps the time spent on the one left, loads
    /// the draft from its current judgement, and reads its image if new.
    fn go_to(&mut self, pos: usize) -> Vec<Cmd> {
        let here = self.clock.elapsed.saturating_sub(self.shown_at);
        *self.spent.entry(self.pos).or_default() += here;
        self.shown_at = self.clock.elapsed;
        self.pos = pos.min(self.units.len().saturating_sub(1));
        self.step = 0;
        self.draft = match self.verdict() {
            Some(v) => Draft {
                labels: v.step_labels.iter().map(|l| (l.step, l.label)).collect(),
                note: v.note.clone(),
            },
            None => Draft::default(),
        };
        let wanted = self.image_path();
        let same = match (&self.scene, &wanted) {
            (Scene::Loading(p) | Scene::Loaded(p, _), Some(w)) => p == w,
            (Scene::None, None) => true,
            _ => false,
        };
        if same {
            return vec![];
        }
        self.image = None;
        match wanted {
            Some(path) => {
                self.scene = Scene::Loading(path.clone());
                vec![Cmd::LoadImage(path)]
            }
            None => {
                self.scene = Scene::None;
                vec![]
            }
        }
    }

    /// Handles one message.
    pub fn update(&mut self, msg: Msg) -> Vec<Cmd> {
        match msg {
            Msg::Key(key) => self.key(key),
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
                        Err(e) => Scene::Failed(e),
                    };
                }
                vec![]
            }
            Msg::ImageReady(area, protocol) => {
                self.image = Some((area, protocol));
                vec![]
            }
            Msg::ImageUndrawable(e) => {
                self.scene = Scene::Failed(format!("the scene image cannot be drawn here: {e}"));
                vec![]
            }
        }
    }

    fn key(&mut self, key: KeyEvent) -> Vec<Cmd> {
        if key.kind == KeyEventKind::Release {
            return vec![];
        }
        match &mut self.mode {
            Mode::Help => {
                self.mode = Mode::Judging;
                return vec![];
            }
            Mode::Note(editor) => {
                match key.code {
                    KeyCode::Enter => {
                        self.draft.note = editor.lines().join(" ").trim().to_string();
                        self.mode = Mode::Judging;
                        self.status = Some((
                            "note kept; it is saved with the judgement".into(),
                            Severity::Info,
                        ));
                    }
                    KeyCode::Esc => self.mode = Mode::Judging,
                    _ => {
                        editor.input(key);
                    }
                }
                return vec![];
            }
            Mode::Judging => {}
        }
        let Some(action) = action_of(key, self.pairwise) else {
            return vec![];
        };
        self.act(action, key)
    }

    fn act(&mut self, action: Action, key: KeyEvent) -> Vec<Cmd> {
        let steps = self.plan().len();
        match action {
            Action::Rate => {
                let KeyCode::Char(c) = key.code else {
                    return vec![];
                };
                let rating = c.to_digit(10).and_then(|d| u8::try_from(d).ok());
                return self.judge(rating, None);
            }
            Action::Prefer(p) => return self.judge(None, Some(p)),
            Action::Label(label) => {
                if steps > 0 {
                    let same = self.draft.labels.get(&self.step) == Some(&label);
                    if same {
                        self.draft.labels.remove(&self.step);
                    } else {
                        self.draft.labels.insert(self.step, label);
                        self.step = (self.step + 1).min(steps - 1);
                    }
                }
            }
            Action::ClearLabel => {
                self.draft.labels.remove(&self.step);
            }
            Action::StepDown => self.step = (self.step + 1).min(steps.saturating_sub(1)),
            Action::StepUp => self.step = self.step.saturating_sub(1),
            Action::Note => {
                let mut editor = TextArea::new(vec![self.draft.note.clone()]);
                editor.move_cursor(ratatui_textarea::CursorMove::End);
                self.mode = Mode::Note(Box::new(editor));
            }
            Action::Next => {
                if self.pos + 1 < self.units.len() {
                    return self.go_to(self.pos + 1);
                }
            }
            Action::Previous => {
                if self.pos > 0 {
                    return self.go_to(self.pos - 1);
                }
            }
            Action::NextUnjudged => return self.advance(),
            Action::Skip => {
                self.skipped.insert(self.pos);
                return self.advance();
            }
            Action::Undo => return self.undo(),
            Action::Help => self.mode = Mode::Help,
            Action::Quit => self.quit = true,
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
pub(crate) mod tests {
    use super::*;
    use crossterm::event::KeyModifiers;

    /// Six items of three tasks: an original and a changed copy each.
    pub(crate) fn items() -> Vec<Pair> {
        let mut out = Vec::new();
        for (t, task) in [
            "Put a mug in the sink.",
            "Heat an apple.",
            "Put a pen in a box.",
        ]
        .into_iter()
        .enumerate()
        {
            let gt = vec![
                "Walk to the counter.".to_string(),
                "Pick up the thing.".into(),
            ];
            let mut original = Pair::new(
                format!("task{t}/multi_agent_image"),
                gt.clone(),
                vec![
                    "Walk to the counter.".into(),
                    "Pick up the thing.".into(),
                    "Put it where it goes.".into(),
                ],
            );
            original.task = Some(task.into());
            let mut copy = original.clone();
            copy.id = format!("{}~object-swap", original.id);
            copy.source = Some(original.id.clone());
            copy.pred[1] = "Pick up the bread.".into();
            out.push(original);
            out.push(copy);
        }
        out
    }

    pub(crate) fn setup(pairwise: bool, existing: Annotations) -> Setup {
        Setup {
            items: items(),
            items_dir: PathBuf::from("/nowhere"),
            annotator: "ana".into(),
            pairwise,
            show_gt: false,
            guidelines: Guidelines::built_in(),
            existing,
            notices: vec![],
        }
    }

    /// The screen opened at a fixed time.
    pub(crate) fn open(setup: Setup) -> (Judging, Vec<Cmd>) {
        let clock = Clock {
            elapsed: Duration::ZERO,
            unix: 1_700_000_000,
        };
        Judging::new(setup, clock)
    }

    pub(crate) fn press(screen: &mut Judging, c: char) -> Vec<Cmd> {
        screen.update(Msg::Key(KeyEvent::new(
            KeyCode::Char(c),
            KeyModifiers::NONE,
        )))
    }

    fn appended(cmds: &[Cmd]) -> Vec<Judgement> {
        cmds.iter()
            .filter_map(|c| match c {
                Cmd::Append { judgement, .. } => Some((**judgement).clone()),
                Cmd::LoadImage(_) => None,
            })
            .collect()
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
