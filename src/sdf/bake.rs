//! Baking a closed triangle mesh into a [`DistanceGrid`]: our own few
//! hundred lines rather than a crate. `mesh_to_sdf` signs by ray casts or
//! normals without checking that the mesh is closed (and pulls in rayon
//! and a BVH crate), `parry3d` brings nalgebra for one query; the exact
//! distance below, signed by angle-weighted pseudo-normals (Bærentzen and
//! Aanæs 2005, exact for a closed, consistently wound mesh) and sped up by
//! a bounding-volume tree, is short, and the checks it needs (closed,
//! wound one way) are what decide whether a sign exists at all.
//!
//! # Refused, naming the file and the face (OBJ line or glTF triangle)
//!
//! - everything a mesh cloth refuses ([`Mesh::load`](crate::mesh::Mesh)):
//!   degenerate and duplicate faces, an edge of more than two faces, …;
//! - an open edge (an edge of one face only): an open mesh has no inside;
//! - two faces running along a shared edge the same way (one of them is
//!   flipped, so the inside is not defined);
//! - a part (faces joined through shared vertices) wound inward that lies
//!   inside no other part ([`parts`](super::parts): an inward part is a
//!   cavity only inside a solid);
//! - a grid of more than [`MAX_GRID_CELLS`] lattice points, counted so
//!   that nothing wraps ([`lattice`](super::lattice)), before anything is
//!   allocated, with the `resolution` or `thickness` that would fit;
//! - a `scale` whose grid the `f32` solvers cannot hold (beyond ±1e18 m,
//!   or cells below 1e-18 m), naming `collider[N].scale`;
//! - a grid the host's memory cannot hold (counted against it, then
//!   allocated fallibly: [`Error::OutOfMemory`]).
//!
//! A mesh wound inside out throughout (negative total volume) is taken as
//! it is meant: its inside is the enclosed volume.
//!
//! # Not detected
//!
//! Self-intersecting meshes (two faces crossing) are not detected: the
//! pseudo-normal sign is then wrong near the crossing. Parts thinner than
//! about two cells (a table top 1 cm thick on a 2 cm grid) lose their
//! inside between lattice points: the trilinear field there never goes
//! negative and a fast particle can pass through; give `resolution` so a
//! cell is at most half the thinnest part, or a `thickness`.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::lattice::{self, Lattice};
use super::parts;
use super::DistanceGrid;
use crate::budget::{array, check_host, try_with_capacity};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::params::format_number;

/// The coarsest `resolution`: fewer than 4 cells along the longest side
/// cannot hold any shape.
pub const MIN_RESOLUTION: u32 = 4;
/// The finest `resolution`: 512 cells along the longest side is 128 Mi
/// lattice points for a cube-shaped grid, beyond [`MAX_GRID_CELLS`] already.
pub const MAX_RESOLUTION: u32 = 512;
/// The most lattice points a grid may have: 16 Mi `f32` samples are 64 MiB,
/// half of WebGPU's default storage binding (128 MiB), which the model
/// buffer holding them shares with the cloth; the bake of that many takes
/// about a minute on one core.
pub const MAX_GRID_CELLS: u64 = 1 << 24;
/// `collider[N].resolution` (`key`: `collider[N]`) as the bake takes it,
/// or its refusal: [`MIN_RESOLUTION`] to [`MAX_RESOLUTION`], however
/// large the number written.
pub(crate) fn check_resolution(key: &str, resolution: u64) -> Result<u32> {
    u32::try_from(resolution)
        .ok()
        .filter(|r| (MIN_RESOLUTION..=MAX_RESOLUTION).contains(r))
        .ok_or_else(|| Error::InvalidParameter {
            key: format!("{key}.resolution"),
            allowed: format!(
                "{MIN_RESOLUTION} to {MAX_RESOLUTION} (cells along the mesh's longest side)"
            ),
            got: resolution.to_string(),
        })
}

