//! A drawn picture and its PNG file.

use std::path::{Path, PathBuf};

/// Why a picture could not be read or written.
#[derive(Debug)]
pub enum PictureError {
    /// The file could not be opened or created.
    Io(std::io::Error),
    /// The bytes are no PNG file the decoder reads.
    Decoding(png::DecodingError),
    /// The encoder failed.
    Encoding(png::EncodingError),
    /// A PNG file of another kind than 8-bit RGBA.
    NotRgba8,
    /// Reading or writing the file at `path` failed as the inner error says.
    At {
        /// The file.
        path: PathBuf,
        /// Whether it was being written (else read).
        writing: bool,
        /// Why.
        error: Box<PictureError>,
    },
}

impl std::fmt::Display for PictureError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let verb = |writing: &bool| if *writing { "write" } else { "read" };
        match self {
            PictureError::Io(e) => write!(f, "{e}"),
            PictureError::At {
                path,
                writing,
                error,
            } => write!(f, "cannot {} {}: {error}", verb(writing), path.display()),
            PictureError::Decoding(e) => write!(f, "{e}"),
            PictureError::Encoding(e) => write!(f, "{e}"),
            PictureError::NotRgba8 => f.write_str("not an 8-bit RGBA picture"),
        }
    }
}

impl std::error::Error for PictureError {}

impl PictureError {
    /// The error, said of the file at `path` being written or read.
    fn at(self, path: &Path, writing: bool) -> Self {
        PictureError::At {
            path: path.to_path_buf(),
            writing,
            error: Box::new(self),
        }
    }
}

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
    pub fn write_png(&self, path: &Path) -> Result<(), PictureError> {
        std::fs::File::create(path)
            .map_err(PictureError::Io)
            .and_then(|file| {
                self.encode(std::io::BufWriter::new(file))
                    .map_err(PictureError::Encoding)
            })
            .map_err(|e| e.at(path, true))
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
    pub fn from_png(bytes: &[u8]) -> Result<Self, PictureError> {
        Self::decode(std::io::Cursor::new(bytes))
    }

    /// Read an 8-bit RGBA PNG file.
    pub fn read_png(path: &Path) -> Result<Self, PictureError> {
        std::fs::File::open(path)
            .map_err(PictureError::Io)
            .and_then(|file| Self::decode(std::io::BufReader::new(file)))
            .map_err(|e| e.at(path, false))
    }

    fn decode(input: impl std::io::BufRead + std::io::Seek) -> Result<Self, PictureError> {
        let mut reader = png::Decoder::new(input)
            .read_info()
            .map_err(PictureError::Decoding)?;
        let mut rgba = vec![0; reader.output_buffer_size().unwrap_or(0)];
        let info = reader
            .next_frame(&mut rgba)
            .map_err(PictureError::Decoding)?;
        if (info.color_type, info.bit_depth) != (png::ColorType::Rgba, png::BitDepth::Eight) {
            return Err(PictureError::NotRgba8);
        }
        rgba.truncate(info.buffer_size());
        Ok(Self {
            width: info.width,
            height: info.height,
            rgba,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_picture_reads_back_and_what_is_no_rgba_png_is_refused_by_kind() {
        let picture = Picture {
            width: 2,
            height: 1,
            rgba: vec![255, 0, 0, 255, 0, 0, 255, 128],
        };
        assert_eq!(Picture::from_png(&picture.to_png()).unwrap(), picture);
        assert!(matches!(
            Picture::from_png(b"not a png"),
            Err(PictureError::Decoding(_))
        ));
        // A grey PNG: a PNG, but not the kind pictures are.
        let mut grey = Vec::new();
        let mut encoder = png::Encoder::new(&mut grey, 1, 1);
        encoder.set_color(png::ColorType::Grayscale);
        encoder
            .write_header()
            .and_then(|mut w| w.write_image_data(&[7]))
            .unwrap();
        assert!(matches!(
            Picture::from_png(&grey),
            Err(PictureError::NotRgba8)
        ));
        let missing = Path::new("/nonexistent/picture.png");
        let e = Picture::read_png(missing).unwrap_err();
        assert!(matches!(
            &e,
            PictureError::At { writing: false, error, .. } if matches!(**error, PictureError::Io(_))
        ));
        assert!(
            e.to_string()
                .starts_with("cannot read /nonexistent/picture.png: "),
            "{e}"
        );
    }
}
