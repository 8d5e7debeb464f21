//! Recorded device traffic: every bulk transfer of a session, to inspect it or to replay it
//! as a device.
//!
//! File format: the 8 bytes `HAPTRAF1`, then one record per transfer: a direction byte
//! (0 OUT, 1 IN), a little-endian u16 length, and the bytes.
//!
//! [`RecordingLink`] wraps any link and hands each transfer to a writer thread through a
//! lock-free ring (the real-time thread never writes files). [`ReplayLink`] answers from a
//! recording: each read returns the next recorded IN transfer, so a session replays
//! deterministically; it counts OUT transfers that differ from the recorded ones.

use std::io::Write;
use std::path::Path;

use hapticd_core::diagnostics::{self, FileRules};
use hapticd_core::sync::spsc;
use hapticd_core::transport::{Link, TransportError};

/// File signature.
pub const MAGIC: &[u8; 8] = b"HAPTRAF1";
/// Largest transfer recorded.
pub const MAX_TRANSFER: usize = 512;

/// Direction of a transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Host to device.
    Out,
    /// Device to host.
    In,
}

/// One transfer, by value (so it can travel through a ring).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transfer {
    /// Direction.
    pub direction: Direction,
    /// Bytes used in `data`.
    pub len: u16,
    /// The bytes.
    pub data: [u8; MAX_TRANSFER],
}

impl Transfer {
    /// A transfer of `bytes` (cut at [`MAX_TRANSFER`]).
    pub fn new(direction: Direction, bytes: &[u8]) -> Self {
        let len = bytes.len().min(MAX_TRANSFER);
        let mut data = [0; MAX_TRANSFER];
        data[..len].copy_from_slice(&bytes[..len]);
        Self {
            direction,
            len: len as u16,
            data,
        }
    }

    /// The bytes of the transfer.
    pub fn bytes(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }
}

/// Write transfers to `out` in the file format (the magic must already be written).
pub fn write_transfer(out: &mut impl Write, t: &Transfer) -> std::io::Result<()> {
    out.write_all(&[u8::from(t.direction == Direction::In)])?;
    out.write_all(&t.len.to_le_bytes())?;
    out.write_all(t.bytes())
}

/// Largest recording read back, bytes: over an hour of an SH4 amplifier at 1 kHz.
pub const MAX_RECORDING_BYTES: u64 = 4 << 30;

/// One transfer of a recording: where its bytes are in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Record {
    direction: Direction,
    start: usize,
    len: usize,
}

/// A recording as read from its file: the file's bytes and an index of its transfers, so
/// it takes the memory of the file and a few bytes per transfer, however short they are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recording {
    bytes: Vec<u8>,
    records: Vec<Record>,
}

impl Recording {
    /// Read and check a whole recording.
    pub fn read(path: &Path) -> std::io::Result<Recording> {
        let invalid = |what: String| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("{}: {what}", path.display()),
            )
        };
        // Guarded as every file is, with room for hours of traffic.
        let rules = FileRules {
            max_bytes: MAX_RECORDING_BYTES,
            within: None,
        };
        let bytes = diagnostics::read_file(path, rules).map_err(std::io::Error::other)?;
        if bytes.len() < 8 || &bytes[..8] != MAGIC {
            return Err(invalid("not a hapticd traffic recording".into()));
        }
        let mut records = Vec::new();
        let mut at = 8;
        while at < bytes.len() {
            let header = bytes
                .get(at..at + 3)
                .ok_or_else(|| invalid(format!("truncated record at byte {at}")))?;
            let direction = match header[0] {
                0 => Direction::Out,
                1 => Direction::In,
                other => return Err(invalid(format!("bad direction byte {other} at byte {at}"))),
            };
            let len = u16::from_le_bytes([header[1], header[2]]) as usize;
            if len > MAX_TRANSFER {
                return Err(invalid(format!("transfer of {len} bytes at byte {at}")));
            }
            if at + 3 + len > bytes.len() {
                return Err(invalid(format!("truncated record at byte {at}")));
            }
            records.push(Record {
                direction,
                start: at + 3,
                len,
            });
            at += 3 + len;
        }
        Ok(Recording { bytes, records })
    }

    /// The transfers in order: direction and bytes.
    pub fn transfers(&self) -> impl Iterator<Item = (Direction, &[u8])> {
        self.records
            .iter()
            .map(|r| (r.direction, &self.bytes[r.start..r.start + r.len]))
    }

    /// How many transfers it holds.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// Whether it holds no transfer.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }
}