/// Bakes the grid of `mesh` scaled by `scale` at `resolution` cells along
/// its longest side, padded for a collider of `thickness` \[m\]. `path`
/// names the mesh in errors and `key` (`collider[0]`) its table.
pub fn bake(
    mesh: &Mesh,
    path: &Path,
    key: &str,
    scale: f64,
    resolution: u32,
    thickness: f64,
) -> Result<DistanceGrid> {
    bake_until(mesh, path, key, scale, resolution, thickness, &|| false)
}

/// [`bake`], asking `stop` before each row of lattice points (a few
/// hundred distance queries, well under a millisecond) and ending with
/// [`Error::Interrupted`] once it says so: a fine grid bakes for a minute,
/// and a host's Ctrl-C must not wait for it.
pub fn bake_until(
    mesh: &Mesh,
    path: &Path,
    key: &str,
    scale: f64,
    resolution: u32,
    thickness: f64,
    stop: &dyn Fn() -> bool,
) -> Result<DistanceGrid> {
    check_resolution(key, u64::from(resolution))?;
    let fail = |message: String| Error::Mesh {
        path: path.to_path_buf(),
        message,
    };
    let faces: Vec<([u32; 3], usize)> = mesh
        .faces
        .iter()
        .enumerate()
        .flat_map(|(f, face)| face.triangles().map(move |t| (t, f)))
        .collect();
    check_closed(mesh, &faces).map_err(fail)?;
    let p: Vec<DVec3> = mesh.positions.iter().map(|&v| v * scale).collect();
    let mut tris: Vec<[DVec3; 3]> = faces
        .iter()
        .map(|(t, _)| t.map(|i| p[i as usize]))
        .collect();
    let mut index: Vec<[u32; 3]> = faces.iter().map(|(t, _)| *t).collect();
    let (part, parts) = parts::parts(&index, p.len());
    let mut volume = parts::volumes(&tris, &part, parts);
    if volume.iter().sum::<f64>() < 0.0 {
        // Wound inside out throughout: turn every face over.
        for (t, i) in tris.iter_mut().zip(&mut index) {
            t.swap(1, 2);
            i.swap(1, 2);
        }
        volume.iter_mut().for_each(|v| *v = -*v);
    }
    if let Some((n, t)) = parts::stray_inward_part(&tris, &part, &volume) {
        return Err(fail(format!(
            "part {} of its {parts} parts (faces joined through shared vertices; the part \
             whose first face is on {}) is wound inward — its faces enclose a negative volume — but lies inside no \
             other part, so it is no cavity: a cloth would fall into it and rest inside; wind \
             that part's faces the other way (outward, counter-clockwise seen from outside)",
            n + 1,
            mesh.where_face(&mesh.faces[faces[t].1])
        )));
    }
    let (lo, hi) = p.iter().fold((DVec3::MAX, DVec3::MIN), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    let lattice = Lattice::new(hi - lo, resolution, thickness);
    if let Some(allowed) = lattice::scale_problem(lo, hi, &lattice) {
        return Err(Error::InvalidParameter {
            key: format!("{key}.scale"),
            allowed,
            got: format_number(scale),
        });
    }
    if !lattice.fits() {
        return Err(fail(lattice::too_many_points(
            key,
            hi - lo,
            resolution,
            thickness,
        )));
    }
    if let Some(allowed) = lattice::reach_problem(lo, hi, &lattice) {
        return Err(Error::InvalidParameter {
            key: format!("{key}.thickness"),
            allowed,
            got: format_number(thickness),
        });
    }
    let cell = lattice.cell;
    let origin = (lo - DVec3::splat(lattice.pad)).as_vec3().to_array();
    let dims = lattice.dims_u32();
    let points = dims.iter().map(|&d| d as usize).product::<usize>();
    let what = || {
        format!(
            "the distance grid of `{key}` ({} × {} × {} lattice points)",
            dims[0], dims[1], dims[2]
        )
    };
    check_host(array::<f32>(points as u64), what)?;
    let mut samples = try_with_capacity::<f32>(points, &what())?;
    let normals = PseudoNormals::new(&tris, &index, p.len());
    let tree = Tree::new(&tris);
    let at = |i: u32, o: f32| f64::from(o) + f64::from(cell) * f64::from(i);
    let mut hint = 0;
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            if stop() {
                return Err(Error::Interrupted);
            }
            for i in 0..dims[0] {
                let x = DVec3::new(at(i, origin[0]), at(j, origin[1]), at(k, origin[2]));
                let (t, q, feature) = tree.nearest(&tris, x, hint);
                hint = t;
                let n = normals.of(t, feature);
                let d = (x - q).length();
                samples.push(if (x - q).dot(n) < 0.0 { -d } else { d } as f32);
            }
        }
    }
    Ok(DistanceGrid {
        origin,
        cell,
        dims,
        samples,
        triangles: tris.iter().map(|t| t.map(|v| v.as_vec3())).collect(),
    })
}

