//! Reading STL and OBJ files (the crate's only file access).

use std::io::Cursor;
use std::path::Path;

use crate::{validate_solid, MeshError, SolidInfo, TriMesh};

/// Read a triangle mesh from an STL (binary or ASCII) or OBJ file, chosen by
/// the extension (case-insensitive). Coordinates are taken as mm. OBJ faces
/// are triangulated and all objects merged; vertices with equal coordinates
/// are welded. The mesh is not checked for being a solid (see [`load_solid`]).
pub fn load_mesh(path: &Path) -> Result<TriMesh, MeshError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let kind = match ext.as_deref() {
        Some("stl") => Kind::Stl,
        Some("obj") => Kind::Obj,
        _ => {
            return Err(MeshError::UnknownExtension {
                path: path.to_path_buf(),
            })
        }
    };
    let bytes = std::fs::read(path).map_err(|error| MeshError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    let parse_error = |message: String| MeshError::Parse {
        path: path.to_path_buf(),
        message,
    };
    let mesh = match kind {
        Kind::Stl => read_stl(&bytes).map_err(|e| parse_error(e.to_string()))?,
        Kind::Obj => read_obj(&bytes).map_err(|e| parse_error(e.to_string()))?,
    };
    if mesh.triangles.is_empty() {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
        });
    }
    if let Some((vertex, &coordinates)) = mesh
        .vertices
        .iter()
        .enumerate()
        .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
    {
        return Err(MeshError::NonFinite {
            path: path.to_path_buf(),
            vertex,
            coordinates,
        });
    }
    Ok(mesh)
}

/// [`load_mesh`] followed by [`validate_solid`]: the mesh must be closed,
/// manifold and consistently wound; it is returned facing outward.
pub fn load_solid(path: &Path) -> Result<(TriMesh, SolidInfo), MeshError> {
    let mut mesh = load_mesh(path)?;
    let info = validate_solid(&mut mesh).map_err(|error| MeshError::NotSolid {
        path: path.to_path_buf(),
        error,
    })?;
    Ok((mesh, info))
}

enum Kind {
    Stl,
    Obj,
}

/// A binary STL is an 80-byte header, a triangle count N and 50 bytes per
/// triangle; a file of another size is truncated (or padded) and refused with
/// the sizes, rather than with the reader's "failed to fill whole buffer".
fn check_stl_size(bytes: &[u8]) -> std::io::Result<()> {
    let ascii = bytes.trim_ascii_start().starts_with(b"solid");
    let invalid = |m: String| Err(std::io::Error::new(std::io::ErrorKind::InvalidData, m));
    if bytes.len() < 84 {
        if !ascii {
            return invalid(format!(
                "{} bytes: too short for a binary STL (84-byte header) and not ASCII STL",
                bytes.len()
            ));
        }
        return Ok(());
    }
    let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
    let expected = 84 + 50 * count;
    if !ascii && bytes.len() as u64 != expected {
        return invalid(format!(
            "binary STL with {count} triangles must have {expected} bytes, the file has {}: truncated or damaged",
            bytes.len()
        ));
    }
    Ok(())
}

fn read_stl(bytes: &[u8]) -> std::io::Result<TriMesh> {
    check_stl_size(bytes)?;
    let mut cursor = Cursor::new(bytes);
    let triangles = stl_io::create_stl_reader(&mut cursor)?
        .map(|t| t.map(|t| t.vertices.map(|v| v.0.map(f64::from))))
        .collect::<std::io::Result<Vec<_>>>()
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                std::io::Error::new(e.kind(), "the file ends inside a triangle: truncated")
            } else {
                e
            }
        })?;
    Ok(TriMesh::from_soup(triangles))
}

fn read_obj(bytes: &[u8]) -> Result<TriMesh, tobj::LoadError> {
    let mut options = tobj::LoadOptions::default();
    (
        options.triangulate,
        options.ignore_points,
        options.ignore_lines,
    ) = (true, true, true);
    // Materials are irrelevant here; refuse to open .mtl files.
    let (models, _materials) = tobj::load_obj_buf(&mut Cursor::new(bytes), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })?;
    let soup = models.iter().flat_map(|model| {
        let m = &model.mesh;
        let at = move |i: u32| {
            let k = 3 * i as usize;
            [
                m.positions[k] as f64,
                m.positions[k + 1] as f64,
                m.positions[k + 2] as f64,
            ]
        };
        m.indices
            .chunks_exact(3)
            .map(move |t| [at(t[0]), at(t[1]), at(t[2])])
    });
    Ok(TriMesh::from_soup(soup))
}
