//! What can go wrong loading a mesh or filling a stock from it ([`MeshError`]).

use std::path::PathBuf;

use crate::solid::SolidError;

/// What can go wrong loading a mesh or filling a stock from it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The file cannot be read.
    #[error("cannot read mesh file {}: {error}", path.display())]
    Read {
        /// The mesh file.
        path: PathBuf,
        /// What the system said.
        error: std::io::Error,
    },
    /// The file is not valid STL or OBJ.
    #[error("cannot parse mesh file {}: {message}", path.display())]
    Parse {
        /// The mesh file.
        path: PathBuf,
        /// What the parser found, with its position where known.
        message: String,
    },
    /// The file name ends in neither `.stl` nor `.obj`.
    #[error("mesh file {}: unknown extension (expected .stl or .obj)", path.display())]
    UnknownExtension {
        /// The mesh file.
        path: PathBuf,
    },
    /// The file holds no triangles.
    #[error("mesh file {}: holds no triangles", path.display())]
    Empty {
        /// The mesh file.
        path: PathBuf,
    },
    /// A vertex has a NaN or infinite coordinate.
    #[error("mesh file {}: vertex {vertex} has a non-finite coordinate {coordinates:?}", path.display())]
    NonFinite {
        /// The mesh file.
        path: PathBuf,
        /// 0-based vertex index.
        vertex: usize,
        /// Its coordinates as read, mm.
        coordinates: [f64; 3],
    },
    /// The triangles do not bound a solid (open, non-manifold, mis-oriented, flat).
    #[error("mesh file {}: not a valid solid: {error}", path.display())]
    NotSolid {
        /// The mesh file.
        path: PathBuf,
        /// What is wrong with it.
        error: SolidError,
    },
    /// An in-memory mesh that cannot be used (bad indices, empty, non-finite).
    #[error("invalid mesh: {0}")]
    Invalid(#[from] SolidError),
    /// The stock grid cannot be built (too fine, too large).
    #[error(transparent)]
    Stock(#[from] dexel::Error),
}
