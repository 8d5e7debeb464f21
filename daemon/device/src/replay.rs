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

use std::io::{Read, Write};
use std::path::Path;

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
    fn new(direction: Direction, bytes: &[u8]) -> Self {
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

/// Read a whole recording.
pub fn read_recording(path: &Path) -> std::io::Result<Vec<Transfer>> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.read_to_end(&mut bytes)?;
    let invalid = |what: &str| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{}: {what}", path.display()),
        )
    };
    if bytes.len() < 8 || &bytes[..8] != MAGIC {
        return Err(invalid("not a hapticd traffic recording"));
    }
    let mut transfers = Vec::new();
    let mut at = 8;
    while at < bytes.len() {
        let header = bytes
            .get(at..at + 3)
            .ok_or_else(|| invalid("truncated record"))?;
        let direction = match header[0] {
            0 => Direction::Out,
            1 => Direction::In,
            _ => return Err(invalid("bad direction byte")),
        };
        let len = u16::from_le_bytes([header[1], header[2]]) as usize;
        let data = bytes
            .get(at + 3..at + 3 + len)
            .ok_or_else(|| invalid("truncated record"))?;
        if len > MAX_TRANSFER {
            return Err(invalid("transfer too long"));
        }
        transfers.push(Transfer::new(direction, data));
        at += 3 + len;
    }
    Ok(transfers)
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
    transfers: Vec<Transfer>,
    next: usize,
    mismatches: u64,
}

impl ReplayLink {
    /// Replay `transfers` in order.
    pub fn new(transfers: Vec<Transfer>) -> Self {
        Self {
            transfers,
            next: 0,
            mismatches: 0,
        }
    }

    /// OUT transfers that differed from the recording.
    pub fn mismatches(&self) -> u64 {
        self.mismatches
    }

    fn take(&mut self, direction: Direction) -> Option<Transfer> {
        let t = *self.transfers.get(self.next)?;
        (t.direction == direction).then(|| {
            self.next += 1;
            t
        })
    }
}

impl Link for ReplayLink {
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let recorded = self
            .take(Direction::Out)
            .ok_or(TransportError::Disconnected)?;
        if recorded.bytes() != bytes {
            self.mismatches += 1;
        }
        Ok(())
    }

    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
        let recorded = self
            .take(Direction::In)
            .ok_or(TransportError::Disconnected)?;
        let n = recorded.bytes().len().min(bytes.len());
        bytes[..n].copy_from_slice(&recorded.bytes()[..n]);
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
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    out.write_all(MAGIC)?;
    Ok(std::thread::spawn(move || {
        loop {
            let finished = done.load(std::sync::atomic::Ordering::Acquire);
            while let Some(t) = ring.pop() {
                write_transfer(&mut out, &t)?;
            }
            if finished {
                return out.flush();
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
        let transfers = read_recording(&path).unwrap();
        assert_eq!(transfers.len(), 6);
        let mut replay = ReplayLink::new(transfers);
        for k in 0..3u8 {
            replay.write(&[k, 10, 20]).unwrap();
            let n = replay.read(&mut buf).unwrap();
            assert_eq!(&buf[..n], &[k + 1, 11, 21]);
        }
        assert_eq!(replay.mismatches(), 0);
        assert_eq!(replay.write(&[0]), Err(TransportError::Disconnected));
        std::fs::remove_file(path).ok();
    }
}