/// Refuses an open edge and two faces that run along an edge the same way.
/// `faces`: each triangle with the face of the file it comes from.
fn check_closed(mesh: &Mesh, faces: &[([u32; 3], usize)]) -> std::result::Result<(), String> {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::with_capacity(3 * faces.len());
    let edges = |t: [u32; 3]| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
    for &(t, f) in faces {
        for e in edges(t) {
            if let Some(g) = directed.insert(e, f) {
                return Err(format!(
                    "{} and {} both run from vertex {} to vertex {} (0-based): faces sharing \
                     an edge must wind the opposite ways along it (one of them is flipped), \
                     or a collider has no consistent inside",
                    mesh.where_face(&mesh.faces[g]),
                    mesh.where_face(&mesh.faces[f]),
                    e.0,
                    e.1
                ));
            }
        }
    }
    for &(t, f) in faces {
        for (a, b) in edges(t) {
            if !directed.contains_key(&(b, a)) {
                let open = directed
                    .keys()
                    .filter(|(a, b)| !directed.contains_key(&(*b, *a)));
                return Err(format!(
                    "{}: the edge from vertex {a} to vertex {b} (0-based) is open (no face on \
                     its other side; {} open edges in all): a collider mesh must be closed, \
                     or it has no inside",
                    mesh.where_face(&mesh.faces[f]),
                    open.count()
                ));
            }
        }
    }
    Ok(())
}

/// Which part of a triangle is nearest a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Feature {
    /// Corner 0, 1 or 2.
    Vertex(usize),
    /// The side from corner `k` to corner `k + 1`.
    Edge(usize),
    /// The inside of the face.
    Face,
}

/// The point of triangle `t` nearest `x`, and which feature it lies on
/// (Ericson, "Real-Time Collision Detection", 5.1.5).
pub(crate) fn closest_on_triangle(t: &[DVec3; 3], x: DVec3) -> (DVec3, Feature) {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, x - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0));
    }
    let bp = x - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (a + ab * (d1 / (d1 - d3)), Feature::Edge(0));
    }
    let cp = x - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (a + ac * (d2 / (d2 - d6)), Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, Feature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    (a + ab * (vb * denom) + ac * (vc * denom), Feature::Face)
}

/// The angle-weighted pseudo-normals of a closed mesh: per face, per edge
/// (the sum of its two faces' normals) and per vertex (its faces' normals
/// weighted by their angles there). The sign of `(x − q) · n` at the
/// nearest point `q` and its feature's pseudo-normal `n` is the side of
/// the surface `x` is on.
struct PseudoNormals {
    face: Vec<DVec3>,
    /// Per triangle, per side (from corner k to k + 1).
    edge: Vec<[DVec3; 3]>,
    vertex: Vec<DVec3>,
    /// The triangles' corners.
    index: Vec<[u32; 3]>,
}

