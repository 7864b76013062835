//! The integration tests, as one test binary (as ripgrep's are): one link of
//! the crate instead of one per area. Each area is a module; run one area
//! with `cargo test --test it tui_e2e::` or one test by its full name, e.g.
//! `cargo test --test it cli_score::pairs_file_scores_each_pair`.
//!
//! Shared support lives in `common` (the real binary, data, tmux, a local
//! server), `agents_support` (a provider server) and `hub_support` (a Hub
//! server).

mod agents_support;
mod common;
mod hub_support;

mod agents_providers;
mod agents_recorded;
mod agents_replay;
mod annotate_e2e;
mod annotate_screen;
mod cache_cli;
mod cli_agree;
mod cli_completions;
mod cli_corrupt;
mod cli_eval;
mod cli_plan;
mod cli_score;
mod cli_shards;
mod corrupt_blind;
mod corrupt_seeds;
mod deploy;
mod docs;
mod en_parse;
mod eval_batch;
mod eval_safety;
mod faults_hostile;
mod faults_input;
mod faults_limits;
mod faults_paths_and_flags;
mod faults_provider;
mod kas_golden;
mod keyed_vectors;
mod models;
mod models_cli;
mod models_fetch_faults;
mod models_hf_cli;
mod models_hub;
mod mpnet;
mod pg2s_golden;
mod run_diff_e2e;
mod tls_and_gzip;
mod tui;
mod tui_agents;
mod tui_corrupt;
mod tui_e2e;
mod tui_graphics;
mod tui_providers;
mod tui_runs;
mod tui_xterm;
mod wordvec;