/// A link that records every transfer of the link it wraps.
pub struct RecordingLink<L: Link> {
    inner: L,
    ring: spsc::Producer<Transfer>,
    dropped: u64,
}

impl<L: Link> RecordingLink<L> {
    /// Record `inner`'s traffic into `ring`.
    pub fn new(inner: L, ring: spsc::Producer<Transfer>) -> Self {
        Self {
            inner,
            ring,
            dropped: 0,
        }
    }

    /// The wrapped link.
    pub fn inner(&self) -> &L {
        &self.inner
    }

    /// Transfers lost because the writer fell behind.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    fn record(&mut self, direction: Direction, bytes: &[u8]) {
        if !self.ring.push(Transfer::new(direction, bytes)) {
            self.dropped += 1;
        }
    }
}

impl<L: Link> Link for RecordingLink<L> {
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let result = self.inner.write(bytes);
        if result.is_ok() {
            self.record(Direction::Out, bytes);
        }
        result
    }

    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
        let n = self.inner.read(bytes)?;
        self.record(Direction::In, &bytes[..n]);
        Ok(n)
    }

    fn reset_in(&mut self) -> Result<(), TransportError> {
        self.inner.reset_in()
    }

    fn replace(&mut self, link: Box<dyn Link>) -> Result<Box<dyn Link>, Box<dyn Link>> {
        self.inner.replace(link)
    }
}

/// A device that answers from a recording.
pub struct ReplayLink {
    recording: Recording,
    next: usize,
    mismatches: u64,
}

impl ReplayLink {
    /// Replay `recording` in order.
    pub fn new(recording: Recording) -> Self {
        Self {
            recording,
            next: 0,
            mismatches: 0,
        }
    }

    /// OUT transfers that differed from the recording.
    pub fn mismatches(&self) -> u64 {
        self.mismatches
    }

    /// [rt] The next recorded transfer, if it goes in `direction`.
    fn take(&mut self, direction: Direction) -> Option<&[u8]> {
        let r = *self.recording.records.get(self.next)?;
        if r.direction != direction {
            return None;
        }
        self.next += 1;
        Some(&self.recording.bytes[r.start..r.start + r.len])
    }
}

impl Link for ReplayLink {
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let recorded = self
            .take(Direction::Out)
            .ok_or(TransportError::Disconnected)?;
        if recorded != bytes {
            self.mismatches += 1;
        }
        Ok(())
    }

    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
        let recorded = self
            .take(Direction::In)
            .ok_or(TransportError::Disconnected)?;
        let n = recorded.len().min(bytes.len());
        bytes[..n].copy_from_slice(&recorded[..n]);
        Ok(n)
    }

    fn reset_in(&mut self) -> Result<(), TransportError> {
        Ok(())
    }
}

