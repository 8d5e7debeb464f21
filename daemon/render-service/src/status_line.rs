//! The status line under a picture (scene, rate, state, time): white 5 × 7 pixel letters on
//! a dark band, written into the pixels after they are read back, so no font, texture or
//! second pipeline is needed.

use hapticd_render::picture::Picture;

/// Rows of a glyph, top down, five bits each (the highest is the leftmost pixel).
type Glyph = [u8; 7];

/// The letters a status line uses; anything else is drawn as `?` (capitals as small ones).
fn glyph(c: char) -> Glyph {
    match c.to_ascii_lowercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1E, 0x01, 0x01, 0x0E, 0x01, 0x01, 0x1E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'a' => [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F],
        'b' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E],
        'c' => [0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E],
        'd' => [0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        'f' => [0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08],
        'g' => [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'h' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11],
        'i' => [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E],
        'j' => [0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0C],
        'k' => [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12],
        'l' => [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'm' => [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'o' => [0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E],
        'p' => [0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10],
        'q' => [0x00, 0x00, 0x0D, 0x13, 0x0F, 0x01, 0x01],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'u' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D],
        'v' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'w' => [0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        'y' => [0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'z' => [0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F],
        ' ' => [0; 7],
        '|' => [0x04; 7],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
        '/' => [0x01, 0x02, 0x02, 0x04, 0x08, 0x08, 0x10],
        _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04],
    }
}

/// Pixels a glyph takes across, its gap included.
const ADVANCE: usize = 6;
/// The band's margin around the letters.
const MARGIN: usize = 3;

/// Write `text` along the bottom left of `picture`, as much of it as fits; letters twice
/// as large on pictures at least 480 pixels high.
pub fn write(picture: &mut Picture, text: &str) {
    let scale = if picture.height >= 480 { 2 } else { 1 };
    let (width, height) = (picture.width as usize, picture.height as usize);
    let band = (7 + 2 * MARGIN) * scale;
    if height < band || width < 2 * MARGIN * scale {
        return;
    }
    let fits = (width - 2 * MARGIN * scale) / (ADVANCE * scale);
    let letters: Vec<Glyph> = text.chars().take(fits).map(glyph).collect();
    let band_width = (letters.len() * ADVANCE + 2 * MARGIN) * scale;
    let mut blend = |x: usize, y: usize, colour: [u8; 3], alpha: u16| {
        let at = (y * width + x) * 4;
        for (c, value) in picture.rgba[at..at + 3].iter_mut().zip(colour) {
            *c = ((u16::from(*c) * (255 - alpha) + u16::from(value) * alpha) / 255) as u8;
        }
    };
    let top = height - band;
    for y in top..height {
        for x in 0..band_width.min(width) {
            blend(x, y, [20, 22, 28], 170);
        }
    }
    for (k, rows) in letters.iter().enumerate() {
        for (row, bits) in rows.iter().enumerate() {
            for column in 0..5 {
                if bits & (0x10 >> column) == 0 {
                    continue;
                }
                let x0 = (MARGIN + k * ADVANCE + column) * scale;
                let y0 = top + (MARGIN + row) * scale;
                for dy in 0..scale {
                    for dx in 0..scale {
                        blend(x0 + dx, y0 + dy, [255, 255, 255], 255);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(width: u32, height: u32) -> Picture {
        Picture {
            width,
            height,
            rgba: vec![128; (width * height * 4) as usize],
        }
    }

    /// White pixels in each column of the picture's bottom band.
    fn white_columns(p: &Picture) -> Vec<usize> {
        (0..p.width as usize)
            .filter(|&x| {
                (0..p.height as usize).any(|y| {
                    let at = (y * p.width as usize + x) * 4;
                    p.rgba[at..at + 3] == [255, 255, 255]
                })
            })
            .collect()
    }

    #[test]
    fn every_letter_of_a_status_has_its_own_glyph() {
        let unknown = glyph('\u{1}');
        for c in
            "blocks | 1000 hz | running fault disconnected uncalibrated | 12.3 s no scene file_-:/"
                .chars()
        {
            assert!(c == '?' || glyph(c) != unknown, "{c:?} has no glyph");
        }
        let distinct: std::collections::BTreeSet<Glyph> =
            ('a'..='z').chain('0'..='9').map(glyph).collect();
        assert_eq!(distinct.len(), 36, "two letters look alike");
    }

    #[test]
    fn the_line_is_written_at_the_bottom_left_and_only_there() {
        let mut p = grey(200, 100);
        write(&mut p, "1 |");
        let columns = white_columns(&p);
        // '1' spans columns 1..4 of its cell, '|' column 2 of the third cell.
        assert_eq!(
            columns,
            [MARGIN + 1, MARGIN + 2, MARGIN + 3, MARGIN + 2 * ADVANCE + 2]
        );
        let band_top = 100 - (7 + 2 * MARGIN);
        assert_eq!(
            &p.rgba[..band_top * 200 * 4],
            &grey(200, 100).rgba[..band_top * 200 * 4]
        );
        let right = ((band_top + 1) * 200 + 150) * 4;
        assert_eq!(
            p.rgba[right..right + 4],
            [128; 4],
            "the band reaches past its text"
        );
    }

    #[test]
    fn a_long_line_is_cut_to_the_picture_and_large_pictures_get_large_letters() {
        let mut small = grey(40, 20);
        write(&mut small, "llllllllllllllllllll");
        assert!(white_columns(&small).iter().all(|&x| x < 40));
        let mut large = grey(640, 480);
        write(&mut large, "l");
        // 'l' is columns 1..3 of its cell, two pixels each at this size.
        assert_eq!(white_columns(&large).len(), 6);
    }
}
