//! Little-endian bytes for other processes and machines: every field in order, no padding,
//! no alignment. What crosses to another machine is written with [`Encoder`] and read back
//! with [`Decoder`], which never reads past its bytes: a short or long message is refused,
//! never misread.

/// Bytes being written.
#[derive(Debug, Default)]
pub struct Encoder {
    bytes: Vec<u8>,
}

impl Encoder {
    /// An empty message with room for `capacity` bytes.
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            bytes: Vec::with_capacity(capacity),
        }
    }

    /// Start again with no bytes, keeping the room.
    pub fn clear(&mut self) {
        self.bytes.clear();
    }

    /// The bytes written.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The bytes written, taken.
    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }

    /// A `u16`.
    pub fn u16(&mut self, value: u16) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// An `i16`.
    pub fn i16(&mut self, value: i16) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// A `u32`.
    pub fn u32(&mut self, value: u32) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// A `u64`.
    pub fn u64(&mut self, value: u64) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// Doubles.
    pub fn f64s(&mut self, values: &[f64]) {
        for v in values {
            self.bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
}

/// Bytes being read: every read is checked against what is left.
#[derive(Debug)]
pub struct Decoder<'a> {
    bytes: &'a [u8],
}

impl<'a> Decoder<'a> {
    /// Read `bytes` from their start.
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes }
    }

    /// Bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.bytes.len()
    }

    /// The next `N` bytes, or None past the end.
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let (head, rest) = self.bytes.split_first_chunk::<N>()?;
        self.bytes = rest;
        Some(*head)
    }

    /// A `u16`.
    pub fn u16(&mut self) -> Option<u16> {
        self.take().map(u16::from_le_bytes)
    }

    /// An `i16`.
    pub fn i16(&mut self) -> Option<i16> {
        self.take().map(i16::from_le_bytes)
    }

    /// A `u32`.
    pub fn u32(&mut self) -> Option<u32> {
        self.take().map(u32::from_le_bytes)
    }

    /// A `u64`.
    pub fn u64(&mut self) -> Option<u64> {
        self.take().map(u64::from_le_bytes)
    }

    /// Doubles into `out`.
    pub fn f64s(&mut self, out: &mut [f64]) -> Option<()> {
        for v in out {
            *v = f64::from_le_bytes(self.take()?);
        }
        Some(())
    }

    /// Doubles as an array.
    pub fn array<const N: usize>(&mut self) -> Option<[f64; N]> {
        let mut out = [0.0; N];
        self.f64s(&mut out)?;
        Some(out)
    }

    /// A count of items of at least `item` bytes each, refused above `limit` or above what
    /// the bytes left could hold (a count no message carries is not trusted to size a loop).
    pub fn count(&mut self, limit: usize, item: usize) -> Option<usize> {
        let n = self.u32()? as usize;
        (n <= limit && n.saturating_mul(item) <= self.remaining()).then_some(n)
    }

    /// Whether every byte was read.
    pub fn finished(&self) -> bool {
        self.bytes.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_is_written_is_read_back_and_nothing_past_the_end() {
        let mut out = Encoder::with_capacity(64);
        out.u16(7);
        out.i16(-3);
        out.u32(0xdead_beef);
        out.u64(u64::MAX - 1);
        out.f64s(&[1.5, -0.0, f64::INFINITY]);
        assert_eq!(out.bytes().len(), 2 + 2 + 4 + 8 + 24);
        assert_eq!(&out.bytes()[..2], &[7, 0], "little-endian");
        let bytes = out.into_bytes();
        let mut from = Decoder::new(&bytes);
        assert_eq!(from.u16(), Some(7));
        assert_eq!(from.i16(), Some(-3));
        assert_eq!(from.u32(), Some(0xdead_beef));
        assert_eq!(from.u64(), Some(u64::MAX - 1));
        assert_eq!(from.array::<3>(), Some([1.5, -0.0, f64::INFINITY]));
        assert!(from.finished());
        assert_eq!(from.u16(), None);
        assert_eq!(Decoder::new(&bytes[..3]).u32(), None);
    }

    #[test]
    fn a_count_is_bounded_by_its_limit_and_by_the_bytes_left() {
        let mut out = Encoder::default();
        out.u32(3);
        out.f64s(&[0.0; 3]);
        let bytes = out.into_bytes();
        assert_eq!(Decoder::new(&bytes).count(8, 8), Some(3));
        assert_eq!(Decoder::new(&bytes).count(2, 8), None, "over the limit");
        assert_eq!(
            Decoder::new(&bytes).count(8, 9),
            None,
            "more than the bytes hold"
        );
        let mut huge = Encoder::default();
        huge.u32(u32::MAX);
        assert_eq!(Decoder::new(huge.bytes()).count(usize::MAX, 1 << 40), None);
    }
}
