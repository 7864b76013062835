//! The workbench driven through its update function with commands carried
//! out synchronously, and rendered on ratatui's TestBackend.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::common;

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers, MouseButton, MouseEvent, MouseEventKind};
use mapvlm::agents::pipeline::AgentEvent;
use mapvlm::agents::replay::Pace;
use mapvlm::agents::AgentRole;
use mapvlm::metrics::pg2s::{Pg2sScorer, Pg2sSettings};
use mapvlm::metrics::{ModelError, SentenceEncoder};
use mapvlm::workbench::agents::AgentsPipeline;
use mapvlm::workbench::app::{App, AppInit};
use mapvlm::workbench::graphics::Graphics;
use mapvlm::workbench::headless::Headless;
use mapvlm::workbench::keymap::{self, Action, Context, BINDINGS};
use mapvlm::workbench::message::{Cmd, Msg};
use mapvlm::workbench::panes::Pane;
use mapvlm::workbench::scoring::{ModelSlot, Pg2sOutcome};
use mapvlm::workbench::snapshot::SNAPSHOT_EVERY;
use mapvlm::workbench::theme::{load_themes, Theme};
use mapvlm::workbench::{prepare_image, render};
use ratatui::backend::TestBackend;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::Terminal;

/// A stand-in sentence encoder for tests: hashed bags of lowercase words,
/// L2-normalised, so that sentences sharing words have a high cosine.
struct BagOfWords;

impl SentenceEncoder for BagOfWords {
    fn encode(&self, sentences: &[&str]) -> Result<Vec<Vec<f32>>, ModelError> {
        Ok(sentences
            .iter()
            .map(|s| {
                let mut v = vec![0f32; 64];
                for w in s.to_lowercase().split(|c: char| !c.is_alphanumeric()) {
                    if w.is_empty() {
                        continue;
                    }
                    let h = w
                        .bytes()
                        .fold(7u32, |h, b| h.wrapping_mul(31).wrapping_add(u32::from(b)));
                    v[(h % 64) as usize] += 1.0;
                }
                let n = v.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-6);
                v.iter().map(|x| x / n).collect()
            })
            .collect())
    }
}

struct Harness {
    app: App,
    models: ModelSlot,
    pipeline: AgentsPipeline,
}

impl Harness {
    fn new(size: (u16, u16), theme: Option<&str>, no_color: bool, models: ModelSlot) -> Harness {
        let (app, cmds) = App::new(AppInit {
            theme: theme.map(str::to_string),
            no_color,
            ..AppInit::demo(size, "no models in this test")
        });
        let pipeline = AgentsPipeline::offline(Pace::Instant).unwrap();
        let mut h = Harness {
            app,
            models,
            pipeline,
        };
        h.run(cmds);
        h
    }

    /// The workbench at `size` on alfred30's tasks (its first open),
    /// scoring with `models`; and the dataset.
    fn on_alfred30(size: (u16, u16), models: ModelSlot) -> (Harness, mapvlm::dataset::Dataset) {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/alfred30");
        let (dataset, _) = mapvlm::dataset::Dataset::load(std::path::Path::new(root)).unwrap();
        let (app, cmds) = App::new(AppInit {
            dataset: Some(dataset.clone()),
            ..AppInit::demo(size, "no models in this test")
        });
        let mut h = Harness {
            app,
            models,
            pipeline: AgentsPipeline::offline(Pace::Instant).unwrap(),
        };
        h.run(cmds);
        (h, dataset)
    }

    /// Carries out `cmds` with timings fixed, so that frames compare.
    fn run(&mut self, cmds: Vec<Cmd>) {
        let runner = Headless::new(&self.pipeline, self.models.clone());
        runner.run(&mut self.app, cmds, &mut |msg| match msg {
            Msg::Agent(_, AgentEvent::Finished { elapsed_ms, .. }) => *elapsed_ms = 100,
            Msg::Scored(outcome) => outcome.millis = 0.0,
            _ => {}
        });
    }

    fn key(&mut self, code: KeyCode) {
        let cmds = self
            .app
            .update(Msg::Key(KeyEvent::new(code, KeyModifiers::NONE)));
        self.run(cmds);
    }

    fn keys(&mut self, text: &str) {
        for c in text.chars() {
            self.key(KeyCode::Char(c));
        }
    }

    fn terminal(&mut self) -> Terminal<TestBackend> {
        let (w, h) = self.app.size;
        prepare_image(&mut self.app, &Graphics::halfblocks());
        let mut terminal = Terminal::new(TestBackend::new(w, h)).unwrap();
        terminal.draw(|f| render::render(f, &self.app)).unwrap();
        terminal
    }

    fn screen(&mut self) -> String {
        self.terminal().backend().to_string()
    }
}

fn unavailable() -> ModelSlot {
    ModelSlot::Unavailable("the sentence encoder is not in this test".into())
}

/// The real models of the pack, as `mapvlm score` loads them.
fn real_models() -> ModelSlot {
    use mapvlm::metrics::pg2s::GoalModels;
    use mapvlm::models::{models_dir, EN_CORE_WEB_SM, GLOVE_6B_50D, MPNET};
    let dir = models_dir(None);
    let encoder = mapvlm::nlp::mpnet::MpnetEncoder::load(&dir.join(MPNET)).unwrap();
    let vectors =
        mapvlm::nlp::wordvec::WordVectorTable::load_glove_pack(&dir.join(GLOVE_6B_50D)).unwrap();
    let parser = mapvlm::nlp::en::EnPipeline::load(&dir.join(EN_CORE_WEB_SM)).unwrap();
    let goal = GoalModels {
        vectors: Arc::new(vectors),
        parser: Arc::new(parser),
    };
    ModelSlot::Ready(Arc::new(Pg2sScorer::new(
        Arc::new(encoder),
        Some(goal),
        Pg2sSettings::default(),
    )))
}

fn bag_of_words() -> ModelSlot {
    ModelSlot::Ready(Arc::new(Pg2sScorer::new(
        Arc::new(BagOfWords),
        None,
        Pg2sSettings::default(),
    )))
}

#[test]
fn demo_fills_every_pane_at_200x60() {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    let screen = h.screen();
    for pane in Pane::ALL {
        assert!(screen.contains(pane.title()), "missing {}", pane.title());
    }
    assert!(screen.contains("KAS 0.720"), "{screen}");
    assert!(screen.contains("PG2S is waiting for models"));
    assert!(screen.contains("[robot]"), "{screen}");
    insta::assert_snapshot!("demo_200x60", screen);
}

#[test]
fn demo_at_120x40() {
    let mut h = Harness::new((120, 40), None, false, unavailable());
    insta::assert_snapshot!("demo_120x40", h.screen());
}

#[test]
fn narrow_terminal_shows_one_pane_with_tabs() {
    let mut h = Harness::new((80, 24), None, false, unavailable());
    let screen = h.screen();
    assert!(
        screen.contains(" Plan run 1 ") && screen.contains(" Graph │ GKM │"),
        "{screen}"
    );
    insta::assert_snapshot!("narrow_80x24", screen);
}

#[test]
fn too_small_terminal_gets_a_message() {
    let mut h = Harness::new((40, 10), None, false, unavailable());
    let screen = h.screen();
    assert!(screen.contains("at least"), "{screen}");
    insta::assert_snapshot!("too_small_40x10", screen);
}

/// The screen's text with every run of blanks and frame lines made one
/// blank, so that wrapped text reads as one line.
fn collapsed(screen: &str, columns: std::ops::Range<usize>) -> String {
    let rows: Vec<String> = screen
        .lines()
        .map(|l| {
            let cells: Vec<char> = l.trim_matches('"').chars().collect();
            cells[columns.start.min(cells.len())..columns.end.min(cells.len())]
                .iter()
                .collect()
        })
        .collect();
    rows.join(" ")
        .replace(['│', '┃'], " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn long_steps_wrap_whole_in_their_pane_and_a_click_selects_the_step_drawn_there() {
    use mapvlm::workbench::layout::{pane_rects, Screen};
    let mut h = Harness::new((120, 40), None, false, unavailable());
    let long = "Walk over to the kitchen counter beside the sink, pick up the blue mug \
                with the chipped handle and carry it carefully to the coffee machine \
                without spilling the water that is still inside it";
    h.app.panes.plan.items[1] = long.to_string();
    let screen = h.screen();
    let Screen::Panes { panes, .. } = pane_rects(Rect::new(0, 0, 120, 40), h.app.focus, false)
    else {
        panic!("no panes at 120x40")
    };
    let plan = panes.iter().find(|(p, _)| *p == Pane::Plan).unwrap().1;
    let columns = usize::from(plan.x)..usize::from(plan.x + plan.width);
    let rows: Vec<&str> = screen.lines().collect();
    let pane_text = collapsed(
        &rows[usize::from(plan.y)..usize::from(plan.y + plan.height)].join("\n"),
        columns,
    );
    let long_words = long.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        pane_text.contains(&format!("2. {long_words}")),
        "{pane_text}"
    );
    // The ground truth's marks say which plan step KAS compared.
    assert!(screen.contains("vs plan 1"), "{screen}");
    // A click on the last line of the wrapped step selects it; one on the
    // step after it selects that one.
    // The row where the Plan pane shows `needle` (the Ground Truth beside
    // it has steps of the same words).
    let row_of = |needle: &str| {
        rows.iter()
            .position(|r| {
                let cells: String = r.chars().skip(usize::from(plan.x) + 1).collect();
                cells
                    .chars()
                    .take(usize::from(plan.width))
                    .collect::<String>()
                    .contains(needle)
            })
            .unwrap_or_else(|| panic!("{needle} not in the Plan pane"))
    };
    let click = |h: &mut Harness, row: usize| {
        h.app.update(Msg::Mouse(MouseEvent {
            kind: MouseEventKind::Down(MouseButton::Left),
            column: plan.x + 5,
            row: row as u16,
            modifiers: KeyModifiers::NONE,
        }));
    };
    click(&mut h, row_of("without spilling"));
    assert_eq!(h.app.panes.plan.selected, 1);
    let third = format!(" 3. {}", h.app.panes.plan.items[2]);
    let third_row = row_of(&third[..third.len().min(20)]);
    click(&mut h, third_row);
    assert_eq!(h.app.panes.plan.selected, 2);
}

#[test]
fn the_prompt_pane_scrolls_to_its_last_line_and_says_what_is_out_of_sight() {
    let mut h = Harness::new((80, 24), None, false, unavailable());
    for _ in 0..10 {
        if h.app.focus == Pane::Prompt {
            break;
        }
        h.key(KeyCode::Tab);
    }
    assert_eq!(h.app.focus, Pane::Prompt);
    h.keys("3");
    let prompt = h.app.panes.prompt.editor.lines().join("\n");
    let last = prompt
        .lines()
        .rev()
        .find(|l| l.split_whitespace().count() >= 2)
        .unwrap()
        .to_string();
    let tail: String = last
        .split_whitespace()
        .take(2)
        .collect::<Vec<_>>()
        .join(" ");
    let first = h.screen();
    assert!(first.contains("↓") && first.contains("more"), "{first}");
    assert!(
        !collapsed(&first, 0..80).contains(&tail),
        "{tail} is in view at once"
    );
    for _ in 0..60 {
        h.key(KeyCode::PageDown);
    }
    let end = h.screen();
    assert!(
        collapsed(&end, 0..80).contains(&tail),
        "{tail} never in view:\n{end}"
    );
    assert!(end.contains("↑") && end.contains("more"), "{end}");
    // The way back is as long as the text, not as the presses.
    h.key(KeyCode::PageUp);
    assert_ne!(h.screen(), end, "PgUp after the end moved nothing");
}

