//! Edges smoothed on the host as a picture is read back, as FXAA does in its simplest form:
//! where a pixel's brightness steps to one of its four neighbours, the pixel is blended with
//! the two neighbours across the edge, more where the step is larger; flat regions are copied.
//! On a CPU rasteriser this costs a fraction of what 4× multisampling or a full-screen pass
//! would (both several times the frame itself at 1280 × 720 on lavapipe).

/// Brightness steps (of 255) between a pixel and a neighbour below this are no edge.
const FLAT: u8 = 10;
/// Steps from this up are blended fully (half-way to the neighbours across).
const SHARP: u32 = 64;

/// `rgba` (`width` × `height` pixels, 4 bytes each) with its edges smoothed.
pub fn smooth_edges(rgba: &[u8], width: usize, height: usize) -> Vec<u8> {
    debug_assert_eq!(rgba.len(), width * height * 4);
    let mut out = rgba.to_vec();
    if width == 0 || height == 0 {
        return out;
    }
    let luma: Vec<u8> = rgba
        .chunks_exact(4)
        .map(|p| {
            let sum = 77 * u32::from(p[0]) + 150 * u32::from(p[1]) + 29 * u32::from(p[2]);
            (sum >> 8) as u8
        })
        .collect();
    let picture = Picture {
        rgba,
        luma: &luma,
        width,
        height,
    };
    picture.smooth_into(&mut out);
    out
}

/// A picture and its pixels' brightness.
struct Picture<'a> {
    rgba: &'a [u8],
    luma: &'a [u8],
    width: usize,
    height: usize,
}

impl Picture<'_> {
    /// Write the smoothed pixels into `out` (a copy of the picture's: flat ones stay).
    fn smooth_into(&self, out: &mut [u8]) {
        let (width, height, luma, rgba) = (self.width, self.height, self.luma, self.rgba);
        // Each pixel's largest step to a neighbour, a row at a time (loops the compiler
        // vectorises; most pixels then fail one comparison).
        let mut step = vec![0u8; width];
        for y in 0..height {
            let row = &luma[y * width..][..width];
            let up = &luma[y.saturating_sub(1) * width..][..width];
            let down = &luma[(y + 1).min(height - 1) * width..][..width];
            for (((s, &l), &u), &d) in step.iter_mut().zip(row).zip(up).zip(down) {
                *s = l.abs_diff(u).max(l.abs_diff(d));
            }
            for x in 1..width {
                let d = row[x].abs_diff(row[x - 1]);
                step[x] = step[x].max(d);
                step[x - 1] = step[x - 1].max(d);
            }
            for (x, &contrast) in step.iter().enumerate() {
                if contrast < FLAT {
                    continue;
                }
                let (left, right) = (x.saturating_sub(1), (x + 1).min(width - 1));
                let l = i32::from(row[x]);
                // An edge running across the picture changes brightness from north to south.
                let vertical = (i32::from(up[x]) + i32::from(down[x]) - 2 * l).abs();
                let horizontal = (i32::from(row[left]) + i32::from(row[right]) - 2 * l).abs();
                let (a, b) = if vertical >= horizontal {
                    (
                        y.saturating_sub(1) * width + x,
                        (y + 1).min(height - 1) * width + x,
                    )
                } else {
                    (y * width + left, y * width + right)
                };
                // Weight of the neighbours, of 256: up to a half, eased in from FLAT to SHARP.
                let t = ((u32::from(contrast) - u32::from(FLAT)) * 256 / (SHARP - u32::from(FLAT)))
                    .min(256);
                let weight = t * t * (768 - 2 * t) / (256 * 256) / 2;
                let c = y * width + x;
                let own = &mut out[4 * c..][..3];
                for (k, o) in own.iter_mut().enumerate() {
                    let mine = u32::from(rgba[4 * c + k]);
                    let across = (u32::from(rgba[4 * a + k]) + u32::from(rgba[4 * b + k])) / 2;
                    *o = ((mine * (256 - weight) + across * weight) / 256) as u8;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn picture(width: usize, height: usize, pixel: impl Fn(usize, usize) -> [u8; 4]) -> Vec<u8> {
        let mut rgba = Vec::with_capacity(width * height * 4);
        for y in 0..height {
            for x in 0..width {
                rgba.extend(pixel(x, y));
            }
        }
        rgba
    }

    #[test]
    fn flat_and_gently_shaded_pictures_pass_unchanged() {
        let flat = picture(8, 6, |_, _| [90, 120, 200, 255]);
        assert_eq!(smooth_edges(&flat, 8, 6), flat);
        let ramp = picture(64, 4, |x, _| [x as u8 * 2, x as u8 * 2, x as u8 * 2, 255]);
        assert_eq!(smooth_edges(&ramp, 64, 4), ramp);
    }

    #[test]
    fn a_hard_edge_is_blended_half_way_to_the_neighbours_across_it() {
        // Black left of x = 4, white from it: each side's edge pixel goes half-way towards
        // the mean of its left and right neighbours (a step of 255 is past SHARP).
        let edge = picture(8, 3, |x, _| if x < 4 { [0, 0, 0, 255] } else { [255; 4] });
        let smoothed = smooth_edges(&edge, 8, 3);
        let grey = |x: usize, y: usize| smoothed[(y * 8 + x) * 4];
        let expected_dark = (0.0 + 127.0) / 2.0;
        let expected_light = (255.0 + 127.0) / 2.0;
        for y in 0..3 {
            assert!(
                (f64::from(grey(3, y)) - expected_dark).abs() <= 1.0,
                "{}",
                grey(3, y)
            );
            assert!(
                (f64::from(grey(4, y)) - expected_light).abs() <= 1.0,
                "{}",
                grey(4, y)
            );
            // Away from the edge, and alpha everywhere, nothing changes.
            assert_eq!((grey(0, y), grey(7, y)), (0, 255));
        }
        assert!(smoothed.chunks(4).all(|p| p[3] == 255));
        // A horizontal edge is blended along the columns, the same way.
        let edge = picture(3, 8, |_, y| if y < 4 { [0, 0, 0, 255] } else { [255; 4] });
        let smoothed = smooth_edges(&edge, 3, 8);
        assert!((f64::from(smoothed[(3 * 3 + 1) * 4]) - expected_dark).abs() <= 1.0);
    }
}
