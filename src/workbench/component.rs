//! The shape of every part of the workbench that has keys: it owns its
//! state, is handed the actions the key table resolves for its contexts
//! (and the keys the table leaves unbound there, such as typed text), and
//! draws itself. New screens and overlays implement [`Component`] and
//! declare their keys in [`crate::workbench::keymap::BINDINGS`].

use crossterm::event::{KeyEvent, MouseEvent};
use ratatui::layout::Rect;
use ratatui::Frame;

use super::keymap::{self, Action, Context};
use super::scroll::wheel_step;
use super::theme::Theme;

/// A pane, overlay or screen that owns its state, its keys and its drawing.
pub trait Component {
    /// What handling a key asks of the component's owner (messages,
    /// commands, "close me").
    type Outcome;

    /// The key contexts whose bindings reach the component, the first
    /// binding a key wins.
    fn contexts(&self) -> Vec<Context>;

    /// Carries out an action the key table resolved.
    fn on_action(&mut self, action: Action) -> Self::Outcome;

    /// Handles a key that no binding of [`Component::contexts`] names.
    fn on_other_key(&mut self, key: KeyEvent) -> Self::Outcome;

    /// Draws the component in `area`, a pure function of its state.
    fn draw(&self, frame: &mut Frame, area: Rect, theme: &Theme);

    /// Handles the mouse over `area`, the screen the component is drawn
    /// in: by default the wheel moves as ↓ and ↑ do, a line a notch, and a
    /// click moves nothing. Components with rows to click override it.
    fn on_mouse(&mut self, mouse: MouseEvent, area: Rect) -> Self::Outcome {
        let _ = area;
        self.on_action(Action::Move(wheel_step(&mouse)))
    }
}

/// What reaches a component: a key, or the mouse over the screen area it
/// is drawn in.
#[derive(Debug, Clone, Copy)]
pub enum Input {
    /// A key.
    Key(KeyEvent),
    /// The mouse, over the screen area given.
    Mouse(MouseEvent, Rect),
}

/// Hands `input` to `component`: a key through the key table
/// ([`dispatch`]), the mouse to [`Component::on_mouse`].
pub fn deliver<C: Component>(component: &mut C, input: &Input) -> C::Outcome {
    match input {
        Input::Key(key) => dispatch(component, key),
        Input::Mouse(mouse, area) => component.on_mouse(*mouse, *area),
    }
}

/// Hands `key` to `component`: as the action the key table binds it to in
/// the component's contexts, else as a plain key.
pub fn dispatch<C: Component>(component: &mut C, key: &KeyEvent) -> C::Outcome {
    match keymap::action(&component.contexts(), key) {
        Some(action) => component.on_action(action),
        None => component.on_other_key(*key),
    }
}
