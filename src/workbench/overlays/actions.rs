//! The framed actions of plan and ground truth, and their matches (`f`), a
//! [`Component`] over the scores it was opened on (kept up to date while
//! it is open), scrolled like the help when longer than its box.

use std::convert::Infallible;

use crossterm::event::{KeyEvent, MouseEvent};
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Clear;
use ratatui::Frame;

use crate::workbench::component::Component;
use crate::workbench::keymap::{self, Action, Context};
use crate::workbench::overlays::{centred, themed_box, Picked};
use crate::workbench::scoring::{Pg2sOutcome, ScoreOutcome};
use crate::workbench::scroll::{self, Motion, Scroll, ScrolledBox};
use crate::workbench::theme::Theme;

/// The framed-actions viewer: the scores it shows, `None` while scoring.
#[derive(Debug, Clone, Default)]
pub struct ActionsView {
    /// The scores shown; the workbench replaces them when new ones arrive.
    pub scores: Option<ScoreOutcome>,
    scroll: Scroll,
    area: Rect,
}

impl ActionsView {
    /// The viewer of `scores` over `area` (the screen), at its top.
    pub fn new(scores: Option<ScoreOutcome>, area: Rect) -> ActionsView {
        ActionsView {
            scores,
            scroll: Scroll::default(),
            area,
        }
    }
}

impl ScrolledBox for ActionsView {
    fn view(&mut self) -> (&mut Scroll, &mut Rect) {
        (&mut self.scroll, &mut self.area)
    }

    fn measure(&self, area: Rect) -> (usize, usize) {
        let (_, lines, viewport) = layout(self.scores.as_ref(), area, &Theme::no_color());
        (lines.len(), viewport)
    }
}

impl Component for ActionsView {
    /// A viewer chooses nothing: it stays open or is closed.
    type Outcome = Picked<Infallible>;

    fn contexts(&self) -> Vec<Context> {
        vec![Context::Viewer]
    }

    fn on_action(&mut self, action: Action) -> Self::Outcome {
        match action {
            Action::Leave => Picked::Cancelled,
            Action::Move(delta) => {
                self.scroll_by(Motion::of_move(delta));
                Picked::Open
            }
            Action::HalfPage(delta) => {
                self.scroll_by(Motion::HalfPage(delta));
                Picked::Open
            }
            _ => Picked::Open,
        }
    }

    fn on_other_key(&mut self, _key: KeyEvent) -> Self::Outcome {
        Picked::Open
    }

    /// The wheel scrolls; a click changes nothing.
    fn on_mouse(&mut self, mouse: MouseEvent, _area: Rect) -> Self::Outcome {
        self.on_wheel(&mouse);
        Picked::Open
    }

    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme) {
        let (rect, lines, _) = layout(self.scores.as_ref(), area, theme);
        frame.render_widget(Clear, rect);
        let title = format!(
            "Framed actions and their matches ({})",
            keymap::hints(Context::Viewer)
        );
        let block = themed_box(theme, &title);
        scroll::render(frame, rect, block, &lines, self.scroll, theme.accent);
    }
}

/// The viewer's box over `area` (at most 110×30), its lines wrapped to it
/// and how many it shows at once.
fn layout(
    scores: Option<&ScoreOutcome>,
    area: Rect,
    t: &Theme,
) -> (Rect, Vec<Line<'static>>, usize) {
    let rect = centred(area, 110, 30);
    let inner = usize::from(rect.width.saturating_sub(2)).max(1);
    let lines = scroll::wrap_text(&lines(scores, t), inner);
    (rect, lines, usize::from(rect.height.saturating_sub(2)))
}

/// What the viewer says: S_goal's action matches, then KAS's key actions.
fn lines(scores: Option<&ScoreOutcome>, t: &Theme) -> Vec<Line<'static>> {
    let mut lines = Vec::new();
    match scores.map(|s| &s.pg2s) {
        Some(Pg2sOutcome::Ready(report)) => match &report.goal {
            Ok(goal) => {
                lines.push(Line::from(Span::styled(
                    format!(
                        "S_goal {:.3}: ground-truth action → plan action (score)",
                        goal.s_goal
                    ),
                    t.accent,
                )));
                for m in &goal.action_matches {
                    let Some(gt) = goal.gt_actions.get(m.gt) else {
                        continue;
                    };
                    let left = format!("GT {} [{}]", gt.step + 1, gt.words.join(" "));
                    let line = match (m.pred.and_then(|p| goal.pred_actions.get(p)), m.score) {
                        (Some(p), Some(score)) => Line::from(vec![
                            Span::styled(format!("✓ {left:<40} → "), t.good),
                            Span::styled(
                                format!("plan {} [{}] ({score:.3})", p.step + 1, p.words.join(" ")),
                                t.base,
                            ),
                        ]),
                        _ => Line::from(Span::styled(
                            format!("✗ {left:<40}   no plan action matched"),
                            t.bad,
                        )),
                    };
                    lines.push(line);
                }
                let unused: Vec<String> = goal
                    .pred_actions
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| !goal.action_matches.iter().any(|m| m.pred == Some(*j)))
                    .map(|(_, a)| format!("plan {} [{}]", a.step + 1, a.words.join(" ")))
                    .collect();
                if !unused.is_empty() {
                    lines.push(Line::from(Span::styled(
                        format!("plan actions matched to nothing: {}", unused.join(", ")),
                        t.muted,
                    )));
                }
            }
            Err(reason) => lines.push(Line::from(Span::styled(
                format!("no framed actions: {reason}"),
                t.warn,
            ))),
        },
        Some(Pg2sOutcome::Waiting(reason)) => lines.push(Line::from(Span::styled(
            format!("framed actions need the PG2S models: {reason}"),
            t.warn,
        ))),
        Some(Pg2sOutcome::Failed(e)) => {
            lines.push(Line::from(Span::styled(format!("PG2S failed: {e}"), t.bad)))
        }
        None => lines.push(Line::from(Span::styled("scoring…", t.muted))),
    }
    if let Some(s) = scores {
        lines.push(Line::from(""));
        lines.push(Line::from(Span::styled(
            "KAS key actions, by step:",
            t.accent,
        )));
        for (i, g) in s.kas.chunks.gt.iter().enumerate() {
            let p = s
                .kas
                .chunks
                .pred
                .get(i)
                .map(|p| p.join(" "))
                .unwrap_or_default();
            lines.push(Line::from(Span::styled(
                format!("{:>2}. GT [{}] · plan [{}]", i + 1, g.join(" "), p),
                t.base,
            )));
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use crossterm::event::{KeyCode, KeyModifiers};

    use super::*;
    use crate::workbench::component::dispatch;

    #[test]
    fn the_viewer_stays_open_until_a_close_key() {
        let mut view = ActionsView::default();
        let press = |code| KeyEvent::new(code, KeyModifiers::NONE);
        assert_eq!(
            dispatch(&mut view, &press(KeyCode::Char('x'))),
            Picked::Open
        );
        assert_eq!(dispatch(&mut view, &press(KeyCode::Down)), Picked::Open);
        for code in [KeyCode::Esc, KeyCode::Char('q'), KeyCode::Enter] {
            assert_eq!(dispatch(&mut view, &press(code)), Picked::Cancelled);
        }
    }
}
