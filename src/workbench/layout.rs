//! The panes and where each goes for a terminal size, shared by rendering
//! and by mouse hit-testing so both always agree (a leaf: the panes'
//! drawing and state build on it).

use ratatui::layout::{Constraint, Layout, Rect};

/// The panes, each with the title users and tests find it by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Pane {
    /// The scene image.
    Scene,
    /// The SKM's knowledge graph.
    Graph,
    /// The GKM's grounded description.
    Description,
    /// The plan, with its matches.
    Plan,
    /// The ground truth.
    GroundTruth,
    /// The scores and the history of runs.
    Scores,
    /// The prompt editor.
    Prompt,
}

/// Which step list an editor works on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepList {
    /// The plan.
    Plan,
    /// The ground truth.
    GroundTruth,
}

impl StepList {
    /// The name the session file gives the list.
    pub fn key(self) -> &'static str {
        match self {
            StepList::Plan => "plan",
            StepList::GroundTruth => "ground_truth",
        }
    }
}

impl Pane {
    /// The panes in focus order.
    pub const ALL: [Pane; 7] = [
        Pane::Scene,
        Pane::Graph,
        Pane::Description,
        Pane::Plan,
        Pane::GroundTruth,
        Pane::Scores,
        Pane::Prompt,
    ];

    /// The pane's title.
    pub fn title(self) -> &'static str {
        match self {
            Pane::Scene => "Scene",
            Pane::Graph => "Knowledge Graph (SKM)",
            Pane::Description => "Grounded Description (GKM)",
            Pane::Plan => "Plan",
            Pane::GroundTruth => "Ground Truth",
            Pane::Scores => "Scores",
            Pane::Prompt => "Prompt",
        }
    }

    /// A short name for the tab strip of narrow terminals.
    pub fn short(self) -> &'static str {
        match self {
            Pane::Scene => "Scene",
            Pane::Graph => "Graph",
            Pane::Description => "GKM",
            Pane::Plan => "Plan",
            Pane::GroundTruth => "Truth",
            Pane::Scores => "Scores",
            Pane::Prompt => "Prompt",
        }
    }

    /// The pane's tab in the tab strip of a narrow terminal.
    pub fn tab(self) -> String {
        format!(" {} ", self.short())
    }

    /// The pane whose tab is at `column` of a tab strip starting at
    /// column `x` (each tab followed by a one-column separator).
    pub fn tab_at(x: u16, column: u16) -> Option<Pane> {
        let mut at = usize::from(x);
        let column = usize::from(column);
        for pane in Pane::ALL {
            let end = at + pane.tab().len();
            if (at..end).contains(&column) {
                return Some(pane);
            }
            at = end + 1;
        }
        None
    }

    pub(crate) fn index(self) -> usize {
        Pane::ALL.iter().position(|p| *p == self).unwrap_or(0)
    }
}

/// The smallest terminal the workbench draws in.
pub const MIN_WIDTH: u16 = 50;
/// The fewest rows the workbench draws in.
pub const MIN_HEIGHT: u16 = 14;
/// Below this width the panes are shown one at a time, with tabs.
pub const GRID_WIDTH: u16 = 100;

/// The screen's parts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Screen {
    /// Too small to draw: a message is shown instead.
    TooSmall,
    /// The header, status line, optional tab strip and visible panes.
    Panes {
        /// The header line.
        header: Rect,
        /// The status line.
        status: Rect,
        /// The tab strip of the one-pane layout.
        tabs: Option<Rect>,
        /// The panes shown, with their areas.
        panes: Vec<(Pane, Rect)>,
    },
}

/// Lays out the screen with a one-row status line: a grid of all panes
/// when wide enough, else (or when zoomed) the focused pane alone.
pub fn pane_rects(area: Rect, focus: Pane, zoom: bool) -> Screen {
    pane_rects_with(area, focus, zoom, 1)
}

/// [`pane_rects`] with a status line `status_rows` rows tall (two while a
/// message does not fit on one).
pub fn pane_rects_with(area: Rect, focus: Pane, zoom: bool, status_rows: u16) -> Screen {
    if area.width < MIN_WIDTH || area.height < MIN_HEIGHT {
        return Screen::TooSmall;
    }
    let [header, body, status] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(1),
        Constraint::Length(status_rows),
    ])
    .areas(area);
    if zoom || area.width < GRID_WIDTH {
        let (tabs, body) = if zoom {
            (None, body)
        } else {
            let [tabs, rest] =
                Layout::vertical([Constraint::Length(1), Constraint::Min(1)]).areas(body);
            (Some(tabs), rest)
        };
        return Screen::Panes {
            header,
            status,
            tabs,
            panes: vec![(focus, body)],
        };
    }
    let [top, middle, bottom] = Layout::vertical([
        Constraint::Percentage(30),
        Constraint::Percentage(40),
        Constraint::Percentage(30),
    ])
    .areas(body);
    let [scene, graph, description] = Layout::horizontal([
        Constraint::Percentage(25),
        Constraint::Percentage(40),
        Constraint::Percentage(35),
    ])
    .areas(top);
    let [plan, ground_truth] =
        Layout::horizontal([Constraint::Percentage(55), Constraint::Percentage(45)]).areas(middle);
    let [scores, prompt] =
        Layout::horizontal([Constraint::Percentage(40), Constraint::Percentage(60)]).areas(bottom);
    Screen::Panes {
        header,
        status,
        tabs: None,
        panes: vec![
            (Pane::Scene, scene),
            (Pane::Graph, graph),
            (Pane::Description, description),
            (Pane::Plan, plan),
            (Pane::GroundTruth, ground_truth),
            (Pane::Scores, scores),
            (Pane::Prompt, prompt),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wide_terminals_get_every_pane_without_overlap() {
        let Screen::Panes { panes, .. } = pane_rects(Rect::new(0, 0, 200, 60), Pane::Plan, false)
        else {
            panic!("too small")
        };
        assert_eq!(panes.len(), 7);
        for (i, (_, a)) in panes.iter().enumerate() {
            for (_, b) in &panes[i + 1..] {
                assert!(!a.intersects(*b), "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn narrow_terminals_show_the_focused_pane_with_tabs() {
        let screen = pane_rects(Rect::new(0, 0, 80, 24), Pane::Scores, false);
        let Screen::Panes { panes, tabs, .. } = screen else {
            panic!("too small")
        };
        assert_eq!(panes.len(), 1);
        assert_eq!(panes[0].0, Pane::Scores);
        assert!(tabs.is_some());
        assert_eq!(
            pane_rects(Rect::new(0, 0, 40, 10), Pane::Plan, false),
            Screen::TooSmall
        );
    }
}