#[test]
fn a_status_message_longer_than_the_hints_leave_room_for_shows_whole_or_marked_cut() {
    let mut h = Harness::new((120, 40), None, false, unavailable());
    let message =
        "SKM has no provider: press m to set SKM's provider and model (e.g. openai, gpt-4o)";
    h.app.messages.status = Some((
        message.to_string(),
        mapvlm::workbench::shared::Severity::Warn,
    ));
    let status = h.screen().lines().last().unwrap().to_string();
    assert!(status.contains(message), "{status}");
    assert!(status.contains("? keys"), "{status}");
    let mut narrow = Harness::new((60, 24), None, false, unavailable());
    narrow.app.messages.status = Some((
        message.to_string(),
        mapvlm::workbench::shared::Severity::Warn,
    ));
    // Too long for one row at 60 columns: it wraps onto a second, whole,
    // the panes giving up a row for it.
    let screen = narrow.screen();
    let rows: Vec<&str> = screen.lines().collect();
    let status = rows[rows.len() - 2..]
        .iter()
        .map(|r| r.trim_matches('"'))
        .collect::<Vec<_>>()
        .join(" ");
    let words = |text: &str| text.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(words(&status).contains(message), "{screen}");
    assert!(
        rows[rows.len() - 3].contains('┛') || rows[rows.len() - 3].contains('┘'),
        "{screen}"
    );
    // Longer than two rows: cut on the second, saying where it is whole.
    let long = format!("{message}; {message}; {message}");
    narrow.app.messages.status = Some((long, mapvlm::workbench::shared::Severity::Warn));
    let screen = narrow.screen();
    let last = screen.lines().last().unwrap();
    assert!(last.contains("· M log"), "{screen}");
    // A short one takes one row again.
    narrow.app.messages.status = Some((
        "run 2 finished".to_string(),
        mapvlm::workbench::shared::Severity::Info,
    ));
    let screen = narrow.screen();
    let rows: Vec<&str> = screen.lines().collect();
    assert!(rows[rows.len() - 1].contains("run 2 finished"), "{screen}");
    assert!(
        rows[rows.len() - 2].contains('┛') || rows[rows.len() - 2].contains('┘'),
        "{screen}"
    );
}

#[test]
fn a_locale_without_utf8_gets_every_frame_in_ascii() {
    let mut h = Harness::new((120, 40), None, false, unavailable());
    let unicode = h.screen();
    assert!(unicode.contains('│') && unicode.contains('─'), "{unicode}");
    h.app.looks.ascii = true;
    for keys in ["", "?", "\u{1b}g"] {
        h.keys(keys);
        let screen = h.screen();
        let odd: String = screen.chars().filter(|c| !c.is_ascii()).collect();
        assert!(odd.is_empty(), "after {keys:?}: {odd:?} in {screen}");
    }
    let screen = h.screen();
    // The same frame, line for line, with its lines drawn in ASCII.
    assert!(screen.contains("+-") && screen.contains('|'), "{screen}");
    assert_eq!(screen.lines().count(), unicode.lines().count());
}

#[test]
fn a_tiny_window_shows_both_sizes_and_keys_do_nothing_unseen() {
    for size in [(10, 5), (20, 3), (49, 13), (6, 2)] {
        let mut h = Harness::new(size, None, false, unavailable());
        let screen: String = h.screen().split_whitespace().collect();
        let (w, rows) = size;
        let wanted = if rows >= 3 {
            vec!["50×14".to_string(), format!("{w}×{rows}")]
        } else {
            vec!["50×14".to_string()]
        };
        for sizes in wanted {
            assert!(screen.contains(&sizes), "{size:?}: {sizes} in {screen}");
        }
    }
    let mut h = Harness::new((10, 5), None, false, unavailable());
    let plan = h.app.panes.plan.items.clone();
    // d deletes a step and Tab moves the focus on a screen that shows them.
    h.keys("d");
    h.key(KeyCode::Tab);
    assert_eq!(h.app.panes.plan.items, plan);
    assert_eq!(h.app.focus, Pane::Plan);
    assert!(!h.app.quit);
    h.keys("q");
    assert!(h.app.quit, "q quits, as the message says");
}

/// The help pages of `h` from the top, scrolled with PgDn until nothing
/// is below: every page's screen.
fn help_pages(h: &mut Harness) -> Vec<String> {
    h.key(KeyCode::Char('?'));
    // PgDn until a page repeats: the end (the panes behind the help have
    // markers of their own, so the help's "↓ N more" is not looked for).
    let mut pages = vec![h.screen()];
    loop {
        assert!(pages.len() < 20, "the help does not end");
        h.key(KeyCode::PageDown);
        let page = h.screen();
        if pages.last() == Some(&page) {
            return pages;
        }
        pages.push(page);
    }
}

/// Every binding of the workbench's key table is in the help under the
/// title of its context, its keys then the start of what it does, and
/// every word of that whole: at 120×40, at 80×24 (scrolled there) and at
/// 200×60. A key the help does not bind closes it.
#[test]
fn help_lists_every_key() {
    for size in [(120, 40), (80, 24), (200, 60)] {
        let mut h = Harness::new(size, None, false, unavailable());
        let pages = help_pages(&mut h);
        if size == (120, 40) {
            insta::assert_snapshot!("help_120x40", pages[0]);
        } else if size == (80, 24) {
            assert!(pages.len() > 1, "80×24 needs scrolling");
            assert!(pages[1].contains("↑ "), "{}", pages[1]);
        }
        // Each line with its runs of blanks made one: the keys column and
        // the text beside it read as "keys text".
        let lines: Vec<String> = pages
            .iter()
            .flat_map(|p| p.lines())
            .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
            .collect();
        let all = lines.join("\n");
        for section in keymap::help_sections(&keymap::workbench_contexts()) {
            let title = section.context.title();
            assert!(all.contains(title), "{title} not in the help at {size:?}");
            for binding in section.rows {
                let label = binding.label();
                let first = binding.help.split_whitespace().next().unwrap_or_default();
                assert!(
                    lines
                        .iter()
                        .any(|l| l.contains(&format!("{label} {first}"))),
                    "{label} then {first} not in the help at {size:?}"
                );
                // Each word of the description is on some page: nothing cut.
                for word in binding.help.split_whitespace() {
                    assert!(all.contains(word), "{word} of {label} cut at {size:?}");
                }
            }
        }
        h.key(KeyCode::Char('x'));
        assert!(!h.screen().contains("Keys ("), "x closes the help");
    }
}

/// `/` in the help filters it by the words typed: only the rows found with
/// them stay, under their section's title; Enter keeps the filter to
/// scroll it, Esc drops it.
#[test]
fn the_help_filters_by_words_typed_in_it() {
    let mut h = Harness::new((120, 40), None, false, unavailable());
    h.key(KeyCode::Char('?'));
    let whole = h.screen();
    assert!(whole.contains("Any pane"), "{whole}");
    h.keys("/diff");
    assert_eq!(h.app.key_context(), Context::HelpFilter);
    let found = h.screen();
    assert!(found.contains("Keys with: diff"), "{found}");
    assert!(
        found.contains("Run history") && found.contains("d c"),
        "{found}"
    );
    assert!(found.contains("diff the marked run"), "{found}");
    assert!(!found.contains("the session is saved"), "{found}");
    h.key(KeyCode::Enter);
    assert_eq!(h.app.key_context(), Context::Help);
    let kept = h.screen();
    assert!(kept.contains("Keys with \"diff\""), "{kept}");
    assert!(!kept.contains("the session is saved"), "{kept}");
    h.key(KeyCode::Char('/'));
    h.keys("qqqq");
    assert!(
        h.screen().contains("no key is found"),
        "q is typed, not quit"
    );
    h.key(KeyCode::Esc);
    assert_eq!(h.app.key_context(), Context::Help);
    assert!(
        h.screen().contains("the session is saved"),
        "Esc drops the filter"
    );
    h.key(KeyCode::Esc);
    assert!(!h.app.quit);
    assert!(!h.screen().contains("Keys ("), "Esc closes the help");
}

#[test]
fn each_theme_and_no_color() {
    let (themes, _) = load_themes(None);
    for theme in themes
        .iter()
        .map(|t| t.name.clone())
        .chain(["no-color".to_string()])
    {
        let no_color = theme == "no-color";
        let mut h = Harness::new((100, 30), Some(&theme), no_color, unavailable());
        assert_eq!(h.app.looks.theme.name, theme);
        let terminal = h.terminal();
        insta::assert_debug_snapshot!(format!("theme_{theme}"), terminal.backend().buffer());
    }
    assert_eq!(Theme::no_color().name, "no-color");
}

#[test]
fn plan_steps_show_their_matches_and_cosines() {
    let mut h = Harness::new((200, 60), None, false, bag_of_words());
    let screen = h.screen();
    assert!(screen.contains("✓ GT 1 · cos"), "{screen}");
    assert!(screen.contains("S_goal unavailable: no framing parser or word vectors loaded"));
    insta::assert_snapshot!("plan_with_matches", screen);
}

#[test]
fn another_ground_truth_and_an_edited_step_change_the_scores() {
    let mut h = Harness::new((200, 60), None, false, bag_of_words());
    let kas_of = |h: &Harness| h.app.work.scores.as_ref().and_then(|s| s.kas.kas);
    let before = kas_of(&h);
    h.key(KeyCode::Char('g'));
    h.key(KeyCode::Down);
    h.key(KeyCode::Enter);
    assert_eq!(h.app.panes.ground_truth.items[1], "Pick up the blue mug.");
    let with_b = kas_of(&h);
    assert_ne!(before, with_b);
    // edit plan step 1 in the Plan pane (focused at start)
    h.key(KeyCode::Enter);
    h.keys(" Then wave");
    h.key(KeyCode::Enter);
    assert!(
        h.app.panes.plan.items[0].ends_with("Then wave"),
        "{:?}",
        h.app.panes.plan.items[0]
    );
    assert_ne!(kas_of(&h), with_b);
    let session = h.app.to_session();
    assert_eq!(session.current.plan[0], h.app.panes.plan.items[0]);
}

/// The session is copied for the saver at most every `SNAPSHOT_EVERY` while
/// a step is typed, not once a keystroke (the copy is the costly part of a
/// save), and at once when the edit is committed.
#[test]
fn typing_copies_the_session_at_most_every_period_and_a_commit_at_once() {
    let mut h = Harness::new((120, 40), None, false, unavailable());
    let start = Instant::now();
    let (after_run, _) = h.app.poll_snapshot(start);
    assert!(after_run.is_some(), "the demo's run changed the session");
    let before = h.app.saving.persist.taken();
    h.key(KeyCode::Enter);
    let mut clock = start;
    let mut last_copy = None;
    for i in 0..200 {
        h.key(KeyCode::Char(if i % 2 == 0 { 'a' } else { 'b' }));
        clock += Duration::from_millis(10);
        if let (Some(copy), _) = h.app.poll_snapshot(clock) {
            last_copy = Some(copy);
        }
    }
    let while_typing = h.app.saving.persist.taken() - before;
    let periods = (clock - start).as_millis() / SNAPSHOT_EVERY.as_millis();
    assert!(
        (1..=periods as u64 + 1).contains(&while_typing),
        "200 keystrokes over {} ms took {while_typing} copies",
        (clock - start).as_millis()
    );
    let draft = last_copy.and_then(|s| s.draft).map(|d| d.text);
    assert!(
        draft.as_deref().is_some_and(|d| d.ends_with("abab")),
        "{draft:?}"
    );
    h.key(KeyCode::Enter);
    let (committed, _) = h.app.poll_snapshot(clock + Duration::from_millis(1));
    assert_eq!(h.app.saving.persist.taken(), before + while_typing + 1);
    let plan = committed.map(|s| s.current.plan).unwrap_or_default();
    assert!(
        plan.first().is_some_and(|s| s.ends_with("abab")),
        "{plan:?}"
    );
}

#[test]
fn a_prompt_edit_reruns_only_what_it_affects_and_the_demo_asks_for_a_provider() {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    assert!(h.app.agents_to_run(false).is_empty());
    while h.app.focus != Pane::Prompt {
        h.key(KeyCode::Tab);
    }
    h.key(KeyCode::Char('2'));
    h.key(KeyCode::Enter);
    h.keys(" Be brief.");
    h.key(KeyCode::Esc);
    assert_eq!(
        h.app.agents_to_run(false),
        [AgentRole::Gkm, AgentRole::Planner]
    );
    let screen = h.screen();
    assert!(screen.contains("GKM needs a provider"), "{screen}");
    let prompt = h.app.to_session().prompts["multi-image-gkm"].clone();
    assert!(prompt.ends_with("Be brief."), "{prompt}");
}

