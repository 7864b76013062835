//! The documentation against the code it describes: every flag of the
//! command line is in the docs, and ARCHITECTURE.md names every module, so
//! neither can drift without a failing test.

use std::collections::BTreeSet;
use std::path::Path;

use clap::CommandFactory;
use mapvlm::cli::Cli;

/// The README and every page of `docs/`, as one text.
fn all_docs() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut text = std::fs::read_to_string(root.join("README.md")).unwrap();
    let mut pages: Vec<_> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|e| e == "md"))
        .collect();
    pages.sort();
    for page in pages {
        text += &std::fs::read_to_string(page).unwrap();
    }
    text
}

/// Whether `flag` (e.g. `--seed`) appears as a whole flag, not as the start
/// of a longer one (`--seed` inside `--seeds`).
fn mentions(docs: &str, flag: &str) -> bool {
    docs.match_indices(flag).any(|(at, _)| {
        !docs[at + flag.len()..]
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    })
}

/// Every long flag of `command` and its subcommands, with the command path it
/// belongs to, e.g. ("mapvlm eval", "--out").
fn flags(command: &clap::Command, path: &str, out: &mut BTreeSet<(String, String)>) {
    for arg in command.get_arguments() {
        if arg.is_hide_set() {
            continue;
        }
        if let Some(long) = arg.get_long() {
            if long != "help" && long != "version" {
                out.insert((path.to_string(), format!("--{long}")));
            }
        }
    }
    for sub in command.get_subcommands() {
        if sub.get_name() != "help" {
            flags(sub, &format!("{path} {}", sub.get_name()), out);
        }
    }
}

#[test]
fn every_flag_is_documented() {
    let docs = all_docs();
    let mut all = BTreeSet::new();
    flags(&Cli::command(), "mapvlm", &mut all);
    assert!(all.len() > 50, "too few flags found: {all:?}");
    let missing: Vec<String> = all
        .iter()
        .filter(|(_, flag)| !mentions(&docs, flag))
        .map(|(command, flag)| format!("{command} {flag}"))
        .collect();
    assert!(
        missing.is_empty(),
        "flags that neither the README nor docs/ mention:\n{}",
        missing.join("\n")
    );
}

#[test]
fn architecture_names_every_module() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let architecture = std::fs::read_to_string(root.join("ARCHITECTURE.md")).unwrap();
    let mut missing = Vec::new();
    let mut stack = vec![root.join("src")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") || path.ends_with("tests.rs") {
                continue;
            }
            let relative = path
                .strip_prefix(root.join("src"))
                .unwrap()
                .with_extension("");
            let module = relative.to_string_lossy().replace('\\', "/");
            let module = module.strip_suffix("/mod").unwrap_or(&module).to_string();
            if module != "lib" && module != "main" && !architecture.contains(&format!("`{module}`"))
            {
                missing.push(module);
            }
        }
    }
    missing.sort();
    assert!(
        missing.is_empty(),
        "modules ARCHITECTURE.md does not name: {missing:?}"
    );
}
