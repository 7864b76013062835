//! When the loop copies the session for the saver. Copying it is the costly
//! part of saving (every step, prompt and run record), so it is not done
//! for every keystroke of an editor or every streamed token: at once when
//! an edit is committed or after a quiet spell, otherwise at most every
//! [`SNAPSHOT_EVERY`]. With the saver's own [`super::SAVE_EVERY`] a kill
//! loses at most the last second.

use std::time::{Duration, Instant};

/// The longest a change waits before the session is copied for the saver.
pub const SNAPSHOT_EVERY: Duration = Duration::from_millis(600);

/// What the loop should do about the session copy now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Snapshot {
    /// Copy the session now.
    Take,
    /// A change waits: wake up at this instant and ask again.
    WaitUntil(Instant),
    /// Nothing changed since the last copy.
    Idle,
}

/// Paces the session copies: see the module documentation.
#[derive(Debug, Clone)]
pub struct SnapshotPacer {
    every: Duration,
    last: Option<Instant>,
    pending: bool,
}

impl SnapshotPacer {
    /// A pacer copying at most every `every` while changes stream in.
    pub fn new(every: Duration) -> Self {
        Self {
            every,
            last: None,
            pending: false,
        }
    }

    /// Notes that the session changed.
    pub fn changed(&mut self) {
        self.pending = true;
    }

    /// Whether to copy now; `committed` when an edit was just committed.
    pub fn poll(&mut self, committed: bool, now: Instant) -> Snapshot {
        if !self.pending {
            return Snapshot::Idle;
        }
        let due = self.last.map(|last| last + self.every);
        match due {
            Some(due) if !committed && now < due => Snapshot::WaitUntil(due),
            _ => {
                self.last = Some(now);
                self.pending = false;
                Snapshot::Take
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typing_is_copied_at_most_every_period_and_a_commit_at_once() {
        let start = Instant::now();
        let every = Duration::from_millis(600);
        let mut pacer = SnapshotPacer::new(every);
        assert_eq!(pacer.poll(false, start), Snapshot::Idle);
        let mut taken = 0;
        // 100 keystrokes in one second, 10 ms apart.
        for i in 0..100 {
            pacer.changed();
            let now = start + Duration::from_millis(10 * i);
            match pacer.poll(false, now) {
                Snapshot::Take => taken += 1,
                Snapshot::WaitUntil(at) => assert!(at <= now + every),
                Snapshot::Idle => panic!("a change is pending"),
            }
        }
        assert_eq!(taken, 2, "copied at 0 ms and 600 ms only");
        pacer.changed();
        assert_eq!(
            pacer.poll(true, start + Duration::from_millis(1000)),
            Snapshot::Take
        );
        assert_eq!(
            pacer.poll(false, start + Duration::from_millis(1001)),
            Snapshot::Idle
        );
    }
}
