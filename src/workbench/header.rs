//! The header line: what is open and how it runs, fitted to the terminal's
//! width by giving up the least important fields first, each shortened or
//! left out as a whole, so nothing is cut silently at the edge. What agents
//! run on (provider and model) and whether PG2S can score go last.

use ratatui::style::Style;
use ratatui::text::{Line, Span};

use crate::workbench::scroll::{cut_line, text_width, truncate};

/// The shortest a cut task text is still worth showing (it is in the Scene
/// pane too); below it the task is left out.
const TASK_MIN: usize = 16;

/// What the header shows, each with its style.
pub struct Header {
    /// `mapvlm`.
    pub name: Span<'static>,
    /// The task's id, or `demo`.
    pub source: Span<'static>,
    /// How the scene is drawn and why (`halfblocks: no answer from the
    /// terminal in 400 ms (--graphics sixel forces)`), shown without its
    /// closing parenthesis, or as the protocol's name alone (`halfblocks`,
    /// the text before the colon) when there is no room; `None` until the
    /// terminal has been asked.
    pub graphics: Option<Span<'static>>,
    /// The robot's task.
    pub task: Span<'static>,
    /// The approach's name.
    pub approach: Span<'static>,
    /// The providers and models of the agents.
    pub providers: Span<'static>,
    /// Whether the PG2S models are ready.
    pub models: Span<'static>,
    /// The separators' style.
    pub border: Style,
}

