//! Colour themes read from `themes/*.toml` (built in) and from the user's
//! `$XDG_CONFIG_HOME/mapvlm/themes/`, and the colourless theme `NO_COLOR` asks for.

use std::path::Path;
use std::str::FromStr;

use ratatui::style::{Color, Modifier, Style};
use serde::Deserialize;

/// The themes shipped with mapvlm, as (file name, TOML text).
const BUILT_IN: [(&str, &str); 3] = [
    ("dark.toml", include_str!("../../themes/dark.toml")),
    ("light.toml", include_str!("../../themes/light.toml")),
    (
        "high-contrast.toml",
        include_str!("../../themes/high-contrast.toml"),
    ),
];

/// The name of the theme used when `NO_COLOR` is set.
pub const NO_COLOR_NAME: &str = "no-color";

/// A theme file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ThemeFile {
    name: String,
    background: String,
    foreground: String,
    muted: String,
    border: String,
    focus: String,
    title: String,
    accent: String,
    good: String,
    warn: String,
    bad: String,
    selection: String,
    highlight: String,
}

/// The styles every view draws with.
#[derive(Debug, Clone, PartialEq)]
pub struct Theme {
    /// The theme's name.
    pub name: String,
    /// Ordinary text on the background.
    pub base: Style,
    /// Secondary text: hints, explanations.
    pub muted: Style,
    /// Borders of panes without focus.
    pub border: Style,
    /// The border of the focused pane.
    pub focus: Style,
    /// Pane titles.
    pub title: Style,
    /// Emphasis: agent names, keys in the help.
    pub accent: Style,
    /// Matched steps, finished agents, good scores.
    pub good: Style,
    /// Waiting, running, partial scores.
    pub warn: Style,
    /// Unmatched steps, failures.
    pub bad: Style,
    /// The selected line.
    pub selection: Style,
    /// Search hits.
    pub highlight: Style,
}

/// Why a theme file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ThemeError {
    /// Not valid TOML or missing fields.
    #[error("{file}: {message}")]
    Parse {
        /// The file name.
        file: String,
        /// What was wrong.
        message: String,
    },
}

fn colour(file: &str, field: &str, value: &str) -> Result<Color, ThemeError> {
    Color::from_str(value).map_err(|_| ThemeError::Parse {
        file: file.to_string(),
        message: format!(
            "`{field} = \"{value}\"` is not a colour; use a name such as \"blue\" or \"#rrggbb\""
        ),
    })
}

impl Theme {
    /// Parses a theme from its TOML text; `file` names it in errors.
    pub fn from_toml(file: &str, text: &str) -> Result<Theme, ThemeError> {
        let t: ThemeFile = toml::from_str(text).map_err(|e| ThemeError::Parse {
            file: file.to_string(),
            message: e.message().to_string(),
        })?;
        let c = |field: &str, v: &str| colour(file, field, v);
        let bg = c("background", &t.background)?;
        let on_bg = |fg: Color| Style::new().fg(fg).bg(bg);
        Ok(Theme {
            name: t.name,
            base: on_bg(c("foreground", &t.foreground)?),
            muted: on_bg(c("muted", &t.muted)?),
            border: on_bg(c("border", &t.border)?),
            focus: on_bg(c("focus", &t.focus)?).add_modifier(Modifier::BOLD),
            title: on_bg(c("title", &t.title)?).add_modifier(Modifier::BOLD),
            accent: on_bg(c("accent", &t.accent)?),
            good: on_bg(c("good", &t.good)?),
            warn: on_bg(c("warn", &t.warn)?),
            bad: on_bg(c("bad", &t.bad)?),
            selection: Style::new()
                .fg(c("foreground", &t.foreground)?)
                .bg(c("selection", &t.selection)?),
            highlight: on_bg(c("highlight", &t.highlight)?).add_modifier(Modifier::UNDERLINED),
        })
    }

    /// The background as a pixel, when the theme names it exactly
    /// (`#rrggbb`): a picture that does not fill its cells is padded with
    /// it, so the padding is the pane's colour whatever the terminal's own
    /// background is (a sixel's unpainted pixels take the terminal's
    /// current background, which inside tmux is the outer terminal's
    /// default: a white strip in xterm).
    pub fn picture_background(&self) -> Option<[u8; 3]> {
        match self.base.bg {
            Some(Color::Rgb(r, g, b)) => Some([r, g, b]),
            _ => None,
        }
    }

