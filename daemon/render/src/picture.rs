//! A drawn picture and its PNG file.

use std::path::Path;

/// `width × height` RGBA pixels, rows top to bottom.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Picture {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// RGBA, 4 bytes a pixel.
    pub rgba: Vec<u8>,
}

impl Picture {
    /// Write the picture to `path` as an RGBA PNG (fast compression: a frame a thirtieth of
    /// a second must not wait for the encoder).
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        let failed = |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", path.display());
        let file = std::fs::File::create(path).map_err(|e| failed(&e))?;
        self.encode(std::io::BufWriter::new(file))
            .map_err(|e| failed(&e))
    }

    /// The picture as an RGBA PNG file's bytes.
    pub fn to_png(&self) -> Vec<u8> {
        let mut bytes = Vec::new();
        self.encode(&mut bytes)
            .expect("encoding into memory fails only on a wrong size, which a Picture has not");
        bytes
    }

    fn encode(&self, out: impl std::io::Write) -> Result<(), png::EncodingError> {
        let mut encoder = png::Encoder::new(out, self.width, self.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_compression(png::Compression::Fast);
        encoder
            .write_header()
            .and_then(|mut w| w.write_image_data(&self.rgba))
    }

    /// A picture from an RGBA PNG file's bytes.
    pub fn from_png(bytes: &[u8]) -> Result<Self, String> {
        Self::decode(std::io::Cursor::new(bytes))
    }

    /// Read an 8-bit RGBA PNG file.
    pub fn read_png(path: &Path) -> Result<Self, String> {
        let file = std::fs::File::open(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        Self::decode(std::io::BufReader::new(file))
            .map_err(|e| format!("cannot read {}: {e}", path.display()))
    }

    fn decode(input: impl std::io::BufRead + std::io::Seek) -> Result<Self, String> {
        let failed = |e: &dyn std::fmt::Display| e.to_string();
        let mut reader = png::Decoder::new(input)
            .read_info()
            .map_err(|e| failed(&e))?;
        let mut rgba = vec![0; reader.output_buffer_size().unwrap_or(0)];
        let info = reader.next_frame(&mut rgba).map_err(|e| failed(&e))?;
        if (info.color_type, info.bit_depth) != (png::ColorType::Rgba, png::BitDepth::Eight) {
            return Err("not an 8-bit RGBA picture".to_string());
        }
        rgba.truncate(info.buffer_size());
        Ok(Self {
            width: info.width,
            height: info.height,
            rgba,
        })
    }
}
