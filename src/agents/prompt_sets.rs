//! Named prompt sets: a folder per set under
//! `$XDG_CONFIG_HOME/mapvlm/prompt-sets/`, holding one `TEMPLATE.txt` file
//! per template, the layout [`PromptSet::load`] reads. A set is plain text
//! a user can diff, commit and share, and `--prompts DIR` (plan, eval, the
//! workbench) runs it.

use std::path::{Path, PathBuf};

use super::prompts::PromptSet;
use super::AgentError;
use crate::fsutil::write_atomic;

/// The longest name a prompt set may have.
pub const MAX_NAME_CHARS: usize = 64;

/// Why a prompt set could not be saved, listed or loaded.
#[derive(Debug, thiserror::Error)]
pub enum PromptSetError {
    /// The name cannot be a folder name of a set.
    #[error(
        "prompt set name `{name}` {why}: use letters, digits, `-`, `_` and `.` \
         (at most {MAX_NAME_CHARS}, not starting with `.`)"
    )]
    BadName {
        /// The name as given.
        name: String,
        /// What is wrong with it.
        why: &'static str,
    },
    /// Neither `XDG_CONFIG_HOME` nor `HOME` is set.
    #[error("no folder for prompt sets: set XDG_CONFIG_HOME or HOME")]
    NoFolder,
    /// No set of that name was saved.
    #[error("no prompt set `{name}` in {}: save one first", root.display())]
    Missing {
        /// The name asked for.
        name: String,
        /// The folder of the sets.
        root: PathBuf,
    },
    /// A file could not be read or written, or a template did not parse.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// A file could not be written whole (see [`crate::fsutil`]).
    #[error(transparent)]
    Write(#[from] crate::fsutil::FsError),
}

/// The folder of the named sets: `$XDG_CONFIG_HOME/mapvlm/prompt-sets`,
/// else `$HOME/.config/mapvlm/prompt-sets`.
pub fn default_root() -> Option<PathBuf> {
    PromptSet::default_dir().map(|prompts| prompts.with_file_name("prompt-sets"))
}

/// Checks that `name` can name a set: a plain folder name, never a path.
pub fn check_name(name: &str) -> Result<(), PromptSetError> {
    let bad = |why| PromptSetError::BadName {
        name: name.to_string(),
        why,
    };
    if name.is_empty() {
        return Err(bad("is empty"));
    }
    if name.chars().count() > MAX_NAME_CHARS {
        return Err(bad("is too long"));
    }
    if name.starts_with('.') {
        return Err(bad("starts with `.`"));
    }
    if !name
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(bad(
            "has a character other than a letter, digit, `-`, `_` or `.`",
        ));
    }
    Ok(())
}

/// Writes every template of `set` as `ROOT/NAME/TEMPLATE.txt`, each file
/// atomically (a reader never sees half a file), and returns the folder.
pub fn save(root: &Path, name: &str, set: &PromptSet) -> Result<PathBuf, PromptSetError> {
    check_name(name)?;
    let dir = root.join(name);
    for template in set.iter() {
        let file = dir.join(format!("{}.txt", template.name));
        write_atomic(&file, format!("{}\n", template.text()).as_bytes())?;
    }
    Ok(dir)
}

/// Reads the set `ROOT/NAME` (templates it lacks are the shipped ones).
pub fn load(root: &Path, name: &str) -> Result<PromptSet, PromptSetError> {
    check_name(name)?;
    let dir = root.join(name);
    if !dir.is_dir() {
        return Err(PromptSetError::Missing {
            name: name.to_string(),
            root: root.to_path_buf(),
        });
    }
    Ok(PromptSet::load(Some(&dir))?)
}

/// The names of the sets saved under `root`, sorted; none when the folder
/// does not exist yet.
pub fn list(root: &Path) -> Result<Vec<String>, PromptSetError> {
    let entries = match std::fs::read_dir(root) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => {
            return Err(AgentError::Io {
                path: root.to_path_buf(),
                message: e.to_string(),
            }
            .into())
        }
    };
    let mut names: Vec<String> = entries
        .flatten()
        .filter(|e| e.path().is_dir())
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|name| check_name(name).is_ok())
        .collect();
    names.sort();
    Ok(names)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::prompts::Template;
    use crate::agents::{AgentRole, Approach};

    fn edited() -> PromptSet {
        let set = PromptSet::load(None).unwrap();
        let skm = set.get(Approach::MultiImage, AgentRole::Skm).unwrap();
        let text = format!("{}\nName every towel.", skm.text());
        let template = Template::parse(&skm.name, "test", &text).unwrap();
        set.with(template)
    }

    fn texts(set: &PromptSet) -> Vec<(String, String)> {
        set.iter().map(|t| (t.name.clone(), t.text())).collect()
    }

    #[test]
    fn a_saved_set_loads_back_to_the_same_prompts_and_is_listed() {
        let root = tempfile::tempdir().unwrap();
        let set = edited();
        let dir = save(root.path(), "towels-v2", &set).unwrap();
        assert_eq!(dir, root.path().join("towels-v2"));
        let file = std::fs::read_to_string(dir.join("multi-image-skm.txt")).unwrap();
        assert!(file.starts_with("[system]\n") && file.ends_with("Name every towel.\n"));
        assert_eq!(texts(&load(root.path(), "towels-v2").unwrap()), texts(&set));
        save(root.path(), "baseline", &PromptSet::load(None).unwrap()).unwrap();
        std::fs::create_dir(root.path().join(".hidden")).unwrap();
        std::fs::write(root.path().join("notes.txt"), "x").unwrap();
        assert_eq!(list(root.path()).unwrap(), ["baseline", "towels-v2"]);
        assert_eq!(
            list(&root.path().join("none")).unwrap(),
            Vec::<String>::new()
        );
    }

    #[test]
    fn bad_names_missing_sets_and_broken_files_are_one_clear_line() {
        let root = tempfile::tempdir().unwrap();
        for (name, why) in [
            ("", "is empty"),
            ("../up", "starts with `.`"),
            ("up/../x", "has a character"),
            ("a/b", "has a character"),
            (".git", "starts with `.`"),
            ("naïve", "has a character"),
        ] {
            let err = save(root.path(), name, &edited()).unwrap_err().to_string();
            assert!(err.contains(why) && !err.contains('\n'), "{name}: {err}");
        }
        assert!(check_name(&"x".repeat(65)).is_err());
        assert!(check_name(&"x".repeat(64)).is_ok());
        let err = load(root.path(), "nope").unwrap_err().to_string();
        assert!(err.starts_with("no prompt set `nope` in "), "{err}");
        let dir = save(root.path(), "broken", &edited()).unwrap();
        std::fs::write(dir.join("multi-image-gkm.txt"), "[user]\n{{nothing}}").unwrap();
        let err = load(root.path(), "broken").unwrap_err().to_string();
        assert!(
            err.contains("multi-image-gkm") && err.contains("unknown variable {{nothing}}"),
            "{err}"
        );
    }
}
