//! Binary glTF (GLB) of the stock's top surface, with vertex colours and
//! optional side walls, for any glTF viewer and the report's 3D view.
//!
//! Positions are in mm in the machine frame (Z up); the single node carries a
//! rotation to glTF's Y-up convention and a 0.001 scale to metres, so generic
//! viewers show the part upright and at true size. The report's own viewer
//! reads the positions directly.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;

use gltf_json as json;
use json::validation::{Checked::Valid, USize64};

use crate::color::ColorScale;
use crate::{render_and_write, Error, HeightField, ScalarMap};

/// Colour of the side walls and of top vertices whose scalar is NaN.
const WALL_RGBA: [u8; 4] = [170, 170, 170, 255];

/// How the stock mesh is built.
#[derive(Clone, Debug, PartialEq)]
pub struct GlbOptions {
    /// Upper bound on top-surface vertices; larger grids are decimated by
    /// sampling every k-th column in X and Y (the last row and column are
    /// always kept so the outline stays exact).
    pub max_vertices: usize,
    /// Add vertical walls along the outline of the surface, down to the base.
    pub side_walls: bool,
    /// Z of the base the walls go down to \[mm\]; `None`: below the lowest
    /// point by 10 % of the part's largest extent (at least 1 mm).
    pub base_z_mm: Option<f32>,
    /// Colour scale for the scalar map; `None`: fitted to the map, diverging
    /// and centred on 0 when `symmetric`, as in the PNG heat map. Without a
    /// scalar map the surface is coloured by height (sequential palette).
    pub color_scale: Option<ColorScale>,
    /// Diverging palette centred on 0 for the fitted scale.
    pub symmetric: bool,
}

impl Default for GlbOptions {
    fn default() -> Self {
        GlbOptions {
            max_vertices: 1_000_000,
            side_walls: true,
            base_z_mm: None,
            color_scale: None,
            symmetric: true,
        }
    }
}

/// What went into a GLB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlbStats {
    /// Vertices in total (top surface and walls).
    pub vertices: usize,
    /// Triangles in total.
    pub triangles: usize,
    /// Grid columns per sampled vertex along X and Y (1 = no decimation).
    pub step: usize,
    /// Bounding box minimum \[mm\], or `None` for an empty mesh.
    pub min_mm: Option<[f32; 3]>,
    /// Bounding box maximum \[mm\].
    pub max_mm: Option<[f32; 3]>,
}

/// Write the stock surface of `height` to the GLB file `path`, coloured by
/// `colors` (same grid) or by height, with default [`GlbOptions`].
pub fn write_stock_glb(
    path: &Path,
    height: &HeightField,
    colors: Option<&ScalarMap>,
) -> Result<GlbStats, Error> {
    write_stock_glb_with(path, height, colors, &GlbOptions::default())
}

/// [`write_stock_glb`] with explicit options.
pub fn write_stock_glb_with(
    path: &Path,
    height: &HeightField,
    colors: Option<&ScalarMap>,
    options: &GlbOptions,
) -> Result<GlbStats, Error> {
    let (bytes, stats) = stock_glb_bytes(height, colors, options).map_err(|e| e.at(path))?;
    render_and_write(path, || Ok(bytes))?;
    Ok(stats)
}

/// Indices of the sampled columns along one axis: every `step`-th and the last.
fn samples(n: usize, step: usize) -> Vec<usize> {
    let mut s: Vec<usize> = (0..n).step_by(step.max(1)).collect();
    if n > 0 && s.last() != Some(&(n - 1)) {
        s.push(n - 1);
    }
    s
}

#[derive(Default)]
struct MeshData {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    colors: Vec<[u8; 4]>,
    indices: Vec<u32>,
}

impl MeshData {
    fn push(&mut self, p: [f32; 3], n: [f32; 3], c: [u8; 4]) -> u32 {
        self.positions.push(p);
        self.normals.push(n);
        self.colors.push(c);
        (self.positions.len() - 1) as u32
    }
}

