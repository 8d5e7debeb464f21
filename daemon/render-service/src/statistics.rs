//! What the drawing thread has done, counted where the bus can read it without asking the
//! thread (which may be busy drawing): streams and drawings open, frames drawn, and how
//! many stream frames were begun while a Snapshot waited for its turn.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

/// The renderer's counters; the drawing thread writes them, anyone reads.
#[derive(Debug, Default)]
pub struct Statistics {
    streams: AtomicU64,
    drawings: AtomicU64,
    pixel_rate: AtomicU64,
    stream_memory: AtomicU64,
    frames_begun: AtomicU64,
    frames_drawn: AtomicU64,
    frames_late: AtomicU64,
    snapshots: AtomicU64,
    snapshot_wait_frames_max: AtomicU64,
}

impl Statistics {
    /// Stream frames begun so far: a Snapshot is stamped with it when it is asked for.
    pub fn frames_begun(&self) -> u64 {
        self.frames_begun.load(Ordering::Acquire)
    }

    /// A stream frame is about to be drawn; `late` when its time had passed by over a
    /// period, so that frames were dropped.
    pub fn frame_begun(&self, late: bool) {
        self.frames_begun.fetch_add(1, Ordering::AcqRel);
        if late {
            self.frames_late.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// A stream frame was drawn into its ring.
    pub fn frame_drawn(&self) {
        self.frames_drawn.fetch_add(1, Ordering::Relaxed);
    }

    /// A Snapshot stamped `stamp` (by [`Self::frames_begun`]) is being drawn.
    pub fn snapshot_served(&self, stamp: u64) {
        self.snapshots.fetch_add(1, Ordering::Relaxed);
        let waited = self.frames_begun().saturating_sub(stamp);
        self.snapshot_wait_frames_max
            .fetch_max(waited, Ordering::Relaxed);
    }

    /// The streams open now: `streams` viewers of `drawings` distinct drawings, which draw
    /// `pixel_rate` pixels a second into rings of `stream_memory` bytes.
    pub fn open(&self, streams: usize, drawings: usize, pixel_rate: u64, stream_memory: u64) {
        self.streams.store(streams as u64, Ordering::Relaxed);
        self.drawings.store(drawings as u64, Ordering::Relaxed);
        self.pixel_rate.store(pixel_rate, Ordering::Relaxed);
        self.stream_memory.store(stream_memory, Ordering::Relaxed);
    }

    /// The counters by name, as the bus shows them.
    pub fn by_name(&self) -> HashMap<String, u64> {
        let read = |counter: &AtomicU64| counter.load(Ordering::Relaxed);
        HashMap::from([
            ("streams".to_string(), read(&self.streams)),
            ("drawings".to_string(), read(&self.drawings)),
            ("pixel_rate".to_string(), read(&self.pixel_rate)),
            ("stream_memory".to_string(), read(&self.stream_memory)),
            ("frames_drawn".to_string(), read(&self.frames_drawn)),
            ("frames_late".to_string(), read(&self.frames_late)),
            ("snapshots".to_string(), read(&self.snapshots)),
            (
                "snapshot_wait_frames_max".to_string(),
                read(&self.snapshot_wait_frames_max),
            ),
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_snapshot_counts_the_frames_begun_since_it_was_asked_for() {
        let statistics = Statistics::default();
        statistics.frame_begun(false);
        let stamp = statistics.frames_begun();
        statistics.frame_begun(true);
        statistics.frame_begun(false);
        statistics.frame_drawn();
        statistics.snapshot_served(stamp);
        statistics.snapshot_served(statistics.frames_begun());
        let counters = statistics.by_name();
        assert_eq!(counters["frames_drawn"], 1);
        assert_eq!(counters["frames_late"], 1);
        assert_eq!(counters["snapshots"], 2);
        assert_eq!(counters["snapshot_wait_frames_max"], 2);
    }
}
