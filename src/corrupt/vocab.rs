//! The vocabularies of the swaps: household objects, places and receptacles,
//! pairs of opposite or wrong actions, and groups of words that name the
//! same thing (never swapped for each other). Built-in lists ship in the binary;
//! a user adds to them with files of the same name in their own folder.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

const BUILT_IN_OBJECTS: &str = include_str!("vocab/objects.txt");
const BUILT_IN_PLACES: &str = include_str!("vocab/places.txt");
const BUILT_IN_VERBS: &str = include_str!("vocab/verbs.txt");
const BUILT_IN_SAME: &str = include_str!("vocab/same.txt");

/// The file names of the four vocabularies, built in and in the user folder.
pub const VOCABULARY_FILES: [&str; 4] = ["objects.txt", "places.txt", "verbs.txt", "same.txt"];

/// An action of a verb pair: a verb and an optional particle (`pick up`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Action {
    /// The verb, lowercase (`pick`).
    pub verb: String,
    /// The particle, lowercase (`up`), when the action has one.
    pub particle: Option<String>,
}

impl Action {
    /// The action as written in a plan and in the record of a swap.
    pub fn phrase(&self) -> String {
        match &self.particle {
            Some(p) => format!("{} {p}", self.verb),
            None => self.verb.clone(),
        }
    }
}

/// What the swaps draw from: every list in file order, built-in words first,
/// each word once.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Vocabulary {
    /// Household objects (`mug`, `laptop`).
    pub objects: Vec<String>,
    /// Places and receptacles (`sink`, `kitchen`).
    pub places: Vec<String>,
    /// Action pairs; each works in both directions.
    pub verbs: Vec<(Action, Action)>,
    /// Groups of words that name the same thing (`fridge`, `refrigerator`):
    /// a swap between two words of one group would change nothing.
    pub same: Vec<Vec<String>>,
}

/// A vocabulary file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum VocabularyError {
    /// The file exists but cannot be read as text.
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// A line is not what the file holds.
    #[error("{}:{line}: {message}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// The 1-based line number.
        line: usize,
        /// What is wrong and what is expected.
        message: String,
    },
}

/// The user's vocabulary folder: `$XDG_CONFIG_HOME/mapvlm/corrupt`, else
/// `$HOME/.config/mapvlm/corrupt`.
pub fn user_vocabulary_dir() -> Option<PathBuf> {
    std::env::var_os("XDG_CONFIG_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME")
                .filter(|v| !v.is_empty())
                .map(|h| PathBuf::from(h).join(".config"))
        })
        .map(|base| base.join("mapvlm").join("corrupt"))
}

impl Vocabulary {
    /// The built-in lists alone.
    pub fn built_in() -> Result<Self, VocabularyError> {
        let mut vocabulary = Vocabulary {
            objects: Vec::new(),
            places: Vec::new(),
            verbs: Vec::new(),
            same: Vec::new(),
        };
        let origin = Path::new("(built in)");
        vocabulary.add(
            [
                BUILT_IN_OBJECTS,
                BUILT_IN_PLACES,
                BUILT_IN_VERBS,
                BUILT_IN_SAME,
            ],
            &VOCABULARY_FILES.map(|f| origin.join(f)),
        )?;
        Ok(vocabulary)
    }

    /// The built-in lists extended by the files of `user_dir` that exist
    /// (`objects.txt`, `places.txt`, `verbs.txt`, `same.txt`).
    pub fn load(user_dir: Option<&Path>) -> Result<Self, VocabularyError> {
        let mut vocabulary = Self::built_in()?;
        let Some(dir) = user_dir else {
            return Ok(vocabulary);
        };
        let paths = VOCABULARY_FILES.map(|f| dir.join(f));
        let mut texts: [String; 4] = Default::default();
        for (text, path) in texts.iter_mut().zip(&paths) {
            match std::fs::read_to_string(path) {
                Ok(t) => *text = t,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(error) => {
                    return Err(VocabularyError::Read {
                        path: path.clone(),
                        error,
                    })
                }
            }
        }
        vocabulary.add(texts.each_ref().map(String::as_str), &paths)?;
        Ok(vocabulary)
    }

