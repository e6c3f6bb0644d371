use mesh::{signed_distances, DesignModel, TriMesh};

use super::geometry::{self, box_faces, ALL};

#[test]
fn signed_distances_to_a_cube() {
    let mut soup = Vec::new();
    box_faces(&mut soup, [100.0, 200.0, 0.0], [110.0, 210.0, 10.0], ALL);
    let cube = TriMesh::from_soup(soup);
    let cases: [([f64; 3], f64); 7] = [
        ([105.0, 205.0, 5.0], -5.0),          // centre
        ([105.0, 205.0, 12.0], 2.0),          // above the top face
        ([105.0, 205.0, 9.5], -0.5),          // just under the top face
        ([113.0, 214.0, 5.0], 5.0),           // off a vertical edge (3-4-5)
        ([112.0, 212.0, 12.0], 12f64.sqrt()), // off a corner
        ([101.0, 201.0, 0.5], -0.5),          // near a corner, inside
        ([105.0, 205.0, 10.0], 0.0),          // on the surface
    ];
    let points: Vec<_> = cases.iter().map(|c| c.0).collect();
    let got = signed_distances(&cube, &points).unwrap();
    for ((p, want), d) in cases.iter().zip(&got) {
        assert!((d - want).abs() < 1e-5, "{p:?}: {d} vs {want}");
    }
}

#[test]
fn sphere_distances_and_inward_input() {
    // Built from an inward-facing copy: DesignModel orients it.
    let mut sphere = geometry::icosphere([0.0; 3], 10.0, 5);
    sphere.flip();
    let model = DesignModel::new(&sphere).unwrap();
    // The mesh lies within 10·(1 − cos θ) ≈ 0.006 mm inside the true sphere.
    for (p, want) in [
        ([0.0, 0.0, 0.0], -10.0),
        ([0.0, 13.0, 0.0], 3.0),
        ([6.0, 0.0, 6.0], 72f64.sqrt() - 10.0),
    ] {
        let d = model.signed_distance_mm(p);
        assert!((d - want).abs() < 0.01, "{p:?}: {d} vs {want}");
    }
    assert!(DesignModel::new(&TriMesh::from_soup(geometry::open_box())).is_err());
}
