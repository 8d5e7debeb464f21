//! The telemetry ring's memory: a sealed memfd the haptic thread writes every tick into
//! ([`hapticd_core::telemetry`]) and any reader the daemon allows maps read-only
//! (`OpenTelemetry` on the bus). Its seals let no one else write, grow or shrink it, so a
//! reader can neither disturb nor slow the haptic thread: it only misses ticks it reads too
//! late, and is told how many.

use std::io;
use std::os::fd::OwnedFd;

use hapticd_core::telemetry::{
    Read, SHARED_SIZE, Sample, SharedTelemetry, TelemetryReader, TelemetryWriter,
};

use crate::shared_memory::{MapError, Mapping, sealed};

/// The daemon's side of one device's telemetry ring.
pub struct SharedTelemetryFile {
    fd: OwnedFd,
}

impl SharedTelemetryFile {
    /// A new ring for a loop of `rate` ticks a second, and its one writer. The writer's
    /// mapping is never unmapped: the haptic thread may write to its last tick, whatever is
    /// dropped first (a few megabytes per device, for the life of the process).
    pub fn create(rate: f64) -> io::Result<(Self, TelemetryWriter)> {
        let (fd, mapping) = sealed("hapticd-telemetry", SHARED_SIZE)?;
        // SAFETY: the mapping is SHARED_SIZE bytes, page-aligned, only this writer writes
        // it, and it is never unmapped.
        let writer =
            unsafe { TelemetryWriter::new(mapping.address().cast::<SharedTelemetry>(), rate) };
        std::mem::forget(mapping);
        Ok((Self { fd }, writer))
    }

    /// A new descriptor of the file, open for reading alone, to hand to a reader.
    pub fn share(&self) -> io::Result<OwnedFd> {
        crate::shared_memory::read_only_descriptor(&self.fd)
    }
}

/// Where a reader is in the ring: the next tick it wants, and how many it missed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Cursor {
    /// The next tick to read.
    pub next: u64,
    /// Ticks overwritten before they were read.
    pub missed: u64,
}

/// A reader's view of a telemetry ring it was handed.
///
/// ```
/// use hapticd_core::haptic_loop::Frame;
/// use hapticd_core::telemetry::Sample;
/// use hapticd_ipc::telemetry_share::{MappedTelemetry, SharedTelemetryFile};
///
/// // The daemon's side: the file, and the haptic thread's writer.
/// let (file, mut writer) = SharedTelemetryFile::create(1000.0)?;
/// writer.write(&Frame::default());
/// // A reader's side: the descriptor the bus hands out, mapped read-only, read tick by tick.
/// let telemetry = MappedTelemetry::open(&file.share()?)?;
/// let mut cursor = telemetry.from_now();
/// cursor.next = 0;
/// let mut sample = Sample::EMPTY;
/// assert!(telemetry.next(&mut cursor, &mut sample));
/// assert_eq!((sample.tick, cursor.next), (0, 1));
/// assert!(!telemetry.next(&mut cursor, &mut sample), "no second tick yet");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct MappedTelemetry {
    reader: TelemetryReader,
    _mapping: Mapping,
}

impl MappedTelemetry {
    /// Map `fd` read-only and check it holds a telemetry ring of this layout.
    pub fn open(fd: &OwnedFd) -> Result<Self, MapError> {
        let mapping = Mapping::read_only(fd).map_err(|error| MapError::Map {
            what: "the telemetry ring",
            error,
        })?;
        // SAFETY: the mapping holds `len` bytes, page-aligned, for the reader's life (both
        // live in this struct and the reader is dropped first).
        let reader = unsafe {
            TelemetryReader::new(mapping.address().cast::<SharedTelemetry>(), mapping.len())
        }
        .map_err(|e| MapError::Layout(e.to_string()))?;
        Ok(Self {
            reader,
            _mapping: mapping,
        })
    }

    /// Haptic ticks per second.
    pub fn rate(&self) -> f64 {
        self.reader.rate()
    }

    /// A cursor at the next tick to be written.
    pub fn from_now(&self) -> Cursor {
        Cursor {
            next: self.reader.written(),
            missed: 0,
        }
    }

    /// Copy the tick at `cursor` into `out` and move on: true when one was read, false when
    /// it is not written yet. Ticks overwritten before they were read are skipped and
    /// counted in `cursor.missed`.
    pub fn next(&self, cursor: &mut Cursor, out: &mut Sample) -> bool {
        loop {
            match self.reader.read(cursor.next, out) {
                Read::Whole => {
                    cursor.next += 1;
                    return true;
                }
                Read::Ahead => return false,
                Read::Missed { oldest } => {
                    cursor.missed += oldest.saturating_sub(cursor.next).max(1);
                    cursor.next = oldest.max(cursor.next + 1);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hapticd_core::haptic_loop::Frame;
    use hapticd_core::telemetry::SLOTS;

    #[test]
    fn a_reader_follows_every_tick_and_counts_those_it_was_too_slow_for() {
        let (file, mut writer) = SharedTelemetryFile::create(1000.0).unwrap();
        let shared = file.share().unwrap();
        let telemetry = MappedTelemetry::open(&shared).unwrap();
        assert_eq!(telemetry.rate(), 1000.0);
        let mut cursor = telemetry.from_now();
        let mut sample = Sample::EMPTY;
        for _ in 0..10 {
            writer.write(&Frame::default());
        }
        let mut ticks = Vec::new();
        while telemetry.next(&mut cursor, &mut sample) {
            ticks.push(sample.tick);
        }
        assert_eq!(ticks, (0..10).collect::<Vec<u64>>());
        // Two laps unread: the reader resumes at the oldest tick held and knows how many it
        // lost.
        for _ in 0..2 * SLOTS {
            writer.write(&Frame::default());
        }
        assert!(telemetry.next(&mut cursor, &mut sample));
        let written = 10 + 2 * SLOTS as u64;
        let oldest = written - SLOTS as u64 + 1;
        assert_eq!(sample.tick, oldest);
        assert_eq!(cursor.missed, oldest - 10);
        crate::shared_memory::tests::assert_sealed(&shared);
    }
}