    /// The theme for `NO_COLOR`: the terminal's own colours, with bold,
    /// reverse and underline carrying the meaning colour would.
    pub fn no_color() -> Theme {
        let plain = Style::new();
        Theme {
            name: NO_COLOR_NAME.to_string(),
            base: plain,
            muted: plain,
            border: plain,
            focus: plain.add_modifier(Modifier::BOLD),
            title: plain.add_modifier(Modifier::BOLD),
            accent: plain.add_modifier(Modifier::BOLD),
            good: plain,
            warn: plain.add_modifier(Modifier::ITALIC),
            bad: plain.add_modifier(Modifier::BOLD),
            selection: plain.add_modifier(Modifier::REVERSED),
            highlight: plain.add_modifier(Modifier::UNDERLINED),
        }
    }
}

/// The themes available: the built-in ones, then the user's, in name order.
/// Files that cannot be used are reported, not fatal.
pub fn load_themes(user_dir: Option<&Path>) -> (Vec<Theme>, Vec<String>) {
    let mut themes = Vec::new();
    let mut problems = Vec::new();
    for (file, text) in BUILT_IN {
        match Theme::from_toml(file, text) {
            Ok(t) => themes.push(t),
            Err(e) => problems.push(e.to_string()),
        }
    }
    let Some(dir) = user_dir else {
        return (themes, problems);
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return (themes, problems);
    };
    let mut paths: Vec<_> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    for path in paths {
        let file = path.display().to_string();
        let loaded = std::fs::read_to_string(&path)
            .map_err(|e| format!("{file}: {e}"))
            .and_then(|text| Theme::from_toml(&file, &text).map_err(|e| e.to_string()));
        match loaded {
            Ok(t) => {
                themes.retain(|old| old.name != t.name);
                themes.push(t);
            }
            Err(e) => problems.push(e),
        }
    }
    (themes, problems)
}

/// The theme called `name` among `themes`: `--theme` names one of them, and
/// a name that is none (a typo) is refused before the screen opens rather
/// than silently started in another.
pub fn named<'a>(themes: &'a [Theme], name: &str) -> Result<&'a Theme, UnknownTheme> {
    themes
        .iter()
        .find(|t| t.name == name)
        .ok_or_else(|| UnknownTheme {
            name: name.to_string(),
            known: themes
                .iter()
                .map(|t| t.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        })
}

/// A `--theme` that names no theme.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("--theme {}: there is no such theme; give one of {known} (or add NAME.toml to the theme folder)", crate::sanitize::for_terminal(.name))]
pub struct UnknownTheme {
    /// The name given.
    pub name: String,
    /// The themes there are, comma-separated.
    pub known: String,
}

/// The user's theme folder, `$XDG_CONFIG_HOME/mapvlm/themes` or
/// `$HOME/.config/mapvlm/themes`.
pub fn user_theme_dir() -> Option<std::path::PathBuf> {
    let base = std::env::var_os("XDG_CONFIG_HOME")
        .filter(|v| !v.is_empty())
        .map(std::path::PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME")
                .filter(|v| !v.is_empty())
                .map(|h| std::path::PathBuf::from(h).join(".config"))
        })?;
    Some(base.join("mapvlm").join("themes"))
}

/// Whether `NO_COLOR` asks for no colour (set and not empty).
pub fn no_color_requested() -> bool {
    std::env::var_os("NO_COLOR").is_some_and(|v| !v.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_themes_parse() {
        let (themes, problems) = load_themes(None);
        assert!(problems.is_empty(), "{problems:?}");
        let names: Vec<_> = themes.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names, ["dark", "light", "high-contrast"]);
    }

    #[test]
    fn a_bad_colour_names_the_field() {
        let text = BUILT_IN[0].1.replace("#d8dee9", "not-a-colour");
        let err = Theme::from_toml("mine.toml", &text)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("mine.toml") && err.contains("foreground"),
            "{err}"
        );
    }

    #[test]
    fn user_themes_add_and_replace() {
        let dir = tempfile::tempdir().unwrap();
        let text = BUILT_IN[0].1.replace("name = \"dark\"", "name = \"mine\"");
        std::fs::write(dir.path().join("mine.toml"), text).unwrap();
        std::fs::write(dir.path().join("bad.toml"), "name = 3").unwrap();
        let (themes, problems) = load_themes(Some(dir.path()));
        assert_eq!(themes.len(), 4);
        assert_eq!(problems.len(), 1);
        assert!(problems[0].contains("bad.toml"));
    }
}
