use std::path::{Path, PathBuf};

use mesh::{load_mesh, load_solid, MeshError, SolidError};

use super::fixtures::{binary_stl, stock_models};

fn scratch(name: &str, contents: &[u8]) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("mesh-load");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path
}

fn check_err(path: &Path, expected: impl Fn(&MeshError) -> bool, message_part: &str) {
    let err = load_mesh(path).expect_err("must fail");
    let message = err.to_string();
    assert!(expected(&err), "wrong kind: {err:?}");
    assert!(
        message.contains(&*path.file_name().unwrap().to_string_lossy()),
        "message must name the file: {message}"
    );
    assert!(
        message.contains(message_part),
        "{message:?} lacks {message_part:?}"
    );
}

#[test]
fn all_fixture_formats_load_to_the_same_welded_mesh() {
    let bin = load_mesh(&stock_models().join("box_with_void.stl")).unwrap();
    let ascii = load_mesh(&stock_models().join("box_with_void_ascii.stl")).unwrap();
    let obj = load_mesh(&stock_models().join("box_with_void.obj")).unwrap();
    assert_eq!((bin.vertices.len(), bin.triangles.len()), (16, 24));
    assert_eq!(bin, ascii);
    assert_eq!(bin, obj);
}

#[test]
fn extension_is_case_insensitive() {
    let bytes = std::fs::read(stock_models().join("box_with_void.stl")).unwrap();
    let mesh = load_mesh(&scratch("UPPER.STL", &bytes)).unwrap();
    assert_eq!(mesh.triangles.len(), 24);
}

#[test]
fn load_errors_name_the_file() {
    check_err(
        &scratch("model.ply", b"ply"),
        |e| matches!(e, MeshError::UnknownExtension { .. }),
        "unknown extension",
    );
    check_err(
        Path::new("/nonexistent/dir/missing.stl"),
        |e| matches!(e, MeshError::Read { .. }),
        "cannot read",
    );
    check_err(
        &scratch("empty.stl", b"solid empty\nendsolid empty\n"),
        |e| matches!(e, MeshError::Empty { .. }),
        "no triangles",
    );
    check_err(
        &scratch("empty.obj", b"# nothing\n"),
        |e| matches!(e, MeshError::Empty { .. }),
        "no triangles",
    );
    check_err(
        &scratch("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
        |e| matches!(e, MeshError::Parse { .. }),
        "cannot parse",
    );
    let mut truncated = vec![0u8; 80];
    truncated.extend(5u32.to_le_bytes()); // five triangles announced, one half there
    truncated.extend([0u8; 25]);
    check_err(
        &scratch("truncated.stl", &truncated),
        |e| matches!(e, MeshError::Parse { .. }),
        "cannot parse",
    );
    let nan = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [f64::NAN, 1.0, 0.0]]];
    check_err(
        &scratch("nan.stl", &binary_stl(&nan)),
        |e| matches!(e, MeshError::NonFinite { vertex: 2, .. }),
        "non-finite",
    );
    check_err(
        &scratch("inf.obj", b"v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n"),
        |e| matches!(e, MeshError::NonFinite { vertex: 2, .. }),
        "non-finite",
    );
}

#[test]
fn open_mesh_is_rejected_naming_the_file() {
    let err = load_solid(&stock_models().join("open_box.stl")).expect_err("open box is no solid");
    let message = err.to_string();
    assert!(message.contains("open_box.stl"), "{message}");
    assert!(
        message.contains("mesh is not closed: 4 boundary edges, first near"),
        "{message}"
    );
    assert!(matches!(
        err,
        MeshError::NotSolid {
            error: SolidError::NotClosed { edges: 4, .. },
            ..
        }
    ));
}

#[test]
fn fixtures_are_valid_solids() {
    for (name, volume) in [
        ("box_with_void.stl", 23_500.0),
        ("box_with_void.obj", 23_500.0),
        ("spool_undercut.stl", 7_800.0),
    ] {
        let (_, info) = load_solid(&stock_models().join(name)).unwrap();
        assert_eq!(info.flipped_shells, 0, "{name}");
        assert!(
            (info.volume_mm3 - volume).abs() < 1e-9 * volume,
            "{name}: {}",
            info.volume_mm3
        );
    }
}
