//! The annotation screen against the one key table, both ways: every key the
//! table binds in an `Annotate…` context does something on the screen, and
//! every key it leaves unbound does nothing.

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::backend::TestBackend;
use ratatui::buffer::Buffer;
use ratatui::Terminal;

use super::fixtures::{open, press, setup};
use super::state::{Judging, Mode, Msg};
use crate::annotate::Annotations;
use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Context, BINDINGS};
use crate::workbench::theme::Theme;

/// The screen drawn in its window (text and styles: a selection shows in
/// its style).
fn drawn(screen: &Judging) -> Buffer {
    let (w, h) = screen.size.unwrap_or((100, 30));
    let mut terminal = Terminal::new(TestBackend::new(w, h)).unwrap_or_else(|e| panic!("{e}"));
    terminal
        .draw(|f| {
            let area = f.area();
            screen.draw(f, area, &Theme::no_color());
        })
        .unwrap_or_else(|e| panic!("{e}"));
    terminal.backend().buffer().clone()
}

/// Presses `key` and tells whether anything happened: the screen changed,
/// commands were asked for, or the screen quits.
fn changes(screen: &mut Judging, key: KeyEvent) -> bool {
    let before = drawn(screen);
    let cmds = screen.update(Msg::Key(key));
    !cmds.is_empty() || screen.quit || drawn(screen) != before
}

/// A screen where `context`'s keys apply; `warm` also moves to the second
/// item and labels its second step, so "previous", "up" and "take the label
/// off" have something to do (in the help: scrolls it down a line). The
/// reference plan is shown for its key; the help opens in a window too
/// small for it, so that it scrolls.
fn state_for(context: Context, warm: bool) -> Judging {
    let mut init = setup(context == Context::AnnotatePairwise, Annotations::default());
    init.show_gt = context == Context::AnnotateReference;
    let (mut s, _) = open(init);
    if context == Context::AnnotateHelp {
        s.update(Msg::Resize(60, 20));
        press(&mut s, '?');
        assert!(matches!(s.mode, Mode::Help));
        if warm {
            press(&mut s, 'j');
        }
        return s;
    }
    if warm {
        let keys: &[char] = if s.pairwise {
            &['n', 'j']
        } else {
            &['n', 'j', 'w', 'k']
        };
        for &c in keys {
            press(&mut s, c);
        }
    }
    if context == Context::AnnotateNote {
        press(&mut s, 'e');
        assert!(matches!(s.mode, Mode::Note(_)));
    }
    s
}

#[test]
fn every_annotation_key_in_the_key_table_is_handled() {
    let mut checked = 0;
    for binding in BINDINGS.iter().filter(|b| b.context.is_annotate()) {
        for &key in binding.keys() {
            let contexts = match binding.context {
                Context::Annotate => vec![Context::AnnotateRating, Context::AnnotatePairwise],
                c => vec![c],
            };
            for context in contexts {
                let handled = [false, true].into_iter().any(|warm| {
                    let mut s = state_for(context, warm);
                    keymap::action(&s.contexts(), &key.event()) == Some(binding.action)
                        && changes(&mut s, key.event())
                });
                assert!(
                    handled,
                    "{key} ({} in {context:?}) is in the key table but does nothing",
                    binding.label()
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 30, "only {checked} keys checked");
}

#[test]
fn a_key_missing_from_the_key_table_does_nothing_on_the_annotation_screen() {
    // While writing a note every other key is typed; in the help any key
    // closes it: neither is a binding.
    for context in [Context::AnnotateRating, Context::AnnotatePairwise] {
        for warm in [false, true] {
            let mut s = state_for(context, warm);
            for key in crate::workbench::keymap::pressable_keys() {
                if keymap::action(&s.contexts(), &key).is_some() {
                    continue;
                }
                assert!(
                    !changes(&mut s, key),
                    "{key:?} does something in {context:?} but is not in the key table"
                );
            }
        }
    }
}

#[test]
fn the_workbench_help_leaves_the_annotation_keys_out() {
    let helps = |contexts: &[Context]| -> Vec<&str> {
        keymap::help_sections(contexts)
            .into_iter()
            .flat_map(|s| s.rows)
            .map(|b| b.help)
            .collect()
    };
    let workbench = helps(&keymap::workbench_contexts());
    assert!(!workbench.iter().any(|w| w.contains("wrong object")));
    let rating = helps(&[Context::AnnotateRating]);
    assert!(rating.iter().any(|w| w.contains("wrong object")));
    assert_eq!(
        keymap::action(
            &[Context::AnnotatePairwise, Context::Annotate],
            &KeyEvent::new(KeyCode::Char('1'), KeyModifiers::NONE)
        ),
        Some(Action::Prefer(crate::annotate::Preference::Left))
    );
}

#[test]
fn no_key_of_the_annotation_screen_is_hidden_by_another() {
    // The contexts the screen looks keys up in, in each of its modes (the
    // reference plan shown or not): a key two of them bind is refused
    // unless the row that wins is marked as an override.
    let mut stacks = 0;
    for context in BINDINGS
        .iter()
        .map(|b| b.context)
        .filter(|c| c.is_annotate())
    {
        for warm in [false, true] {
            let contexts = state_for(context, warm).contexts();
            for clash in keymap::clashes(&contexts) {
                assert!(
                    clash.wins.overrides,
                    "{} of {:?} hides {:?} in {contexts:?}",
                    clash.key, clash.wins.context, clash.hidden.context
                );
            }
            stacks += 1;
        }
    }
    assert!(stacks >= 12, "{stacks}");
}
