//! Convex pieces kept between runs: a mesh's decomposition takes seconds, so it is done once
//! and kept under the mesh's content hash in hapticd's cache directory (the unit's
//! `CacheDirectory=`, which systemd hands over as `$CACHE_DIRECTORY`; a user's
//! `$XDG_CACHE_HOME/hapticd` elsewhere).
//!
//! The key is the mesh as read at scale 1 (vertices and triangles, so a glTF's buffers count
//! too) with the decomposition's settings: a scaled use of the same file shares its entry,
//! as V-HACD's voxels are measured along the mesh's own longest side. An entry is checked when
//! read (its key, finite points within the mesh's bounds); one that fails is decomposed again.
//! The hash is no defence against a crafted collision: whoever can write meshes for hapticd can
//! already have it touch any shape.

use std::path::{Path, PathBuf};

use glam::DVec3;

use hapticd_core::diagnostics::{FileRules, read_file};

use crate::decomposition::{RESOLUTION, decompose};
use crate::{Limits, MeshError, TriangleMesh};

/// What an entry starts with: the format and its version (2: a convex mesh is its own one
/// piece, where entries of 1 hold V-HACD's cut of it).
const MAGIC: &[u8; 16] = b"hapticd-pieces2\n";
/// Most pieces, and points of a piece, an entry may hold (V-HACD makes far fewer).
const MAX_PIECES: usize = 1024;
const MAX_POINTS: usize = 1 << 16;

/// Where convex pieces are kept; none: each is decomposed where it is needed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cache {
    dir: Option<PathBuf>,
}

impl Cache {
    /// The cache at `dir`.
    pub fn at(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: Some(dir.into()),
        }
    }

    /// The cache of this process: `$CACHE_DIRECTORY` (its first entry) under systemd,
    /// `$XDG_CACHE_HOME/hapticd` or `~/.cache/hapticd` otherwise, each only when absolute.
    pub fn from_environment() -> Self {
        let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
        let dir = var("CACHE_DIRECTORY")
            .and_then(|v| std::env::split_paths(&v).next())
            .or_else(|| var("XDG_CACHE_HOME").map(|d| Path::new(&d).join("hapticd")))
            .or_else(|| var("HOME").map(|h| Path::new(&h).join(".cache/hapticd")))
            .filter(|d| d.is_absolute());
        Self { dir }
    }

    /// The directory, if any.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    /// Where `mesh`'s pieces are kept.
    pub fn entry(&self, mesh: &TriangleMesh) -> Option<PathBuf> {
        let dir = self.dir.as_ref()?;
        Some(
            dir.join("meshes")
                .join(format!("{:016x}.pieces", key(mesh))),
        )
    }

    /// `mesh`'s pieces (each a closed convex surface, in the mesh's frame) if the cache holds
    /// a sound entry for them.
    pub fn lookup(&self, mesh: &TriangleMesh) -> Option<Vec<TriangleMesh>> {
        // Through the guarded reader: an entry that is a FIFO, or a link to /dev/zero, is
        // no entry (one hung the reader, the other read gigabytes).
        let rules = FileRules {
            max_bytes: Limits::DEFAULT.bytes,
            within: None,
        };
        let bytes = read_file(&self.entry(mesh)?, rules).ok()?;
        decode(&bytes, key(mesh), mesh.bounds())
    }

    /// `mesh`'s pieces, from the cache or decomposed now and kept (a cache that cannot be
    /// written only costs the next run the time again); with whether they were cached. An
    /// error where the decomposition fails on it.
    pub fn pieces(&self, mesh: &TriangleMesh) -> Result<(Vec<TriangleMesh>, bool), MeshError> {
        if let Some(pieces) = self.lookup(mesh) {
            return Ok((pieces, true));
        }
        let pieces = decompose(mesh, RESOLUTION)?.pieces;
        self.store(mesh, &pieces);
        Ok((pieces, false))
    }

    /// Keep `pieces` as `mesh`'s; where, if the cache could be written.
    pub fn store(&self, mesh: &TriangleMesh, pieces: &[TriangleMesh]) -> Option<PathBuf> {
        let entry = self.entry(mesh)?;
        hapticd_core::diagnostics::write_atomically(&entry, &encode(key(mesh), pieces)).ok()?;
        Some(entry)
    }
}

/// The cache key of `mesh`: FNV-1a over its vertices, triangles and the decomposition's
/// settings (stable across builds, unlike std's hasher).
fn key(mesh: &TriangleMesh) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |bytes: &[u8]| {
        for b in bytes {
            hash = (hash ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3);
        }
    };
    eat(MAGIC);
    eat(&RESOLUTION.to_le_bytes());
    eat(&(mesh.vertices.len() as u64).to_le_bytes());
    for v in &mesh.vertices {
        for c in v.to_array() {
            eat(&c.to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        for k in t {
            eat(&k.to_le_bytes());
        }
    }
    hash
}

/// An entry: the magic, the key, the piece count, and each piece's point and triangle
/// counts, points and triangles.
fn encode(key: u64, pieces: &[TriangleMesh]) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    out.extend(key.to_le_bytes());
    out.extend((pieces.len() as u32).to_le_bytes());
    for piece in pieces {
        out.extend((piece.vertices.len() as u32).to_le_bytes());
        out.extend((piece.triangles.len() as u32).to_le_bytes());
        for c in piece.vertices.iter().flat_map(|p| p.to_array()) {
            out.extend(c.to_le_bytes());
        }
        for k in piece.triangles.iter().flatten() {
            out.extend(k.to_le_bytes());
        }
    }
    out
}

