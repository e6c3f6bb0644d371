//! The closed surface of a stock's material: the boundary of the union of
//! its columns' prisms (each column's cell times each of its intervals), as
//! triangles a CAM system imports as in-process stock (an STL).
//!
//! The surface encloses exactly the stock's material: top and bottom faces
//! of every interval, and on every border between two columns the walls
//! where one holds material and the other not. It is closed and manifold
//! (every edge used by exactly two triangles, in opposite directions),
//! which [`crate::check_closed`] checks, in three steps:
//!
//! * a wall's sides are split at every interval end of the four columns
//!   around its corner, so no vertex of one face lies on another's edge;
//! * where two diagonal columns hold material at a corner and the two others
//!   not (a saddle), four walls would share one vertical edge: the walls of
//!   one of the two columns take that edge's midpoint as a vertex, so each
//!   column's corner is its own pair of edges (the two prisms touch along
//!   the line, as they do);
//! * where one column's interval ends at the height another's begins on the
//!   next cell (they touch along a horizontal edge), the upper one's bottom
//!   is raised by four f32 steps (under 4e-5 mm at 100 mm): they no longer
//!   touch, and the volume changes by less than that step times the cell.

use dexel::Stock;
use rayon::prelude::*;

/// A triangle, counter-clockwise seen from outside (outward normal by the
/// right-hand rule), vertices in mm.
pub type Triangle = [[f32; 3]; 3];

/// Rounds of separating touching intervals before giving up (each round
/// raises a bottom by one f32 step; a second round is needed only where a
/// raised bottom meets a third column's top).
const SEPARATING_ROUNDS: usize = 16;

/// The surface of a stock's material, made row of columns by row of columns.
pub struct StockSurface {
    nx: usize,
    ny: usize,
    /// Start of each column's intervals in `intervals` (row-major), and the end.
    offsets: Vec<u32>,
    /// Every column's intervals, ascending, disjoint and apart (touching ones merged).
    intervals: Vec<[f32; 2]>,
    /// Grid lines, mm: the cells' edges along X and along Y.
    xs: Vec<f32>,
    ys: Vec<f32>,
    /// Column borders where intervals touched, separated by four f32 steps.
    pub separated: usize,
}

/// Whether `z` lies inside one of `intervals`.
/// Heights are compared in f64: the midpoint of two neighbouring f32
/// values is one in f64, not in f32.
fn holds(intervals: &[[f32; 2]], z: f64) -> bool {
    intervals
        .iter()
        .any(|&[lo, hi]| f64::from(lo) < z && z < f64::from(hi))
}

/// The midpoint of two heights, in f64.
fn mid(a: f32, b: f32) -> f64 {
    0.5 * (f64::from(a) + f64::from(b))
}

/// How far a touching bottom is raised: a few f32 steps, so that the gap
/// has a midpoint an f32 vertex can stand on.
const SEPARATION_STEPS: usize = 4;

/// The sorted, distinct interval ends of `columns` into `out`.
fn levels_of<'a>(columns: impl IntoIterator<Item = &'a [[f32; 2]]>, out: &mut Vec<f32>) {
    out.clear();
    for c in columns {
        out.extend(c.iter().flat_map(|&[lo, hi]| [lo, hi]));
    }
    out.sort_unstable_by(f32::total_cmp);
    out.dedup();
}

impl StockSurface {
    /// The surface of `stock` (a whole stock, every row of its grid).
    pub fn of(stock: &Stock) -> StockSurface {
        let g = *stock.grid();
        assert_eq!(stock.rows(), 0..g.ny, "a stock's surface needs every row");
        let mut offsets = Vec::with_capacity(g.len() + 1);
        let mut intervals = Vec::with_capacity(g.len());
        offsets.push(0);
        for c in stock.columns() {
            for [lo, hi] in c.intervals() {
                if !(lo < hi) {
                    continue;
                }
                // Touching intervals of one column are one.
                let start = offsets.last().copied().unwrap_or(0) as usize;
                if intervals.len() > start {
                    let last: &mut [f32; 2] = intervals.last_mut().expect("checked");
                    if last[1] >= lo {
                        last[1] = last[1].max(hi);
                        continue;
                    }
                }
                intervals.push([lo, hi]);
            }
            offsets.push(intervals.len() as u32);
        }
        let xs = (0..=g.nx)
            .map(|i| (g.x0_mm + i as f64 * g.spacing_mm) as f32)
            .collect();
        let ys = (0..=g.ny)
            .map(|j| (g.y0_mm + j as f64 * g.spacing_mm) as f32)
            .collect();
        let mut s = StockSurface {
            nx: g.nx,
            ny: g.ny,
            offsets,
            intervals,
            xs,
            ys,
            separated: 0,
        };
        for _ in 0..SEPARATING_ROUNDS {
            let n = s.separate_touching();
            s.separated += n;
            if n == 0 {
                break;
            }
        }
        s
    }

