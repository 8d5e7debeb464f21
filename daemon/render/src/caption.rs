//! A line of text on a picture (the renderer's status line under each frame, a viewer's
//! note over a stale one): white letters of the 5 × 7 bitmap font on a dark band, written
//! into the pixels after they are read back, so no font file, texture or pipeline is needed.

use crate::font::{self, GLYPH_WIDTH};
use crate::picture::Picture;

/// Pixels a glyph takes across, its gap included.
const ADVANCE: usize = GLYPH_WIDTH + 1;
/// The band's margin around the letters.
const MARGIN: usize = 3;
/// Rows of a line: the glyphs' seven and two for descenders.
const LINE: usize = 9;

/// The edge of a picture a line is written along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Edge {
    /// The top left.
    Top,
    /// The bottom left.
    Bottom,
}

/// Write `text` along `edge` of `picture`, from the left, as much of it as fits; letters
/// twice as large on pictures at least 480 pixels high.
pub fn write(picture: &mut Picture, text: &str, edge: Edge) {
    let scale = if picture.height >= 480 { 2 } else { 1 };
    let (width, height) = (picture.width as usize, picture.height as usize);
    let band = (LINE + 2 * MARGIN) * scale;
    if height < band || width < 2 * MARGIN * scale {
        return;
    }
    let fits = (width - 2 * MARGIN * scale) / (ADVANCE * scale);
    let letters: Vec<char> = text.chars().take(fits).collect();
    let band_width = (letters.len() * ADVANCE + 2 * MARGIN) * scale;
    let mut blend = |x: usize, y: usize, colour: [u8; 3], alpha: u16| {
        let at = (y * width + x) * 4;
        for (c, value) in picture.rgba[at..at + 3].iter_mut().zip(colour) {
            *c = ((u16::from(*c) * (255 - alpha) + u16::from(value) * alpha) / 255) as u8;
        }
    };
    let top = match edge {
        Edge::Top => 0,
        Edge::Bottom => height - band,
    };
    for y in top..top + band {
        for x in 0..band_width.min(width) {
            blend(x, y, [20, 22, 28], 170);
        }
    }
    for (k, &c) in letters.iter().enumerate() {
        for (row, bits) in font::glyph(c).iter().enumerate() {
            for column in 0..GLYPH_WIDTH {
                if bits & (1 << (GLYPH_WIDTH - 1 - column)) == 0 {
                    continue;
                }
                let x0 = (MARGIN + k * ADVANCE + column) * scale;
                let y0 = top + (MARGIN + row + font::drop(c)) * scale;
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
    fn the_line_is_written_at_the_bottom_left_and_only_there() {
        let mut p = grey(200, 100);
        write(&mut p, "1 |", Edge::Bottom);
        // Each letter's lit columns, in its cell.
        let lit = |c: char, cell: usize| -> Vec<usize> {
            (0..GLYPH_WIDTH)
                .filter(|col| {
                    font::glyph(c)
                        .iter()
                        .any(|bits| bits & (1 << (GLYPH_WIDTH - 1 - col)) != 0)
                })
                .map(|col| MARGIN + cell * ADVANCE + col)
                .collect()
        };
        assert_eq!(white_columns(&p), [lit('1', 0), lit('|', 2)].concat());
        let band_top = 100 - (LINE + 2 * MARGIN);
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
        let mut narrow = grey(40, 20);
        write(&mut narrow, "llllllllllllllllllll", Edge::Bottom);
        assert!(white_columns(&narrow).iter().all(|&x| x < 40));
        let (mut small, mut large) = (grey(640, 479), grey(640, 480));
        write(&mut small, "m", Edge::Bottom);
        write(&mut large, "m", Edge::Bottom);
        assert_eq!(white_columns(&large).len(), 2 * white_columns(&small).len());
    }

    #[test]
    fn a_line_at_the_top_leaves_the_rest_as_it_was() {
        let mut p = grey(200, 100);
        write(&mut p, "away", Edge::Top);
        let band = (LINE + 2 * MARGIN) * 200 * 4;
        assert_ne!(&p.rgba[..band], &grey(200, 100).rgba[..band]);
        assert_eq!(&p.rgba[band..], &grey(200, 100).rgba[band..]);
    }
}
