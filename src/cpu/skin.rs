//! Render meshes on the CPU (see [`crate::render_mesh`]): the cloth's vertex
//! normals and each render vertex skinned from them, in the solver's
//! precision. Twins of the GPU's `normals` kernel and of
//! `skin_vertex` (`shaders/common/skin.wgsl`), operation for operation, so
//! the `f32` results are the GPU's bits where it rounds like this code.

use crate::model::Model;
use crate::real::{Real, Vec3};
use crate::render_mesh::{Embedded, Embedding};

/// The cloth's unit vertex normals at positions `x`: the normalised sum
/// of the incident triangles' `(b − a) × (c − a)`, in
/// [`Model::particle_triangles`] order (`+y` where it has no length).
/// Twin of the `normals` kernel.
pub fn normals<R: Real>(model: &Model, x: &[Vec3<R>]) -> Vec<Vec3<R>> {
    (0..x.len())
        .map(|p| {
            let mut n = Vec3::ZERO;
            for &t in model.particle_triangles.of(p) {
                let [a, b, c] = model.triangles[t as usize].map(|i| x[i as usize]);
                n += (b - a).cross(c - a);
            }
            normalize_or(n, Vec3::new(R::ZERO, R::ONE, R::ZERO))
        })
        .collect()
}

/// `n / |n|`, or `fallback` where `|n|` is at most [`Real::TINY`].
fn normalize_or<R: Real>(n: Vec3<R>, fallback: Vec3<R>) -> Vec3<R> {
    let l = n.length();
    if l > R::TINY {
        n / l
    } else {
        fallback
    }
}

/// Render vertex `e`'s position and unit normal on the cloth at positions
/// `x` with vertex normals `normals` (see the module docs of
/// [`crate::render_mesh`] for the formulas). Twin of `skin_vertex`.
pub fn skin_vertex<R: Real>(
    model: &Model,
    x: &[Vec3<R>],
    normals: &[Vec3<R>],
    e: &Embedded,
) -> (Vec3<R>, Vec3<R>) {
    let [a, b, c] = model.triangles[e.triangle as usize].map(|i| i as usize);
    let u = R::from_f64(f64::from(e.uv[0]));
    let v = R::from_f64(f64::from(e.uv[1]));
    let w = R::ONE - u - v;
    let base = x[a] * w + x[b] * u + x[c] * v;
    let n = normalize_or(
        normals[a] * w + normals[b] * u + normals[c] * v,
        Vec3::new(R::ZERO, R::ONE, R::ZERO),
    );
    let position = base + n * R::from_f64(f64::from(e.offset));
    let edge = x[b] - x[a];
    let t = normalize_or(edge - n * n.dot(edge), Vec3::new(R::ONE, R::ZERO, R::ZERO));
    let bt = n.cross(t);
    let [mt, mb, mn] = e.normal.map(|c| R::from_f64(f64::from(c)));
    let normal = normalize_or(t * mt + bt * mb + n * mn, n);
    (position, normal)
}

/// Every vertex of `embedding` skinned on the cloth at positions `x`:
/// positions and unit normals, in the render mesh's order.
pub fn skin<R: Real>(
    model: &Model,
    x: &[Vec3<R>],
    embedding: &Embedding,
) -> (Vec<Vec3<R>>, Vec<Vec3<R>>) {
    let normals = normals(model, x);
    embedding
        .vertices
        .iter()
        .map(|e| skin_vertex(model, x, &normals, e))
        .unzip()
}
