use mesh::{check_closed, validate_solid, SolidError, TriMesh};
use parry3d::mass_properties::MassProperties;
use parry3d::math::Vector;
use parry3d::shape::{TriMesh as ParryMesh, TriMeshFlags};

use super::geometry::{self, box_faces, flipped, ALL};

fn parry_vertices(mesh: &TriMesh) -> Vec<Vector> {
    mesh.vertices
        .iter()
        .map(|p| Vector::new(p[0] as f32, p[1] as f32, p[2] as f32))
        .collect()
}

/// parry3d's half-edge topology accepts exactly what `check_closed` accepts
/// (for these meshes) — an independent cross-check of the edge bookkeeping.
fn parry_topology_ok(mesh: &TriMesh) -> bool {
    let mut shape = ParryMesh::new(parry_vertices(mesh), mesh.triangles.clone()).unwrap();
    shape.set_flags(TriMeshFlags::HALF_EDGE_TOPOLOGY).is_ok()
}

#[test]
fn volume_matches_parry_mass_properties() {
    for (name, mesh) in [
        (
            "box_with_void",
            TriMesh::from_soup(geometry::box_with_void()),
        ),
        ("spool", TriMesh::from_soup(geometry::spool())),
        ("icosphere", geometry::icosphere([1.0, 2.0, 3.0], 10.0, 4)),
    ] {
        let ours = mesh.signed_volume_mm3();
        let parry = MassProperties::from_trimesh(1.0, &parry_vertices(&mesh), &mesh.triangles)
            .mass() as f64;
        println!("{name}: divergence theorem {ours:.6} mm³, parry3d {parry:.6} mm³");
        assert!(
            (ours - parry).abs() < 1e-5 * ours,
            "{name}: {ours} vs {parry}"
        );
        assert!(parry_topology_ok(&mesh), "{name}");
        check_closed(&mesh).unwrap();
    }
}

#[test]
fn inward_mesh_is_flipped() {
    let mut mesh = TriMesh::from_soup(flipped(geometry::box_with_void()));
    assert!(mesh.signed_volume_mm3() < 0.0);
    let info = validate_solid(&mut mesh).unwrap();
    assert_eq!((info.shells, info.flipped_shells), (2, 2));
    assert!((info.volume_mm3 - 23_500.0).abs() < 1e-9);
    assert!((mesh.signed_volume_mm3() - 23_500.0).abs() < 1e-9);
}

/// A void shell wound like the outer skin (a common export fault) passes
/// `check_closed`; `validate_solid` finds it nested once and flips it, and
/// an island inside the void (nested twice) stays outward.
#[test]
fn misoriented_void_shell_is_flipped() {
    let mut soup = Vec::new();
    box_faces(&mut soup, [0.0; 3], [40.0, 30.0, 20.0], ALL);
    box_faces(&mut soup, [10.0, 10.0, 5.0], [30.0, 20.0, 15.0], ALL); // void, wrong way
    box_faces(&mut soup, [15.0, 12.0, 7.0], [25.0, 18.0, 13.0], ALL); // island, right way
    let mut mesh = TriMesh::from_soup(soup);
    check_closed(&mesh).unwrap();
    let before = mesh::stock_from_mesh(&mesh, 1.0).unwrap().1;
    assert_eq!(before.overlap_columns, 20 * 10);
    let info = validate_solid(&mut mesh).unwrap();
    let exact = 24_000.0 - 2_000.0 + 360.0;
    assert_eq!((info.shells, info.flipped_shells), (3, 1));
    assert!(
        (info.volume_mm3 - exact).abs() < 1e-9,
        "{}",
        info.volume_mm3
    );
    let (stock, stats) = mesh::stock_from_mesh(&mesh, 1.0).unwrap();
    assert_eq!((stats.overlap_columns, stats.unpaired_columns), (0, 0));
    assert_eq!(stock.volume_mm3(), exact);
}

#[test]
fn one_reversed_triangle_is_inconsistent() {
    let mut mesh = TriMesh::from_soup(geometry::box_with_void());
    mesh.triangles[3].swap(1, 2);
    assert!(!parry_topology_ok(&mesh));
    let err = check_closed(&mesh).unwrap_err();
    assert!(
        matches!(err, SolidError::InconsistentOrientation { edges: 3, .. }),
        "{err}"
    );
    assert!(
        err.to_string()
            .starts_with("inconsistent orientation: 3 edges"),
        "{err}"
    );
}

#[test]
fn boxes_sharing_an_edge_are_non_manifold() {
    let mut soup = Vec::new();
    box_faces(&mut soup, [0.0; 3], [1.0; 3], ALL);
    box_faces(&mut soup, [1.0, 1.0, 0.0], [2.0, 2.0, 1.0], ALL);
    let err = check_closed(&TriMesh::from_soup(soup)).unwrap_err();
    assert!(
        matches!(
            err,
            SolidError::NonManifold {
                edges: 1,
                near_mm: [1.0, 1.0, 0.5]
            }
        ),
        "{err}"
    );
    assert!(
        err.to_string()
            .contains("first near (1.0000, 1.0000, 0.5000) mm"),
        "{err}"
    );
}

#[test]
fn open_mesh_reports_boundary_edges() {
    let err = check_closed(&TriMesh::from_soup(geometry::open_box())).unwrap_err();
    assert_eq!(
        err.to_string().split(", first").next().unwrap(),
        "mesh is not closed: 4 boundary edges"
    );
}

#[test]
fn bad_indices_and_empty_meshes_are_errors() {
    assert_eq!(check_closed(&TriMesh::default()), Err(SolidError::Empty));
    let bad = TriMesh {
        vertices: vec![[0.0; 3]; 3],
        triangles: vec![[0, 1, 3]],
    };
    assert!(matches!(
        check_closed(&bad),
        Err(SolidError::IndexOutOfRange {
            triangle: 0,
            vertex: 3,
            vertices: 3
        })
    ));
    assert!(mesh::stock_from_mesh(&bad, 1.0).is_err());
}
