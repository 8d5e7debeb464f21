//! STL, binary or ASCII; STL gives no corner normals, only a face's, which are not read.
//!
//! A binary file is an 80-byte header, a triangle count and 50 bytes a triangle, so its
//! length tells it apart: a file of exactly that length is binary even when its header
//! starts with `solid`, as many exporters' do. Anything else that starts with `solid` and
//! holds no NUL byte is ASCII, read token by token (any whitespace between them, a tab after `solid` too).

use glam::DVec3;

use crate::{Budget, Format, Limits, MeshError, Read};

/// Bytes before a binary file's triangles: the header and the count.
const HEADER: usize = 84;
/// Bytes of a binary triangle: normal, three corners (f32 each) and the attribute count.
const TRIANGLE: usize = 50;

/// The triangles of STL `bytes`, at most `limits.triangles` of them.
pub(crate) fn read(bytes: &[u8], limits: Limits) -> Result<Read, MeshError> {
    let declared = bytes
        .get(80..HEADER)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as usize);
    match declared {
        Some(n)
            if n.checked_mul(TRIANGLE).and_then(|b| b.checked_add(HEADER)) == Some(bytes.len()) =>
        {
            binary(bytes, n, limits)
        }
        // Text holds no NUL; a binary file's zeros (of its header or numbers) say it is one.
        _ if bytes.trim_ascii_start().starts_with(b"solid") && !bytes.contains(&0) => {
            ascii(bytes, limits)
        }
        Some(n) => Err(malformed(format!(
            "not a readable STL file: a binary STL of {n} triangles is {} bytes long, not {}",
            HEADER as u128 + n as u128 * TRIANGLE as u128,
            bytes.len()
        ))),
        None => Err(malformed(
            "not a readable STL file: too short for a binary STL, and not ASCII",
        )),
    }
}

/// A binary file of `count` triangles (its length already checked).
fn binary(bytes: &[u8], count: usize, limits: Limits) -> Result<Read, MeshError> {
    if count > limits.triangles {
        return Err(too_many(count, limits));
    }
    let float = |b: &[u8], k: usize| {
        f64::from(f32::from_le_bytes([
            b[4 * k],
            b[4 * k + 1],
            b[4 * k + 2],
            b[4 * k + 3],
        ]))
    };
    let mut positions = Vec::with_capacity(3 * count);
    for triangle in bytes[HEADER..].chunks_exact(TRIANGLE) {
        // The face normal (floats 0–2) is not read: the corners' order gives the face.
        positions.extend((1..4).map(|c| {
            DVec3::new(
                float(triangle, 3 * c),
                float(triangle, 3 * c + 1),
                float(triangle, 3 * c + 2),
            )
        }));
    }
    Ok(soup(positions))
}

/// An ASCII file: `solid`, facets of `facet normal x y z`, `outer loop`, three or more
/// `vertex x y z`, `endloop`, `endfacet`, and `endsolid`, perhaps several solids. A loop of
/// more than three corners is cut into a fan.
fn ascii(bytes: &[u8], limits: Limits) -> Result<Read, MeshError> {
    let mut tokens = Tokens {
        words: bytes
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty()),
        facet: 0,
    };
    let mut positions: Vec<DVec3> = Vec::new();
    let mut triangles = 0usize;
    while let Some(word) = tokens.words.next() {
        // Outside facets only solids' names and ends: skipped.
        if word != b"facet" {
            continue;
        }
        tokens.facet += 1;
        tokens.expect(b"normal")?;
        tokens.point()?;
        tokens.expect(b"outer")?;
        tokens.expect(b"loop")?;
        let mut corners = Vec::with_capacity(3);
        loop {
            match tokens.word()? {
                b"vertex" => corners.push(tokens.point()?),
                b"endloop" => break,
                other => return Err(tokens.unexpected(other, "vertex or endloop")),
            }
        }
        tokens.expect(b"endfacet")?;
        if corners.len() < 3 {
            return Err(malformed(format!(
                "not a readable STL file: facet {} has {} corners",
                tokens.facet,
                corners.len()
            )));
        }
        triangles += corners.len() - 2;
        if triangles > limits.triangles {
            return Err(too_many(triangles, limits));
        }
        for k in 1..corners.len() - 1 {
            positions.extend([corners[0], corners[k], corners[k + 1]]);
        }
    }
    Ok(soup(positions))
}

/// Triangles of three corners each, in order.
fn soup(positions: Vec<DVec3>) -> Read {
    Read {
        triangles: (0..positions.len() / 3)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect(),
        positions,
        normals: None,
    }
}

fn too_many(triangles: usize, limits: Limits) -> MeshError {
    MeshError::too_large(
        Budget::Triangles,
        format!(
            "more than {} triangles ({triangles} so far); a mesh has at most {}",
            limits.triangles, limits.triangles
        ),
    )
}

fn malformed(reason: impl Into<String>) -> MeshError {
    MeshError::malformed(Format::Stl, reason)
}

/// An ASCII file's words, and the facet being read (counted from 1) for errors.
struct Tokens<'a, I: Iterator<Item = &'a [u8]>> {
    words: I,
    facet: usize,
}

impl<'a, I: Iterator<Item = &'a [u8]>> Tokens<'a, I> {
    fn word(&mut self) -> Result<&'a [u8], MeshError> {
        self.words.next().ok_or_else(|| {
            malformed(format!(
                "not a readable STL file: it ends within facet {}",
                self.facet
            ))
        })
    }

    fn unexpected(&self, word: &[u8], wanted: &str) -> MeshError {
        malformed(format!(
            "not a readable STL file: facet {} has {:?} where {wanted} belongs",
            self.facet,
            String::from_utf8_lossy(&word[..word.len().min(32)])
        ))
    }

    fn expect(&mut self, wanted: &[u8]) -> Result<(), MeshError> {
        let word = self.word()?;
        if word == wanted {
            Ok(())
        } else {
            Err(self.unexpected(word, &String::from_utf8_lossy(wanted)))
        }
    }

    fn point(&mut self) -> Result<DVec3, MeshError> {
        let mut c = [0.0; 3];
        for v in &mut c {
            let word = self.word()?;
            *v = std::str::from_utf8(word)
                .ok()
                .and_then(|w| w.parse().ok())
                .ok_or_else(|| self.unexpected(word, "a number"))?;
        }
        Ok(DVec3::from(c))
    }
}