#[test]
fn the_knowledge_graph_is_navigable() {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    while h.app.focus != Pane::Graph {
        h.key(KeyCode::Tab);
    }
    h.key(KeyCode::Char('v'));
    assert!(h.screen().contains("counter ─right of─▶"));
    let start = h.app.panes.graph.cursor.node;
    h.key(KeyCode::Enter);
    let next = h.app.panes.graph.cursor.node;
    assert_ne!(start, next);
    assert_eq!(h.app.panes.graph.kg.nodes[next], "counter");
    h.key(KeyCode::Backspace);
    assert_eq!(h.app.panes.graph.cursor.node, start);
}

#[test]
fn scores_of_a_finished_run_are_kept_in_its_record() {
    let h = Harness::new((200, 60), None, false, unavailable());
    assert_eq!(h.app.runs.history.len(), 1);
    let scores = h.app.runs.history[0].scores.expect("scored");
    assert!((scores.kas.unwrap() - 0.72).abs() < 0.01);
    assert!(matches!(
        h.app.work.scores.as_ref().map(|s| &s.pg2s),
        Some(Pg2sOutcome::Waiting(_))
    ));
    // Each step's KAS is kept beside the run's, as the Plan pane shows it;
    // PG2S matched nothing here (its models are unavailable).
    let run = &h.app.runs.history[0];
    let kas_steps = &h.app.work.scores.as_ref().expect("scored").kas.step_scores;
    assert_eq!(run.steps.len(), run.plan.len());
    for (i, step) in run.steps.iter().enumerate() {
        assert_eq!(step.kas, kas_steps.get(i).copied(), "step {i}");
        assert_eq!(step.matched, None, "step {i}");
    }
    assert_eq!(run.sample_scores(), vec![scores]);
}

#[test]
fn each_step_of_a_scored_run_keeps_its_pg2s_match() {
    let h = Harness::new((120, 40), None, false, bag_of_words());
    let run = &h.app.runs.history[0];
    let Some(Pg2sOutcome::Ready(report)) = h.app.work.scores.as_ref().map(|s| &s.pg2s) else {
        panic!("PG2S was scored");
    };
    let matched: Vec<(usize, usize)> = report
        .sentence_matches
        .iter()
        .filter_map(|m| m.pred.map(|p| (p, m.gt)))
        .collect();
    assert!(!matched.is_empty());
    for (pred, gt) in matched {
        assert_eq!(
            run.steps[pred].matched.map(|m| m.0),
            Some(gt),
            "step {pred}"
        );
    }
}

#[test]
fn published_plans_score_as_in_mapvlm_score() {
    let (mut h, dataset) = Harness::on_alfred30((200, 60), real_models());
    let dir = tempfile::tempdir().unwrap();
    for index in [0usize, 7, 21] {
        if index > 0 {
            h.key(KeyCode::Char('g'));
            for _ in 0..dataset.tasks.len() {
                h.key(KeyCode::Up);
            }
            for _ in 0..index {
                h.key(KeyCode::Down);
            }
            h.key(KeyCode::Enter);
        }
        let task = &dataset.tasks[index];
        assert_eq!(h.app.work.task.id.as_deref(), Some(task.id.as_str()));
        let plan = &task.plans["multi_agent_image"];
        assert_eq!(&h.app.panes.plan.items, plan);
        let gt_file = dir.path().join("gt.txt");
        let pred_file = dir.path().join("pred.txt");
        std::fs::write(&gt_file, task.ground_truth.join("\n")).unwrap();
        std::fs::write(&pred_file, plan.join("\n")).unwrap();
        let out = common::mapvlm_command()
            .args(["score", "--json", "--gt"])
            .arg(&gt_file)
            .arg("--pred")
            .arg(&pred_file)
            .output()
            .unwrap();
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let scores = h.app.work.scores.clone().unwrap();
        let shown = scores.kas.kas;
        assert_eq!(json["kas"].as_f64(), shown, "task {}", task.id);
        let Pg2sOutcome::Ready(report) = &scores.pg2s else {
            panic!("PG2S not scored for task {}", task.id);
        };
        assert_eq!(json["pg2s"].as_f64(), report.pg2s(), "task {}", task.id);
        assert_eq!(
            json["s_plan"].as_f64(),
            Some(report.s_plan),
            "task {}",
            task.id
        );
        assert_eq!(json["s_goal"].as_f64(), report.s_goal(), "task {}", task.id);
        let screen = h.screen();
        let kas = shown.map_or("  –  ".to_string(), |k| format!("KAS {k:.3}"));
        let pg2s = format!("PG2S {:.3}", report.pg2s().unwrap());
        for expected in [kas, pg2s] {
            assert!(
                screen.contains(&expected),
                "{expected} not on screen:\n{screen}"
            );
        }
    }
}

#[test]
fn a_start_notice_stays_until_dismissed() {
    let moved_to = "/tmp/state/session.json.corrupt-1764547200";
    let (app, cmds) = App::new(AppInit {
        notice: Some((
            format!("the session file could not be read; it was moved to {moved_to}"),
            mapvlm::workbench::shared::Severity::Warn,
        )),
        ..AppInit::demo((200, 60), "none")
    });
    let mut h = Harness {
        app,
        models: unavailable(),
        pipeline: AgentsPipeline::offline(Pace::Instant).unwrap(),
    };
    h.run(cmds);
    h.keys("jjt");
    let screen = h.screen();
    assert!(screen.contains("run 1 finished") || screen.contains("theme:"));
    assert!(screen.contains(moved_to), "{screen}");
    h.key(KeyCode::Esc);
    assert!(!h.screen().contains(moved_to));
}

impl Harness {
    fn focus(&mut self, pane: Pane) {
        for _ in 0..Pane::ALL.len() {
            if self.app.focus == pane {
                return;
            }
            self.key(KeyCode::Tab);
        }
        panic!("{pane:?} cannot be focused");
    }

    /// Presses `key` and tells whether anything happened: the screen (its
    /// text or its colours) changed, commands were asked for, or the app quits.
    fn press_changes(&mut self, key: KeyEvent) -> bool {
        let before = self.terminal().backend().buffer().clone();
        self.press_changes_from(&before, key)
    }

    /// [`Harness::press_changes`] against `before`, the screen as it was
    /// drawn before the key: a loop over keys that must change nothing draws
    /// it once, not once a key.
    fn press_changes_from(&mut self, before: &Buffer, key: KeyEvent) -> bool {
        let cmds = self.app.update(Msg::Key(key));
        let asked = !cmds.is_empty();
        self.run(cmds);
        asked || self.app.quit || self.terminal().backend().buffer() != before
    }
}

/// Presses each key in `keys` that the key table does not bind in
/// `contexts` and fails on the first that does something; the screen before
/// is drawn once, since a key that changes nothing leaves it as it was.
fn assert_unbound_keys_do_nothing(h: &mut Harness, contexts: &[Context], what: &str) {
    let before = h.terminal().backend().buffer().clone();
    for key in mapvlm::workbench::keymap::pressable_keys() {
        if keymap::action(contexts, &key).is_some() {
            continue;
        }
        assert!(
            !h.press_changes_from(&before, key),
            "{key:?} does something in {what} but is not in the key table"
        );
    }
}

#[test]
fn a_key_missing_from_the_key_table_does_nothing_in_any_pane() {
    for pane in Pane::ALL {
        let mut h = Harness::new((200, 60), None, false, unavailable());
        h.focus(pane);
        let contexts: Vec<Context> = [Context::Always]
            .into_iter()
            .chain(h.app.pane_contexts())
            .collect();
        assert_unbound_keys_do_nothing(&mut h, &contexts, &format!("{pane:?}"));
    }
}

/// Starts in a state where `context`'s bindings apply. `warm` also moves
/// the selection and sets a search, so that "back", "up" and "next hit"
/// have somewhere to go.
fn state_for(context: Context, action: Action, warm: bool) -> Harness {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    let pane = match context {
        Context::Graph | Context::WholeGraph => Pane::Graph,
        Context::Prompt | Context::PromptEditor => Pane::Prompt,
        Context::Panes if matches!(action, Action::NextPane | Action::PreviousPane) => Pane::Scene,
        _ => Pane::Plan,
    };
    h.focus(pane);
    if context == Context::Graph {
        h.key(KeyCode::Char('v'));
    }
    open_overlay(&mut h, context, warm);
    if warm {
        match context {
            // Zoomed in, so that `-` has a level to go back to.
            Context::WholeGraph => h.keys("]]+"),
            Context::Graph => {
                h.key(KeyCode::Down);
                h.key(KeyCode::Enter);
            }
            Context::Prompt => h.key(KeyCode::Right),
            Context::Search | Context::Help | Context::HelpFilter | Context::Viewer => {}
            _ => {
                h.keys("/the");
                h.key(KeyCode::Enter);
                h.key(KeyCode::Down);
                h.key(KeyCode::Down);
            }
        }
    }
    match context {
        Context::StepEditor | Context::PromptEditor => h.key(KeyCode::Enter),
        Context::Search if warm => h.keys("/the"),
        Context::Search => h.key(KeyCode::Char('/')),
        _ => {}
    }
    h
}

/// Opens the overlay whose keys `context` holds (nothing for the others);
/// `warm` moves its selection off the end first.
fn open_overlay(h: &mut Harness, context: Context, warm: bool) {
    match context {
        Context::Picker => h.key(KeyCode::Char('g')),
        Context::History => {
            h.keys("RH");
            if warm {
                h.key(KeyCode::Up);
            }
        }
        Context::PathPrompt => {
            h.key(KeyCode::Char('g'));
            h.keys("jj");
            h.key(KeyCode::Enter);
        }
        Context::RunDiff => {
            // At 80×24 the diff of two runs is longer than the screen.
            let cmds = h.app.update(Msg::Resize(80, 24));
            h.run(cmds);
            h.keys("RHd");
            if warm {
                h.key(KeyCode::End);
            }
        }
        Context::ModelForm => h.key(KeyCode::Char('m')),
        Context::SetName => {
            while h.app.focus != Pane::Prompt {
                h.key(KeyCode::Tab);
            }
            h.key(KeyCode::Char('S'));
        }
        Context::Viewer => {
            // At 80×24, thirty messages are more than the log shows.
            let cmds = h.app.update(Msg::Resize(80, 24));
            h.run(cmds);
            h.keys(&"t".repeat(30));
            h.key(KeyCode::Char('M'));
            if warm {
                h.key(KeyCode::Home);
            }
        }
        Context::Help | Context::HelpFilter => {
            // At 80×24 the help is longer than the screen.
            let cmds = h.app.update(Msg::Resize(80, 24));
            h.run(cmds);
            h.key(KeyCode::Char('?'));
            if warm {
                h.key(KeyCode::End);
            }
            if context == Context::HelpFilter {
                h.keys(if warm { "/o" } else { "/" });
            }
        }
        _ => return,
    }
    if warm && context == Context::Picker {
        h.key(KeyCode::Down);
    }
    assert_eq!(
        h.app.key_context(),
        context,
        "the overlay of {context:?} is open"
    );
}

const OVERLAYS: [Context; 8] = [
    Context::Picker,
    Context::History,
    Context::PathPrompt,
    Context::ModelForm,
    Context::SetName,
    Context::Viewer,
    Context::RunDiff,
    Context::Help,
];

#[test]
fn a_key_missing_from_the_key_table_does_nothing_in_an_overlay() {
    // The path prompt, the model form and the set name type every other key.
    for context in [
        Context::Picker,
        Context::History,
        Context::Viewer,
        Context::RunDiff,
    ] {
        let mut h = Harness::new((200, 60), None, false, unavailable());
        open_overlay(&mut h, context, false);
        assert_unbound_keys_do_nothing(
            &mut h,
            &[Context::Always, context],
            &format!("{context:?}"),
        );
    }
}

#[test]
fn an_overlay_shows_all_its_keys_in_the_status_bar() {
    for context in OVERLAYS {
        let mut h = Harness::new((200, 60), None, false, unavailable());
        open_overlay(&mut h, context, false);
        let screen = h.screen();
        let status = screen.lines().last().unwrap_or_default();
        for hint in keymap::hints_of(&[context]) {
            assert!(
                status.contains(&hint),
                "{hint} not in the status bar of {context:?}: {status}"
            );
        }
        // Every row of the overlay is among them by its first key.
        for binding in BINDINGS.iter().filter(|b| b.context == context) {
            let (Some(word), Some(key)) = (binding.hint, binding.keys().first()) else {
                panic!("{} of {context:?} has no hint", binding.label());
            };
            assert!(status.contains(word) && status.contains(&key.to_string()));
        }
    }
}

