//! The options of the screens that draw the scene image (`mapvlm tui`,
//! `mapvlm annotate`): which graphics protocol, and how long the terminal
//! has to answer the start-up query.

use std::time::Duration;

use clap::{Args, ValueEnum};

use crate::workbench::graphics::Request;
use crate::workbench::terminal_query::QUERY_TIMEOUT;

/// How the scene image is drawn.
#[derive(Debug, Args)]
pub struct GraphicsArgs {
    /// How to draw the scene image: auto asks the terminal; sixel, kitty
    /// and iterm2 force a protocol (e.g. over a slow link); halfblocks and
    /// none need no graphics (default: `graphics` in the config file, else
    /// auto).
    #[arg(long, value_enum, value_name = "HOW")]
    pub graphics: Option<Request>,
    /// The same as `--graphics halfblocks`.
    #[arg(long, conflicts_with = "graphics")]
    pub halfblocks: bool,
    /// Milliseconds the terminal has to answer the start-up query (10 to
    /// 10000).
    #[arg(long, value_name = "MS", default_value_t = QUERY_TIMEOUT.as_millis() as u64, value_parser = clap::value_parser!(u64).range(10..=10_000))]
    pub query_timeout: u64,
}

impl GraphicsArgs {
    /// What the user asked for: the flags, else the config file's
    /// `graphics` (which must be one of the flag's values), else auto.
    pub fn request(&self, configured: Option<&str>) -> anyhow::Result<Request> {
        if self.halfblocks {
            return Ok(Request::Halfblocks);
        }
        if let Some(request) = self.graphics {
            return Ok(request);
        }
        match configured {
            None => Ok(Request::Auto),
            Some(name) => Request::from_str(name, true).map_err(|_| {
                anyhow::anyhow!(
                    "the config file's graphics = {:?} is not one of auto, sixel, kitty, iterm2, halfblocks, none; fix that entry",
                    crate::sanitize::for_terminal(name)
                )
            }),
        }
    }

    /// How long the terminal has to answer.
    pub fn timeout(&self) -> Duration {
        Duration::from_millis(self.query_timeout)
    }
}