impl PseudoNormals {
    fn new(tris: &[[DVec3; 3]], index: &[[u32; 3]], vertices: usize) -> Self {
        let face: Vec<DVec3> = tris
            .iter()
            .map(|[a, b, c]| (*b - *a).cross(*c - *a).normalize_or_zero())
            .collect();
        let mut vertex = vec![DVec3::ZERO; vertices];
        let mut sides: HashMap<(u32, u32), DVec3> = HashMap::with_capacity(3 * tris.len());
        for (t, (corners, n)) in tris.iter().zip(index.iter().zip(&face)) {
            for k in 0..3 {
                let (p, q, r) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let angle = (q - p).angle_between(r - p);
                vertex[corners[k] as usize] += *n * angle;
                let (a, b) = (corners[k], corners[(k + 1) % 3]);
                *sides.entry((a.min(b), a.max(b))).or_default() += *n;
            }
        }
        let edge = index
            .iter()
            .map(|c| {
                [0, 1, 2].map(|k| {
                    let (a, b) = (c[k], c[(k + 1) % 3]);
                    sides[&(a.min(b), a.max(b))]
                })
            })
            .collect();
        PseudoNormals {
            face,
            edge,
            vertex,
            index: index.to_vec(),
        }
    }

    /// The pseudo-normal of `feature` of triangle `t`.
    fn of(&self, t: usize, feature: Feature) -> DVec3 {
        match feature {
            Feature::Face => self.face[t],
            Feature::Edge(k) => self.edge[t][k],
            Feature::Vertex(k) => self.vertex[self.index[t][k] as usize],
        }
    }
}

/// A bounding-volume tree over the triangles (median splits along the
/// longest axis, up to [`LEAF`] triangles a leaf), for the nearest one.
struct Tree {
    nodes: Vec<Node>,
    /// Triangle numbers, each leaf's a run of them.
    order: Vec<usize>,
}

/// Triangles per leaf.
const LEAF: usize = 4;

struct Node {
    lo: DVec3,
    hi: DVec3,
    /// A leaf: its run of `order`; an inner node: its children.
    leaf: bool,
    a: usize,
    b: usize,
}

impl Tree {
    fn new(tris: &[[DVec3; 3]]) -> Self {
        let mut tree = Tree {
            nodes: Vec::with_capacity(2 * tris.len().div_ceil(LEAF)),
            order: (0..tris.len()).collect(),
        };
        let centres: Vec<DVec3> = tris.iter().map(|[a, b, c]| (*a + *b + *c) / 3.0).collect();
        tree.build(tris, &centres, 0, tris.len());
        tree
    }

    /// Builds the node of `order[begin..end]`, returning its number.
    fn build(&mut self, tris: &[[DVec3; 3]], centres: &[DVec3], begin: usize, end: usize) -> usize {
        let (lo, hi) = self.order[begin..end]
            .iter()
            .flat_map(|&t| tris[t])
            .fold((DVec3::MAX, DVec3::MIN), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        let me = self.nodes.len();
        self.nodes.push(Node {
            lo,
            hi,
            leaf: true,
            a: begin,
            b: end,
        });
        if end - begin > LEAF {
            let axis = (hi - lo).to_array();
            let axis = (0..3).fold(0, |m, k| if axis[k] > axis[m] { k } else { m });
            let mid = (begin + end) / 2;
            self.order[begin..end].select_nth_unstable_by(mid - begin, |&s, &t| {
                centres[s][axis].total_cmp(&centres[t][axis])
            });
            let a = self.build(tris, centres, begin, mid);
            let b = self.build(tris, centres, mid, end);
            self.nodes[me] = Node {
                lo,
                hi,
                leaf: false,
                a,
                b,
            };
        }
        me
    }

    /// The triangle nearest `x`, its nearest point and feature; `hint` is a
    /// triangle likely near (the last answer), whose distance bounds the
    /// search from the start.
    fn nearest(&self, tris: &[[DVec3; 3]], x: DVec3, hint: usize) -> (usize, DVec3, Feature) {
        let (q, f) = closest_on_triangle(&tris[hint], x);
        let mut best = (x.distance_squared(q), hint, q, f);
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            if box_distance_squared(node, x) >= best.0 {
                continue;
            }
            if node.leaf {
                for &t in &self.order[node.a..node.b] {
                    let (q, f) = closest_on_triangle(&tris[t], x);
                    let d = x.distance_squared(q);
                    if d < best.0 {
                        best = (d, t, q, f);
                    }
                }
            } else {
                // The nearer child last, so it is searched first.
                let (da, db) = (
                    box_distance_squared(&self.nodes[node.a], x),
                    box_distance_squared(&self.nodes[node.b], x),
                );
                if da < db {
                    stack.extend([node.b, node.a]);
                } else {
                    stack.extend([node.a, node.b]);
                }
            }
        }
        (best.1, best.2, best.3)
    }
}