/// The contexts a key is looked up in with `h` as it is, the first that
/// binds it winning: Ctrl-C's, then the open editor's, else the open
/// overlay's, else the focused pane's (as `App::on_key` hands keys on).
fn lookup_contexts(h: &Harness) -> Vec<Context> {
    let inner = if h.app.is_editing() || h.app.overlay.is_some() {
        vec![h.app.key_context()]
    } else {
        h.app.pane_contexts()
    };
    [Context::Always].into_iter().chain(inner).collect()
}

#[test]
fn every_key_in_the_key_table_is_handled() {
    // The annotation screen's keys are checked on that screen
    // (`workbench::annotate::key_table`).
    for binding in BINDINGS.iter().filter(|b| !b.context.is_annotate()) {
        for &key in binding.keys() {
            let handled = [false, true].into_iter().any(|warm| {
                let mut h = state_for(binding.context, binding.action, warm);
                let contexts = match binding.context {
                    Context::Always => vec![Context::Always],
                    _ => lookup_contexts(&h),
                };
                keymap::action(&contexts, &key.event()) == Some(binding.action)
                    && h.press_changes(key.event())
            });
            assert!(
                handled,
                "{key} ({} in {:?}) is in the key table but does nothing",
                binding.label(),
                binding.context
            );
        }
    }
}

/// No key of the workbench hides another unless its row says it means to:
/// in every pane (the graph in both its views), editor and overlay, the
/// contexts looked up together bind a key twice only where the winning
/// row is marked as an override, and every row so marked overrides a key
/// somewhere.
#[test]
fn no_key_is_hidden_by_another_unless_marked() {
    let mut states: Vec<Harness> = Vec::new();
    for pane in Pane::ALL {
        let mut h = Harness::new((200, 60), None, false, unavailable());
        h.focus(pane);
        if pane == Pane::Graph {
            let mut other = Harness::new((200, 60), None, false, unavailable());
            other.focus(pane);
            other.key(KeyCode::Char('v'));
            states.push(other);
        }
        states.push(h);
    }
    for context in [
        Context::StepEditor,
        Context::PromptEditor,
        Context::Search,
        Context::HelpFilter,
    ]
    .into_iter()
    .chain(OVERLAYS)
    {
        states.push(state_for(context, Action::Help, false));
    }
    let mut looked_up: Vec<Vec<Context>> = states.iter().map(lookup_contexts).collect();
    looked_up.dedup();
    let mut overriding = Vec::new();
    for contexts in &looked_up {
        for clash in keymap::clashes(contexts) {
            assert!(
                clash.wins.overrides,
                "{} of {:?} hides {:?} in {contexts:?}: mark the row as an override or bind another key",
                clash.key, clash.wins.context, clash.hidden.context
            );
            overriding.push(clash.wins.label());
        }
    }
    for binding in BINDINGS.iter().filter(|b| b.overrides) {
        assert!(
            overriding.contains(&binding.label()),
            "{} of {:?} is marked as an override but hides no key",
            binding.label(),
            binding.context
        );
    }
    // Every context of the workbench was reached.
    for context in keymap::workbench_contexts() {
        assert!(
            looked_up.iter().any(|c| c.contains(&context)),
            "{context:?} never looked up"
        );
    }
}

#[test]
fn the_whole_graph_is_the_default_and_the_neighbourhood_a_mode() {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    h.focus(Pane::Graph);
    let whole = h.screen();
    assert!(!whole.contains("node 1/13"), "{whole}");
    let first = h.app.panes.graph.view.selected();
    let drawn = h.terminal().backend().buffer().clone();
    h.key(KeyCode::Char(']'));
    assert_ne!(h.app.panes.graph.view.selected(), first);
    assert_ne!(
        h.terminal().backend().buffer(),
        &drawn,
        "the selection moved"
    );
    h.key(KeyCode::Char('v'));
    assert!(h.screen().contains("node 1/13"));
    h.key(KeyCode::Char('v'));
    assert!(!h.screen().contains("node 1/13"));
}

/// Thirty triples of a kitchen (33 objects, no name inside another's
/// brackets): more than a pane of a normal terminal shows at once.
const KITCHEN: &str = "(robot, faces, kitchen table)
(kitchen table, left of, fridge)
(fridge, next to, pantry door)
(stove, right of, sink)
(sink, under, window)
(tap, above, sink)
(kettle, on, stove)
(frying pan, on, stove)
(blue mug, on, counter)
(red mug, on, kitchen table)
(counter, under, window)
(coffee machine, on, counter)
(spout, part of, coffee machine)
(drip tray, part of, coffee machine)
(toaster, next to, coffee machine)
(bread box, left of, toaster)
(cutting board, on, counter)
(knife, on, cutting board)
(fruit bowl, on, kitchen table)
(apple, in, fruit bowl)
(banana, in, fruit bowl)
(chair, in front of, kitchen table)
(second chair, behind, kitchen table)
(dish rack, right of, sink)
(plate, in, dish rack)
(dish towel, hangs on, oven door)
(oven door, part of, stove)
(trash can, under, sink)
(spice rack, above, stove)
(plant, on, window sill)";

/// The inside of the Knowledge Graph pane as drawn now: where it is on
/// screen, and its rows of text.
fn graph_pane(h: &mut Harness) -> (Rect, Vec<String>) {
    use mapvlm::workbench::layout::{pane_rects, Screen};
    let (w, height) = h.app.size;
    let Screen::Panes { panes, .. } =
        pane_rects(Rect::new(0, 0, w, height), h.app.focus, h.app.panes.zoom)
    else {
        panic!("no panes at {w}x{height}")
    };
    let area = panes.iter().find(|(p, _)| *p == Pane::Graph).unwrap().1;
    let inner = Rect::new(area.x + 1, area.y + 1, area.width - 2, area.height - 2);
    let buf = h.terminal().backend().buffer().clone();
    let rows = (inner.y..inner.y + inner.height)
        .map(|y| {
            (inner.x..inner.x + inner.width)
                .map(|x| buf[(x, y)].symbol().to_string())
                .collect::<String>()
        })
        .collect();
    (inner, rows)
}

/// Where `needle` is drawn in the Knowledge Graph pane: its column and
/// row on screen.
fn drawn_at(h: &mut Harness, needle: &str) -> Option<(u16, u16)> {
    let (inner, rows) = graph_pane(h);
    rows.iter().enumerate().find_map(|(y, row)| {
        let at = row.find(needle)?;
        let column = row[..at].chars().count() as u16;
        Some((inner.x + column, inner.y + y as u16))
    })
}

/// Whether the pane shows node `name` whole: `[name]` in the compact
/// drawing, `│ name │` or `│ name ├` in a boxed one.
fn shows_whole(rows: &[String], name: &str) -> bool {
    let text = rows.join("\n");
    [
        format!("[{name}]"),
        format!("│ {name} │"),
        format!("│ {name} ├"),
    ]
    .iter()
    .any(|n| text.contains(n))
}

#[test]
fn the_demo_graph_at_200x60_draws_every_triple_whole() {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    let (_, rows) = graph_pane(&mut h);
    let text = rows.join("\n");
    let g = h.app.panes.graph.kg.clone();
    assert_eq!(g.edges.len(), 11, "the demo's SKM triples");
    for name in &g.nodes {
        assert!(shows_whole(&rows, name), "{name} whole in\n{text}");
    }
    assert!(text.contains("[blue mug]─on─"), "{text}");
    for e in &g.edges {
        let drawn = text.matches(&format!("─{}─", e.label)).count();
        let wanted = g.edges.iter().filter(|o| o.label == e.label).count();
        assert!(drawn >= wanted, "{} drawn {drawn} times\n{text}", e.label);
    }
    assert!(!text.contains("hidden"), "{text}");
}

#[test]
fn a_30_triple_graph_shows_every_node_or_says_how_many_are_hidden() {
    for size in [(200, 60), (120, 40), (80, 24)] {
        let mut h = Harness::new(size, None, false, unavailable());
        h.focus(Pane::Graph);
        h.app.panes.graph.set_output(KITCHEN);
        let g = h.app.panes.graph.kg.clone();
        assert_eq!((g.nodes.len(), g.edges.len()), (33, 30));
        // As drawn first, then panned with the wheel right and down.
        for pan in 0..3 {
            let (inner, rows) = graph_pane(&mut h);
            let text = rows.join("\n");
            let shown = g.nodes.iter().filter(|n| shows_whole(&rows, n)).count();
            let note = rows.last().unwrap().trim_end();
            if shown < g.nodes.len() {
                let hidden = g.nodes.len() - shown;
                assert!(
                    note.starts_with(&format!("hidden: {hidden} of 33 nodes, ")),
                    "{size:?}, pan {pan}: {hidden} hidden but the pane says\n{text}"
                );
                assert!(note.contains(" of 30 edges"), "{note}");
            } else {
                assert!(!text.contains("hidden"), "{size:?}: {text}");
            }
            for kind in [MouseEventKind::ScrollDown, MouseEventKind::ScrollRight] {
                h.app.update(Msg::Mouse(MouseEvent {
                    kind,
                    column: inner.x + 2,
                    row: inner.y + 2,
                    modifiers: KeyModifiers::NONE,
                }));
            }
        }
    }
}

#[test]
fn the_compact_view_keeps_relation_labels_and_whole_names() {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    h.focus(Pane::Graph);
    h.key(KeyCode::Char('z'));
    let (_, rows) = graph_pane(&mut h);
    assert!(shows_whole(&rows, "coffee machine"), "{}", rows.join("\n"));
    assert!(!rows.join("").contains('['), "boxes when the pane has room");
    h.keys("--");
    let (_, rows) = graph_pane(&mut h);
    let text = rows.join("\n");
    assert!(text.contains("[coffee machine]"), "{text}");
    for e in &h.app.panes.graph.kg.edges {
        assert!(
            text.contains(&format!("─{}─", e.label)),
            "{}\n{text}",
            e.label
        );
    }
}

#[test]
fn the_list_of_triples_shows_each_one_and_scrolls_with_markers() {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    h.focus(Pane::Plan);
    h.key(KeyCode::Char('T'));
    assert_eq!(h.app.focus, Pane::Graph, "T from any pane");
    let (_, rows) = graph_pane(&mut h);
    let text = rows.join("\n");
    assert!(text.contains(" 1. robot —faces→ table"), "{text}");
    assert!(text.contains("11. plant —on→ window sill"), "{text}");
    h.key(KeyCode::Char('T'));
    let (_, rows) = graph_pane(&mut h);
    assert!(rows.join("").contains("[blue mug]"), "drawn again");

    // Thirty triples in an 80×24 terminal: the list scrolls, the frame
    // says how many lines are out of sight, and every triple is seen.
    let mut h = Harness::new((80, 24), None, false, unavailable());
    h.app.panes.graph.set_output(KITCHEN);
    h.key(KeyCode::Char('T'));
    let g = h.app.panes.graph.kg.clone();
    let triple = |i: usize| {
        let e = &g.edges[i];
        format!(
            "{}. {} —{}→ {}",
            i + 1,
            g.nodes[e.from],
            e.label,
            g.nodes[e.to]
        )
    };
    // The pane's top and bottom edges, where the markers are.
    let edges = |h: &mut Harness| {
        let (inner, _) = graph_pane(h);
        let screen = h.screen();
        let lines: Vec<&str> = screen.lines().collect();
        let top = usize::from(inner.y - 1);
        let bottom = usize::from(inner.y + inner.height);
        format!("{}\n{}", lines[top], lines[bottom])
    };
    let frame = edges(&mut h);
    assert!(frame.contains("↓ ") && !frame.contains("↑ "), "{frame}");
    let mut seen = String::new();
    for _ in 0..30 {
        let (_, rows) = graph_pane(&mut h);
        seen.push_str(&rows.join("\n"));
        h.key(KeyCode::PageDown);
    }
    for i in 0..g.edges.len() {
        assert!(seen.contains(&triple(i)), "{} never shown", triple(i));
    }
    let frame = edges(&mut h);
    assert!(frame.contains("↑ ") && !frame.contains("↓ "), "{frame}");
    let (inner, _) = graph_pane(&mut h);
    let before = h.screen();
    h.app.update(Msg::Mouse(MouseEvent {
        kind: MouseEventKind::ScrollUp,
        column: inner.x + 3,
        row: inner.y + 3,
        modifiers: KeyModifiers::NONE,
    }));
    assert_ne!(h.screen(), before, "the wheel scrolls the list");
}