    /// The intervals of column `(ix, iy)`; none outside the grid.
    fn column(&self, ix: isize, iy: isize) -> &[[f32; 2]] {
        if ix < 0 || iy < 0 || ix >= self.nx as isize || iy >= self.ny as isize {
            return &[];
        }
        let i = iy as usize * self.nx + ix as usize;
        &self.intervals[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Raise by one f32 step every bottom that meets a neighbouring column's
    /// top at its height (see the module's notes); intervals left empty are
    /// dropped. Returns how many were raised.
    fn separate_touching(&mut self) -> usize {
        let (nx, ny) = (self.nx, self.ny);
        let mut raised = 0;
        for iy in 0..ny {
            for ix in 0..nx {
                let a = iy * nx + ix;
                for b in [(ix + 1 < nx).then(|| a + 1), (iy + 1 < ny).then(|| a + nx)]
                    .into_iter()
                    .flatten()
                {
                    for (p, q) in [(a, b), (b, a)] {
                        for j in self.offsets[q]..self.offsets[q + 1] {
                            let lo = self.intervals[j as usize][0];
                            let touches = (self.offsets[p]..self.offsets[p + 1])
                                .any(|k| self.intervals[k as usize][1] == lo);
                            if touches {
                                let raised_lo = (0..SEPARATION_STEPS).fold(lo, |z, _| z.next_up());
                                self.intervals[j as usize][0] = raised_lo;
                                raised += 1;
                            }
                        }
                    }
                }
            }
        }
        if raised > 0 {
            let (mut offsets, mut intervals) =
                (vec![0u32], Vec::with_capacity(self.intervals.len()));
            for w in self.offsets.windows(2) {
                intervals.extend(
                    self.intervals[w[0] as usize..w[1] as usize]
                        .iter()
                        .filter(|[lo, hi]| lo < hi),
                );
                offsets.push(intervals.len() as u32);
            }
            (self.offsets, self.intervals) = (offsets, intervals);
        }
        raised
    }

    /// The interval ends of the four columns around grid corner `(cx, cy)`.
    fn corner_levels(&self, cx: isize, cy: isize, out: &mut Vec<f32>) {
        levels_of(
            [
                self.column(cx - 1, cy - 1),
                self.column(cx, cy - 1),
                self.column(cx - 1, cy),
                self.column(cx, cy),
            ],
            out,
        );
    }

    /// At corner `(cx, cy)` and height `z`: where two diagonal columns hold
    /// material and the two others not, the column whose walls take the
    /// midpoint (the one at `(cx, cy)` if it holds material, else the one at
    /// `(cx − 1, cy)`); `None` where it is no saddle.
    fn saddle_owner(&self, cx: isize, cy: isize, z: f64) -> Option<(isize, isize)> {
        let q0 = holds(self.column(cx, cy), z);
        let q1 = holds(self.column(cx - 1, cy), z);
        let q2 = holds(self.column(cx - 1, cy - 1), z);
        let q3 = holds(self.column(cx, cy - 1), z);
        (q0 == q2 && q1 == q3 && q0 != q1).then_some(if q0 { (cx, cy) } else { (cx - 1, cy) })
    }

    /// The vertex heights of a wall's side at corner `(cx, cy)`, from `za`
    /// to `zb`, of a wall of column `owner`, into `out`.
    fn chain(
        &self,
        (cx, cy): (isize, isize),
        [za, zb]: [f32; 2],
        owner: (isize, isize),
        levels: &mut Vec<f32>,
        out: &mut Vec<f32>,
    ) {
        self.corner_levels(cx, cy, levels);
        out.clear();
        let from = levels.partition_point(|&z| z < za);
        for w in levels[from..].windows(2) {
            if w[0] >= zb {
                break;
            }
            out.push(w[0]);
            let m = mid(w[0], w[1]);
            if self.saddle_owner(cx, cy, m) == Some(owner) {
                out.push(m as f32);
            }
        }
        out.push(zb);
    }

    /// The triangles of the walls on the border between columns `a` and `b`
    /// (from grid corner `p` at `pp` to corner `q` at `qp`), into `out`.
    /// The border's triangles as made from `p` to `q` face to the right of
    /// `p → q` seen from above; `a_faces_that_way`: column `a`'s walls do.
    #[allow(clippy::too_many_arguments)]
    fn border(
        &self,
        a: (isize, isize),
        b: (isize, isize),
        (p, pp): ((isize, isize), [f32; 2]),
        (q, qp): ((isize, isize), [f32; 2]),
        a_faces_that_way: bool,
        scratch: &mut Scratch,
        out: &mut Vec<Triangle>,
    ) {
        let (ca, cb) = (self.column(a.0, a.1), self.column(b.0, b.1));
        if ca == cb {
            return;
        }
        levels_of([ca, cb], &mut scratch.levels);
        let levels = std::mem::take(&mut scratch.levels);
        // Runs of elementary ranges where one column holds material and the other not.
        let mut run: Option<(bool, f32, f32)> = None;
        let mut walls = std::mem::take(&mut scratch.walls);
        walls.clear();
        for w in levels.windows(2) {
            let m = mid(w[0], w[1]);
            let (ha, hb) = (holds(ca, m), holds(cb, m));
            let owner_a = match (ha, hb) {
                (true, false) => Some(true),
                (false, true) => Some(false),
                _ => None,
            };
            match (&mut run, owner_a) {
                (Some((o, _, hi)), Some(oa)) if *o == oa && *hi == w[0] => *hi = w[1],
                (_, owner) => {
                    walls.extend(run.take());
                    run = owner.map(|o| (o, w[0], w[1]));
                }
            }
        }
        walls.extend(run);
        scratch.levels = levels;
        for &(owner_a, za, zb) in &walls {
            let owner = if owner_a { a } else { b };
            let (mut left, mut right) = (
                std::mem::take(&mut scratch.left),
                std::mem::take(&mut scratch.right),
            );
            self.chain(p, [za, zb], owner, &mut scratch.corner, &mut left);
            self.chain(q, [za, zb], owner, &mut scratch.corner, &mut right);
            let flip = owner_a != a_faces_that_way;
            ladder(pp, &left, qp, &right, flip, out);
            (scratch.left, scratch.right) = (left, right);
        }
        scratch.walls = walls;
    }

    /// The triangles of grid row `iy`: its columns' top and bottom faces,
    /// the walls on the borders between its columns (and the grid's left and
    /// right edges), and those on the border below it (with the last row,
    /// also the one above it).
    pub fn row(&self, iy: usize, out: &mut Vec<Triangle>) {
        let mut scratch = Scratch::default();
        let (xs, ys) = (&self.xs, &self.ys);
        let j = iy as isize;
        for ix in 0..self.nx {
            let (x0, x1, y0, y1) = (xs[ix], xs[ix + 1], ys[iy], ys[iy + 1]);
            for &[lo, hi] in self.column(ix as isize, j) {
                let t = |z| [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]];
                let [a, b, c, d] = t(hi);
                out.extend([[a, b, c], [a, c, d]]);
                let [a, b, c, d] = t(lo);
                out.extend([[a, c, b], [a, d, c]]);
            }
        }
        // Borders along Y, at x = xs[cx]: column cx − 1 on the left, cx on the
        // right; from (cx, iy) to (cx, iy + 1) the triangles face +X.
        for (cx, &x) in xs.iter().enumerate().take(self.nx + 1) {
            let c = cx as isize;
            self.border(
                (c - 1, j),
                (c, j),
                ((c, j), [x, ys[iy]]),
                ((c, j + 1), [x, ys[iy + 1]]),
                true,
                &mut scratch,
                out,
            );
        }
        // Borders along X, at y = ys[cy]: column row cy − 1 below, cy above;
        // from (ix, cy) to (ix + 1, cy) the triangles face −Y.
        let last = iy + 1 == self.ny;
        for cy in [Some(iy), last.then_some(iy + 1)].into_iter().flatten() {
            let r = cy as isize;
            for ix in 0..self.nx {
                let i = ix as isize;
                self.border(
                    (i, r),
                    (i, r - 1),
                    ((i, r), [xs[ix], ys[cy]]),
                    ((i + 1, r), [xs[ix + 1], ys[cy]]),
                    true,
                    &mut scratch,
                    out,
                );
            }
        }
    }

    /// Rows of the grid.
    pub fn rows(&self) -> usize {
        self.ny
    }

    /// Triangles in all (made once, row by row in parallel, and counted).
    pub fn triangle_count(&self) -> usize {
        (0..self.ny)
            .into_par_iter()
            .map_init(Vec::new, |buf, iy| {
                buf.clear();
                self.row(iy, buf);
                buf.len()
            })
            .sum()
    }

    /// Write the surface as a binary STL (coordinates in mm, each triangle's
    /// normal outward) to `w`: made twice, once to count its triangles for
    /// the header and once to write them, row by row, so no more than a row's
    /// triangles are held. Returns the number of triangles.
    pub fn write_stl(&self, w: &mut impl std::io::Write) -> std::io::Result<usize> {
        let count = self.triangle_count();
        let normal = |t: &Triangle| {
            let d = |a: [f32; 3], b: [f32; 3]| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let (u, v) = (d(t[0], t[1]), d(t[0], t[2]));
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            n.map(|c| if len > 0.0 { c / len } else { 0.0 })
        };
        let triangles = self.triangles().map(|t| stl_io::Triangle {
            normal: stl_io::Normal::new(normal(&t)),
            vertices: t.map(stl_io::Vertex::new),
        });
        stl_io::write_stl(
            w,
            Counted {
                inner: triangles,
                left: count,
            },
        )?;
        Ok(count)
    }

    /// Every triangle, row by row (each row made when it is reached).
    pub fn triangles(&self) -> impl Iterator<Item = Triangle> + '_ {
        let mut buf = Vec::new();
        (0..self.ny).flat_map(move |iy| {
            buf.clear();
            self.row(iy, &mut buf);
            std::mem::take(&mut buf)
        })
    }
}

