//! Triangle meshes for stocks and design models.
//!
//! * [`load_mesh`] reads STL (binary or ASCII) and OBJ files into a welded
//!   [`TriMesh`] (mm); this and [`load_solid`] are the only file access here.
//! * [`check_closed`] / [`validate_solid`] check that a mesh bounds a solid
//!   (closed, manifold, consistently wound) and orient it outward.
//! * [`stock_from_mesh`] fills a Z-dexel [`dexel::Stock`] by rasterising the
//!   triangles onto the column centres; [`top_heights`] gives a design model's
//!   top surface on a grid, and [`DesignModel`] signed distances (via parry3d);
//! * [`StockSurface`] is the closed surface of a stock's material, for an
//!   STL of the stock a run leaves.
//!
//! In the pipeline of the `dexcut` library
//! (job → stock (`dexel`, `mesh`) + program (`nc`) → motion (`schedule`) →
//! sweep (`dexel`) → loads (`cutting`) → outputs (`export`))
//! this crate makes a stock from a mesh file, and reads a `[design]` model
//! for its top heights and signed distances; it depends only on `dexel`.
//!
//! Architecture invariant: a column centre lying exactly on an edge or vertex
//! shared by several triangles is counted by exactly one of them (half-open
//! fill rule with edge functions evaluated identically from both sides).
#![warn(missing_docs)]
mod distance;
mod error;
mod fill;
mod load;
mod solid;
mod surface;
mod triangle;

pub use distance::{signed_distances, DesignModel};
pub use error::MeshError;
pub use fill::{stock_from_mesh, stock_on_grid, top_heights, FillStats};
pub use load::{load_mesh, load_solid};
pub use solid::{check_closed, validate_solid, SolidError, SolidInfo};
pub use surface::StockSurface;

/// An indexed triangle mesh, coordinates in mm. Triangles are counter-clockwise
/// seen from outside for a solid (outward normals, right-hand rule).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions, mm.
    pub vertices: Vec<[f64; 3]>,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Mesh from a triangle soup: vertices with exactly equal coordinates are
    /// merged (`-0.0` and `0.0` count as equal).
    pub fn from_soup(soup: impl IntoIterator<Item = [[f64; 3]; 3]>) -> TriMesh {
        let mut index = std::collections::HashMap::new();
        let mut mesh = TriMesh::default();
        for tri in soup {
            let ids = tri.map(|p| {
                // `+ 0.0` turns -0.0 into 0.0 so both weld.
                let key = p.map(|c| (c + 0.0).to_bits());
                *index.entry(key).or_insert_with(|| {
                    mesh.vertices.push(p);
                    (mesh.vertices.len() - 1) as u32
                })
            });
            mesh.triangles.push(ids);
        }
        mesh
    }

    /// Axis-aligned bounds `(min, max)` of the vertices used by triangles, mm;
    /// `None` for a mesh without triangles.
    pub fn bounds_mm(&self) -> Option<([f64; 3], [f64; 3])> {
        bounds_of(
            self.triangles
                .iter()
                .flatten()
                .filter_map(|&i| self.vertices.get(i as usize).copied()),
        )
    }

    /// Centre of [`TriMesh::bounds_mm`]: the reference point of the volume sums.
    pub(crate) fn centre_mm(&self) -> Option<[f64; 3]> {
        let (lo, hi) = self.bounds_mm()?;
        Some(std::array::from_fn(|k| 0.5 * (lo[k] + hi[k])))
    }

    /// Signed enclosed volume by the divergence theorem, mm³ (f64, summed in
    /// triangle order about the bounds' centre): positive when the triangles
    /// face outward. Meaningful only for a closed mesh.
    ///
    /// # Panics
    /// If a triangle refers to a vertex that does not exist.
    pub fn signed_volume_mm3(&self) -> f64 {
        match self.centre_mm() {
            Some(c) => self.signed_volume_about_mm3(c, &self.triangles),
            None => 0.0,
        }
    }

    /// Signed volume of some of the triangles (e.g. one shell) summed about
    /// the point `c` (mm), as in [`TriMesh::signed_volume_mm3`].
    pub(crate) fn signed_volume_about_mm3<'a>(
        &self,
        c: [f64; 3],
        triangles: impl IntoIterator<Item = &'a [u32; 3]>,
    ) -> f64 {
        let rel = |i: u32| {
            let p = self.vertices[i as usize];
            [p[0] - c[0], p[1] - c[1], p[2] - c[2]]
        };
        triangles
            .into_iter()
            .map(|t| {
                let (a, b, d) = (rel(t[0]), rel(t[1]), rel(t[2]));
                a[0] * (b[1] * d[2] - b[2] * d[1])
                    + a[1] * (b[2] * d[0] - b[0] * d[2])
                    + a[2] * (b[0] * d[1] - b[1] * d[0])
            })
            .sum::<f64>()
            / 6.0
    }

    /// Reverse every triangle's winding (turns normals around).
    pub fn flip(&mut self) {
        for t in &mut self.triangles {
            t.swap(1, 2);
        }
    }
}

/// Axis-aligned bounds `(min, max)` of `points`, mm; `None` when there are none.
pub(crate) fn bounds_of(
    mut points: impl Iterator<Item = [f64; 3]>,
) -> Option<([f64; 3], [f64; 3])> {
    let first = points.next()?;
    Some(points.fold((first, first), |(lo, hi), p| {
        (
            std::array::from_fn(|k| lo[k].min(p[k])),
            std::array::from_fn(|k| hi[k].max(p[k])),
        )
    }))
}