    /// Whether `a` and `b` name the same thing, so that swapping one for
    /// the other is no corruption: the same word, a plural of the other
    /// (`book`, `books`), a compound ending in the other (`coffeetable`,
    /// `table`), or two words of one group of `same.txt`.
    pub fn same_thing(&self, a: &str, b: &str) -> bool {
        let (a, b) = (a.to_lowercase(), b.to_lowercase());
        let derived = |short: &str, long: &str| {
            long == short
                || long
                    .strip_prefix(short)
                    .is_some_and(|s| s == "s" || s == "es")
                || short
                    .strip_suffix('y')
                    .is_some_and(|stem| long == format!("{stem}ies"))
                || (short.chars().count() >= 3 && long.ends_with(short))
        };
        derived(&a, &b)
            || derived(&b, &a)
            || self
                .same
                .iter()
                .any(|group| group.contains(&a) && group.contains(&b))
    }

    /// Adds the words of the objects, places, verbs and same-thing texts.
    fn add(&mut self, texts: [&str; 4], paths: &[PathBuf; 4]) -> Result<(), VocabularyError> {
        let [objects, places, verbs, same] = texts;
        add_words(&mut self.objects, objects, &paths[0])?;
        add_words(&mut self.places, places, &paths[1])?;
        for (line, content) in lines(verbs) {
            let bad = |message: String| VocabularyError::Line {
                path: paths[2].clone(),
                line,
                message,
            };
            let (a, b) = content.split_once(',').ok_or_else(|| {
                bad(format!(
                    "`{content}` is not a pair: write two actions separated by a comma, e.g. `pick up, put down`"
                ))
            })?;
            let pair = (
                parse_action(a).map_err(&bad)?,
                parse_action(b).map_err(&bad)?,
            );
            if pair.0 == pair.1 {
                return Err(bad(format!("`{content}` pairs an action with itself")));
            }
            if !self.verbs.contains(&pair) {
                self.verbs.push(pair);
            }
        }
        for (line, content) in lines(same) {
            let group: Vec<String> = content
                .split(',')
                .map(|w| w.trim().to_lowercase())
                .collect();
            if group.len() < 2 || group.iter().any(|w| w.split_whitespace().count() != 1) {
                return Err(VocabularyError::Line {
                    path: paths[3].clone(),
                    line,
                    message: format!(
                        "`{content}` is not a group: write two or more one-word names of one thing separated by commas, e.g. `fridge, refrigerator`"
                    ),
                });
            }
            if !self.same.contains(&group) {
                self.same.push(group);
            }
        }
        Ok(())
    }
}

/// The numbered lines of a vocabulary text that hold something, with
/// comments (`# …`) and surrounding blanks removed.
fn lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().filter_map(|(n, line)| {
        let content = line.split('#').next().unwrap_or_default().trim();
        (!content.is_empty()).then_some((n + 1, content))
    })
}

/// Appends the words of a one-word-a-line text that `list` lacks.
fn add_words(list: &mut Vec<String>, text: &str, path: &Path) -> Result<(), VocabularyError> {
    let mut seen: HashSet<String> = list.iter().cloned().collect();
    for (line, content) in lines(text) {
        if content.split_whitespace().count() != 1 {
            return Err(VocabularyError::Line {
                path: path.to_path_buf(),
                line,
                message: format!(
                    "`{content}` is not one word: a word vector has one word, so write one a line"
                ),
            });
        }
        let word = content.to_lowercase();
        if seen.insert(word.clone()) {
            list.push(word);
        }
    }
    Ok(())
}