/// An iterator of a known length (what `stl_io` writes in the header).
struct Counted<I> {
    inner: I,
    left: usize,
}

impl<I: Iterator> Iterator for Counted<I> {
    type Item = I::Item;
    fn next(&mut self) -> Option<I::Item> {
        let item = self.inner.next()?;
        self.left = self.left.saturating_sub(1);
        Some(item)
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left, Some(self.left))
    }
}

impl<I: Iterator> ExactSizeIterator for Counted<I> {}

/// Buffers one row's walls reuse.
#[derive(Default)]
struct Scratch {
    levels: Vec<f32>,
    corner: Vec<f32>,
    left: Vec<f32>,
    right: Vec<f32>,
    walls: Vec<(bool, f32, f32)>,
}

/// A wall between the vertical sides at `p` (heights `left`, ascending) and
/// `q` (`right`), both from the same bottom to the same top, as a strip of
/// triangles facing right of `p → q` seen from above (the other way with `flip`).
fn ladder(
    p: [f32; 2],
    left: &[f32],
    q: [f32; 2],
    right: &[f32],
    flip: bool,
    out: &mut Vec<Triangle>,
) {
    let at = |xy: [f32; 2], z: f32| [xy[0], xy[1], z];
    let (mut i, mut j) = (0, 0);
    while i + 1 < left.len() || j + 1 < right.len() {
        let up_left = j + 1 >= right.len() || (i + 1 < left.len() && left[i + 1] <= right[j + 1]);
        let t = if up_left {
            i += 1;
            [at(p, left[i - 1]), at(q, right[j]), at(p, left[i])]
        } else {
            j += 1;
            [at(p, left[i]), at(q, right[j - 1]), at(q, right[j])]
        };
        out.push(if flip { [t[0], t[2], t[1]] } else { t });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{check_closed, TriMesh};

    fn mesh_of(stock: &Stock) -> (TriMesh, usize) {
        let s = StockSurface::of(stock);
        let tris: Vec<Triangle> = s.triangles().collect();
        assert_eq!(tris.len(), s.triangle_count());
        let soup = tris.iter().map(|t| t.map(|v| v.map(f64::from)));
        (TriMesh::from_soup(soup), s.separated)
    }

    /// A stock of the given columns on a grid of 1 mm cells.
    fn stock(nx: usize, ny: usize, cols: &[&[[f32; 2]]]) -> Stock {
        let grid = dexel::Grid {
            x0_mm: 0.0,
            y0_mm: 0.0,
            spacing_mm: 1.0,
            nx,
            ny,
        };
        Stock::from_columns(grid, |ix, iy, out| {
            out.extend_from_slice(cols[iy * nx + ix])
        })
        .unwrap()
    }

    fn assert_solid(stock: &Stock) {
        let (mesh, separated) = mesh_of(stock);
        check_closed(&mesh).unwrap();
        let v = mesh.signed_volume_mm3();
        let exact = stock.volume_mm3();
        assert_eq!(separated, 0);
        assert!((v - exact).abs() <= 1e-5 * exact.max(1.0), "{v} vs {exact}");
    }

    #[test]
    fn a_box_is_a_closed_solid_of_its_volume() {
        let c: &[[f32; 2]] = &[[0.0, 2.0]];
        assert_solid(&stock(3, 2, &[c; 6]));
    }

    #[test]
    fn steps_saddles_holes_and_undercuts_are_closed() {
        // Heights that differ everywhere, a saddle (diagonal columns high),
        // an empty column and a column with a void.
        type Col<'a> = &'a [[f32; 2]];
        let (a, b, c, d): (Col, Col, Col, Col) =
            (&[[0.0, 3.0]], &[[0.0, 1.0]], &[], &[[0.0, 1.0], [1.5, 4.0]]);
        let e: &[[f32; 2]] = &[[0.5, 2.5]];
        let cols = [a, b, a, c, b, a, b, d, a, e, d, b, c, a, e, a];
        let s = stock(4, 4, &cols);
        assert_solid(&s);
        // A checkerboard: every inner corner a saddle.
        let cols: Vec<&[[f32; 2]]> = (0..25).map(|i| if i % 2 == 0 { a } else { b }).collect();
        assert_solid(&stock(5, 5, &cols));
    }

    /// Random stocks of heights on a coarse set of levels (so that columns
    /// share heights, touch, and make saddles): always closed, and of the
    /// stock's volume within the one-step separations.
    #[test]
    fn random_stocks_are_closed_solids_of_their_volume() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % n
        };
        for case in 0..3000 {
            let (nx, ny) = (1 + next(6) as usize, 1 + next(6) as usize);
            let columns: Vec<Vec<[f32; 2]>> = (0..nx * ny)
                .map(|_| {
                    let mut z = 0.0f32;
                    let mut c = Vec::new();
                    for _ in 0..next(3) {
                        let lo = z + next(3) as f32 * 0.5;
                        let hi = lo + 0.5 + next(3) as f32 * 0.5;
                        c.push([lo, hi]);
                        z = hi + 0.5;
                    }
                    c
                })
                .collect();
            let cols: Vec<&[[f32; 2]]> = columns.iter().map(Vec::as_slice).collect();
            let s = stock(nx, ny, &cols);
            let (mesh, separated) = mesh_of(&s);
            if mesh.triangles.is_empty() {
                assert_eq!(s.volume_mm3(), 0.0);
                continue;
            }
            check_closed(&mesh)
                .unwrap_or_else(|e| panic!("case {case} {nx}x{ny} {columns:?}: {e}"));
            let (v, exact) = (mesh.signed_volume_mm3(), s.volume_mm3());
            let step = separated as f64 * 4e-6;
            assert!(
                (v - exact).abs() <= 1e-5 + step,
                "case {case}: {v} vs {exact}"
            );
        }
    }

    #[test]
    fn touching_intervals_are_separated_by_one_step() {
        // Column 0 ends at 2 where column 1 begins: they touch along an edge.
        let (a, b): (&[[f32; 2]], &[[f32; 2]]) = (&[[0.0, 2.0]], &[[2.0, 5.0]]);
        let s = stock(2, 1, &[a, b]);
        let (mesh, separated) = mesh_of(&s);
        assert_eq!(separated, 1);
        check_closed(&mesh).unwrap();
        let v = mesh.signed_volume_mm3();
        assert!((v - s.volume_mm3()).abs() < 1e-5, "{v}");
    }
}
