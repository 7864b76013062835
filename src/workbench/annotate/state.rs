//! The annotation screen's state (the Elm architecture): keys and finished
//! tasks come in as [`Msg`] (handled in [`super::update`]), the work to do
//! goes out as [`Cmd`]; nothing here reads or writes a file.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use crossterm::event::KeyEvent;
use image::DynamicImage;
use ratatui::layout::Rect;
use ratatui_textarea::TextArea;

use crate::annotate::guidelines::Guidelines;
use crate::annotate::order::{pairwise_units, single_units, Unit};
use crate::annotate::{Annotations, Judgement, StepLabelKind, Subject, Verdict};
use crate::dataset::Pair;
use crate::workbench::keymap::Context;
use crate::workbench::scene_image::{Encoded, SceneImageError};
use crate::workbench::scroll::Scroll;

/// The clock as the screen knows it: time since start (for the seconds
/// spent on an item) and the wall clock (for `at`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Clock {
    /// Time since the screen opened.
    pub elapsed: Duration,
    /// Unix seconds now.
    pub unix: u64,
}

pub use crate::workbench::shared::Severity;

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
    Image(PathBuf, Result<Arc<DynamicImage>, SceneImageError>),
    /// The scene image read from this file is encoded for an area.
    ImageReady(PathBuf, Encoded),
    /// The scene image read from this file cannot be drawn on this terminal.
    ImageUndrawable(PathBuf, String),
    /// A line of the skips file could not be written (file and cause).
    SkipNotSaved(String),
    /// The terminal has this size (columns, rows): the screen lays itself
    /// out for it, and keeps the selected steps in view.
    Resize(u16, u16),
    /// The mouse wheel turned this many lines down (+) or up (-).
    Wheel(isize),
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
    /// Record in the skips file that this unit is skipped (or, `false`,
    /// no longer), so that a later sitting still leaves it for last.
    Skip {
        /// The item or pair.
        subject: Subject,
        /// Skipped, or judged after all.
        skipped: bool,
    },
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
    /// The key list is open: the scroll keys scroll it, any other key
    /// closes it.
    Help,
}

/// Which list the movement keys move in when the reference plan is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Focus {
    /// The plan judged (or both plans of a pair).
    #[default]
    Plan,
    /// The reference plan.
    Reference,
}

/// The scroll position of each list of the screen (see
/// [`crate::workbench::scroll`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Scrolls {
    /// The plan rated.
    pub plan: Scroll,
    /// The left plan of a pair.
    pub left: Scroll,
    /// The right plan of a pair.
    pub right: Scroll,
    /// The reference plan.
    pub reference: Scroll,
    /// The help.
    pub help: Scroll,
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
    /// What this annotator skipped in earlier sittings (the skips file).
    pub skipped: HashSet<Subject>,
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
    /// Positions skipped, in this sitting or an earlier one.
    pub skipped: HashSet<usize>,
    /// What `u` undoes, last on top: each judgement line of this annotator
    /// with the judgement it replaced (`None`: there was none, so undo
    /// withdraws it).
    pub(super) undo: Vec<(Subject, Option<Verdict>)>,
    /// The labels and note being made.
    pub draft: Draft,
    /// The selected step (of the plan, or of both plans of a pair).
    pub step: usize,
    /// The selected step of the reference plan.
    pub reference_step: usize,
    /// Where the movement keys move.
    pub focus: Focus,
    /// How far each list is scrolled.
    pub scrolls: Scrolls,
    /// The terminal's size (columns, rows), once known: nothing can be
    /// judged before the screen knows what it shows.
    pub size: Option<(u16, u16)>,
    /// Help, note editing or judging.
    pub mode: Mode,
    /// The clock.
    pub clock: Clock,
    /// When the unit on screen was shown.
    pub(super) shown_at: Duration,
    /// Time spent earlier on each position in this sitting.
    pub(super) spent: HashMap<usize, Duration>,
    /// The status line.
    pub status: Option<(String, Severity)>,
    /// The scene image of the unit on screen.
    pub scene: Scene,
    /// The image encoded for an area of the screen.
    pub image: Option<Encoded>,
    /// The image file and area an encoding was last asked for, so that a
    /// frame drawn while it is under way does not ask again.
    pub(super) requested: Option<(PathBuf, Rect)>,
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
        // Replaying the lines in order gives what is current and, for each
        // line, what it replaced: what undo brings back.
        let mut current: HashMap<Subject, Verdict> = HashMap::new();
        let mut undo = Vec::new();
        for j in mine {
            let replaced = match &j.verdict {
                Some(v) => current.insert(j.subject.clone(), v.clone()),
                None => current.remove(&j.subject),
            };
            undo.push((j.subject.clone(), replaced));
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
            reference_step: 0,
            focus: Focus::Plan,
            scrolls: Scrolls::default(),
            size: None,
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
            requested: None,
            quit: false,
        };
        screen.skipped = (0..screen.units.len())
            .filter(|&p| {
                screen
                    .subject(p)
                    .is_some_and(|s| setup.skipped.contains(&s))
            })
            .collect();
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
    pub(super) fn next_unjudged_from(&self, from: usize) -> Option<usize> {
        let n = self.units.len();
        let ring = (0..n).map(|k| (from + k) % n);
        ring.clone()
            .find(|&p| !self.is_judged(p) && !self.skipped.contains(&p))
            .or_else(|| ring.into_iter().find(|&p| !self.is_judged(p)))
    }

    /// Shows the unit at `pos`: keeps the time spent on the one left, loads
    /// the draft from its current judgement, and reads its image if new.
    pub(super) fn go_to(&mut self, pos: usize) -> Vec<Cmd> {
        let here = self.clock.elapsed.saturating_sub(self.shown_at);
        *self.spent.entry(self.pos).or_default() += here;
        self.shown_at = self.clock.elapsed;
        self.pos = pos.min(self.units.len().saturating_sub(1));
        self.step = 0;
        self.reference_step = 0;
        self.scrolls = Scrolls {
            help: self.scrolls.help,
            ..Scrolls::default()
        };
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

    /// The key-table contexts of the screen as it is now, the first that
    /// binds a key winning: Ctrl-C always; in the help its scroll keys (any
    /// other key closes it); while writing a note, its keys (the rest are
    /// typed); the reference plan's key when it is shown.
    pub fn contexts(&self) -> Vec<Context> {
        let mut contexts = vec![Context::Always];
        match self.mode {
            Mode::Help => contexts.push(Context::AnnotateHelp),
            Mode::Note(_) => contexts.push(Context::AnnotateNote),
            Mode::Judging => {
                contexts.push(if self.pairwise {
                    Context::AnnotatePairwise
                } else {
                    Context::AnnotateRating
                });
                if self.show_gt {
                    contexts.push(Context::AnnotateReference);
                }
                contexts.push(Context::Annotate);
            }
        }
        contexts
    }
}
