//! The files in `stock_models/` are written from the solids in `geometry.rs`:
//! `cargo test -p mesh --test mesh -- --ignored write_fixtures` rewrites them,
//! and `fixtures_are_up_to_date` checks that the committed files match.

use std::path::PathBuf;

use super::geometry::{self, Tri};

pub fn stock_models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../stock_models")
}

fn normal(t: &Tri) -> [f64; 3] {
    let [a, b, c] = t;
    let (u, v) = (
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
        [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
    );
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|c| c / len)
}

pub fn binary_stl(tris: &[Tri]) -> Vec<u8> {
    let stl: Vec<stl_io::Triangle> = tris
        .iter()
        .map(|t| stl_io::Triangle {
            normal: stl_io::Normal::new(normal(t).map(|c| c as f32)),
            vertices: t.map(|p| stl_io::Vertex::new(p.map(|c| c as f32))),
        })
        .collect();
    let mut out = Vec::new();
    stl_io::write_stl(&mut out, stl.iter()).expect("writing to memory");
    out
}

pub fn ascii_stl(name: &str, tris: &[Tri]) -> Vec<u8> {
    let mut s = format!("solid {name}\n");
    for t in tris {
        let n = normal(t);
        s += &format!(
            "  facet normal {} {} {}\n    outer loop\n",
            n[0], n[1], n[2]
        );
        for p in t {
            s += &format!("      vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        s += "    endloop\n  endfacet\n";
    }
    s += &format!("endsolid {name}\n");
    s.into_bytes()
}

pub fn obj(tris: &[Tri]) -> Vec<u8> {
    let mesh = mesh::TriMesh::from_soup(tris.iter().copied());
    let mut s = String::from("# written by crates/mesh/tests/mesh/fixtures.rs\no solid\n");
    for p in &mesh.vertices {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for t in &mesh.triangles {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s.into_bytes()
}

fn all() -> Vec<(&'static str, Vec<u8>)> {
    let void = geometry::box_with_void();
    vec![
        ("box_with_void.stl", binary_stl(&void)),
        ("box_with_void_ascii.stl", ascii_stl("box_with_void", &void)),
        ("box_with_void.obj", obj(&void)),
        ("open_box.stl", binary_stl(&geometry::open_box())),
        ("spool_undercut.stl", binary_stl(&geometry::spool())),
    ]
}

#[test]
#[ignore = "rewrites stock_models/; run by hand after changing geometry.rs"]
fn write_fixtures() {
    for (name, bytes) in all() {
        std::fs::write(stock_models().join(name), bytes).unwrap();
    }
}

#[test]
fn fixtures_are_up_to_date() {
    for (name, bytes) in all() {
        let on_disk =
            std::fs::read(stock_models().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            on_disk == bytes,
            "stock_models/{name} differs from geometry.rs; run write_fixtures"
        );
    }
}