/// The squared distance from `x` to `node`'s box (0 inside).
fn box_distance_squared(node: &Node, x: DVec3) -> f64 {
    (node.lo - x)
        .max(x - node.hi)
        .max(DVec3::ZERO)
        .length_squared()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The OBJ text as a mesh.
    fn obj(text: &str) -> Mesh {
        Mesh::parse(text.as_bytes(), Path::new("m.obj"), None, &|_| {
            Err("no buffers".to_string())
        })
        .expect("a valid mesh")
    }

    /// A unit cube centred on the origin, outward faces as quads.
    const CUBE: &str = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n\
        v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n\
        f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

    /// The grid's worst error against the exact distance to the unit cube
    /// is rounding only: the bake is exact at the lattice points.
    const EXACT: f64 = 1e-6;

    fn cube_distance(x: DVec3) -> f64 {
        let q = x.abs() - DVec3::splat(0.5);
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
    }

    #[test]
    fn a_cube_bakes_to_its_exact_signed_distance_either_way_it_is_wound() {
        let flipped: String = CUBE
            .lines()
            .map(|l| match l.strip_prefix("f ") {
                Some(f) => format!("f {}\n", f.split(' ').rev().collect::<Vec<_>>().join(" ")),
                None => format!("{l}\n"),
            })
            .collect();
        for text in [CUBE, flipped.as_str()] {
            let g = bake(&obj(text), Path::new("m.obj"), "collider[0]", 1.0, 8, 0.0).unwrap();
            let mut worst = 0.0f64;
            for k in 0..g.dims[2] {
                for j in 0..g.dims[1] {
                    for i in 0..g.dims[0] {
                        let x = DVec3::new(
                            f64::from(g.origin[0]) + f64::from(g.cell) * f64::from(i),
                            f64::from(g.origin[1]) + f64::from(g.cell) * f64::from(j),
                            f64::from(g.origin[2]) + f64::from(g.cell) * f64::from(k),
                        );
                        worst = worst.max((f64::from(g.at(i, j, k)) - cube_distance(x)).abs());
                    }
                }
            }
            assert!(worst < EXACT, "worst error {worst} m");
            assert!(g.samples.iter().any(|&s| s < 0.0), "no inside");
        }
    }

    #[test]
    fn an_open_mesh_and_a_flipped_face_are_refused_naming_the_line() {
        let open = CUBE.replace("f 2 3 7 6\n", "");
        let e = bake(&obj(&open), Path::new("m.obj"), "collider[0]", 1.0, 8, 0.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.obj") && e.contains("is open") && e.contains("line "),
            "{e}"
        );
        let flipped = CUBE.replace("f 2 3 7 6", "f 6 7 3 2");
        let e = bake(
            &obj(&flipped),
            Path::new("m.obj"),
            "collider[0]",
            1.0,
            8,
            0.0,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("line 14") && e.contains("wind the opposite ways"),
            "{e}"
        );
    }

    #[test]
    fn a_grid_too_fine_is_refused_before_it_is_allocated() {
        let e = bake(&obj(CUBE), Path::new("m.obj"), "collider[0]", 1.0, 8, 1e3)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("lattice points") && e.contains("resolution"),
            "{e}"
        );
        let e = bake(&obj(CUBE), Path::new("m.obj"), "collider[0]", 1.0, 2, 0.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("collider[0].resolution"), "{e}");
    }
}
