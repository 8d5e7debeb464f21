//! CDR as ROS 2 writes it (XCDR version 1, little-endian, `CDR_LE`): a 4-byte encapsulation
//! header, then each primitive aligned to its own size counted from the end of the header,
//! strings as a 32-bit length counting their NUL, the bytes and the NUL.

/// The encapsulation header of little-endian plain CDR, and its options (none).
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Longest string a message is read with: a frame id, not a document.
pub const MAX_STRING: usize = 4096;

/// A message being written.
#[derive(Debug, Clone, Default)]
pub struct Writer {
    bytes: Vec<u8>,
}

impl Writer {
    /// A message with its encapsulation header written.
    pub fn new() -> Self {
        Self {
            bytes: CDR_LE.to_vec(),
        }
    }

    /// Pad with zeros to a multiple of `size` from the end of the header.
    fn align(&mut self, size: usize) {
        while !(self.bytes.len() - CDR_LE.len()).is_multiple_of(size) {
            self.bytes.push(0);
        }
    }

    /// A signed 32-bit integer.
    pub fn i32(&mut self, value: i32) {
        self.align(4);
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// An unsigned 32-bit integer.
    pub fn u32(&mut self, value: u32) {
        self.align(4);
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// A double.
    pub fn f64(&mut self, value: f64) {
        self.align(8);
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// A string (its length counts the NUL written after it).
    pub fn string(&mut self, value: &str) {
        self.u32(value.len() as u32 + 1);
        self.bytes.extend_from_slice(value.as_bytes());
        self.bytes.push(0);
    }

    /// The length of a sequence, written before its elements.
    pub fn sequence(&mut self, length: usize) {
        self.u32(length as u32);
    }

    /// The message's bytes.
    pub fn finish(self) -> Vec<u8> {
        self.bytes
    }
}

/// Why a message could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DecodeError {
    /// Not little-endian plain CDR (another header, or none).
    Encapsulation,
    /// It ends before the message does.
    Truncated,
    /// A string too long, without its NUL, or not UTF-8.
    BadString,
}

impl std::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DecodeError::Encapsulation => "not little-endian CDR (encapsulation 00 01)",
            DecodeError::Truncated => "the message ends too soon",
            DecodeError::BadString => "a string is too long, unterminated or not UTF-8",
        })
    }
}

impl std::error::Error for DecodeError {}

/// A message being read.
#[derive(Debug, Clone)]
pub struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// A reader of `bytes`, their encapsulation header checked.
    pub fn new(bytes: &'a [u8]) -> Result<Self, DecodeError> {
        // Options (the last two bytes) only say how much padding ends the message.
        if bytes.len() < CDR_LE.len() || bytes[..2] != CDR_LE[..2] {
            return Err(DecodeError::Encapsulation);
        }
        Ok(Self {
            bytes,
            at: CDR_LE.len(),
        })
    }

    /// The next `n` bytes, after padding to a multiple of `align` from the header's end.
    fn take(&mut self, n: usize, align: usize) -> Result<&'a [u8], DecodeError> {
        let offset = self.at - CDR_LE.len();
        let start = self.at + (align - offset % align) % align;
        let end = start.checked_add(n).ok_or(DecodeError::Truncated)?;
        let taken = self.bytes.get(start..end).ok_or(DecodeError::Truncated)?;
        self.at = end;
        Ok(taken)
    }

    /// A signed 32-bit integer.
    pub fn i32(&mut self) -> Result<i32, DecodeError> {
        Ok(i32::from_le_bytes(
            self.take(4, 4)?.try_into().expect("4 bytes"),
        ))
    }

    /// An unsigned 32-bit integer.
    pub fn u32(&mut self) -> Result<u32, DecodeError> {
        Ok(u32::from_le_bytes(
            self.take(4, 4)?.try_into().expect("4 bytes"),
        ))
    }

    /// A double.
    pub fn f64(&mut self) -> Result<f64, DecodeError> {
        Ok(f64::from_le_bytes(
            self.take(8, 8)?.try_into().expect("8 bytes"),
        ))
    }

    /// The length of a sequence of elements of at least `element` bytes each, refused when
    /// the message cannot hold that many (a hostile length allocates nothing).
    pub fn sequence(&mut self, element: usize) -> Result<usize, DecodeError> {
        let length = self.u32()? as usize;
        let left = self.bytes.len() - self.at;
        if length.saturating_mul(element.max(1)) > left {
            return Err(DecodeError::Truncated);
        }
        Ok(length)
    }

    /// A string.
    pub fn string(&mut self) -> Result<String, DecodeError> {
        let length = self.u32()? as usize;
        if length == 0 || length > MAX_STRING {
            return Err(DecodeError::BadString);
        }
        let bytes = self.take(length, 1)?;
        let (text, nul) = bytes.split_at(length - 1);
        if nul != [0] {
            return Err(DecodeError::BadString);
        }
        String::from_utf8(text.to_vec()).map_err(|_| DecodeError::BadString)
    }
}
