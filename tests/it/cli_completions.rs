//! `mapvlm completions SHELL` and `mapvlm man` cover every subcommand of the
//! command line. The list comes from the clap definition itself, so a
//! subcommand added later is checked without touching this test.

use std::process::Command;

use clap::CommandFactory;
use mapvlm::cli::Cli;

/// Every subcommand as the words a user types, e.g. `["models", "fetch"]`.
fn subcommand_paths(command: &clap::Command, prefix: &[String], out: &mut Vec<Vec<String>>) {
    for sub in command.get_subcommands().filter(|s| !s.is_hide_set()) {
        let mut path = prefix.to_vec();
        path.push(sub.get_name().to_string());
        out.push(path.clone());
        subcommand_paths(sub, &path, out);
    }
}

fn all_subcommands() -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    subcommand_paths(&Cli::command(), &[], &mut paths);
    assert!(
        paths.iter().any(|p| p == &["models", "fetch"]),
        "the walk found no nested subcommand: {paths:?}"
    );
    paths
}

fn mapvlm(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_mapvlm"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "mapvlm {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn every_shell_completes_every_subcommand() {
    let paths = all_subcommands();
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let script = mapvlm(&["completions", shell]);
        for path in &paths {
            let name = path.last().unwrap();
            assert!(
                script.contains(name.as_str()),
                "{shell} completion lacks `{}`",
                path.join(" ")
            );
        }
    }
}

#[test]
fn bash_completion_knows_nested_subcommands_by_their_parent() {
    let script = mapvlm(&["completions", "bash"]);
    // clap_complete names each bash state after the full path.
    for path in all_subcommands() {
        let words: Vec<String> = path.iter().map(|w| w.replace('-', "__subcmd__")).collect();
        let state = format!("mapvlm__subcmd__{}", words.join("__subcmd__"));
        assert!(script.contains(&state), "bash completion lacks {state}");
    }
}

#[test]
fn man_page_has_a_section_for_every_subcommand() {
    let page = mapvlm(&["man"]);
    assert!(
        page.starts_with(".ie"),
        "not roff: {}",
        &page[..80.min(page.len())]
    );
    assert!(page.contains(".TH mapvlm 1"), "no title line");
    for path in all_subcommands() {
        let heading = format!(".SH \"MAPVLM {}\"", path.join(" ").to_uppercase());
        assert!(page.contains(&heading), "man page lacks {heading}");
    }
    // Options of a nested subcommand are documented too.
    assert!(
        page.contains("\\-\\-json"),
        "man page lacks the --json option"
    );
}

#[test]
fn an_unknown_shell_is_refused_with_the_list_of_known_ones() {
    let out = Command::new(env!("CARGO_BIN_EXE_mapvlm"))
        .args(["completions", "tcsh"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("bash") && stderr.contains("zsh"),
        "{stderr}"
    );
}
