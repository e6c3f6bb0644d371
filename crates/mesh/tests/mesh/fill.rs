use std::time::Instant;

use dexel::{Grid, Stock};
use mesh::{load_mesh, stock_from_mesh, top_heights, FillStats, TriMesh};

use super::fixtures::stock_models;
use super::geometry::{self, box_faces, flipped, ALL};

fn fill(mesh: &TriMesh, spacing_mm: f64) -> (Stock, FillStats) {
    stock_from_mesh(mesh, spacing_mm).unwrap()
}

fn intervals_at(stock: &Stock, x: f64, y: f64) -> Vec<[f32; 2]> {
    let g = stock.grid();
    let ix = g
        .ix_range(x - 0.5 * g.spacing_mm, x + 0.5 * g.spacing_mm)
        .unwrap()
        .0;
    let iy = g
        .iy_range(y - 0.5 * g.spacing_mm, y + 0.5 * g.spacing_mm)
        .unwrap()
        .0;
    stock.column(ix, iy).intervals().collect()
}

#[test]
fn box_with_void_volume_is_exact() {
    let mesh = load_mesh(&stock_models().join("box_with_void.stl")).unwrap();
    for spacing in [2.5, 1.0, 0.5, 0.25] {
        let (stock, stats) = fill(&mesh, spacing);
        let err = stock.volume_mm3() - 23_500.0;
        println!("box_with_void g={spacing}: volume error {err:e} mm³, {stats:?}");
        assert!(err.abs() < 1e-9, "g={spacing}: {}", stock.volume_mm3());
        assert_eq!(
            (
                stats.unpaired_columns,
                stats.overlap_columns,
                stats.vertical_triangles
            ),
            (0, 0, 16)
        );
        assert_eq!(
            stats.crossings,
            2 * stock.grid().len() + 2 * (10.0 * 10.0 / (spacing * spacing)) as usize
        );
    }
}

#[test]
fn columns_through_the_cavity_have_two_intervals() {
    let mesh = load_mesh(&stock_models().join("box_with_void.stl")).unwrap();
    let (stock, _) = fill(&mesh, 1.0);
    assert_eq!(
        intervals_at(&stock, 20.0, 15.0),
        vec![[0.0, 5.0], [10.0, 20.0]]
    );
    assert_eq!(
        intervals_at(&stock, 15.5, 10.5),
        vec![[0.0, 5.0], [10.0, 20.0]]
    );
    assert_eq!(intervals_at(&stock, 14.5, 15.0), vec![[0.0, 20.0]]);
    let two = stock.columns().filter(|c| c.interval_count() == 2).count();
    assert_eq!(two, 100);
}

#[test]
fn stl_binary_ascii_and_obj_give_identical_stocks() {
    let stocks: Vec<Stock> = [
        "box_with_void.stl",
        "box_with_void_ascii.stl",
        "box_with_void.obj",
    ]
    .iter()
    .map(|f| fill(&load_mesh(&stock_models().join(f)).unwrap(), 0.5).0)
    .collect();
    for s in &stocks[1..] {
        assert_eq!(s.grid(), stocks[0].grid());
        assert!(s.columns().eq(stocks[0].columns()));
    }
}

#[test]
fn spool_overhang_has_a_gap() {
    let mesh = load_mesh(&stock_models().join("spool_undercut.stl")).unwrap();
    let (stock, stats) = fill(&mesh, 0.5);
    assert_eq!((stats.unpaired_columns, stats.overlap_columns), (0, 0));
    assert_eq!(
        intervals_at(&stock, 7.0, 7.0),
        vec![[0.0, 4.0], [10.0, 14.0]]
    );
    assert_eq!(intervals_at(&stock, 20.0, 15.0), vec![[0.0, 14.0]]);
    assert_eq!(intervals_at(&stock, 2.0, 2.0), vec![[0.0, 4.0]]);
    assert!(
        (stock.volume_mm3() - 7_800.0).abs() < 1e-9,
        "{}",
        stock.volume_mm3()
    );
}

