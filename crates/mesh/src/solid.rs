//! Is a mesh the boundary of a solid? Closedness, manifoldness, winding, volume.

use crate::triangle::crossings_above;
use crate::{bounds_of, TriMesh};

/// Why a mesh does not bound a solid. Points are in mm.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SolidError {
    /// No triangles at all.
    #[error("mesh has no triangles")]
    Empty,
    /// A triangle names a vertex the mesh does not have.
    #[error("triangle {triangle} refers to vertex {vertex}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        /// 0-based triangle index.
        triangle: usize,
        /// The vertex index it names.
        vertex: u32,
        /// Vertices in the mesh.
        vertices: usize,
    },
    /// A vertex has a NaN or infinite coordinate.
    #[error("vertex {vertex} has a non-finite coordinate {coordinates:?}")]
    NonFinite {
        /// 0-based vertex index.
        vertex: usize,
        /// Its coordinates, mm.
        coordinates: [f64; 3],
    },
    #[error(
        "mesh is not closed: {edges} boundary edges, first near {}",
        Near(near_mm)
    )]
    /// Some edges belong to one triangle only: the surface has holes.
    NotClosed {
        /// Boundary edges.
        edges: usize,
        /// A point of the first one, mm.
        near_mm: [f64; 3],
    },
    #[error(
        "non-manifold edge: {edges} edges are shared by more than two triangles, first near {}",
        Near(near_mm)
    )]
    /// Some edges belong to more than two triangles.
    NonManifold {
        /// Such edges.
        edges: usize,
        /// A point of the first one, mm.
        near_mm: [f64; 3],
    },
    /// Neighbouring triangles disagree on which side is outside.
    #[error("inconsistent orientation: {edges} edges are traversed in the same direction by both of their triangles, first near {}", Near(near_mm))]
    InconsistentOrientation {
        /// Edges traversed the same way by both their triangles.
        edges: usize,
        /// A point of the first one, mm.
        near_mm: [f64; 3],
    },
    /// The closed surface has zero signed volume.
    #[error("mesh encloses no volume")]
    ZeroVolume,
}

struct Near<'a>(&'a [f64; 3]);

impl std::fmt::Display for Near<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [x, y, z] = self.0;
        write!(f, "({x:.4}, {y:.4}, {z:.4}) mm")
    }
}

/// A validated solid: its volume and which shells had to be turned around.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolidInfo {
    /// Enclosed volume, mm³ (positive).
    pub volume_mm3: f64,
    /// Closed shells (vertex-connected parts): the outer skin, voids, islands.
    pub shells: usize,
    /// Shells that faced the wrong way and were flipped.
    pub flipped_shells: usize,
}

/// Check that triangles exist, indices are in range and the vertices they use
/// are finite. Everything else in this crate relies on this.
pub(crate) fn check_indices(mesh: &TriMesh) -> Result<(), SolidError> {
    if mesh.triangles.is_empty() {
        return Err(SolidError::Empty);
    }
    let n = mesh.vertices.len();
    for (triangle, t) in mesh.triangles.iter().enumerate() {
        for &vertex in t {
            let Some(p) = mesh.vertices.get(vertex as usize) else {
                return Err(SolidError::IndexOutOfRange {
                    triangle,
                    vertex,
                    vertices: n,
                });
            };
            if !p.iter().all(|c| c.is_finite()) {
                return Err(SolidError::NonFinite {
                    vertex: vertex as usize,
                    coordinates: *p,
                });
            }
        }
    }
    Ok(())
}

/// Check that `mesh` is closed and consistently wound: every undirected edge is
/// used by exactly two triangles, which traverse it in opposite directions.
/// Triangles that repeat a vertex index (zero area after welding) are ignored.
/// Says nothing about which way the mesh faces (see [`validate_solid`]) or
/// about self-intersections.
pub fn check_closed(mesh: &TriMesh) -> Result<(), SolidError> {
    check_indices(mesh)?;
    // One entry per directed edge: (undirected key, forward?, triangle).
    let mut edges: Vec<(u64, bool, u32)> = Vec::with_capacity(3 * mesh.triangles.len());
    for (ti, t) in mesh.triangles.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.push(((a.min(b) as u64) << 32 | a.max(b) as u64, a < b, ti as u32));
        }
    }
    edges.sort_unstable();
    // Per problem kind: count and the offending edge of the lowest-numbered triangle.
    let mut problems = [(0usize, u32::MAX, 0u64); 3]; // open, non-manifold, inconsistent
    for group in edges.chunk_by(|a, b| a.0 == b.0) {
        let forward = group.iter().filter(|e| e.1).count();
        let kind = match (group.len(), forward) {
            (2, 1) => continue,
            (1, _) => 0,
            (2, _) => 2,
            _ => 1,
        };
        let first_triangle = group.iter().map(|e| e.2).min().unwrap_or(u32::MAX);
        let p = &mut problems[kind];
        p.0 += 1;
        if first_triangle < p.1 {
            (p.1, p.2) = (first_triangle, group[0].0);
        }
    }
    let near = |key: u64| {
        let (a, b) = (
            mesh.vertices[(key >> 32) as usize],
            mesh.vertices[(key & 0xffff_ffff) as usize],
        );
        std::array::from_fn(|k| 0.5 * (a[k] + b[k]))
    };
    let [open, non_manifold, inconsistent] = problems;
    if open.0 > 0 {
        return Err(SolidError::NotClosed {
            edges: open.0,
            near_mm: near(open.2),
        });
    }
    if non_manifold.0 > 0 {
        return Err(SolidError::NonManifold {
            edges: non_manifold.0,
            near_mm: near(non_manifold.2),
        });
    }
    if inconsistent.0 > 0 {
        return Err(SolidError::InconsistentOrientation {
            edges: inconsistent.0,
            near_mm: near(inconsistent.2),
        });
    }
    Ok(())
}

