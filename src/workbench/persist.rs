//! When the loop copies the session for the saver ([`Persist`]): what the
//! copy holds is [`crate::workbench::app::App::to_session`].

use std::time::Instant;

use crate::workbench::snapshot::{Snapshot, SnapshotPacer, SNAPSHOT_EVERY};

/// The session copies of the loop: when the next one is due, and how many
/// were taken (a copy is the costly part of saving, so tests check that
/// typing does not take one a keystroke).
#[derive(Debug, Clone)]
pub struct Persist {
    pacer: SnapshotPacer,
    taken: u64,
    was_editing: bool,
}

impl Persist {
    /// No copy taken yet, paced at [`SNAPSHOT_EVERY`].
    pub fn new() -> Self {
        Self {
            pacer: SnapshotPacer::new(SNAPSHOT_EVERY),
            taken: 0,
            was_editing: false,
        }
    }

    /// How many copies of the session
    /// [`crate::workbench::app::App::poll_snapshot`] has taken.
    pub fn taken(&self) -> u64 {
        self.taken
    }

    /// Whether a copy is due now (`changed`: the session changed since the
    /// last poll; `editing`: an editor is open, and a copy is taken at once
    /// when one was just closed), and otherwise when to ask again.
    pub fn due(&mut self, changed: bool, editing: bool, now: Instant) -> Snapshot {
        if changed {
            self.pacer.changed();
        }
        let committed = self.was_editing && !editing;
        self.was_editing = editing;
        let due = self.pacer.poll(committed, now);
        if due == Snapshot::Take {
            self.taken += 1;
        }
        due
    }
}

impl Default for Persist {
    fn default() -> Self {
        Self::new()
    }
}