#[test]
fn a_click_on_a_node_selects_it_and_on_a_neighbour_highlights_it() {
    let mut h = Harness::new((200, 60), None, false, unavailable());
    h.focus(Pane::Plan);
    let g = h.app.panes.graph.kg.clone();
    let click = |h: &mut Harness, (column, row): (u16, u16)| {
        h.app.update(Msg::Mouse(MouseEvent {
            kind: MouseEventKind::Down(MouseButton::Left),
            column,
            row,
            modifiers: KeyModifiers::NONE,
        }));
    };
    for name in ["counter", "window sill", "blue mug"] {
        let at = drawn_at(&mut h, &format!("[{name}]")).unwrap();
        click(&mut h, (at.0 + 2, at.1));
        assert_eq!(h.app.focus, Pane::Graph);
        assert_eq!(h.app.panes.graph.view.selected(), g.find(name), "{name}");
    }
    h.key(KeyCode::Char('v'));
    // The robot's neighbourhood: counter, sink and coffee machine lead into
    // it, table is out of it.
    let at = drawn_at(&mut h, "coffee machine ─behind─▶").unwrap();
    click(&mut h, at);
    let neighbours = h.app.panes.graph.neighbours();
    let chosen = neighbours[h.app.panes.graph.cursor.neighbour];
    assert_eq!(g.nodes[chosen], "coffee machine");
    h.key(KeyCode::Enter);
    assert_eq!(g.nodes[h.app.panes.graph.cursor.node], "coffee machine");
}

#[test]
fn a_neighbourhood_taller_than_its_pane_follows_the_highlight_and_says_what_is_out_of_sight() {
    let mut h = Harness::new((120, 40), None, false, unavailable());
    h.focus(Pane::Graph);
    h.app.panes.graph.set_output(KITCHEN);
    h.keys("v]");
    let g = h.app.panes.graph.kg.clone();
    let table = h.app.panes.graph.cursor.node;
    assert_eq!(g.nodes[table], "kitchen table");
    assert_eq!(g.incoming(table).count(), 5, "more than the pane's 4 rows");
    let (_, rows) = graph_pane(&mut h);
    let text = rows.join("\n");
    assert!(text.contains("◀ into it · ↓ 1 more"), "{text}");
    assert!(!text.contains("second chair ─behind"), "{text}");
    for _ in 0..4 {
        h.key(KeyCode::Down);
    }
    let (_, rows) = graph_pane(&mut h);
    let text = rows.join("\n");
    assert!(text.contains("◀ into it · ↑ 1 more"), "{text}");
    // Wider than the half: cut with `…`, not at the edge.
    assert!(text.contains("second chair ─behind─▶…"), "{text}");
    let at = drawn_at(&mut h, "red mug ─on─▶").unwrap();
    h.app.update(Msg::Mouse(MouseEvent {
        kind: MouseEventKind::Down(MouseButton::Left),
        column: at.0,
        row: at.1,
        modifiers: KeyModifiers::NONE,
    }));
    let neighbours = h.app.panes.graph.neighbours();
    assert_eq!(
        g.nodes[neighbours[h.app.panes.graph.cursor.neighbour]],
        "red mug"
    );
}

/// A run whose agents asked gpt-4o (the Planner's answer from the cache),
/// with a price table for gpt-4o: the history and the comparison show what
/// each agent and the run cost; an unpriced model shows `no price`.
#[test]
fn run_history_shows_each_agent_and_run_cost_from_the_price_table() {
    use mapvlm::agents::config::Price;
    use mapvlm::agents::cost::PriceTable;
    use mapvlm::agents::Usage;
    use std::collections::BTreeMap;

    let mut h = Harness::new((120, 40), None, false, unavailable());
    let price = Price {
        input_per_million: 2.5,
        output_per_million: 10.0,
        batch_input_per_million: None,
        batch_output_per_million: None,
    };
    let models = BTreeMap::from([("gpt-4o".to_string(), price)]);
    h.app.work.prices =
        PriceTable::from_config(&BTreeMap::from([("openai".to_string(), models)])).unwrap();
    let mut paid = h.app.runs.history[0].clone();
    for a in &mut paid.agents {
        a.settings.provider = mapvlm::agents::ProviderKind::Openai;
        a.settings.model = "gpt-4o".into();
        a.usage = Usage {
            input_tokens: 1_000,
            output_tokens: 200,
        };
        a.cached = a.role == AgentRole::Planner;
    }
    let mut unpriced = paid.clone();
    unpriced.id = paid.id + 1;
    unpriced.agents[0].settings.model = "gpt-4.1".into();
    let paid_agents = paid.agents.iter().filter(|a| !a.cached).count();
    assert!(paid_agents >= 1 && paid_agents < paid.agents.len());
    h.app.runs.history = vec![paid, unpriced];

    h.key(KeyCode::Char('H'));
    let history = h.screen();
    // Each paid agent: 1,000 × $2.50 + 200 × $10 per million = $0.0045.
    let total = format!("${:.4}", 0.0045 * paid_agents as f64);
    assert!(history.contains(&total), "{history}");
    assert!(history.contains("no price"), "{history}");
    // The selected run's agents, each with its own cost.
    assert!(history.contains("run #2 finished"), "{history}");
    assert!(
        history.contains("over 1 of 1 samples); per agent:"),
        "{history}"
    );
    assert!(
        history.contains("openai/gpt-4.1 · 100 ms · 1000+200 tok · no price"),
        "{history}"
    );
    assert!(
        history.contains("1000+200 tok · $0.0000 (cached)"),
        "{history}"
    );
    insta::assert_snapshot!("run_history_costs", history);

    h.key(KeyCode::Char('d'));
    let diff = h.screen();
    assert!(
        diff.contains(&format!("Cost    #1 {total} → #2 no price")),
        "{diff}"
    );
    assert!(
        diff.contains("1000+200 tok $0.0045 → #2 1000+200 tok no price"),
        "{diff}"
    );
    assert!(diff.contains("model: gpt-4o → gpt-4.1"), "{diff}");
}

/// Two runs of the demo task, the second after a Planner prompt edit that
/// rewrote one step and raised its KAS: at 80×24 the diff shows the
/// verdicts, the prompt's changed words and, scrolled, each step's change.
#[test]
fn the_run_diff_shows_the_prompt_change_and_each_steps_score_change() {
    let mut h = Harness::new((80, 24), None, false, bag_of_words());
    let first = h.app.runs.history[0].clone();
    let mut second = first.clone();
    second.id = first.id + 1;
    let planner = second
        .prompts
        .get_mut(&AgentRole::Planner)
        .expect("the demo runs a Planner");
    *planner = planner.replacen("atomic action", "short, atomic action", 1);
    assert_ne!(Some(&*planner), first.prompts.get(&AgentRole::Planner));
    second.agents.retain(|a| a.role == AgentRole::Planner);
    second.plan[1] = format!("{} carefully", second.plan[1].trim_end_matches('.'));
    let mut scores = second.scores.expect("the demo run was scored");
    scores.kas = scores.kas.map(|k| k + 0.1);
    second.scores = Some(scores);
    second.steps[1].kas = Some(1.0);
    h.app.runs.history.push(second);

    h.key(KeyCode::Char('H'));
    h.key(KeyCode::Char('d'));
    assert_eq!(h.app.key_context(), Context::RunDiff);
    let top = h.screen();
    assert!(top.contains("Diff run #1 → #2"), "{top}");
    assert!(
        top.contains("1+1 samples: cannot tell a change from noise"),
        "{top}"
    );
    assert!(top.contains("+0.100"), "{top}");
    assert!(
        top.contains("did not run (the output of #1 was reused)"),
        "{top}"
    );
    insta::assert_snapshot!("run_diff_80x24_top", top);

    let mut seen = top.clone();
    for _ in 0..20 {
        h.key(KeyCode::PageDown);
        seen.push_str(&h.screen());
    }
    assert!(seen.contains("{+short,"), "{seen}");
    assert!(seen.contains("carefully+}"), "{seen}");
    assert!(seen.contains("→ KAS 1.00"), "{seen}");
    h.key(KeyCode::End);
    insta::assert_snapshot!("run_diff_80x24_end", h.screen());
    h.key(KeyCode::Esc);
    assert_eq!(h.app.key_context(), Context::History);
    h.key(KeyCode::Esc);
    assert!(h.app.overlay.is_none());
}

/// The screen with the Scores pane zoomed.
fn zoomed_scores(h: &mut Harness) -> String {
    h.app.focus = Pane::Scores;
    h.key(KeyCode::Char('z'));
    h.screen()
}

/// A run of three samples: the Scores pane shows each score's mean ±sd
/// right after its name, then its min–max; the history's sparkline shows
/// the run's min, mean and max.
#[test]
fn scores_of_a_sampled_run_show_their_spread() {
    use mapvlm::workbench::session::{SampleRecord, ScoreRecord};

    let mut h = Harness::new((120, 40), None, false, bag_of_words());
    let first = h.app.runs.history[0].clone();
    let one = first.clone();
    let mut sampled = first.clone();
    sampled.id = first.id + 1;
    sampled.scores = Some(ScoreRecord {
        kas: Some(0.5),
        s_plan: Some(0.6),
        s_goal: Some(0.7),
        pg2s: Some(0.41),
    });
    sampled.samples = [(1, 0.455, 0.25), (2, 0.434, 0.75)]
        .into_iter()
        .map(|(sample, pg2s, kas)| SampleRecord {
            sample,
            agents: Vec::new(),
            plan: first.plan.clone(),
            usage: Default::default(),
            error: None,
            scores: Some(ScoreRecord {
                kas: Some(kas),
                s_plan: Some(0.6),
                s_goal: None,
                pg2s: Some(pg2s),
            }),
        })
        .collect();
    h.app.runs.history = vec![one, sampled];
    h.app.work.plan_source = mapvlm::workbench::session::PlanSource::Run { run: first.id + 1 };
    let screen = zoomed_scores(&mut h);
    // PG2S of the samples 0.41, 0.455, 0.434: mean 0.433, sd 0.0225.
    assert!(
        screen.contains("PG2S 0.433 ±0.023  0.410–0.455"),
        "{screen}"
    );
    assert!(screen.contains("KAS 0.500 ±0.250  0.250–0.750"), "{screen}");
    assert!(
        screen.contains("S_plan 0.600 ±0.000  0.600–0.600"),
        "{screen}"
    );
    assert!(
        screen.contains("S_goal 0.700  0.700–0.700"),
        "one sample has S_goal: {screen}"
    );
    assert!(screen.contains("run #2: 3 of 3 samples scored"), "{screen}");
    assert!(
        screen.contains("#2   PG2S 0.433 ±0.023 KAS 0.500 ±0.250"),
        "{screen}"
    );
    insta::assert_snapshot!("scores_with_spread_120x40", screen);
}

/// The README's picture of the workbench is the demo as drawn now: the lines
/// between its capture markers equal this frame. `MAPVLM_UPDATE_README=1`
/// rewrites them instead, after a change to the screen.
#[test]
fn readme_capture_is_the_demo_as_drawn() {
    let models = real_models();
    let mut h = Harness::new((120, 36), None, true, models.clone());
    h.app.work.models = models;
    let frame: Vec<String> = h
        .screen()
        .lines()
        .map(|line| {
            let line = line.strip_prefix('"').unwrap_or(line);
            line.strip_suffix('"')
                .unwrap_or(line)
                .trim_end()
                .to_string()
        })
        .collect();
    let block = format!("```text\n{}\n```\n", frame.join("\n"));
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let readme = std::fs::read_to_string(&path).unwrap();
    let (begin, end) = ("<!-- capture begin -->\n", "<!-- capture end -->");
    let start = readme
        .find(begin)
        .expect("README has a capture begin marker")
        + begin.len();
    let stop = readme.find(end).expect("README has a capture end marker");
    if std::env::var_os("MAPVLM_UPDATE_README").is_some() {
        let updated = format!("{}{block}{}", &readme[..start], &readme[stop..]);
        std::fs::write(&path, updated).unwrap();
        return;
    }
    assert_eq!(
        &readme[start..stop],
        block,
        "the README's capture is not the demo as drawn: rerun with MAPVLM_UPDATE_README=1"
    );
}