/// Drain `ring` into a recording at `path` until `done` is set and the ring is empty.
pub fn spawn_traffic_writer(
    path: &Path,
    mut ring: spsc::Consumer<Transfer>,
    done: &'static std::sync::atomic::AtomicBool,
) -> std::io::Result<std::thread::JoinHandle<std::io::Result<()>>> {
    let mut out = std::fs::File::create(path)?;
    out.write_all(MAGIC)?;
    Ok(std::thread::spawn(move || {
        // Whole records per write: a daemon killed between two writes leaves a file that
        // ends on a record, which the guardian's zero-current record can follow.
        let mut batch = Vec::new();
        loop {
            let finished = done.load(std::sync::atomic::Ordering::Acquire);
            while let Some(t) = ring.pop() {
                write_transfer(&mut batch, &t)?;
            }
            out.write_all(&batch)?;
            batch.clear();
            if finished {
                return Ok(());
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Echo(Vec<u8>);

    impl Link for Echo {
        fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
            self.0 = bytes.iter().map(|b| b.wrapping_add(1)).collect();
            Ok(())
        }
        fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
            bytes[..self.0.len()].copy_from_slice(&self.0);
            Ok(self.0.len())
        }
        fn reset_in(&mut self) -> Result<(), TransportError> {
            Ok(())
        }
    }

    #[test]
    fn a_recorded_session_replays_byte_for_byte() {
        let (tx, mut rx) = spsc::channel(16);
        let mut link = RecordingLink::new(Echo(Vec::new()), tx);
        let mut buf = [0u8; 8];
        for k in 0..3u8 {
            link.write(&[k, 10, 20]).unwrap();
            link.read(&mut buf).unwrap();
        }
        let path = std::env::temp_dir().join(format!("hapticd-traffic-{}.bin", std::process::id()));
        let mut file = std::fs::File::create(&path).unwrap();
        file.write_all(MAGIC).unwrap();
        while let Some(t) = rx.pop() {
            write_transfer(&mut file, &t).unwrap();
        }
        drop(file);
        let recording = Recording::read(&path).unwrap();
        assert_eq!(recording.len(), 6);
        let mut replay = ReplayLink::new(recording);
        for k in 0..3u8 {
            replay.write(&[k, 10, 20]).unwrap();
            let n = replay.read(&mut buf).unwrap();
            assert_eq!(&buf[..n], &[k + 1, 11, 21]);
        }
        assert_eq!(replay.mismatches(), 0);
        assert_eq!(replay.write(&[0]), Err(TransportError::Disconnected));
        std::fs::remove_file(path).ok();
    }

    #[test]
    fn a_recording_of_empty_transfers_takes_the_memory_of_its_file() {
        let path = std::env::temp_dir().join(format!("hapticd-zeros-{}.bin", std::process::id()));
        let mut bytes = MAGIC.to_vec();
        bytes.resize(8 + 3 * 100_000, 0);
        std::fs::write(&path, &bytes).unwrap();
        let recording = Recording::read(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(recording.len(), 100_000);
        assert!(
            recording
                .transfers()
                .all(|(d, b)| d == Direction::Out && b.is_empty())
        );
        // The index, not a 512-byte buffer per transfer.
        let held = recording.bytes.capacity()
            + recording.records.capacity() * std::mem::size_of::<Record>();
        assert!(
            held < 40 * bytes.len() / 3,
            "{held} bytes for a {}-byte file",
            bytes.len()
        );
    }

    #[test]
    fn damaged_recordings_are_refused_with_the_place() {
        let path = std::env::temp_dir().join(format!("hapticd-bad-{}.bin", std::process::id()));
        for (tail, want) in [
            (&[2u8, 0, 0][..], "bad direction byte 2 at byte 8"),
            (&[0, 5, 0, 1][..], "truncated record at byte 8"),
            (&[1, 0xff, 0xff][..], "transfer of 65535 bytes at byte 8"),
        ] {
            std::fs::write(&path, [&MAGIC[..], tail].concat()).unwrap();
            let e = Recording::read(&path).unwrap_err().to_string();
            assert!(e.ends_with(want), "{e}");
        }
        std::fs::remove_file(&path).ok();
        // Read as every file is: a device never, however large recordings may be.
        let e = Recording::read(Path::new("/dev/zero"))
            .unwrap_err()
            .to_string();
        assert_eq!(e, "/dev/zero: error: not a regular file");
    }
}
