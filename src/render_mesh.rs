//! Render meshes: a detailed mesh drawn in place of the cloth it is
//! embedded in, so that a coarse simulation drives a fine garment.
//!
//! Each vertex of a [`RenderMesh`] is embedded once, at set-up, in the
//! cloth's rest shape ([`Embedding::new`]): a simulation triangle, two
//! barycentric coordinates `(u, v)` on it, an offset `h` along the
//! interpolated vertex normal there (a lining, a hem's thickness), and the
//! vertex's own normal in the frame of that point. Every frame the vertex
//! follows the triangle ([`crate::cpu::skin::skin_vertex`], and its GPU
//! twin `shaders/common/skin.wgsl`):
//!
//! ```text
//! n̂ = normalize((1 − u − v) n_a + u n_b + v n_c)       (the cloth's vertex normals)
//! p = (1 − u − v) x_a + u x_b + v x_c + h n̂
//! t̂ = normalize((x_b − x_a) − n̂ (n̂ · (x_b − x_a)))    b̂ = n̂ × t̂
//! n = normalize(m_t t̂ + m_b b̂ + m_n n̂)                 (m: the normal's rest coordinates)
//! ```
//!
//! `(u, v, h)` solve that first equation exactly at rest (they may lie a
//! little outside the triangle near its edges, where the normal field
//! bends), so at rest every vertex is where the file put it, to rounding;
//! a rigid motion of the cloth moves and turns the mesh rigidly.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::error::{Error, Result};
use crate::mesh::{Attributes, Mesh};
use crate::model::Model;
use crate::sdf::closest_on_triangle;

/// A detailed mesh to draw: positions and triangles in the cloth's frame,
/// each vertex's normal (the file's, or computed from the triangles) and
/// texture coordinates (where the file gives them).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderMesh {
    /// What the mesh is called in messages (its file).
    pub name: PathBuf,
    /// Vertex positions \[m\].
    pub positions: Vec<DVec3>,
    /// Unit vertex normals, one per vertex.
    pub normals: Vec<DVec3>,
    /// Texture coordinates, one per vertex, when the file gives every
    /// corner one.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Triangles (0-based vertex indices; a quad of the file as two).
    pub triangles: Vec<[u32; 3]>,
    /// The file's vertex each vertex is: the same index, unless the file
    /// gives one position several normals or texture coordinates (an OBJ's
    /// hard edge or UV seam), which makes a vertex of each, in the file's
    /// order.
    pub source: Vec<u32>,
}

impl RenderMesh {
    /// A render mesh from a checked [`Mesh`] (see [`Mesh::load`] for what
    /// a file may hold), placed by `scale` then `origin` as a mesh cloth
    /// is. A corner's normal is the file's where it gives one (normalised),
    /// else the area-weighted normal of the position's faces; its texture
    /// coordinates are the file's. A position whose corners carry different
    /// ones becomes a vertex for each.
    pub fn from_mesh(name: &Path, mesh: &Mesh, scale: f64, origin: DVec3) -> RenderMesh {
        let placed: Vec<DVec3> = mesh.positions.iter().map(|&p| p * scale + origin).collect();
        let welded: Vec<[u32; 3]> = mesh.faces.iter().flat_map(|f| f.triangles()).collect();
        let computed = area_normals(&placed, &welded);
        let a = &mesh.attributes;
        let none = [[Attributes::NONE; 2]; 4];
        // Each corner's key (position, uv, normal), then the distinct keys
        // in the order of their positions, ties by first use.
        let corner_keys: Vec<[[u32; 3]; 4]> = mesh
            .faces
            .iter()
            .enumerate()
            .map(|(f, face)| {
                let extra = a.corners.get(f).unwrap_or(&none);
                std::array::from_fn(|k| [face.corners[k], extra[k][0], extra[k][1]])
            })
            .collect();
        let mut first_use: HashMap<[u32; 3], usize> = HashMap::new();
        for key in corner_keys
            .iter()
            .zip(&mesh.faces)
            .flat_map(|(keys, face)| keys[..face.corners().len()].iter())
        {
            let n = first_use.len();
            first_use.entry(*key).or_insert(n);
        }
        let mut keys: Vec<[u32; 3]> = first_use.keys().copied().collect();
        keys.sort_by_key(|k| (k[0], first_use[k]));
        let index: HashMap<[u32; 3], u32> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (*k, i as u32))
            .collect();
        let triangles = corner_keys
            .iter()
            .zip(&mesh.faces)
            .flat_map(|(keys, face)| {
                let [a, b, c, d] = keys.map(|k| index.get(&k).copied().unwrap_or(0));
                let second = face.quad.then_some([a, c, d]);
                std::iter::once([a, b, c]).chain(second)
            })
            .collect();
        let normals = keys
            .iter()
            .map(|k| {
                a.normals
                    .get(k[2] as usize)
                    .and_then(|n| n.try_normalize())
                    .unwrap_or(computed[k[0] as usize])
            })
            .collect();
        let uvs = keys
            .iter()
            .map(|k| a.uvs.get(k[1] as usize).map(|t| t.map(|c| c as f32)))
            .collect::<Option<Vec<_>>>();
        RenderMesh {
            name: name.to_path_buf(),
            positions: keys.iter().map(|k| placed[k[0] as usize]).collect(),
            normals,
            uvs,
            triangles,
            source: keys.iter().map(|k| k[0]).collect(),
        }
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
}