/// The fields after the name, in the order shown.
type Fields = [Option<Span<'static>>; 6];
const GRAPHICS: usize = 1;
const TASK: usize = 2;
const APPROACH: usize = 3;
const MODELS: usize = 5;

impl Header {
    /// The header within `width` columns: the task cut with `…` to the
    /// room left (down to a few words) whenever that is enough, else, in
    /// this order, the graphics' closing parenthesis left out, the task
    /// left out, the approach left out, the graphics' reason left out for
    /// the protocol's name, the graphics left out, the models' state left
    /// out; what still does not fit (very long model names) is cut with `…`.
    pub fn line(self, width: u16) -> Line<'static> {
        let width = usize::from(width);
        let Header {
            name,
            source,
            graphics,
            task,
            approach,
            providers,
            models,
            border,
        } = self;
        let (medium, short) = match &graphics {
            Some(g) => {
                let form = |text: &str| Some(Span::styled(text.to_string(), g.style));
                let medium = match g.content.rfind(" (") {
                    Some(at) if g.content.ends_with(')') => form(&g.content[..at]),
                    _ => graphics.clone(),
                };
                (
                    medium,
                    form(g.content.split(':').next().unwrap_or_default()),
                )
            }
            None => (None, None),
        };
        let mut fields: Fields = [
            Some(source),
            graphics,
            Some(task),
            Some(approach),
            Some(providers),
            Some(models),
        ];
        // ` mapvlm │ a │ b`: three columns between fields, two after the name.
        let used = |fields: &Fields| {
            let present: Vec<&Span> = fields.iter().flatten().collect();
            let text: usize = present.iter().map(|s| text_width(&s.content)).sum();
            text_width(&name.content) + text + (3 * present.len()).saturating_sub(1)
        };
        // The task cut to the room the others leave, when that is enough.
        let fit_task = |fields: &mut Fields| {
            let over = used(fields);
            if let Some(task) = &mut fields[TASK] {
                let room = width.saturating_sub(over - text_width(&task.content));
                if over > width && room >= TASK_MIN {
                    task.content = truncate(&task.content, room).into();
                }
            }
        };
        let steps: [&dyn Fn(&mut Fields); 6] = [
            &|f| f[GRAPHICS] = medium.clone(),
            &|f| f[TASK] = None,
            &|f| f[APPROACH] = None,
            &|f| f[GRAPHICS] = short.clone(),
            &|f| f[GRAPHICS] = None,
            &|f| f[MODELS] = None,
        ];
        for step in steps {
            fit_task(&mut fields);
            if used(&fields) <= width {
                break;
            }
            step(&mut fields);
        }
        let mut spans = vec![name];
        for (i, field) in fields.into_iter().flatten().enumerate() {
            spans.push(Span::styled(if i == 0 { "│ " } else { " │ " }, border));
            spans.push(field);
        }
        cut_line(Line::from(spans), width)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(task: &str, graphics: bool) -> Header {
        Header {
            name: Span::raw(" mapvlm "),
            source: Span::raw("demo"),
            graphics: graphics.then(|| {
                Span::raw(
                    "halfblocks: no answer from the terminal in 400 ms (--graphics sixel forces)",
                )
            }),
            task: Span::raw(task.to_string()),
            approach: Span::raw("multi-image"),
            providers: Span::raw("SKM·GKM openai/gpt-4o, Planner anthropic/claude-sonnet-4-5"),
            models: Span::raw("models ready"),
            border: Style::new(),
        }
    }

    fn text(line: &Line) -> String {
        line.spans.iter().map(|s| s.content.as_ref()).collect()
    }

    const TASK: &str = "Put a rinsed mug in the coffee machine and turn it on.";

    #[test]
    fn everything_fits_on_a_wide_terminal() {
        let line = header(TASK, true).line(250);
        assert_eq!(
            text(&line),
            " mapvlm │ demo │ halfblocks: no answer from the terminal in 400 ms \
             (--graphics sixel forces) │ Put a rinsed mug in the coffee machine and turn \
             it on. │ multi-image │ SKM·GKM openai/gpt-4o, Planner \
             anthropic/claude-sonnet-4-5 │ models ready"
        );
    }

    #[test]
    fn the_least_important_fields_go_first_and_providers_and_models_stay() {
        for width in [60u16, 80, 100, 120, 140, 160, 200] {
            for graphics in [false, true] {
                let line = header(TASK, graphics).line(width);
                let shown = text(&line);
                assert!(line.width() <= usize::from(width), "{width}: {shown}");
                if width >= 100 {
                    assert!(
                        shown
                            .contains("SKM·GKM openai/gpt-4o, Planner anthropic/claude-sonnet-4-5")
                            && shown.contains("models ready"),
                        "{width}: {shown}"
                    );
                }
                // The task is whole, cut with an ellipsis, or not there.
                if shown.contains("Put a") && !shown.contains(TASK) {
                    let task = shown.split(" │ ").find(|f| f.starts_with("Put a")).unwrap();
                    assert!(
                        task.ends_with('…') && text_width(task) >= TASK_MIN,
                        "{shown}"
                    );
                }
            }
        }
        let narrow = text(&header(TASK, true).line(140));
        assert!(
            narrow.contains("│ halfblocks │"),
            "the protocol's name stays: {narrow}"
        );
        let medium = text(&header(TASK, true).line(150));
        assert!(
            medium.contains("│ halfblocks: no answer from the terminal in 400 ms │ SKM·GKM"),
            "the reason without its parenthesis, before the approach and the task: {medium}"
        );
        let wider = text(&header(TASK, true).line(180));
        assert!(
            wider.contains("in 400 ms │ Put a rinsed mug in… │ multi-image │"),
            "the task cut to the room left: {wider}"
        );
        let wide = text(&header(TASK, true).line(220));
        assert!(
            wide.contains("(--graphics sixel forces) │ Put a rinsed"),
            "{wide}"
        );
    }

    #[test]
    fn what_still_does_not_fit_is_cut_with_an_ellipsis() {
        let line = header(TASK, true).line(50);
        let shown = text(&line);
        assert_eq!(line.width(), 50, "{shown}");
        assert!(shown.ends_with('…'), "{shown}");
        assert!(
            shown.starts_with(" mapvlm │ demo │ SKM·GKM openai/gpt-4o"),
            "{shown}"
        );
    }
}