/// Build the stock GLB in memory.
pub fn stock_glb_bytes(
    height: &HeightField,
    colors: Option<&ScalarMap>,
    options: &GlbOptions,
) -> Result<(Vec<u8>, GlbStats), Error> {
    let g = height.grid;
    g.check_len("height field", height.z_mm.len())?;
    if let Some(map) = colors {
        map.grid.check_len("colour map", map.values.len())?;
        if map.grid.nx != g.nx || map.grid.ny != g.ny {
            return Err(Error::Invalid {
                what: "colour map".into(),
                reason: format!(
                    "grid {}×{} differs from the height field's {}×{}",
                    map.grid.nx, map.grid.ny, g.nx, g.ny
                ),
            });
        }
    }

    // Decimation step: smallest k whose samples (at most ⌈n/k⌉ + 1 per axis)
    // stay within max_vertices.
    let max_v = options.max_vertices.max(4);
    let mut step = 1;
    while (g.nx.div_ceil(step) + 1) * (g.ny.div_ceil(step) + 1) > max_v
        && step < g.nx.max(g.ny).max(1)
    {
        step += 1;
    }
    let sx = samples(g.nx, step);
    let sy = samples(g.ny, step);

    let z_at = |i: usize, j: usize| -> f32 { height.z_mm[g.index(sx[i], sy[j])] };
    let has = |i: usize, j: usize| z_at(i, j).is_finite();

    let scale = match (colors, options.color_scale) {
        (_, Some(s)) => s,
        (Some(map), None) => ColorScale::for_values(&map.values, options.symmetric),
        (None, None) => ColorScale::for_values(&height.z_mm, false),
    };
    let color_of = |ix: usize, iy: usize| -> [u8; 4] {
        let v = match colors {
            Some(map) => map.values[g.index(ix, iy)],
            None => height.z_mm[g.index(ix, iy)],
        };
        scale
            .rgb(f64::from(v))
            .map_or(WALL_RGBA, |[r, gg, b]| [r, gg, b, 255])
    };

    let (nsx, nsy) = (sx.len(), sy.len());
    let mut mesh = MeshData::default();
    let mut vid = vec![u32::MAX; nsx * nsy];
    for j in 0..nsy {
        for i in 0..nsx {
            if !has(i, j) {
                continue;
            }
            let (x, y, z) = (g.x_mm(sx[i]) as f32, g.y_mm(sy[j]) as f32, z_at(i, j));
            // Central differences over the neighbours with material; one-sided
            // at the outline and at holes, flat where there is neither.
            let (il, ir) = (
                i.checked_sub(1).filter(|&ii| has(ii, j)).unwrap_or(i),
                Some(i + 1)
                    .filter(|&ii| ii < nsx && has(ii, j))
                    .unwrap_or(i),
            );
            let (jd, ju) = (
                j.checked_sub(1).filter(|&jj| has(i, jj)).unwrap_or(j),
                Some(j + 1)
                    .filter(|&jj| jj < nsy && has(i, jj))
                    .unwrap_or(j),
            );
            let slope = |pa: f64, za: f32, pb: f64, zb: f32| -> f32 {
                if pb != pa {
                    ((zb - za) as f64 / (pb - pa)) as f32
                } else {
                    0.0
                }
            };
            let dzdx = slope(g.x_mm(sx[il]), z_at(il, j), g.x_mm(sx[ir]), z_at(ir, j));
            let dzdy = slope(g.y_mm(sy[jd]), z_at(i, jd), g.y_mm(sy[ju]), z_at(i, ju));
            let n = normalize([-dzdx, -dzdy, 1.0]);
            vid[j * nsx + i] = mesh.push([x, y, z], n, color_of(sx[i], sy[j]));
        }
    }
    let cell = |i: usize, j: usize| -> bool {
        i + 1 < nsx
            && j + 1 < nsy
            && has(i, j)
            && has(i + 1, j)
            && has(i, j + 1)
            && has(i + 1, j + 1)
    };
    for j in 0..nsy.saturating_sub(1) {
        for i in 0..nsx.saturating_sub(1) {
            if cell(i, j) {
                let v00 = vid[j * nsx + i];
                let v10 = vid[j * nsx + i + 1];
                let v01 = vid[(j + 1) * nsx + i];
                let v11 = vid[(j + 1) * nsx + i + 1];
                mesh.indices
                    .extend_from_slice(&[v00, v10, v11, v00, v11, v01]);
            }
        }
    }

    if options.side_walls && !mesh.indices.is_empty() {
        let (lo, hi) = bbox(&mesh.positions).expect("non-empty mesh");
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(hi[2] - lo[2]);
        let base = options.base_z_mm.unwrap_or(lo[2] - (0.1 * extent).max(1.0));
        for j in 0..nsy.saturating_sub(1) {
            for i in 0..nsx.saturating_sub(1) {
                if !cell(i, j) {
                    continue;
                }
                // Edges walked counter-clockwise seen from +Z, with the cell across each edge.
                let edges = [
                    ((i, j), (i + 1, j), j.checked_sub(1).map(|jj| (i, jj))),
                    ((i + 1, j), (i + 1, j + 1), Some((i + 1, j))),
                    ((i + 1, j + 1), (i, j + 1), Some((i, j + 1))),
                    ((i, j + 1), (i, j), i.checked_sub(1).map(|ii| (ii, j))),
                ];
                for (a, b, across) in edges {
                    if across.is_some_and(|(ci, cj)| cell(ci, cj)) {
                        continue;
                    }
                    let pa = mesh.positions[vid[a.1 * nsx + a.0] as usize];
                    let pb = mesh.positions[vid[b.1 * nsx + b.0] as usize];
                    let n = normalize([pb[1] - pa[1], pa[0] - pb[0], 0.0]);
                    let at = mesh.push(pa, n, WALL_RGBA);
                    let bt = mesh.push(pb, n, WALL_RGBA);
                    let bb = mesh.push([pb[0], pb[1], base], n, WALL_RGBA);
                    let ab = mesh.push([pa[0], pa[1], base], n, WALL_RGBA);
                    mesh.indices.extend_from_slice(&[at, ab, bb, at, bb, bt]);
                }
            }
        }
    }

    let (min, max) = match bbox(&mesh.positions) {
        Some((lo, hi)) => (Some(lo), Some(hi)),
        None => (None, None),
    };
    let stats = GlbStats {
        vertices: mesh.positions.len(),
        triangles: mesh.indices.len() / 3,
        step,
        min_mm: min,
        max_mm: max,
    };
    let bytes = encode_glb(&mesh, min, max)?;
    Ok((bytes, stats))
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        [0.0, 0.0, 1.0]
    }
}

