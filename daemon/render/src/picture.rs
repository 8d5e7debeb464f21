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
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_compression(png::Compression::Fast);
        encoder
            .write_header()
            .and_then(|mut w| w.write_image_data(&self.rgba))
            .map_err(|e| failed(&e))
    }

    /// Read an 8-bit RGBA PNG file.
    pub fn read_png(path: &Path) -> Result<Self, String> {
        let failed = |e: &dyn std::fmt::Display| format!("cannot read {}: {e}", path.display());
        let file = std::fs::File::open(path).map_err(|e| failed(&e))?;
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .map_err(|e| failed(&e))?;
        let mut rgba = vec![0; reader.output_buffer_size().unwrap_or(0)];
        let info = reader.next_frame(&mut rgba).map_err(|e| failed(&e))?;
        if (info.color_type, info.bit_depth) != (png::ColorType::Rgba, png::BitDepth::Eight) {
            return Err(failed(&"not an 8-bit RGBA picture"));
        }
        rgba.truncate(info.buffer_size());
        Ok(Self {
            width: info.width,
            height: info.height,
            rgba,
        })
    }
}