/// Starts a run of every agent with `R` without carrying it out, and hands
/// the app the pipeline's `events` for it instead (what a provider that
/// fails would make the pipeline send); returns the run's id.
fn run_with_events(h: &mut Harness, events: Vec<AgentEvent>) -> u64 {
    let priced = h.app.update(Msg::Key(KeyEvent::new(
        KeyCode::Char('R'),
        KeyModifiers::NONE,
    )));
    assert!(
        matches!(priced.first(), Some(Cmd::PriceFreshRun(_))),
        "R priced no run"
    );
    // The demo's answers are recorded: nothing to pay, so the run starts.
    let started = h.app.update(Msg::FreshRunPriced(Ok(Default::default())));
    let Some(Cmd::StartRun(request)) = started.into_iter().next() else {
        panic!("R started no run");
    };
    for event in events {
        let cmds = h.app.update(Msg::Agent(request.run, event));
        h.run(cmds);
    }
    request.run
}

/// The Planner starting and writing `text`, as the pipeline reports it.
fn planner_writes(text: &str) -> Vec<AgentEvent> {
    vec![
        AgentEvent::Started {
            role: AgentRole::Planner,
        },
        AgentEvent::Token {
            role: AgentRole::Planner,
            text: text.into(),
        },
    ]
}

/// The SKM refused while the GKM is still waiting for its answer: the run
/// fails and the GKM's request is dropped with it, so its pane says it was
/// cancelled (not "no answer yet" counting on after the run), and nothing
/// wakes the screen to count a silence that is over.
#[test]
fn a_miners_failure_ends_the_other_miners_wait_in_its_pane_too() {
    use mapvlm::workbench::runs::AgentStatus;
    use mapvlm::workbench::session::RunState;

    let mut h = Harness::new((200, 60), None, false, bag_of_words());
    let events = vec![
        AgentEvent::Started {
            role: AgentRole::Skm,
        },
        AgentEvent::Started {
            role: AgentRole::Gkm,
        },
        AgentEvent::Failed {
            role: AgentRole::Skm,
            error: "openai answered HTTP 500".into(),
            elapsed_ms: 73,
        },
    ];
    let run = run_with_events(&mut h, events);
    assert_eq!(h.app.runs.history.last().unwrap().state, RunState::Failed);
    assert_eq!(
        h.app.runs.agents[&AgentRole::Gkm].status,
        AgentStatus::Cancelled
    );
    assert_eq!(h.app.countdown_wake(Instant::now()), None);
    let screen = h.screen();
    let gkm = screen
        .lines()
        .find(|l| l.contains("Grounded Description (GKM)"))
        .unwrap();
    assert!(gkm.contains("(GKM) cancelled"), "{gkm}");
    assert!(!screen.contains("no answer yet"), "{screen}");
    // Its plan, loaded from the history, is none (not "partial").
    h.key(KeyCode::Char('H'));
    h.key(KeyCode::Enter);
    assert!(h.app.panes.plan.items.is_empty());
    let screen = h.screen();
    assert!(
        screen.contains(&format!("run {run} · failed, no plan, not scored")),
        "{screen}"
    );
}

/// A message longer than the status line ends with where it is whole, and
/// `M` shows it whole under its time, with the messages before it.
#[test]
fn a_cut_status_message_points_to_the_log_which_keeps_it_whole() {
    let mut h = Harness::new((80, 24), None, false, bag_of_words());
    let error = "openai answered HTTP 500: the upstream model server is overloaded, \
                 try again in a few minutes or ask another model";
    let events = vec![
        AgentEvent::Started {
            role: AgentRole::Skm,
        },
        AgentEvent::Failed {
            role: AgentRole::Skm,
            error: error.into(),
            elapsed_ms: 73,
        },
    ];
    run_with_events(&mut h, events);
    let screen = h.screen();
    let status = screen.lines().last().unwrap().trim_matches('"').trim_end();
    assert!(status.ends_with("… · M log"), "{status}");
    h.key(KeyCode::Char('M'));
    let log = h.screen();
    let words = |text: &str| {
        text.split_whitespace()
            .filter(|w| {
                w.chars()
                    .all(|c| c.is_alphanumeric() || ":,.()#".contains(c))
            })
            .map(str::to_string)
            .collect::<Vec<_>>()
            .join(" ")
    };
    assert!(
        words(&log).contains(&words(error)),
        "the whole message: {log}"
    );
    assert!(log.contains("Messages, newest last"), "{log}");
    assert!(
        log.lines()
            .any(|l| l.contains("0:00  ") && l.contains("run")),
        "each under its time: {log}"
    );
    h.key(KeyCode::Esc);
    assert!(!h.screen().contains("Messages, newest last"));
}

/// At 80×24 the run history gives up its least important columns (the
/// approach, the steps, S_plan) so that the cost and the state stay, and
/// wraps the run's details instead of cutting them at the box's edge.
#[test]
fn the_run_history_at_80_columns_keeps_the_cost_and_the_state_and_wraps_the_details() {
    let mut h = Harness::new((80, 24), None, false, bag_of_words());
    h.key(KeyCode::Char('H'));
    let screen = h.screen();
    let header = screen
        .lines()
        .find(|l| l.contains("PG2S") && l.contains("KAS") && l.contains("run"))
        .unwrap_or_else(|| panic!("no table header: {screen}"));
    for column in ["cost", "state", "PG2S", "KAS", "samples"] {
        assert!(header.contains(column), "{column}: {header}");
    }
    assert!(
        !header.contains("approach"),
        "the approach gave way: {header}"
    );
    let row = screen
        .lines()
        .find(|l| l.contains("#1 "))
        .unwrap_or_else(|| panic!("no row of run 1: {screen}"));
    assert!(row.contains("finished"), "{row}");
    assert!(
        screen.contains("samples); per agent:"),
        "the details wrapped, not cut: {screen}"
    );
}

/// A Planner whose answer breaks off after two steps: the run is kept as
/// failed with the partial plan marked and unscored, the Plan pane keeps
/// the last good plan and says why the new run failed, and the history,
/// the Scores pane and the diff say so in words.
#[test]
fn a_failed_run_is_kept_failed_unscored_and_the_last_good_plan_stays() {
    use mapvlm::workbench::session::{PlanSource, RunState};

    let mut h = Harness::new((200, 60), None, false, bag_of_words());
    let good = h.app.runs.history[0].clone();
    assert_eq!(good.state, RunState::Finished);
    let before = h.app.runs.agents[&AgentRole::Planner].clone();
    assert!(before.usage.output_tokens > 0);
    let mut events = planner_writes("1. Walk to the sink.\n2. Pick up");
    events.push(AgentEvent::Failed {
        role: AgentRole::Planner,
        error: "the stream ended before the answer did".into(),
        elapsed_ms: 250,
    });
    let run = run_with_events(&mut h, events);
    assert_eq!(h.app.runs.active, None);
    let failed = h.app.runs.history.last().unwrap().clone();
    assert_eq!(failed.id, run);
    assert_eq!(failed.state, RunState::Failed);
    assert_eq!(
        failed.error.as_deref(),
        Some("Planner: the stream ended before the answer did")
    );
    assert_eq!(
        failed.plan,
        ["Walk to the sink.", "Pick up"],
        "the partial plan is kept"
    );
    assert_eq!(failed.scores, None, "never scored");
    assert!(failed.sample_scores().is_empty());
    let planner = failed
        .agents
        .iter()
        .find(|a| a.role == AgentRole::Planner)
        .unwrap();
    assert_eq!(
        planner.elapsed_ms, 250,
        "its own time, not the run before's"
    );
    assert_eq!(
        planner.usage,
        Default::default(),
        "nothing reported, nothing counted"
    );
    assert!(!planner.cached);
    let miners: Vec<_> = failed
        .agents
        .iter()
        .filter(|a| a.role != AgentRole::Planner)
        .collect();
    assert!(miners
        .iter()
        .all(|a| a.output.is_none() && a.elapsed_ms == 0 && a.usage == Default::default()));
    // The last good plan is back, with its source.
    assert_eq!(h.app.panes.plan.items, good.plan);
    assert_eq!(h.app.work.plan_source, PlanSource::Run { run: good.id });
    assert_eq!(h.app.runs.awaiting_scores, None);
    let screen = h.screen();
    assert!(
        screen.contains(&format!("run {run} failed: Planner: the stream ended")),
        "{screen}"
    );
    assert!(screen.contains(&good.plan[0]), "{screen}");
    assert!(
        screen.contains(&format!("#{run:<3} PG2S   –   KAS   –  ")),
        "{screen}"
    );

    h.key(KeyCode::Char('H'));
    let history = h.screen();
    assert!(history.contains("1/1 finished"), "{history}");
    assert!(history.contains("0/1 failed"), "{history}");
    assert!(
        history.contains(&format!(
            "run #{run} failed: Planner: the stream ended before the answer did (its partial plan"
        )),
        "{history}"
    );
    h.key(KeyCode::Char('d'));
    let diff = h.screen();
    assert!(diff.contains(&format!("run #{run} failed:")), "{diff}");
    assert!(diff.contains("not in the verdict"), "{diff}");
    assert!(diff.contains("not scored in both runs"), "{diff}");
    h.key(KeyCode::Esc);
    // Loading the failed run's plan shows it marked, and still unscored.
    h.key(KeyCode::Enter);
    assert_eq!(h.app.panes.plan.items, failed.plan);
    let screen = h.screen();
    assert!(
        screen.contains(&format!("run {run} · failed, partial plan, not scored")),
        "{screen}"
    );
    assert_eq!(h.app.runs.history.last().unwrap().scores, None);
}

/// A cancelled run: kept as cancelled, unscored, the last good plan back;
/// a session saved during a run restores it as cancelled.
#[test]
fn a_cancelled_run_and_a_run_in_flight_at_quit_are_kept_as_cancelled() {
    use mapvlm::workbench::session::RunState;

    let mut h = Harness::new((200, 60), None, false, bag_of_words());
    let good = h.app.runs.history[0].clone();
    let run = run_with_events(&mut h, planner_writes("1. Walk"));
    let saved = h.app.to_session();
    let in_flight = saved.current.runs.last().unwrap();
    assert_eq!((in_flight.id, in_flight.state), (run, RunState::Running));
    let (restored, _) = App::new(AppInit {
        session: Some(saved.clone()),
        ..AppInit::demo((200, 60), "no models in this test")
    });
    let back = restored.runs.history.iter().find(|r| r.id == run).unwrap();
    assert_eq!(back.state, RunState::Cancelled);
    assert!(back
        .state_text()
        .contains("the workbench stopped during the run"));

    h.key(KeyCode::Char('x'));
    let cancelled = h.app.runs.history.last().unwrap().clone();
    assert_eq!((cancelled.id, cancelled.state), (run, RunState::Cancelled));
    assert_eq!(cancelled.scores, None);
    assert_eq!(h.app.panes.plan.items, good.plan);
    let screen = h.screen();
    assert!(screen.contains(&format!("run {run} cancelled")), "{screen}");
}