fn bbox(p: &[[f32; 3]]) -> Option<([f32; 3], [f32; 3])> {
    let first = *p.first()?;
    Some(p.iter().fold((first, first), |(mut lo, mut hi), q| {
        for k in 0..3 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
        (lo, hi)
    }))
}

fn accessor(
    view: json::Index<json::buffer::View>,
    count: usize,
    component: json::accessor::ComponentType,
    type_: json::accessor::Type,
    normalized: bool,
    min_max: Option<([f32; 3], [f32; 3])>,
) -> json::Accessor {
    json::Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64(0)),
        count: USize64::from(count),
        component_type: Valid(json::accessor::GenericComponentType(component)),
        extensions: None,
        extras: Default::default(),
        type_: Valid(type_),
        min: min_max.map(|(lo, _)| json::Value::from(lo.to_vec())),
        max: min_max.map(|(_, hi)| json::Value::from(hi.to_vec())),
        name: None,
        normalized,
        sparse: None,
    }
}

fn encode_glb(
    mesh: &MeshData,
    min: Option<[f32; 3]>,
    max: Option<[f32; 3]>,
) -> Result<Vec<u8>, Error> {
    let mut root = json::Root {
        asset: json::Asset {
            generator: Some("dexcut export".into()),
            ..Default::default()
        },
        ..Default::default()
    };
    let mut bin: Vec<u8> = Vec::new();
    let mut node = json::Node {
        name: Some("stock".into()),
        // Machine frame (Z up, mm) to glTF (Y up, m): -90° about X, then mm → m.
        rotation: Some(json::scene::UnitQuaternion([
            -std::f32::consts::FRAC_1_SQRT_2,
            0.0,
            0.0,
            std::f32::consts::FRAC_1_SQRT_2,
        ])),
        scale: Some([0.001; 3]),
        ..Default::default()
    };

    if !mesh.indices.is_empty() {
        let buffer = root.push(json::Buffer {
            byte_length: USize64(0),
            name: None,
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        let view = |root: &mut json::Root,
                    bin: &mut Vec<u8>,
                    data: &[u8],
                    target: json::buffer::Target| {
            let offset = bin.len();
            bin.extend_from_slice(data);
            bin.resize(bin.len().next_multiple_of(4), 0);
            root.push(json::buffer::View {
                buffer,
                byte_length: USize64::from(data.len()),
                byte_offset: Some(USize64::from(offset)),
                byte_stride: None,
                name: None,
                target: Some(Valid(target)),
                extensions: None,
                extras: Default::default(),
            })
        };
        let f32_bytes = |v: &[[f32; 3]]| -> Vec<u8> {
            v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect()
        };
        let n = mesh.positions.len();
        let pos_view = view(
            &mut root,
            &mut bin,
            &f32_bytes(&mesh.positions),
            json::buffer::Target::ArrayBuffer,
        );
        let nrm_view = view(
            &mut root,
            &mut bin,
            &f32_bytes(&mesh.normals),
            json::buffer::Target::ArrayBuffer,
        );
        let col_bytes: Vec<u8> = mesh.colors.iter().flatten().copied().collect();
        let col_view = view(
            &mut root,
            &mut bin,
            &col_bytes,
            json::buffer::Target::ArrayBuffer,
        );
        let idx_bytes: Vec<u8> = mesh.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let idx_view = view(
            &mut root,
            &mut bin,
            &idx_bytes,
            json::buffer::Target::ElementArrayBuffer,
        );

        use json::accessor::{ComponentType as C, Type as T};
        let pos = root.push(accessor(pos_view, n, C::F32, T::Vec3, false, min.zip(max)));
        let nrm = root.push(accessor(nrm_view, n, C::F32, T::Vec3, false, None));
        let col = root.push(accessor(col_view, n, C::U8, T::Vec4, true, None));
        let idx = root.push(accessor(
            idx_view,
            mesh.indices.len(),
            C::U32,
            T::Scalar,
            false,
            None,
        ));
        root.buffers[buffer.value()].byte_length = USize64::from(bin.len());

        let mut attributes = BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), pos);
        attributes.insert(Valid(json::mesh::Semantic::Normals), nrm);
        attributes.insert(Valid(json::mesh::Semantic::Colors(0)), col);
        let material = root.push(json::Material {
            name: Some("vertex colours".into()),
            double_sided: true,
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(0.8),
                ..Default::default()
            },
            ..Default::default()
        });
        let mesh_index = root.push(json::Mesh {
            name: Some("stock top surface".into()),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: Default::default(),
                indices: Some(idx),
                material: Some(material),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            }],
            weights: None,
            extensions: None,
            extras: Default::default(),
        });
        node.mesh = Some(mesh_index);
    }
    let node = root.push(node);
    let scene = root.push(json::Scene {
        name: None,
        nodes: vec![node],
        extensions: None,
        extras: Default::default(),
    });
    root.scene = Some(scene);

    let json_bytes = json::serialize::to_vec(&root).map_err(|e| Error::Gltf(e.to_string()))?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        json: Cow::Owned(json_bytes),
        bin: if bin.is_empty() {
            None
        } else {
            Some(Cow::Owned(bin))
        },
    };
    glb.to_vec().map_err(|e| Error::Gltf(e.to_string()))
}
