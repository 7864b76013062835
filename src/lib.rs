//! mapvlm: multi-agent planning with visual language models, and the PG2S and
//! KAS plan metrics, as a library, a headless command line and a terminal UI.
//!
//! Data flows one way: a dataset or scene goes to the agents, the agents make a
//! plan, the metrics judge the plan, and the views show all of it.

#![warn(missing_docs)]

pub mod agents;
pub mod agree;
pub mod annotate;
pub mod cli;
pub mod corrupt;
pub mod dataset;
pub mod demo;
pub mod eval_record;
pub mod fsutil;
pub mod limits;
pub mod locale;
pub mod lock;
pub mod metrics;
pub mod models;
pub mod nlp;
pub mod plan;
pub mod sanitize;
pub mod shard;
pub mod stats;
pub mod store;
pub mod workbench;