/// Unit vertex normals: the normalised sums of the incident triangles'
/// area-weighted normals (`+y` where they cancel), as the GPU's `normals`
/// kernel finds the cloth's.
pub fn area_normals(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<DVec3> {
    let mut sums = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums.into_iter()
        .map(|n| n.try_normalize().unwrap_or(DVec3::Y))
        .collect()
}

/// One render vertex's place on the cloth, as the GPU reads it (32 bytes,
/// the layout of `Embedded` in `shaders/common/skin.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Embedded {
    /// The cloth triangle, an index into [`Model::triangles`].
    pub triangle: u32,
    /// Barycentric coordinates of corners `b` and `c` (corner `a` has
    /// `1 − u − v`).
    pub uv: [f32; 2],
    /// Offset along the interpolated normal \[m\].
    pub offset: f32,
    /// The vertex's unit normal in the frame `(t̂, b̂, n̂)` of its place at
    /// rest.
    pub normal: [f32; 3],
    /// Unused (the GPU struct's padding).
    pub pad: u32,
}

/// Every vertex of a render mesh embedded in a cloth's rest shape, and what
/// draws it besides: the mesh's triangles and texture coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Embedding {
    /// One per render vertex, in the mesh's order.
    pub vertices: Vec<Embedded>,
    /// The render mesh's triangles.
    pub triangles: Vec<[u32; 3]>,
    /// The render mesh's texture coordinates, if it has them.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// The cloth of the world it follows and is drawn in place of
    /// ([`Embedding::on_cloth`]); `None`: the whole model, drawn in place of
    /// every cloth ([`Embedding::new`]).
    pub cloth: Option<usize>,
}

/// Iterations of the embedding's solve for `(u, v, h)` (each a 3 × 3
/// linear solve with the normal of the last guess). The map contracts by
/// about `|h| × curvature` per iteration: for an offset of a tenth of the
/// radius of curvature, 40 iterations take the error to 1e-40 of the
/// first guess's, below `f64` rounding.
const EMBED_ITERATIONS: usize = 40;

impl Embedding {
    /// Embeds every vertex of `mesh` in `model`'s rest shape: its nearest
    /// cloth triangle, refused (naming the vertex) where that is farther
    /// than `max_distance` \[m\].
    pub fn new(model: &Model, mesh: &RenderMesh, max_distance: f64) -> Result<Embedding> {
        Self::embed(model, None, mesh, max_distance)
    }

    /// As [`Embedding::new`], on cloth `cloth` of a world (`model`, see
    /// [`crate::world`]) alone: every vertex on that cloth's nearest
    /// triangle, and the mesh drawn in place of that cloth only.
    pub fn on_cloth(
        model: &Model,
        cloth: usize,
        mesh: &RenderMesh,
        max_distance: f64,
    ) -> Result<Embedding> {
        Self::embed(model, Some(cloth), mesh, max_distance)
    }

    fn embed(
        model: &Model,
        cloth: Option<usize>,
        mesh: &RenderMesh,
        max_distance: f64,
    ) -> Result<Embedding> {
        let ranges = crate::world::cloth_ranges(model);
        let particles = match cloth {
            None => 0..model.particle_count(),
            Some(c) => match ranges.get(c) {
                Some(r) => r.clone(),
                None => {
                    return Err(Error::InvalidParameter {
                        key: "render_mesh.cloth".into(),
                        allowed: format!("a cloth of the model: 0 ≤ cloth < {}", ranges.len()),
                        got: c.to_string(),
                    })
                }
            },
        };
        let fail = |message: String| Error::Mesh {
            path: mesh.name.clone(),
            message,
        };
        if !(max_distance.is_finite() && max_distance > 0.0) {
            return Err(Error::InvalidParameter {
                key: "render_mesh.max_distance".into(),
                allowed: "a finite distance > 0 [m]".into(),
                got: format!("{max_distance}"),
            });
        }
        if mesh.positions.is_empty() || mesh.triangles.is_empty() {
            return Err(fail("has no vertices or no triangles to draw".into()));
        }
        let n = mesh.positions.len();
        if mesh.normals.len() != n || mesh.uvs.as_ref().is_some_and(|t| t.len() != n) {
            return Err(fail(format!(
                "has {n} positions but {} normals and {} texture coordinates: one of each per \
                 vertex",
                mesh.normals.len(),
                mesh.uvs.as_ref().map_or(n, Vec::len)
            )));
        }
        if let Some(t) = mesh
            .triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(fail(format!(
                "triangle {t}: {:?} names a vertex past the {n} it has",
                mesh.triangles[t]
            )));
        }
        // How a refusal names the cloth: by its index in a world.
        let the_cloth = match cloth {
            Some(c) if ranges.len() > 1 => format!("cloth {c}"),
            _ => String::from("the cloth"),
        };
        let x = &model.rest_positions;
        let normals = area_normals(x, &model.triangles);
        let cells = TriangleCells::new(x, &model.triangles, max_distance);
        let mut vertices = Vec::with_capacity(mesh.positions.len());
        for (i, (&p, &normal)) in mesh.positions.iter().zip(&mesh.normals).enumerate() {
            let nearest = cells
                .near(p)
                .iter()
                .filter(|&&t| particles.contains(&(model.triangles[t as usize][0] as usize)))
                .map(|&t| {
                    let tri = corners(x, model.triangles[t as usize]);
                    (t, (p - closest_on_triangle(&tri, p).0).length())
                })
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            let t = match nearest {
                Some((t, d)) if d <= max_distance => t,
                other => {
                    let how_far = match other {
                        Some((_, d)) => {
                            format!("{d:.4} m from {the_cloth}'s nearest triangle, farther than")
                        }
                        None => format!("farther from every triangle of {the_cloth} than"),
                    };
                    return Err(fail(format!(
                        "vertex {i} (0-based) at {p} lies {how_far} `max_distance` = \
                         {max_distance} m: move it onto the cloth or raise `max_distance`"
                    )));
                }
            };
            let tri = model.triangles[t as usize];
            let (uv, offset, frame) = solve_place(p, corners(x, tri), corners(&normals, tri));
            let [ft, fb, fn_] = frame;
            let m = [normal.dot(ft), normal.dot(fb), normal.dot(fn_)];
            vertices.push(Embedded {
                triangle: t,
                uv: [uv[0] as f32, uv[1] as f32],
                offset: offset as f32,
                normal: m.map(|c| c as f32),
                pad: 0,
            });
        }
        Ok(Embedding {
            vertices,
            triangles: mesh.triangles.clone(),
            uvs: mesh.uvs.clone(),
            cloth,
        })
    }

    /// Number of render vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }
}

