//! Height maps: a grey PNG a scene lays over a surface as its texture, read with the same
//! care as a mesh (from the scene's directory, its size and pixels bounded).

use std::io::Cursor;
use std::path::Path;

use hapticd_core::diagnostics::{FileRules, read_file};
use hapticd_core::haptics::texture::HeightImage;

/// Largest height-map file, bytes.
const MOST_BYTES: u64 = 16 << 20;
/// Most pixels across or down: a 5 cm tile at 2 048 pixels is finer than 25 µm.
const MOST_SIDE: u32 = 4096;

/// The heights of the PNG `file`, read only from within `scene_dir`: its pixels' luminance
/// (alpha ignored) from 0 (black) to 1 (white). The reader hapticd and hapticctl give scenes
/// (`hapticd_core::haptics::texture::ImageReader`).
pub fn height_map(
    file: &Path,
    scene_dir: &Path,
) -> Result<HeightImage, Box<dyn std::error::Error + Send + Sync>> {
    let named = |e: &dyn std::fmt::Display| format!("{}: {e}", file.display());
    let rules = FileRules {
        max_bytes: MOST_BYTES,
        within: Some(scene_dir),
    };
    let bytes = read_file(file, rules).map_err(|e| named(&e.message()))?;
    let mut decoder = png::Decoder::new_with_limits(
        Cursor::new(bytes),
        png::Limits {
            bytes: 4 * (MOST_SIDE as usize).pow(2),
        },
    );
    // Palettes and small depths to 8 bits a channel, 16 bits kept.
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| named(&e))?;
    let (width, height) = reader.info().size();
    if width > MOST_SIDE || height > MOST_SIDE || width == 0 || height == 0 {
        return Err(named(&format!(
            "is {width} × {height} pixels; a height map has 1 to {MOST_SIDE} a side"
        ))
        .into());
    }
    let mut buffer = vec![0; reader.output_buffer_size().unwrap_or(0)];
    let info = reader.next_frame(&mut buffer).map_err(|e| named(&e))?;
    let wide = info.bit_depth == png::BitDepth::Sixteen;
    let channels = info.color_type.samples();
    let step = channels * if wide { 2 } else { 1 };
    let sample = |p: &[u8], k: usize| -> f32 {
        if wide {
            f32::from(u16::from_be_bytes([p[2 * k], p[2 * k + 1]])) / 65535.0
        } else {
            f32::from(p[k]) / 255.0
        }
    };
    let heights = buffer[..info.buffer_size()]
        .chunks_exact(info.line_size)
        .flat_map(|row| row[..width as usize * step].chunks_exact(step))
        .map(|p| match channels {
            // Grey, with or without alpha.
            1 | 2 => sample(p, 0),
            // Rec. 709 luminance of colour.
            _ => 0.2126 * sample(p, 0) + 0.7152 * sample(p, 1) + 0.0722 * sample(p, 2),
        })
        .collect();
    Ok(HeightImage {
        width: width as usize,
        height: height as usize,
        heights,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(path: &Path, width: u32, height: u32, colour: png::ColorType, data: &[u8]) {
        let file = std::fs::File::create(path).unwrap();
        let mut encoder = png::Encoder::new(file, width, height);
        encoder.set_color(colour);
        encoder.set_depth(png::BitDepth::Eight);
        encoder
            .write_header()
            .unwrap()
            .write_image_data(data)
            .unwrap();
    }

    #[test]
    fn grey_and_colour_read_as_heights_and_what_is_no_image_is_named() {
        let dir = std::env::temp_dir().join(format!("hapticd-height-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let grey = dir.join("grey.png");
        write(&grey, 3, 1, png::ColorType::Grayscale, &[0, 51, 255]);
        let image = height_map(&grey, &dir).unwrap();
        assert_eq!((image.width, image.height), (3, 1));
        assert_eq!(image.heights, vec![0.0, 0.2, 1.0]);
        let colour = dir.join("colour.png");
        write(
            &colour,
            1,
            2,
            png::ColorType::Rgb,
            &[255, 255, 255, 255, 0, 0],
        );
        let image = height_map(&colour, &dir).unwrap();
        assert!((image.heights[0] - 1.0).abs() < 1e-6 && (image.heights[1] - 0.2126).abs() < 1e-6);
        let bogus = dir.join("bogus.png");
        std::fs::write(&bogus, b"not a picture").unwrap();
        let said = height_map(&bogus, &dir).unwrap_err().to_string();
        assert!(said.starts_with(&bogus.display().to_string()), "{said}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
