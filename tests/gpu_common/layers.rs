//! A render mesh for the tests: two layers over a grid cloth's rest
//! rectangle, finer than the cloth, a shell above it and a lining below.

use std::path::Path;

use wgcloth::glam::DVec3;
use wgcloth::mesh::Mesh;
use wgcloth::render_mesh::{Embedding, RenderMesh};
use wgcloth::Model;

/// The shell's offset above the cloth and the lining's below it \[m\].
pub const SHELL: f64 = 0.002;
pub const LINING: f64 = -0.0015;
/// Render vertices per cloth cell along each side.
pub const FINE: usize = 3;
/// How far a render vertex may lie from the cloth in these tests \[m\].
pub const MAX_DISTANCE: f64 = 0.01;

/// Two layers over the cloth's rest rectangle, `FINE` times finer: a shell
/// `SHELL` above it and a lining `LINING` below (facing down).
pub fn layers(model: &Model) -> Mesh {
    let spec = model.grid.as_ref().expect("a grid cloth");
    let (nx, ny) = (spec.nx, spec.ny);
    let x = &model.rest_positions;
    let [c00, c10, c01] = [x[0], x[nx - 1], x[(ny - 1) * nx]];
    let (fx, fy) = (FINE * (nx - 1) + 1, FINE * (ny - 1) + 1);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (layer, h) in [SHELL, LINING].into_iter().enumerate() {
        let base = positions.len() as u32;
        for j in 0..fy {
            for i in 0..fx {
                let (s, t) = (i as f64 / (fx - 1) as f64, j as f64 / (fy - 1) as f64);
                positions.push(c00 + (c10 - c00) * s + (c01 - c00) * t + DVec3::Y * h);
            }
        }
        for j in 0..fy - 1 {
            for i in 0..fx - 1 {
                let a = base + (j * fx + i) as u32;
                let (b, c, d) = (a + 1, a + fx as u32, a + fx as u32 + 1);
                // The cloth's own winding faces +y; the lining's, down.
                if layer == 0 {
                    triangles.extend([[a, c, b], [b, c, d]]);
                } else {
                    triangles.extend([[a, b, c], [b, d, c]]);
                }
            }
        }
    }
    Mesh::from_triangles("two layers", positions, &triangles).expect("a valid render mesh")
}

/// The layers over `model` as a render mesh, and embedded in it.
pub fn embedded(model: &Model) -> (RenderMesh, Embedding) {
    let mesh = RenderMesh::from_mesh(Path::new("two layers"), &layers(model), 1.0, DVec3::ZERO);
    let embedding = Embedding::new(model, &mesh, MAX_DISTANCE).expect("embeds");
    (mesh, embedding)
}