#[test]
fn sphere_volume_converges() {
    let mesh = geometry::icosphere([0.3, -0.2, 5.0], 10.0, 5);
    let exact = mesh.signed_volume_mm3();
    let mut errors = Vec::new();
    for spacing in [0.5, 0.25, 0.1] {
        let (stock, stats) = fill(&mesh, spacing);
        let rel = stock.volume_mm3() / exact - 1.0;
        println!("icosphere r=10 ({} triangles) g={spacing}: relative volume error {rel:+.2e}, {stats:?}", mesh.triangles.len());
        assert_eq!((stats.unpaired_columns, stats.overlap_columns), (0, 0));
        errors.push(rel.abs());
    }
    assert!(
        errors[0] < 3e-3 && errors[1] < 1e-3 && errors[2] < 3e-4,
        "{errors:?}"
    );
}

/// Every column centre is a mesh vertex (shared by 4 or 8 triangles): each
/// column must get exactly one bottom and one top crossing.
#[test]
fn vertices_on_column_centres_count_once() {
    let n = 12;
    let (soup, height) = geometry::lattice_block(n);
    let mesh = TriMesh::from_soup(soup);
    mesh::check_closed(&mesh).unwrap();
    let (stock, stats) = fill(&mesh, 1.0);
    assert_eq!(
        (stock.grid().nx, stock.grid().ny, stock.grid().x0_mm),
        (n, n, 0.0)
    );
    assert_eq!(stats.crossings, 2 * n * n);
    assert_eq!((stats.unpaired_columns, stats.overlap_columns), (0, 0));
    for j in 0..n {
        for i in 0..n {
            let got: Vec<_> = stock.column(i, j).intervals().collect();
            assert_eq!(got, vec![[0.0, height(i, j) as f32]], "column ({i}, {j})");
        }
    }
    let height = &height;
    let exact: f64 = (0..n).flat_map(|j| (0..n).map(move |i| height(i, j))).sum();
    assert_eq!(stock.volume_mm3(), exact);
}

/// A cube whose top and bottom diagonals pass through column centres, and whose
/// walls stand exactly on a line of centres (half-open: counted on one side).
#[test]
fn shared_edges_through_centres_count_once() {
    let mut soup = Vec::new();
    box_faces(&mut soup, [0.0; 3], [8.0, 8.0, 3.0], ALL);
    let mesh = TriMesh::from_soup(soup);
    let grid = Grid {
        x0_mm: -0.5,
        y0_mm: -0.5,
        spacing_mm: 1.0,
        nx: 10,
        ny: 10,
    };
    // Centres at 0, 1, …, 9: x = 0 and y = 0 lie on walls, x = 8 and y = 8 too.
    let tops = top_heights(&mesh, &grid).unwrap();
    let covered = tops.iter().filter(|z| !z.is_nan()).count();
    assert_eq!(covered, 64, "half-open: centres 0..8 on each axis, not 8");
    let (stock, stats) = mesh::stock_on_grid(&mesh, grid).unwrap();
    assert_eq!(stats.crossings, 2 * 64);
    assert_eq!(stock.volume_mm3(), 192.0);
    let bits = |v: &[f32]| v.iter().map(|z| z.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&stock.top_heights()), bits(&tops));
}

#[test]
fn top_heights_of_the_spool() {
    let mesh = load_mesh(&stock_models().join("spool_undercut.stl")).unwrap();
    let grid = Grid::covering(-5.0, -5.0, 45.0, 35.0, 1.0).unwrap();
    let tops = top_heights(&mesh, &grid).unwrap();
    let at = |x: f64, y: f64| {
        tops[grid.iy_range(y - 0.5, y + 0.5).unwrap().0 * grid.nx
            + grid.ix_range(x - 0.5, x + 0.5).unwrap().0]
    };
    assert!(at(-2.0, -2.0).is_nan());
    assert_eq!(at(2.0, 2.0), 4.0);
    assert_eq!(at(7.0, 7.0), 14.0);
    assert_eq!(at(20.0, 15.0), 14.0);
}