/// [`check_closed`], then orient every shell so the mesh bounds a solid with
/// outward normals: a shell nested inside an even number of other shells
/// (outer skin, island in a void) must enclose positive volume by the
/// divergence theorem, one inside an odd number (a void) negative. Shells
/// that disagree are flipped in place and counted. Nesting is found by
/// counting, over a point of each shell, the crossings of the other shells
/// above it; shells are assumed not to intersect each other.
pub fn validate_solid(mesh: &mut TriMesh) -> Result<SolidInfo, SolidError> {
    check_closed(mesh)?;
    let shells = shells(mesh);
    let triangle = |t: u32| mesh.triangles[t as usize].map(|i| mesh.vertices[i as usize]);
    let bounds: Vec<([f64; 3], [f64; 3])> = shells
        .iter()
        .map(|shell| {
            bounds_of(shell.iter().flat_map(|&t| triangle(t))).expect("a shell has triangles")
        })
        .collect();
    // One reference point for every shell's volume sum, as in `signed_volume_mm3`.
    let centre = mesh.centre_mm().ok_or(SolidError::Empty)?;
    let mut wrong = Vec::new();
    for (k, shell) in shells.iter().enumerate() {
        let volume = mesh
            .signed_volume_about_mm3(centre, shell.iter().map(|&t| &mesh.triangles[t as usize]));
        let Some(probe) = probe_point(shell.iter().map(|&t| triangle(t))) else {
            continue;
        };
        let depth = (0..shells.len())
            .filter(|&j| {
                j != k && (0..2).all(|d| (bounds[j].0[d]..=bounds[j].1[d]).contains(&probe[d]))
            })
            .filter(|&j| crossings_above(shells[j].iter().map(|&t| triangle(t)), probe) % 2 == 1)
            .count();
        if volume != 0.0 && (volume > 0.0) != (depth % 2 == 0) {
            wrong.push(k);
        }
    }
    for &k in &wrong {
        for &t in &shells[k] {
            mesh.triangles[t as usize].swap(1, 2);
        }
    }
    let volume = mesh.signed_volume_mm3();
    if volume <= 0.0 {
        return Err(SolidError::ZeroVolume);
    }
    Ok(SolidInfo {
        volume_mm3: volume,
        shells: shells.len(),
        flipped_shells: wrong.len(),
    })
}

/// Triangle indices of each vertex-connected part of `mesh`.
fn shells(mesh: &TriMesh) -> Vec<Vec<u32>> {
    let mut parent: Vec<u32> = (0..mesh.vertices.len() as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    for t in &mesh.triangles {
        for k in 1..3 {
            let (a, b) = (root(&mut parent, t[0]), root(&mut parent, t[k]));
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    let mut index = std::collections::HashMap::new();
    let mut shells: Vec<Vec<u32>> = Vec::new();
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let r = root(&mut parent, t[0]);
        let s = *index.entry(r).or_insert_with(|| {
            shells.push(Vec::new());
            shells.len() - 1
        });
        shells[s].push(ti as u32);
    }
    shells
}

/// A point on a shell away from its own edges: the centroid of the triangle
/// with the largest area seen from above. `None` if the shell has no such area.
fn probe_point(triangles: impl Iterator<Item = [[f64; 3]; 3]>) -> Option<[f64; 3]> {
    let projected_area = |[a, b, c]: &[[f64; 3]; 3]| {
        ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs()
    };
    let best = triangles.max_by(|p, q| projected_area(p).total_cmp(&projected_area(q)))?;
    (projected_area(&best) > 0.0)
        .then(|| std::array::from_fn(|k| (best[0][k] + best[1][k] + best[2][k]) / 3.0))
}
