//! Meshes built in code: the fixture solids, an icosphere, and a lattice whose
//! vertices sit exactly on column centres.

pub type Tri = [[f64; 3]; 3];

/// Two triangles for a planar quad given counter-clockwise seen from outside.
pub fn quad(out: &mut Vec<Tri>, a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) {
    out.push([a, b, c]);
    out.push([a, c, d]);
}

pub fn flipped(tris: Vec<Tri>) -> Vec<Tri> {
    tris.into_iter().map(|[a, b, c]| [a, c, b]).collect()
}

/// Which faces of an axis-aligned box to emit.
#[derive(Clone, Copy)]
pub struct Faces {
    pub bottom: bool,
    pub top: bool,
    pub sides: bool,
}

impl Faces {
    const fn new(bottom: bool, top: bool, sides: bool) -> Faces {
        Faces { bottom, top, sides }
    }
}

pub const ALL: Faces = Faces::new(true, true, true);
const NO_TOP: Faces = Faces::new(true, false, true);
const NO_BOTTOM: Faces = Faces::new(false, true, true);
const SIDES: Faces = Faces::new(false, false, true);

/// Outward-facing faces of the box [lo, hi].
pub fn box_faces(out: &mut Vec<Tri>, lo: [f64; 3], hi: [f64; 3], faces: Faces) {
    let ([x0, y0, z0], [x1, y1, z1]) = (lo, hi);
    if faces.bottom {
        quad(out, [x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]);
    }
    if faces.top {
        quad(out, [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]);
    }
    if faces.sides {
        quad(out, [x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]);
        quad(out, [x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]);
        quad(out, [x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]);
        quad(out, [x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]);
    }
}

/// Horizontal rectangle `outer` minus rectangle `inner` (both [x0, y0, x1, y1]) at
/// height z, facing up or down, as four trapezoids.
pub fn frame(out: &mut Vec<Tri>, outer: [f64; 4], inner: [f64; 4], z: f64, up: bool) {
    let o = [
        [outer[0], outer[1]],
        [outer[2], outer[1]],
        [outer[2], outer[3]],
        [outer[0], outer[3]],
    ];
    let i = [
        [inner[0], inner[1]],
        [inner[2], inner[1]],
        [inner[2], inner[3]],
        [inner[0], inner[3]],
    ];
    let p = |v: [f64; 2]| [v[0], v[1], z];
    let mut faces = Vec::new();
    for k in 0..4 {
        let n = (k + 1) % 4;
        quad(&mut faces, p(o[k]), p(o[n]), p(i[n]), p(i[k]));
    }
    out.extend(if up { faces } else { flipped(faces) });
}

/// 40×30×20 box with an internal 10×10×5 cavity [15,25]×[10,20]×[5,10],
/// whose faces point into the cavity. Volume 23 500 mm³.
pub fn box_with_void() -> Vec<Tri> {
    let mut t = Vec::new();
    box_faces(&mut t, [0.0; 3], [40.0, 30.0, 20.0], ALL);
    let mut cavity = Vec::new();
    box_faces(&mut cavity, [15.0, 10.0, 5.0], [25.0, 20.0, 10.0], ALL);
    t.extend(flipped(cavity));
    t
}

/// The box without its top face: not closed.
pub fn open_box() -> Vec<Tri> {
    let mut t = Vec::new();
    box_faces(&mut t, [0.0; 3], [40.0, 30.0, 20.0], NO_TOP);
    t
}

/// A spool: base plate [0,40]×[0,30]×[0,4], pillar [15,25]×[10,20]×[4,10], top
/// plate [5,35]×[5,25]×[10,14]. Under the top plate's overhang a column has
/// material [0,4] and [10,14] with a gap between. Volume 7800 mm³.
pub fn spool() -> Vec<Tri> {
    let pillar = [15.0, 10.0, 25.0, 20.0];
    let mut t = Vec::new();
    box_faces(&mut t, [0.0; 3], [40.0, 30.0, 4.0], NO_TOP);
    frame(&mut t, [0.0, 0.0, 40.0, 30.0], pillar, 4.0, true);
    box_faces(&mut t, [15.0, 10.0, 4.0], [25.0, 20.0, 10.0], SIDES);
    frame(&mut t, [5.0, 5.0, 35.0, 25.0], pillar, 10.0, false);
    box_faces(&mut t, [5.0, 5.0, 10.0], [35.0, 25.0, 14.0], NO_BOTTOM);
    t
}

