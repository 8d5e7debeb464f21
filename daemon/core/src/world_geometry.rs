//! A scene's solids as pictures show them, in a block of their own sized by the scene: made
//! when the scene is swapped in, off the haptic thread, and never written again. A device's
//! `OpenGeometry` hands it out beside the world's frames (the world state's block), whose
//! `scene_switches` says which scene a reader should hold the solids of. Unlike the frames,
//! the block needs no sequence lock: it is sealed whole before anyone can map it.
//!
//! Layout: a [`Header`] (`hapticdG`, [`VERSION`], the block's size), then the scene's
//! `scene_switches`, its body count, the solid count and the triangle count (`u32` each),
//! the solids ([`HapticdSolid`]), and the triangles ([`HapticdTriangle`]).

use hapticd_plugin_api::{Geometry, HapticdSolid, HapticdTriangle};

use crate::shared_header::{Header, WrongLayout};

/// First bytes of a scene's geometry block.
pub const MAGIC: [u8; 8] = *b"hapticdG";

/// Layout version: raised with any change to the layout.
pub const VERSION: u32 = 1;

/// Most solids a block holds; a larger scene shows its first ones.
pub const MAX_SOLIDS: usize = 1 << 16;

/// Most triangles a block holds: four of the largest mesh files a scene may name.
pub const MAX_TRIANGLES: usize = 2_000_000;

/// The counts after the header.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
struct Counts {
    scene_switches: u32,
    body_count: u32,
    solid_count: u32,
    triangle_count: u32,
}

const HEAD: usize = size_of::<Header>() + size_of::<Counts>();

/// The solids and triangles of `geometry` a block holds (at most [`MAX_SOLIDS`] and
/// [`MAX_TRIANGLES`]).
fn kept(geometry: &Geometry) -> (usize, usize) {
    (
        geometry.solids.len().min(MAX_SOLIDS),
        geometry.triangles.len().min(MAX_TRIANGLES),
    )
}

fn size(solids: usize, triangles: usize) -> usize {
    HEAD + solids * size_of::<HapticdSolid>() + triangles * size_of::<HapticdTriangle>()
}

/// Bytes of the block of `geometry`.
pub fn block_size(geometry: &Geometry) -> usize {
    let (solids, triangles) = kept(geometry);
    size(solids, triangles)
}

/// Write the block of `geometry`, the solids of the scene counted `scene_switches`.
///
/// # Safety
/// `block` is valid for writes of [`block_size`] bytes and aligned for `f64`.
pub unsafe fn write(block: *mut u8, scene_switches: u32, geometry: &Geometry) {
    let (solids, triangles) = kept(geometry);
    let header = Header::new(MAGIC, VERSION, size(solids, triangles));
    let counts = Counts {
        scene_switches,
        body_count: geometry.body_count,
        solid_count: solids as u32,
        triangle_count: triangles as u32,
    };
    // SAFETY: per this function's contract; each part lies within the block's size and at
    // an offset aligned for its type (the head and the solids are multiples of 8 bytes).
    unsafe {
        block.cast::<Header>().write(header);
        block
            .add(size_of::<Header>())
            .cast::<Counts>()
            .write(counts);
        let at = block.add(HEAD).cast::<HapticdSolid>();
        std::ptr::copy_nonoverlapping(geometry.solids.as_ptr(), at, solids);
        let at = block
            .add(HEAD + solids * size_of::<HapticdSolid>())
            .cast::<HapticdTriangle>();
        std::ptr::copy_nonoverlapping(geometry.triangles.as_ptr(), at, triangles);
    }
}

