//! The collider meshes, made once: a unit quad (the ground) and a unit
//! capsule (spheres and capsules), as interleaved position + normal
//! vertices.

/// Latitude bands of the sphere mesh.
const STACKS: u32 = 24;
/// Longitude segments of the sphere mesh.
const SLICES: u32 = 48;

/// Interleaved vertices (`[x, y, z, nx, ny, nz]`) and triangle indices,
/// counter-clockwise seen from outside.
pub struct Mesh {
    pub vertices: Vec<[f32; 6]>,
    pub indices: Vec<u32>,
}

/// The square −1..1 in x and z at y = 0, facing +y.
pub fn quad() -> Mesh {
    let v = |x: f32, z: f32| [x, 0.0, z, 0.0, 1.0, 0.0];
    Mesh {
        vertices: vec![v(-1.0, -1.0), v(1.0, -1.0), v(1.0, 1.0), v(-1.0, 1.0)],
        // Seen from +y, (−1,−1) → (−1,1) → (1,1) turns counter-clockwise.
        indices: vec![0, 3, 2, 0, 2, 1],
    }
}

/// A mesh collider's triangles where it is set, flat-shaded, divided by
/// a factor that puts every vertex within |y| < 0.5 (so `vs_collider`
/// moves none to a capsule end); returns the mesh and the factor, the
/// scale of its instance at the origin.
pub fn body(m: &crate::sdf::MeshCollider) -> (Mesh, f32) {
    let rotation = m.rotation.as_quat();
    let position = m.position.as_vec3();
    let world: Vec<[glam::Vec3; 3]> = m
        .grid
        .triangles
        .iter()
        .map(|t| t.map(|v| position + rotation * v))
        .collect();
    let reach = world
        .iter()
        .flatten()
        .map(|v| v.y.abs())
        .fold(0.0f32, f32::max);
    let factor = 2.0 * reach + 1.0;
    let mut vertices = Vec::with_capacity(3 * world.len());
    for t in &world {
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        for v in t {
            let p = *v / factor;
            vertices.push([p.x, p.y, p.z, n.x, n.y, n.z]);
        }
    }
    let indices = (0..vertices.len() as u32).collect();
    (Mesh { vertices, indices }, factor)
}

/// The unit capsule: the unit sphere's upper half raised to y = 1 and its
/// lower half lowered to y = −1, joined by a cylinder (the equator ring
/// twice). Every vertex has |y| ≥ 1 (up to the rounding of cos(π/2)),
/// whose sign says which end it follows:
/// `vs_collider` puts the ends at `centre ± axis` and shrinks the gap
/// between them to nothing, so with a zero axis it draws a sphere.
pub fn capsule() -> Mesh {
    let half = STACKS / 2;
    let rings: Vec<(u32, f32)> = (0..=half)
        .map(|i| (i, 1.0))
        .chain((half..=STACKS).map(|i| (i, -1.0)))
        .collect();
    banded(&rings)
}

/// A surface of revolution through `rings`, each a latitude band number
/// of the unit UV sphere (0 at +y, [`STACKS`] at −y) and a shift along y.
fn banded(rings: &[(u32, f32)]) -> Mesh {
    let count = rings.len() as u32;
    let mut vertices = Vec::with_capacity((count * (SLICES + 1)) as usize);
    for &(i, shift) in rings {
        let theta = std::f32::consts::PI * i as f32 / STACKS as f32;
        for j in 0..=SLICES {
            let phi = std::f32::consts::TAU * j as f32 / SLICES as f32;
            let n = [
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ];
            vertices.push([n[0], n[1] + shift, n[2], n[0], n[1], n[2]]);
        }
    }
    let mut indices = Vec::with_capacity(((count - 1) * SLICES * 6) as usize);
    let at = |i: u32, j: u32| i * (SLICES + 1) + j;
    for i in 0..count - 1 {
        for j in 0..SLICES {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            indices.extend_from_slice(&[a, d, b, b, d, c]);
        }
    }
    Mesh { vertices, indices }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle turns counter-clockwise seen from outside: its
    /// geometric normal points along the vertex normals.
    #[test]
    fn every_capsule_vertex_says_which_end_it_follows() {
        // `vs_collider` reads the end from |y| > 0.5 (a quad has y = 0).
        let least = capsule()
            .vertices
            .iter()
            .map(|v| v[1].abs())
            .fold(f32::MAX, f32::min);
        assert!(least > 0.999, "a capsule vertex at |y| = {least}");
    }

    #[test]
    fn triangles_face_outwards() {
        for mesh in [quad(), capsule()] {
            for t in mesh.indices.chunks_exact(3) {
                let p = [t[0], t[1], t[2]].map(|i| mesh.vertices[i as usize]);
                let e1 = [0, 1, 2].map(|k| p[1][k] - p[0][k]);
                let e2 = [0, 1, 2].map(|k| p[2][k] - p[0][k]);
                let n = [
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                ];
                let out: f32 = (0..3)
                    .map(|k| n[k] * (p[0][k + 3] + p[1][k + 3] + p[2][k + 3]))
                    .sum();
                // The poles' triangles are degenerate (n ≈ 0, either sign).
                let area2 = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                assert!(area2 < 1e-6 || out > 0.0, "{t:?} faces inwards");
            }
        }
    }
}