/// The pieces of entry `bytes` when it is whole, of `key`, every point finite and within the
/// mesh's `bounds`, and every triangle naming points the piece has.
fn decode(bytes: &[u8], key: u64, bounds: (DVec3, DVec3)) -> Option<Vec<TriangleMesh>> {
    let mut rest = bytes.strip_prefix(MAGIC)?;
    let mut take = |n: usize| -> Option<&[u8]> {
        let (head, tail) = rest.split_at_checked(n)?;
        rest = tail;
        Some(head)
    };
    let u32_at = |b: &[u8]| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize;
    if u64::from_le_bytes(take(8)?.try_into().ok()?) != key {
        return None;
    }
    let count = u32_at(take(4)?);
    if count == 0 || count > MAX_PIECES {
        return None;
    }
    let (low, high) = bounds;
    let slack = (high - low).max_element() * 1e-6;
    let mut pieces = Vec::with_capacity(count);
    for _ in 0..count {
        let points = u32_at(take(4)?);
        let triangles = u32_at(take(4)?);
        if !(4..=MAX_POINTS).contains(&points) || !(4..=2 * MAX_POINTS).contains(&triangles) {
            return None;
        }
        let raw = take(points * 24)?;
        let piece: Vec<DVec3> = raw
            .chunks_exact(24)
            .map(|c| {
                let f = |k: usize| f64::from_le_bytes(c[k..k + 8].try_into().expect("8 bytes"));
                DVec3::new(f(0), f(8), f(16))
            })
            .collect();
        let inside = |p: &DVec3| p.cmpge(low - slack).all() && p.cmple(high + slack).all();
        if !piece.iter().all(|p| p.is_finite() && inside(p)) {
            return None;
        }
        let corners: Vec<u32> = take(triangles * 12)?
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        if corners.iter().any(|&k| k as usize >= points) {
            return None;
        }
        pieces.push(TriangleMesh {
            vertices: piece,
            triangles: corners
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
            normals: None,
        });
    }
    rest.is_empty().then_some(pieces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::properties::cuboid;

    #[test]
    fn pieces_are_kept_once_and_bad_entries_are_decomposed_again() {
        let dir = std::env::temp_dir().join(format!("hapticd-cache-{}", std::process::id()));
        let cache = Cache::at(&dir);
        let mesh = cuboid(DVec3::ZERO, DVec3::new(0.1, 0.05, 0.02));
        let (pieces, cached) = cache.pieces(&mesh).unwrap();
        assert!(!cached && !pieces.is_empty());
        let entry = cache.entry(&mesh).unwrap();
        assert!(entry.is_file());
        assert_eq!(cache.pieces(&mesh), Ok((pieces.clone(), true)));
        // Another mesh has another entry.
        let other = cuboid(DVec3::ZERO, DVec3::new(0.1, 0.05, 0.03));
        assert_ne!(cache.entry(&other), Some(entry.clone()));
        // A truncated entry, one with a point outside the mesh, or one of another key is no entry.
        let bytes = std::fs::read(&entry).unwrap();
        let key = key(&mesh);
        assert!(decode(&bytes[..bytes.len() - 1], key, mesh.bounds()).is_none());
        assert!(decode(&bytes, key ^ 1, mesh.bounds()).is_none());
        assert_eq!(decode(&bytes, key, mesh.bounds()), Some(pieces.clone()));
        let mut far = pieces.clone();
        far[0].vertices[0].x = 5.0;
        assert!(decode(&encode(key, &far), key, mesh.bounds()).is_none());
        let mut nan = pieces.clone();
        nan[0].vertices[0].y = f64::NAN;
        assert!(decode(&encode(key, &nan), key, mesh.bounds()).is_none());
        let mut dangling = pieces.clone();
        dangling[0].triangles[0][1] = 999;
        assert!(decode(&encode(key, &dangling), key, mesh.bounds()).is_none());
        std::fs::write(&entry, &bytes[..20]).unwrap();
        assert_eq!(cache.pieces(&mesh), Ok((pieces.clone(), false)));
        assert_eq!(cache.pieces(&mesh), Ok((pieces.clone(), true)));
        // A FIFO in the entry's place (which hung the reader) or a link to /dev/zero (which
        // read gigabytes) is no entry, at once.
        std::fs::remove_file(&entry).unwrap();
        nix::unistd::mkfifo(&entry, nix::sys::stat::Mode::S_IRWXU).unwrap();
        assert_eq!(cache.lookup(&mesh), None);
        std::fs::remove_file(&entry).unwrap();
        std::os::unix::fs::symlink("/dev/zero", &entry).unwrap();
        assert_eq!(cache.lookup(&mesh), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