/// The `scene_switches` and the geometry of the block at `block`, `len` bytes mapped;
/// refused when it is no such block or its counts do not fit its size.
///
/// # Safety
/// `block` is valid for reads of `len` bytes and aligned for `f64`, and nobody writes it.
pub unsafe fn read(block: *const u8, len: usize) -> Result<(u32, Geometry), WrongLayout> {
    if len < HEAD {
        return Err(WrongLayout(format!(
            "{len} bytes: too short for a scene's geometry"
        )));
    }
    // SAFETY: the counts lie within the `len` bytes checked above.
    let counts = unsafe { block.add(size_of::<Header>()).cast::<Counts>().read() };
    let (solids, triangles) = (counts.solid_count as usize, counts.triangle_count as usize);
    if solids > MAX_SOLIDS || triangles > MAX_TRIANGLES {
        return Err(WrongLayout(format!(
            "a scene's geometry of {solids} solids and {triangles} triangles: at most \
             {MAX_SOLIDS} and {MAX_TRIANGLES}"
        )));
    }
    let expected = Header::new(MAGIC, VERSION, size(solids, triangles));
    // SAFETY: as above; the header lies within `len` too.
    unsafe { expected.check(block.cast::<Header>(), len, "a scene's geometry") }?;
    // SAFETY: the solids and triangles lie within the size just checked, aligned as
    // written; every bit pattern of them is a value (numbers only).
    let geometry = unsafe {
        let solids_at = block.add(HEAD).cast::<HapticdSolid>();
        let triangles_at = block
            .add(HEAD + solids * size_of::<HapticdSolid>())
            .cast::<HapticdTriangle>();
        Geometry {
            body_count: counts.body_count,
            solids: std::slice::from_raw_parts(solids_at, solids).to_vec(),
            triangles: std::slice::from_raw_parts(triangles_at, triangles).to_vec(),
        }
    };
    Ok((counts.scene_switches, geometry))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry(triangles: usize) -> Geometry {
        let mut g = Geometry {
            body_count: 2,
            ..Geometry::default()
        };
        g.add_triangles(
            HapticdSolid::default(),
            (0..triangles).map(|k| HapticdTriangle {
                corners: [[k as f64, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            }),
        );
        g.add_solid(HapticdSolid::default());
        g
    }

    /// A block in 8-aligned memory of `len` bytes.
    fn memory(len: usize) -> Vec<u64> {
        vec![0; len.div_ceil(8)]
    }

    #[test]
    fn a_scene_of_any_size_reads_back_whole() {
        // Past the 16 384 triangles the world's block once had room for.
        for n in [0, 3, 100_000] {
            let g = geometry(n);
            let len = block_size(&g);
            let mut m = memory(len);
            // SAFETY: `m` holds `len` bytes, 8-aligned.
            unsafe { write(m.as_mut_ptr().cast(), 7, &g) };
            // SAFETY: as above.
            let (switches, back) = unsafe { read(m.as_ptr().cast(), len) }.unwrap();
            assert_eq!((switches, &back), (7, &g));
        }
    }

    #[test]
    fn a_block_whose_counts_lie_is_refused() {
        let g = geometry(10);
        let len = block_size(&g);
        let mut m = memory(len);
        // SAFETY: `m` holds `len` bytes, 8-aligned.
        unsafe { write(m.as_mut_ptr().cast(), 1, &g) };
        // SAFETY: a shorter view of the same memory.
        let short = unsafe { read(m.as_ptr().cast(), len - 1) };
        assert!(short.is_err_and(|e| e.0.contains("bytes")));
        // One triangle more than the block holds: its size no longer matches its header.
        let bytes: &mut [u8] =
            // SAFETY: the same `len` bytes, viewed as bytes.
            unsafe { std::slice::from_raw_parts_mut(m.as_mut_ptr().cast(), len) };
        bytes[size_of::<Header>() + 12..size_of::<Header>() + 16]
            .copy_from_slice(&11u32.to_le_bytes());
        // SAFETY: as above.
        assert!(unsafe { read(m.as_ptr().cast(), len) }.is_err());
        bytes[size_of::<Header>() + 12..size_of::<Header>() + 16]
            .copy_from_slice(&u32::MAX.to_le_bytes());
        // SAFETY: as above.
        let huge = unsafe { read(m.as_ptr().cast(), len) };
        assert!(huge.is_err_and(|e| e.0.contains("at most")));
    }
}