/// A run of three samples whose third failed: partial, scored over its two
/// complete samples only, and it says so.
#[test]
fn a_partial_sampled_run_is_scored_over_its_complete_samples() {
    use mapvlm::workbench::session::{RunState, SampleRecord, ScoreRecord};

    let mut h = Harness::new((120, 40), None, false, bag_of_words());
    let mut run = h.app.runs.history[0].clone();
    let score = |pg2s| ScoreRecord {
        kas: Some(0.5),
        s_plan: Some(0.6),
        s_goal: Some(0.7),
        pg2s: Some(pg2s),
    };
    run.scores = Some(score(0.4));
    run.samples = vec![
        SampleRecord {
            sample: 1,
            agents: Vec::new(),
            plan: run.plan.clone(),
            usage: Default::default(),
            error: None,
            scores: Some(score(0.5)),
        },
        SampleRecord {
            sample: 2,
            agents: Vec::new(),
            plan: Vec::new(),
            usage: Default::default(),
            error: Some("Planner: HTTP 500".into()),
            scores: Some(score(0.0)),
        },
    ];
    run.state = RunState::Partial;
    h.app.runs.history = vec![run.clone()];
    assert_eq!(run.sample_scores(), vec![score(0.4), score(0.5)]);
    let screen = zoomed_scores(&mut h);
    assert!(
        screen.contains("run #1 partial: 2 of 3 samples scored"),
        "{screen}"
    );
    assert!(screen.contains("PG2S 0.450 ±0.071"), "{screen}");
}

#[test]
fn a_start_up_flag_wins_over_the_session_which_keeps_its_own_value() {
    use mapvlm::workbench::session::Session;
    let start = |session: Option<Session>, theme: Option<&str>, samples: Option<u32>| {
        App::new(AppInit {
            session,
            theme: theme.map(str::to_string),
            samples,
            ..AppInit::demo((120, 40), "no models in this test")
        })
        .0
    };
    let mut saved = start(None, None, None).to_session();
    saved.theme = "light".into();
    saved.samples = 3;
    // Each flag with a session counterpart: what it shows with the flag, and
    // what the session it saves gives the next start without it.
    type Shown = fn(&App) -> String;
    let cases: [(Option<&str>, Option<u32>, Shown, &str); 2] = [
        (
            Some("high-contrast"),
            None,
            |app| app.looks.theme.name.clone(),
            "high-contrast",
        ),
        (None, Some(10), |app| app.work.samples.to_string(), "10"),
    ];
    for (theme, samples, shown, flagged) in cases {
        let with_flag = start(Some(saved.clone()), theme, samples);
        assert_eq!(shown(&with_flag), flagged, "the flag wins");
        let kept = with_flag.to_session();
        assert_eq!(
            (kept.theme.as_str(), kept.samples),
            ("light", 3),
            "the session keeps its own"
        );
        let next = start(Some(kept), None, None);
        assert_eq!(next.looks.theme.name, "light");
        assert_eq!(next.work.samples, 3);
    }
    // Changed in the workbench, the setting is the session's again.
    let mut changed = start(Some(saved.clone()), None, Some(10));
    changed.update(Msg::Key(KeyEvent::new(
        KeyCode::Char('S'),
        KeyModifiers::NONE,
    )));
    assert_eq!(changed.to_session().samples, changed.work.samples);
}

/// The harness of a workbench started from `init`, scoring with `models`.
fn started(init: AppInit, models: ModelSlot) -> Harness {
    let (app, cmds) = App::new(init);
    let mut h = Harness {
        app,
        models,
        pipeline: AgentsPipeline::offline(Pace::Instant).unwrap(),
    };
    h.run(cmds);
    h
}

/// The demo and each dataset task keep their own plans and runs: the demo
/// started after a dataset session is the demo, scored on its own ground
/// truth as a fresh start is, and the task's edited plan and runs are as
/// they were left when it is opened again, by a new start or by `g`.
#[test]
fn the_demo_and_a_dataset_task_keep_their_own_plans_and_runs() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/alfred30");
    let (dataset, _) = mapvlm::dataset::Dataset::load(std::path::Path::new(root)).unwrap();
    let models = real_models();
    let demo = |session| AppInit {
        session,
        ..AppInit::demo((200, 60), "no models in this test")
    };
    let on_dataset = |session| AppInit {
        dataset: Some(dataset.clone()),
        session,
        ..AppInit::demo((200, 60), "no models in this test")
    };
    let fresh = started(demo(None), models.clone());
    let fresh_pg2s = h_pg2s(&fresh);
    assert_eq!(
        format!("{fresh_pg2s:.3}"),
        "0.900",
        "the built-in demo's score"
    );

    // A dataset session: the first task, its published plan with a step
    // deleted, and a corrupted run of it in the history.
    let mut task = started(on_dataset(None), models.clone());
    let task_id = dataset.tasks[0].id.clone();
    assert_eq!(task.app.work.task.id.as_deref(), Some(task_id.as_str()));
    task.app.focus = mapvlm::workbench::panes::Pane::Plan;
    task.key(KeyCode::Char('d'));
    let edited = task.app.panes.plan.items.clone();
    assert_eq!(
        edited.len() + 1,
        dataset.tasks[0].plans["multi_agent_image"].len()
    );
    let task_session = task.app.to_session();

    // Plain `mapvlm` after it: the demo, as a fresh start has it.
    let mut back_to_demo = started(demo(Some(task_session.clone())), models.clone());
    assert!(back_to_demo.app.is_demo());
    assert_eq!(
        back_to_demo.app.panes.plan.items,
        fresh.app.panes.plan.items
    );
    assert_eq!(
        back_to_demo.app.panes.ground_truth.items,
        fresh.app.panes.ground_truth.items
    );
    assert_eq!(h_pg2s(&back_to_demo), fresh_pg2s);
    let screen = back_to_demo.screen();
    assert!(screen.contains("PG2S 0.900"), "{screen}");
    assert!(
        screen.contains("the session's task") && screen.contains("are kept"),
        "the start says where the task went, after the demo's run too: {screen}"
    );
    assert!(
        back_to_demo
            .app
            .runs
            .history
            .iter()
            .all(|r| r.task == fresh.app.work.task.text),
        "only the demo's runs are shown"
    );
    let demo_runs = back_to_demo.app.runs.history.len();

    // The dataset again: the task as it was left, and the demo kept too.
    let both = back_to_demo.app.to_session();
    let mut reopened = started(on_dataset(Some(both)), models.clone());
    assert_eq!(reopened.app.work.task.id.as_deref(), Some(task_id.as_str()));
    assert_eq!(reopened.app.panes.plan.items, edited);
    assert_eq!(reopened.app.runs.history, task.app.runs.history);

    // `g` to the demo and back, in one workbench: a step deleted on the
    // task before is undone after, on the task.
    reopened.app.focus = mapvlm::workbench::panes::Pane::Plan;
    reopened.key(KeyCode::Char('d'));
    pick(&mut reopened, "Demo: the built-in task");
    reopened.key(KeyCode::Char('u'));
    assert!(reopened.app.is_demo());
    assert_eq!(reopened.app.runs.history.len(), demo_runs);
    assert_eq!(h_pg2s(&reopened), fresh_pg2s);
    assert_eq!(
        reopened.app.panes.plan.items, fresh.app.panes.plan.items,
        "u on the demo has no edit of the task to undo"
    );
    pick(&mut reopened, &task_id);
    assert_eq!(reopened.app.work.task.id.as_deref(), Some(task_id.as_str()));
    assert_eq!(reopened.app.panes.plan.items.len() + 1, edited.len());
    reopened.app.focus = mapvlm::workbench::panes::Pane::Plan;
    reopened.key(KeyCode::Char('u'));
    assert_eq!(reopened.app.panes.plan.items, edited);
    assert_eq!(reopened.app.runs.history, task.app.runs.history);
}

/// `g`, then Enter on the first choice whose label starts with `label`.
fn pick(h: &mut Harness, label: &str) {
    h.key(KeyCode::Char('g'));
    let choices = h.app.ground_truth_choices();
    let at = choices
        .iter()
        .position(|(_, l)| l.starts_with(label))
        .unwrap_or_else(|| panic!("no choice {label}: {choices:?}"));
    for _ in 0..choices.len() {
        h.key(KeyCode::Up);
    }
    for _ in 0..at {
        h.key(KeyCode::Down);
    }
    h.key(KeyCode::Enter);
}

/// The PG2S the Scores pane shows.
fn h_pg2s(h: &Harness) -> f64 {
    let scores = h.app.work.scores.as_ref().expect("scored");
    let Pg2sOutcome::Ready(report) = &scores.pg2s else {
        panic!("PG2S not scored");
    };
    report.pg2s().expect("PG2S with goal models")
}

/// A session saved by version 5 on a dataset task, opened without its
/// dataset: the demo opens, and the task's plan and runs are kept, whole,
/// in the session it saves next.
#[test]
fn a_version_5_session_on_a_dataset_task_loses_nothing() {
    use mapvlm::workbench::session::{restore, Restored};
    let fixture = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/session-v5.json"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("session.json");
    std::fs::copy(fixture, &path).unwrap();
    let Restored::Loaded { session, repaired } = restore(&path).unwrap() else {
        panic!("the version 5 session was not loaded");
    };
    assert!(repaired.is_empty(), "{repaired:?}");
    let old = session.current.clone();
    assert_eq!(old.task_id.as_deref(), Some("pick-mug-1"));
    let h = started(
        AppInit {
            session: Some(*session),
            ..AppInit::demo((200, 60), "no models in this test")
        },
        unavailable(),
    );
    assert!(h.app.is_demo());
    assert!(h.app.runs.history.iter().all(|r| !old.runs.contains(r)));
    let saved = h.app.to_session();
    assert!(saved.current.task_id.is_none());
    let kept = saved
        .parked
        .iter()
        .find(|p| p.task_id.as_deref() == Some("pick-mug-1"))
        .expect("the task is kept");
    assert_eq!(kept, &old);
}

/// `u` takes back step edits, insertions, deletions and moves one at a
/// time, more than a hundred deep, with where the steps came from; Ctrl-Z
/// in the step editor takes back typing, not the list.
#[test]
fn undo_restores_edited_deleted_and_moved_steps_a_hundred_levels_deep() {
    use mapvlm::workbench::panes::Pane;
    use mapvlm::workbench::session::GroundTruthSource;
    let mut h = Harness::new((200, 60), None, false, bag_of_words());
    let plan = h.app.panes.plan.items.clone();
    assert!(plan.len() >= 3, "{plan:?}");
    h.app.focus = Pane::Plan;
    h.key(KeyCode::Char('d'));
    assert_eq!(h.app.panes.plan.items, plan[1..]);
    h.key(KeyCode::Char('u'));
    assert_eq!(h.app.panes.plan.items, plan);

    for n in 0..120 {
        match n % 3 {
            0 => {
                h.key(KeyCode::Char('o'));
                h.keys(&format!("step {n}"));
                h.key(KeyCode::Enter);
            }
            1 => h.key(KeyCode::Char('J')),
            _ => {
                h.key(KeyCode::Char('e'));
                h.keys(" more");
                h.key(KeyCode::Enter);
            }
        }
    }
    assert_ne!(h.app.panes.plan.items, plan);
    for _ in 0..120 {
        h.key(KeyCode::Char('u'));
    }
    assert_eq!(h.app.panes.plan.items, plan, "120 edits taken back");
    h.key(KeyCode::Char('u'));
    assert!(h.screen().contains("no step edit to undo"));

    h.app.focus = Pane::GroundTruth;
    let ground_truth = h.app.panes.ground_truth.items.clone();
    h.key(KeyCode::Char('e'));
    h.keys(" now");
    let ctrl_z = KeyEvent::new(KeyCode::Char('z'), KeyModifiers::CONTROL);
    let cmds = h.app.update(Msg::Key(ctrl_z));
    h.run(cmds);
    h.key(KeyCode::Enter);
    assert_eq!(
        h.app.panes.ground_truth.items[0],
        format!("{} no", ground_truth[0]),
        "Ctrl-Z took back the last letter typed"
    );
    assert_eq!(h.app.work.ground_truth_source, GroundTruthSource::Typed);
    h.key(KeyCode::Char('u'));
    assert_eq!(h.app.panes.ground_truth.items, ground_truth);
    assert_eq!(
        h.app.work.ground_truth_source,
        GroundTruthSource::Demo { index: 0 }
    );
}

