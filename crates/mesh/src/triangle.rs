//! A triangle prepared for the fill rule of [`crate::fill`] ([`Prepared`]:
//! its edge functions in canonical form and its plane), and the point-in-shell
//! test that uses the same rule ([`crossings_above`]).

/// Number of `triangles` over the point (x, y) (same fill rule as the stock)
/// that lie above height `z` (mm) there: odd when the point is inside a closed
/// shell made of them.
pub(crate) fn crossings_above(
    triangles: impl Iterator<Item = [[f64; 3]; 3]>,
    [x, y, z]: [f64; 3],
) -> usize {
    triangles
        .filter_map(|[a, b, c]| Prepared::new(a, b, c, false))
        .filter(|t| {
            (t.x_range[0]..=t.x_range[1]).contains(&x)
                && t.edges.iter().all(|e| e.admits(x, y))
                && t.z_at(x, y) > z
        })
        .count()
}

/// One edge of a triangle made counter-clockwise in XY, in canonical form.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Edge {
    /// Lexicographically smaller end point, and the vector to the other end.
    ox: f64,
    oy: f64,
    dx: f64,
    dy: f64,
    /// +1 if the triangle runs from (ox, oy) along (dx, dy), −1 otherwise.
    sign: f64,
    /// A centre exactly on this edge belongs to this triangle.
    owns_ties: bool,
}

impl Edge {
    fn new(p: [f64; 3], q: [f64; 3]) -> Edge {
        let forward = (p[0], p[1]) < (q[0], q[1]);
        let (o, e) = if forward { (p, q) } else { (q, p) };
        let (tx, ty) = (q[0] - p[0], q[1] - p[1]);
        Edge {
            ox: o[0],
            oy: o[1],
            dx: e[0] - o[0],
            dy: e[1] - o[1],
            sign: if forward { 1.0 } else { -1.0 },
            owns_ties: ty < 0.0 || (ty == 0.0 && tx > 0.0),
        }
    }

    /// Does the centre (x, y) lie on the triangle's side of this edge?
    #[inline]
    pub(crate) fn admits(&self, x: f64, y: f64) -> bool {
        let w = self.sign * (self.dx * (y - self.oy) - self.dy * (x - self.ox));
        w > 0.0 || (w == 0.0 && self.owns_ties)
    }

    /// X where the edge's line crosses height y, if the edge spans y.
    #[inline]
    pub(crate) fn x_at(&self, y: f64) -> Option<f64> {
        let t = (y - self.oy) / self.dy;
        (self.dy != 0.0 && (0.0..=1.0).contains(&t)).then_some(self.ox + t * self.dx)
    }
}

/// A non-vertical triangle prepared for rasterising.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prepared {
    pub(crate) edges: [Edge; 3],
    /// Plane through the first vertex: z = z0 − (nx·(x − x0) + ny·(y − y0)) / nz.
    p0: [f64; 3],
    n: [f64; 3],
    z_range: [f64; 2],
    pub(crate) x_range: [f64; 2],
    pub(crate) enter: bool,
}

impl Prepared {
    /// `None` for a triangle with no area seen from above.
    pub(crate) fn new(a: [f64; 3], b: [f64; 3], c: [f64; 3], flipped: bool) -> Option<Prepared> {
        let (u, v) = (sub(b, a), sub(c, a));
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        if n[2] == 0.0 || !n[2].is_finite() {
            return None;
        }
        let up = n[2] > 0.0;
        // Counter-clockwise in XY whichever way it faces.
        let (b, c) = if up { (b, c) } else { (c, b) };
        Some(Prepared {
            edges: [Edge::new(a, b), Edge::new(b, c), Edge::new(c, a)],
            p0: a,
            n,
            z_range: [a[2].min(b[2]).min(c[2]), a[2].max(b[2]).max(c[2])],
            x_range: [a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0])],
            enter: up == flipped,
        })
    }

    #[inline]
    pub(crate) fn z_at(&self, x: f64, y: f64) -> f64 {
        let [x0, y0, z0] = self.p0;
        let z = z0 - (self.n[0] * (x - x0) + self.n[1] * (y - y0)) / self.n[2];
        // Guards nearly vertical triangles against rounding far outside them.
        z.clamp(self.z_range[0], self.z_range[1])
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
