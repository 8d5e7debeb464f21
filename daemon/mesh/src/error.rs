//! Why a mesh is refused: one kind of refusal per variant, so that a caller can tell a file
//! that breaks its format from one that is too large or one that bounds no volume; each
//! says what a user reads.

use std::fmt;

/// The mesh formats read here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Wavefront OBJ.
    Obj,
    /// STL, binary or ASCII.
    Stl,
    /// glTF 2.0, `.gltf` or `.glb`.
    Gltf,
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Obj => "OBJ",
            Format::Stl => "STL",
            Format::Gltf => "glTF",
        })
    }
}

/// What a mesh holds too much of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Budget {
    /// Triangles.
    Triangles,
    /// Vertex positions as the file lists them.
    Positions,
    /// Distinct vertices.
    Vertices,
    /// glTF nodes.
    Nodes,
    /// Bytes of buffers.
    Bytes,
}

/// Why a mesh is refused.
#[derive(Debug, Clone, PartialEq)]
pub enum MeshError {
    /// The scale asked for is no positive finite number.
    Scale(f64),
    /// The file's extension names no format read here.
    UnknownFormat,
    /// The file, or a buffer it names, cannot be read where it is (the reason).
    Unreadable(String),
    /// The file breaks its format: which format, and how.
    Malformed {
        /// The format.
        format: Format,
        /// How, in words.
        reason: String,
    },
    /// It holds more than a limit allows: which limit, and by how much in words.
    TooLarge {
        /// The limit passed.
        budget: Budget,
        /// How, in words.
        reason: String,
    },
    /// It has no triangle.
    Empty,
    /// A vertex (counted from 1) is not a finite point.
    NotFinite(usize),
    /// A triangle names a vertex the file does not have (both counted from 1).
    NoSuchVertex {
        /// The triangle.
        triangle: usize,
        /// The vertex it names.
        vertex: usize,
        /// How many there are.
        vertices: usize,
    },
    /// A format crate failed on it: a fault of the reader's, caught.
    ReaderFault,
    /// A body's surface bounds no volume: edges of one face only, and edges of more than
    /// two faces or of two that run the same way.
    Open {
        /// Edges only one triangle has.
        open_edges: usize,
        /// Edges shared wrongly.
        bad_edges: usize,
    },
    /// The surface's faces point inwards (the volume they close is negative).
    InsideOut,
    /// The decomposition failed on it at this many voxels along its longest side: a fault
    /// of the decomposition's, caught.
    Uncut(u32),
}

impl MeshError {
    /// The file breaks `format` as `reason` says.
    pub(crate) fn malformed(format: Format, reason: impl Into<String>) -> Self {
        MeshError::Malformed {
            format,
            reason: reason.into(),
        }
    }

    /// The same refusal, said of the part of the file `at` names.
    pub(crate) fn within(self, at: &str) -> Self {
        match self {
            MeshError::Malformed { format, reason } => MeshError::Malformed {
                format,
                reason: format!("{at}: {reason}"),
            },
            MeshError::TooLarge { budget, reason } => MeshError::TooLarge {
                budget,
                reason: format!("{at}: {reason}"),
            },
            other => other,
        }
    }

    /// The file passes the `budget` as `reason` says.
    pub(crate) fn too_large(budget: Budget, reason: impl Into<String>) -> Self {
        MeshError::TooLarge {
            budget,
            reason: reason.into(),
        }
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshError::Scale(scale) => write!(f, "scale must be a finite number > 0, not {scale}"),
            MeshError::UnknownFormat => {
                f.write_str("not a mesh file hapticd reads: .obj, .stl, .gltf or .glb")
            }
            MeshError::Unreadable(reason)
            | MeshError::Malformed { reason, .. }
            | MeshError::TooLarge { reason, .. } => f.write_str(reason),
            MeshError::Empty => f.write_str("no triangles"),
            MeshError::NotFinite(k) => write!(f, "vertex {k} is not finite"),
            MeshError::NoSuchVertex {
                triangle,
                vertex,
                vertices,
            } => write!(
                f,
                "triangle {triangle} names vertex {vertex}, but there are {vertices}"
            ),
            MeshError::ReaderFault => {
                f.write_str("its reader failed on it (a fault of the reader's)")
            }
            MeshError::Open {
                open_edges,
                bad_edges,
            } => write!(
                f,
                "not a closed surface ({open_edges} open edges, {bad_edges} edges not shared by \
                 two faces in turn): a movable body's mesh, and any under engine: penalty (its \
                 contacts are volumes), must enclose its volume (fill its holes in a modelling \
                 tool, such as MeshLab's \"Close Holes\"), or make the body fixed (fixed: true) \
                 under engine: rapier, or a static scene's shape: both take any surface"
            ),
            MeshError::InsideOut => {
                f.write_str("its faces point inwards (the volume they close is negative)")
            }
            MeshError::Uncut(resolution) => write!(
                f,
                "V-HACD failed to cut it into convex pieces at {resolution} voxels along its \
                 longest side (a fault of the decomposition's): remesh or simplify it, or make \
                 the body fixed (fixed: true) under engine: rapier, which takes its triangles \
                 as they are"
            ),
        }
    }
}

impl std::error::Error for MeshError {}

/// A mesh error and the file it is about, as the public readers return it.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFileError {
    /// The file.
    pub file: std::path::PathBuf,
    /// Why it is refused.
    pub error: MeshError,
}

impl fmt::Display for MeshFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.file.display(), self.error)
    }
}

impl std::error::Error for MeshFileError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}