#[test]
fn open_and_degenerate_meshes_do_not_panic() {
    let mesh = load_mesh(&stock_models().join("open_box.stl")).unwrap();
    let (stock, stats) = fill(&mesh, 1.0);
    assert_eq!(stats.unpaired_columns, stock.grid().len());
    assert_eq!(stock.volume_mm3(), 0.0);

    // A lone triangle: one crossing per covered column, all dropped.
    let tri = TriMesh {
        vertices: vec![[0.0, 0.0, 1.0], [4.0, 0.0, 1.0], [0.0, 4.0, 2.0]],
        triangles: vec![[0, 1, 2]],
    };
    let (stock, stats) = fill(&tri, 0.5);
    assert!(stats.unpaired_columns > 0 && stats.unpaired_columns == stats.crossings);
    assert_eq!(stock.volume_mm3(), 0.0);

    // Three crossings (box plus a stray triangle through it): paired in z
    // order, the last dropped. 10 columns inside the box, 11 outside with one.
    let mut soup = Vec::new();
    box_faces(&mut soup, [0.0; 3], [4.0, 4.0, 4.0], ALL);
    soup.push([[-1.0, -1.0, 2.0], [6.0, -1.0, 2.0], [-1.0, 6.0, 2.0]]);
    let (stock, stats) = fill(&TriMesh::from_soup(soup), 1.0);
    assert_eq!(stats.unpaired_columns, 21);
    assert_eq!(intervals_at(&stock, 0.5, 0.5), vec![[0.0, 2.0]]);
    assert_eq!(intervals_at(&stock, 3.5, 3.5), vec![[0.0, 4.0]]);
}

#[test]
fn inward_mesh_fills_the_same() {
    let mesh = TriMesh::from_soup(geometry::box_with_void());
    let inward = TriMesh::from_soup(flipped(geometry::box_with_void()));
    let ((a, _), (b, stats)) = (fill(&mesh, 1.0), fill(&inward, 1.0));
    assert!(stats.flipped);
    assert!(a.columns().eq(b.columns()));
}

#[test]
fn overlapping_shells_fill_as_union() {
    let mut soup = Vec::new();
    box_faces(&mut soup, [0.0; 3], [10.0, 10.0, 10.0], ALL);
    box_faces(&mut soup, [5.0, 5.0, 5.0], [15.0, 15.0, 15.0], ALL);
    let (stock, stats) = fill(&TriMesh::from_soup(soup), 1.0);
    assert_eq!(stats.overlap_columns, 25);
    assert_eq!(stock.volume_mm3(), 2000.0 - 125.0);
    assert_eq!(intervals_at(&stock, 7.5, 7.5), vec![[0.0, 15.0]]);
}

#[test]
#[ignore = "timing; run with --release --ignored --nocapture"]
fn fill_timing_large_sphere() {
    let mesh = geometry::icosphere([0.0; 3], 50.0, 6);
    let t = Instant::now();
    let (stock, stats) = fill(&mesh, 0.05);
    let elapsed = t.elapsed();
    let rel = stock.volume_mm3() / mesh.signed_volume_mm3() - 1.0;
    println!(
        "icosphere d=100 mm, {} triangles, grid 0.05 mm ({}×{} columns, {} threads): fill {:.3} s, relative volume error {rel:+.2e}, {stats:?}",
        mesh.triangles.len(),
        stock.grid().nx,
        stock.grid().ny,
        rayon::current_num_threads(),
        elapsed.as_secs_f64()
    );
    let grid = *stock.grid();
    let t = Instant::now();
    let tops = top_heights(&mesh, &grid).unwrap();
    println!(
        "top_heights on the same grid: {:.3} s ({} columns)",
        t.elapsed().as_secs_f64(),
        tops.len()
    );
    let t = Instant::now();
    let model = mesh::DesignModel::new(&mesh).unwrap();
    let build = t.elapsed();
    let points: Vec<[f64; 3]> = (0..100_000)
        .map(|k| {
            [
                (k % 100) as f64 - 50.0,
                (k / 100 % 100) as f64 - 50.0,
                (k / 10_000) as f64 * 5.0,
            ]
        })
        .collect();
    let t = Instant::now();
    let d = model.signed_distances_mm(&points);
    println!(
        "DesignModel::new (validate + BVH + pseudo-normals): {:.3} s; {} signed distances: {:.3} s",
        build.as_secs_f64(),
        d.len(),
        t.elapsed().as_secs_f64()
    );
}