/// On a task without a table file, the table approaches show the paper's
/// table plan, scored, as a reference titled so; `r` says what is missing
/// and sends nothing, and no run enters the history.
#[test]
fn a_table_approach_without_a_table_file_shows_the_papers_plan_as_a_reference() {
    use mapvlm::agents::Approach;
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/alfred30");
    let (dataset, _) = mapvlm::dataset::Dataset::load(std::path::Path::new(root)).unwrap();
    let task = &dataset.tasks[0];
    assert!(task.table.is_none(), "the first task has no table file");
    let mut h = started(
        AppInit {
            dataset: Some(dataset.clone()),
            ..AppInit::demo((200, 60), "no models in this test")
        },
        bag_of_words(),
    );
    while h.app.work.approach != Approach::MultiTable {
        h.key(KeyCode::Char('a'));
    }
    assert_eq!(h.app.panes.plan.items, task.plans["multi_agent_table"]);
    assert!(h.app.work.scores.is_some(), "the reference is scored");
    let screen = h.screen();
    assert!(screen.contains("the paper's multi-table plan"), "{screen}");
    let runs = h.app.runs.history.len();
    h.key(KeyCode::Char('r'));
    assert!(h.app.runs.active.is_none());
    assert_eq!(h.app.runs.history.len(), runs, "no run enters the history");
    let screen = h.screen();
    assert!(screen.contains("this task has none"), "{screen}");
}

/// On a task with a table file a table approach's Scene pane shows the
/// table as its agents read it, scrollable to its last row, and the
/// picture again on an image approach.
#[test]
fn the_scene_pane_shows_the_table_a_table_approach_reads() {
    use mapvlm::agents::Approach;
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/alfred30");
    let (mut dataset, _) = mapvlm::dataset::Dataset::load(std::path::Path::new(root)).unwrap();
    dataset.tasks.retain(|t| t.table.is_some());
    let table = dataset.tasks[0].table.clone().unwrap();
    let rendered = mapvlm::agents::prompts::render_table(&table).unwrap();
    let mut h = started(
        AppInit {
            dataset: Some(dataset),
            ..AppInit::demo((120, 40), "no models in this test")
        },
        bag_of_words(),
    );
    assert!(
        h.app.image_area().is_some(),
        "an image approach shows the picture"
    );
    while h.app.work.approach != Approach::MultiTable {
        h.key(KeyCode::Char('a'));
    }
    assert!(h.app.image_area().is_none(), "no picture over the table");
    let first_row = rendered.lines().next().unwrap();
    let last_row = rendered.lines().last().unwrap();
    let screen = h.screen();
    let head: String = first_row.chars().take(20).collect();
    assert!(screen.contains(&head), "{head} in\n{screen}");
    assert!(screen.contains("↓") && screen.contains("more"), "{screen}");
    while h.app.focus != Pane::Scene {
        h.key(KeyCode::Tab);
    }
    for _ in 0..200 {
        h.key(KeyCode::PageDown);
    }
    let end = h.screen();
    let tail: String = last_row.chars().take(20).collect();
    assert!(end.contains(&tail), "{tail} never in view:\n{end}");
    while !h.app.work.approach.uses_image() {
        h.key(KeyCode::Char('a'));
    }
    assert!(h.app.image_area().is_some(), "the picture is back");
}

#[test]
fn the_first_alfred30_tasks_long_ground_truth_step_reads_whole_at_200x60() {
    use mapvlm::workbench::layout::{pane_rects, Screen};
    let (mut h, dataset) = Harness::on_alfred30((200, 60), unavailable());
    let long = dataset.tasks[0]
        .ground_truth
        .iter()
        .find(|s| s.ends_with("before turning it off again."))
        .expect("alfred30's first task has the step")
        .clone();
    let Screen::Panes { panes, .. } = pane_rects(Rect::new(0, 0, 200, 60), h.app.focus, false)
    else {
        panic!("no panes at 200x60")
    };
    let gt = panes
        .iter()
        .find(|(p, _)| *p == Pane::GroundTruth)
        .unwrap()
        .1;
    let screen = h.screen();
    let rows: Vec<&str> = screen.lines().collect();
    let pane_text = collapsed(
        &rows[usize::from(gt.y)..usize::from(gt.y + gt.height)].join("\n"),
        usize::from(gt.x)..usize::from(gt.x + gt.width),
    );
    assert!(pane_text.contains(&format!("4. {long}")), "{pane_text}");
}

/// Where `needle` is drawn on `screen` (a test backend's text): its first
/// cell's column and row.
fn where_is(screen: &str, needle: &str) -> (u16, u16) {
    screen
        .lines()
        .enumerate()
        .find_map(|(row, line)| {
            let line = line.strip_prefix('"').unwrap_or(line);
            let at = line.find(needle)?;
            Some((line[..at].chars().count() as u16, row as u16))
        })
        .unwrap_or_else(|| panic!("{needle:?} is not on the screen:\n{screen}"))
}

/// The mouse at (`column`, `row`): a left click, or a wheel notch.
fn mouse(h: &mut Harness, kind: crossterm::event::MouseEventKind, (column, row): (u16, u16)) {
    let cmds = h.app.update(Msg::Mouse(crossterm::event::MouseEvent {
        kind,
        column,
        row,
        modifiers: KeyModifiers::NONE,
    }));
    h.run(cmds);
}

fn click(h: &mut Harness, at: (u16, u16)) {
    use crossterm::event::{MouseButton, MouseEventKind};
    mouse(h, MouseEventKind::Down(MouseButton::Left), at);
}

#[test]
fn a_click_on_a_tab_of_a_narrow_terminal_focuses_that_pane() {
    let mut h = Harness::new((80, 24), None, false, unavailable());
    assert_eq!(h.app.focus, Pane::Plan);
    for pane in [Pane::Scores, Pane::Description, Pane::Scene, Pane::Plan] {
        let at = where_is(&h.screen(), &pane.tab());
        click(&mut h, (at.0 + 1, at.1));
        assert_eq!(h.app.focus, pane);
        assert!(
            h.screen().contains(&format!("┏ {}", pane.title())),
            "{pane:?}"
        );
    }
}

#[test]
fn a_click_on_an_agents_tab_in_the_prompt_pane_shows_its_prompt() {
    use mapvlm::agents::AgentRole;
    let mut h = Harness::new((200, 60), None, false, unavailable());
    assert_eq!(h.app.panes.prompt.agent, AgentRole::Skm);
    let at = where_is(&h.screen(), " 2 GKM ");
    click(&mut h, (at.0 + 2, at.1));
    assert_eq!(h.app.focus, Pane::Prompt);
    assert_eq!(h.app.panes.prompt.agent, AgentRole::Gkm);
    let at = where_is(&h.screen(), " 3 Planner ");
    click(&mut h, (at.0 + 9, at.1));
    assert_eq!(h.app.panes.prompt.agent, AgentRole::Planner);
    // A click on the body selects no agent.
    click(&mut h, (at.0 + 9, at.1 + 3));
    assert_eq!(h.app.panes.prompt.agent, AgentRole::Planner);
}

#[test]
fn pickers_take_a_click_to_select_a_second_to_choose_and_the_wheel_to_move() {
    use crossterm::event::MouseEventKind;
    use mapvlm::workbench::overlays::Overlay;
    let mut h = Harness::new((120, 40), None, false, unavailable());
    h.keys("g");
    let screen = h.screen();
    let b = where_is(&screen, "Demo: annotator B's ground truth");
    click(&mut h, b);
    assert!(matches!(h.app.overlay, Some(Overlay::GroundTruthPicker(_))));
    assert!(h.app.panes.ground_truth.items[0].starts_with("Turn right"));
    // The wheel moves the selection up to A and back down to B.
    mouse(&mut h, MouseEventKind::ScrollUp, b);
    mouse(&mut h, MouseEventKind::ScrollDown, b);
    click(&mut h, b);
    assert!(h.app.overlay.is_none());
    assert_eq!(
        h.app.work.ground_truth_source,
        mapvlm::workbench::session::GroundTruthSource::Demo { index: 1 }
    );
    // The corruption picker: a click on a kind selects it, a second
    // corrupts with it.
    h.keys("c");
    let drop = where_is(&h.screen(), "one step is removed");
    click(&mut h, drop);
    assert!(h.app.overlay.is_some());
    click(&mut h, drop);
    assert!(h.app.overlay.is_none());
    assert!(
        h.app
            .messages
            .log
            .iter()
            .any(|m| m.text == "corrupting the plan: drop…"),
        "{:?}",
        h.app.messages.log
    );
}

#[test]
fn the_run_history_takes_a_click_on_a_run_and_loads_its_plan_on_a_second() {
    use crossterm::event::MouseEventKind;
    use mapvlm::workbench::overlays::Overlay;
    use mapvlm::workbench::session::PlanSource;
    let mut h = Harness::new((160, 50), None, false, unavailable());
    // A second run: every agent again.
    h.keys("R");
    assert_eq!(h.app.runs.history.len(), 2);
    h.keys("H");
    let screen = h.screen();
    let first = where_is(&screen, "#1 ");
    click(&mut h, first);
    assert!(matches!(h.app.overlay, Some(Overlay::Runs(_))));
    click(&mut h, first);
    assert!(h.app.overlay.is_none());
    assert_eq!(h.app.work.plan_source, PlanSource::Run { run: 1 });
    // The wheel moves the history's selection.
    h.keys("H");
    mouse(&mut h, MouseEventKind::ScrollUp, first);
    h.key(KeyCode::Enter);
    assert_eq!(h.app.work.plan_source, PlanSource::Run { run: 1 });
}

#[test]
fn the_wheel_scrolls_the_help_and_a_click_closes_it() {
    use crossterm::event::MouseEventKind;
    let mut h = Harness::new((80, 24), None, false, unavailable());
    h.keys("?");
    let top = h.screen();
    mouse(&mut h, MouseEventKind::ScrollDown, (40, 12));
    let scrolled = h.screen();
    assert_ne!(top, scrolled);
    assert!(h.app.overlay.is_some());
    click(&mut h, (40, 12));
    assert!(h.app.overlay.is_none());
}

#[test]
fn ctrl_d_ctrl_u_home_and_end_move_by_half_a_pane_and_to_the_ends_in_panes_and_the_help() {
    let ctrl = |c| KeyEvent::new(KeyCode::Char(c), KeyModifiers::CONTROL);
    let mut h = Harness::new((120, 40), None, false, unavailable());
    let steps = h.app.panes.plan.items.len();
    assert!(steps >= 6, "{steps}");
    h.key(KeyCode::End);
    assert_eq!(h.app.panes.plan.selected, steps - 1);
    h.key(KeyCode::Home);
    assert_eq!(h.app.panes.plan.selected, 0);
    let cmds = h.app.update(Msg::Key(ctrl('d')));
    h.run(cmds);
    let half = h.app.panes.plan.selected;
    assert!(half > 1, "{half} of {steps}");
    assert_eq!(h.app.panes.plan.items.len(), steps, "Ctrl-D deleted a step");
    let cmds = h.app.update(Msg::Key(ctrl('u')));
    h.run(cmds);
    assert_eq!(h.app.panes.plan.selected, 0);
    // The message log: Ctrl-D scrolls half of what a page does.
    for i in 0..60 {
        h.app.log(
            format!("message {i}"),
            mapvlm::workbench::shared::Severity::Info,
        );
    }
    h.keys("M");
    h.key(KeyCode::Home);
    let top = h.screen();
    let cmds = h.app.update(Msg::Key(ctrl('d')));
    h.run(cmds);
    let half_down = h.screen();
    assert_ne!(top, half_down);
    let cmds = h.app.update(Msg::Key(ctrl('u')));
    h.run(cmds);
    assert_eq!(h.screen(), top);
}

#[test]
fn the_scores_pane_scrolls_to_its_oldest_run_and_says_what_is_out_of_sight() {
    let mut h = Harness::new((120, 40), None, false, unavailable());
    // Twelve runs: more than the pane has rows for.
    for _ in 0..11 {
        h.keys("R");
    }
    assert_eq!(h.app.runs.history.len(), 12);
    while h.app.focus != Pane::Scores {
        h.key(KeyCode::Tab);
    }
    let top = h.screen();
    assert!(top.contains("#12 "), "{top}");
    assert!(!top.contains("#1  "), "{top}");
    assert!(top.contains("more ┘"), "{top}");
    h.key(KeyCode::End);
    let end = h.screen();
    assert!(end.contains("#1  "), "{end}");
    assert!(end.contains("↑ "), "{end}");
    h.key(KeyCode::Home);
    assert_eq!(h.screen(), top);
}