/// `verb` or `verb particle`, lowercased.
fn parse_action(text: &str) -> Result<Action, String> {
    let words: Vec<String> = text.split_whitespace().map(str::to_lowercase).collect();
    match words.as_slice() {
        [verb] => Ok(Action {
            verb: verb.clone(),
            particle: None,
        }),
        [verb, particle] => Ok(Action {
            verb: verb.clone(),
            particle: Some(particle.clone()),
        }),
        _ => Err(format!(
            "`{}` is not an action: write a verb and at most one particle, e.g. `turn on`",
            text.trim()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_lists_load_and_hold_the_spec_pairs() {
        let v = Vocabulary::built_in().unwrap_or_else(|e| panic!("{e}"));
        assert!(v.objects.contains(&"laptop".to_string()));
        assert!(v.places.contains(&"sink".to_string()));
        let phrases: Vec<(String, String)> = v
            .verbs
            .iter()
            .map(|(a, b)| (a.phrase(), b.phrase()))
            .collect();
        for (a, b) in [
            ("pick up", "put down"),
            ("open", "close"),
            ("turn on", "turn off"),
            ("heat", "cool"),
        ] {
            assert!(phrases.contains(&(a.into(), b.into())), "{a} ↔ {b}");
        }
    }

    #[test]
    fn words_of_one_thing_are_known_from_the_list_plurals_and_compounds() {
        let v = Vocabulary::built_in().unwrap_or_else(|e| panic!("{e}"));
        for (a, b) in [
            ("fridge", "refrigerator"),
            ("CD", "disc"),
            ("book", "books"),
            ("dish", "dishes"),
            ("strawberry", "strawberries"),
            ("coffeetable", "table"),
            ("sink", "basin"),
            ("basin", "bathtub"),
        ] {
            assert!(v.same_thing(a, b), "{a} {b}");
            assert!(v.same_thing(b, a), "{b} {a}");
        }
        for (a, b) in [
            ("mug", "cup"),
            ("sink", "bathtub"),
            ("pen", "pencil"),
            ("cd", "d"),
        ] {
            assert!(!v.same_thing(a, b), "{a} {b}");
        }
    }

    #[test]
    fn user_files_add_words_and_name_their_bad_lines() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.path().join("objects.txt"), "# mine\nHarmonica\nmug\n")
            .unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.path().join("verbs.txt"), "plug in, unplug\n")
            .unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.path().join("same.txt"), "mug, beaker\n")
            .unwrap_or_else(|e| panic!("{e}"));
        let v = Vocabulary::load(Some(dir.path())).unwrap_or_else(|e| panic!("{e}"));
        let built_in = Vocabulary::built_in().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(v.objects.len(), built_in.objects.len() + 1);
        assert_eq!(v.objects.last().map(String::as_str), Some("harmonica"));
        assert_eq!(v.places, built_in.places);
        assert!(v.same_thing("beaker", "mug") && !built_in.same_thing("beaker", "mug"));
        assert_eq!(
            v.verbs.last().map(|(a, b)| (a.phrase(), b.phrase())),
            Some(("plug in".into(), "unplug".into()))
        );

        std::fs::write(dir.path().join("places.txt"), "sink\nliving room\n")
            .unwrap_or_else(|e| panic!("{e}"));
        let err = Vocabulary::load(Some(dir.path())).map(|_| ()).unwrap_err();
        assert!(
            err.to_string()
                .contains("places.txt:2: `living room` is not one word"),
            "{err}"
        );
        std::fs::write(dir.path().join("places.txt"), "").unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.path().join("same.txt"), "mug\n").unwrap_or_else(|e| panic!("{e}"));
        let err = Vocabulary::load(Some(dir.path())).map(|_| ()).unwrap_err();
        assert!(
            err.to_string().contains("same.txt:1: `mug` is not a group"),
            "{err}"
        );
        std::fs::write(dir.path().join("same.txt"), "").unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.path().join("verbs.txt"), "open close\n")
            .unwrap_or_else(|e| panic!("{e}"));
        let err = Vocabulary::load(Some(dir.path())).map(|_| ()).unwrap_err();
        assert!(
            err.to_string()
                .contains("verbs.txt:1: `open close` is not a pair"),
            "{err}"
        );
    }
}