/// Icosphere of `radius` about `centre`: an icosahedron subdivided `levels`
/// times (20·4^levels triangles), outward.
pub fn icosphere(centre: [f64; 3], radius: f64, levels: u32) -> mesh::TriMesh {
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, p, 0.0],
        [1.0, p, 0.0],
        [-1.0, -p, 0.0],
        [1.0, -p, 0.0],
        [0.0, -1.0, p],
        [0.0, 1.0, p],
        [0.0, -1.0, -p],
        [0.0, 1.0, -p],
        [p, 0.0, -1.0],
        [p, 0.0, 1.0],
        [-p, 0.0, -1.0],
        [-p, 0.0, 1.0],
    ];
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let unit = |a: [f64; 3]| {
        let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        a.map(|c| c / n)
    };
    v = v.into_iter().map(unit).collect();
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(4 * f.len());
        for t in &f {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (pa, pb) = (v[a as usize], v[b as usize]);
                    v.push(unit([pa[0] + pb[0], pa[1] + pb[1], pa[2] + pb[2]]));
                    (v.len() - 1) as u32
                });
            }
            next.extend([
                [t[0], m[0], m[2]],
                [t[1], m[1], m[0]],
                [t[2], m[2], m[1]],
                m,
            ]);
        }
        f = next;
    }
    let vertices = v
        .iter()
        .map(|p| {
            [
                centre[0] + radius * p[0],
                centre[1] + radius * p[1],
                centre[2] + radius * p[2],
            ]
        })
        .collect();
    mesh::TriMesh {
        vertices,
        triangles: f,
    }
}

/// A block over [0,n]² (unit grid ⇒ column centres at k + ½) whose top and
/// bottom are lattices with vertices at x, y ∈ {0, ½, 1½, …, n−½, n}, so every
/// column centre is a mesh vertex, shared by 4 or 8 triangles. Cell diagonals
/// alternate. Returns the mesh and the exact top height at column (i, j).
pub fn lattice_block(n: usize) -> (Vec<Tri>, impl Fn(usize, usize) -> f64) {
    let coord = move |k: usize| {
        if k == 0 {
            0.0
        } else if k > n {
            n as f64
        } else {
            k as f64 - 0.5
        }
    };
    // Lattice index k = 1..=n is column k-1's centre.
    let height = |i: usize, j: usize| 5.0 + ((i * 7 + j * 3) % 5) as f64 * 0.25;
    let top = move |a: usize, b: usize| height(a.clamp(1, n) - 1, b.clamp(1, n) - 1);
    let mut t = Vec::new();
    for a in 0..=n {
        for b in 0..=n {
            let up = |a: usize, b: usize| [coord(a), coord(b), top(a, b)];
            let down = |a: usize, b: usize| [coord(a), coord(b), 0.0];
            let cell_top = [up(a, b), up(a + 1, b), up(a + 1, b + 1), up(a, b + 1)];
            let cell_bottom = [
                down(a, b),
                down(a, b + 1),
                down(a + 1, b + 1),
                down(a + 1, b),
            ];
            if (a + b) % 2 == 0 {
                quad(&mut t, cell_top[0], cell_top[1], cell_top[2], cell_top[3]);
                quad(
                    &mut t,
                    cell_bottom[0],
                    cell_bottom[1],
                    cell_bottom[2],
                    cell_bottom[3],
                );
            } else {
                quad(&mut t, cell_top[1], cell_top[2], cell_top[3], cell_top[0]);
                quad(
                    &mut t,
                    cell_bottom[1],
                    cell_bottom[2],
                    cell_bottom[3],
                    cell_bottom[0],
                );
            }
        }
    }
    // Vertical walls along the four sides, one quad per lattice step.
    for k in 0..=n {
        let wall = |p: [usize; 2], q: [usize; 2]| {
            let (pa, qa) = ([coord(p[0]), coord(p[1])], [coord(q[0]), coord(q[1])]);
            (
                [pa[0], pa[1], 0.0],
                [qa[0], qa[1], 0.0],
                [qa[0], qa[1], top(q[0], q[1])],
                [pa[0], pa[1], top(p[0], p[1])],
            )
        };
        let m = n + 1;
        for (p, q) in [
            ([k, 0], [k + 1, 0]),
            ([m, k], [m, k + 1]),
            ([k + 1, m], [k, m]),
            ([0, k + 1], [0, k]),
        ] {
            let (a, b, c, d) = wall(p, q);
            quad(&mut t, a, b, c, d);
        }
    }
    (t, move |i: usize, j: usize| height(i, j))
}