/// The three values of `v` at triangle `t`'s corners.
fn corners(v: &[DVec3], t: [u32; 3]) -> [DVec3; 3] {
    t.map(|i| v[i as usize])
}

/// `(u, v)`, `h` and the frame `(t̂, b̂, n̂)` at rest of point `p` over the
/// triangle of corners `x` and vertex normals `n` (see the module docs).
fn solve_place(p: DVec3, x: [DVec3; 3], n: [DVec3; 3]) -> ([f64; 2], f64, [DVec3; 3]) {
    let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
    let face = e1.cross(e2).normalize_or(DVec3::Y);
    let normal_at = |u: f64, v: f64| {
        ((1.0 - u - v) * n[0] + u * n[1] + v * n[2])
            .try_normalize()
            .unwrap_or(face)
    };
    let (mut u, mut v, mut h) = (0.0, 0.0, 0.0);
    let mut nh = face;
    for _ in 0..EMBED_ITERATIONS {
        // p − x_a = u e1 + v e2 + h n̂, by Cramer's rule.
        let d = p - x[0];
        let det = e1.dot(e2.cross(nh));
        if det.abs() < f64::MIN_POSITIVE {
            break;
        }
        u = d.dot(e2.cross(nh)) / det;
        v = e1.dot(d.cross(nh)) / det;
        h = e1.dot(e2.cross(d)) / det;
        nh = normal_at(u, v);
    }
    let t = (e1 - nh * nh.dot(e1)).try_normalize().unwrap_or(DVec3::X);
    ([u, v], h, [t, nh.cross(t), nh])
}

/// A uniform grid of cubic cells, each listing the triangles whose bounding
/// box grown by the search distance meets it: every triangle within that
/// distance of a point is listed in the point's cell.
struct TriangleCells {
    size: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl TriangleCells {
    fn new(x: &[DVec3], triangles: &[[u32; 3]], distance: f64) -> TriangleCells {
        let longest = triangles
            .iter()
            .map(|&t| {
                let [a, b, c] = corners(x, t);
                (b - a).length().max((c - b).length()).max((a - c).length())
            })
            .fold(0.0, f64::max);
        // At least the distance and the longest side: a grown box spans at
        // most four cells along each axis.
        let size = distance.max(longest).max(f64::MIN_POSITIVE);
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (k, &t) in triangles.iter().enumerate() {
            let [a, b, c] = corners(x, t);
            let lo = cell_of(a.min(b).min(c) - DVec3::splat(distance), size);
            let hi = cell_of(a.max(b).max(c) + DVec3::splat(distance), size);
            for i in lo[0]..=hi[0] {
                for j in lo[1]..=hi[1] {
                    for l in lo[2]..=hi[2] {
                        cells.entry([i, j, l]).or_default().push(k as u32);
                    }
                }
            }
        }
        TriangleCells { size, cells }
    }

    /// The triangles listed in `p`'s cell.
    fn near(&self, p: DVec3) -> &[u32] {
        self.cells
            .get(&cell_of(p, self.size))
            .map_or(&[], Vec::as_slice)
    }
}

/// The cell holding `p`.
fn cell_of(p: DVec3, size: f64) -> [i64; 3] {
    (p / size).floor().to_array().map(|c| c as i64)
}
