//! A mesh's springs, triangles, masses and pins: what [`Model::from_parts`]
//! needs, in a fixed order (every spring list is sorted by its particle
//! pair, so the model and every sum over it are the same on each run).

use glam::DVec3;

use super::{area, Mesh, MeshCloth};
use crate::budget;
use crate::error::{Error, Result};
use crate::model::{
    check_position, point, ClothSpec, Model, Pin, Spring, MAX_COORDINATE, MIN_AREA, MIN_SIDE,
};
use crate::params::{check, format_number, SpringKind, SpringParams};

/// One side of a face, with what lies across the face from it.
#[derive(Clone, Copy)]
struct Side {
    /// The side's ends, smaller index first.
    edge: [u32; 2],
    /// The face's index in the mesh.
    face: u32,
    /// For a quad, the corner next to each end of `edge` across the quad
    /// (`near[0]` beside `edge[0]`); for a triangle, the opposite corner
    /// twice.
    near: [u32; 2],
    /// The corner opposite the side in the face's drawing triangle that
    /// holds it.
    apex: u32,
}

/// Every face side, sorted by edge and then face.
fn sides(mesh: &Mesh) -> Vec<Side> {
    let mut sides = Vec::new();
    for (f, face) in mesh.faces.iter().enumerate() {
        let c = face.corners();
        let m = c.len();
        for k in 0..m {
            let (a, b) = (c[k], c[(k + 1) % m]);
            let (near_a, near_b, apex) = if face.quad {
                // Drawn as c0 c1 c2 and c0 c2 c3: sides 0 and 3 face c2.
                let apex = if k == 0 || k == 3 { c[2] } else { c[0] };
                (c[(k + 3) % 4], c[(k + 2) % 4], apex)
            } else {
                let o = c[(k + 2) % 3];
                (o, o, o)
            };
            let (edge, near) = if a < b {
                ([a, b], [near_a, near_b])
            } else {
                ([b, a], [near_b, near_a])
            };
            sides.push(Side {
                edge,
                face: f as u32,
                near,
                apex,
            });
        }
    }
    sides.sort_unstable_by_key(|s| (s.edge, s.face));
    sides
}

/// Runs of sides sharing an edge.
fn by_edge(sides: &[Side]) -> impl Iterator<Item = &[Side]> {
    sides.chunk_by(|a, b| a.edge == b.edge)
}

/// Refuses an edge shared by more than two faces, naming them.
pub(super) fn check_manifold(mesh: &Mesh) -> std::result::Result<(), String> {
    let sides = sides(mesh);
    let crowded = by_edge(&sides).find(|run| run.len() > 2);
    match crowded {
        None => Ok(()),
        Some(run) => {
            let faces: Vec<String> = run
                .iter()
                .map(|s| mesh.where_face(&mesh.faces[s.face as usize]))
                .collect();
            Err(format!(
                "non-manifold edge: the edge between vertices {} and {} borders {} faces ({}); \
                 a cloth's edge borders one face (on its border) or two, so such meshes are \
                 refused: split the sheets apart",
                run[0].edge[0],
                run[0].edge[1],
                run.len(),
                faces.join(", ")
            ))
        }
    }
}

/// `(i, j)` with `i < j`.
fn ordered(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// The particle pairs of each spring kind, sorted and without repeats:
/// stretch on every face side, shear on quad diagonals, bend across every
/// edge two faces share (see [`Mesh::model`]).
fn spring_pairs(mesh: &Mesh) -> [Vec<(u32, u32)>; 3] {
    let sides = sides(mesh);
    let mut stretch: Vec<(u32, u32)> = by_edge(&sides)
        .map(|run| (run[0].edge[0], run[0].edge[1]))
        .collect();
    let mut shear = Vec::new();
    for face in mesh.faces.iter().filter(|f| f.quad) {
        let c = face.corners;
        shear.push(ordered(c[0], c[2]));
        shear.push(ordered(c[1], c[3]));
    }
    let mut bend = Vec::new();
    for run in by_edge(&sides) {
        let [s, t] = run else {
            continue;
        };
        let quads = mesh.faces[s.face as usize].quad && mesh.faces[t.face as usize].quad;
        if quads {
            // Across two quads: each end's neighbour on one side to its
            // neighbour on the other, as a grid's two-apart springs.
            bend.push(ordered(s.near[0], t.near[0]));
            bend.push(ordered(s.near[1], t.near[1]));
        } else {
            bend.push(ordered(s.apex, t.apex));
        }
    }
    for pairs in [&mut stretch, &mut shear, &mut bend] {
        pairs.retain(|(i, j)| i != j);
        pairs.sort_unstable();
        pairs.dedup();
    }
    [stretch, shear, bend]
}

/// Where a mesh goes in the world: `origin + scale · p` for a file
/// position `p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Factor on the file's coordinates (`> 0`).
    pub scale: f64,
    /// Translation after scaling \[m\].
    pub origin: DVec3,
}

impl Placement {
    /// The world position of file position `p` \[m\].
    pub fn apply(&self, p: DVec3) -> DVec3 {
        self.origin + self.scale * p
    }
}

impl Mesh {
    /// The cloth this mesh makes at `placement`, of total `mass` \[kg\],
    /// with `pins` (vertex indices and boxes) and the spring `materials`
    /// (a kind of zero stiffness gets no springs):
    ///
    /// - particles: the vertices, file order; each gets the share of
    ///   `mass` of its lumped area (a third of each triangle it is a
    ///   corner of, a quad counting as its two drawing triangles);
    /// - **stretch** springs on every face side, **shear** springs on each
    ///   quad's two diagonals, rest lengths from the placed positions;
    /// - **bend** springs across every edge two faces share: between the
    ///   corners opposite it in the two (drawing) triangles, or, between
    ///   two quads, from each end's neighbour in one quad to its neighbour
    ///   in the other (so a quad grid gets a grid's two-apart springs);
    /// - triangles: each face's drawing triangles, file order.
    ///
    /// Refused before anything is allocated when the model would not fit
    /// in the host's memory ([`Error::OutOfMemory`]).
    pub fn model(
        &self,
        placement: Placement,
        mass: f64,
        pins: &[Pin],
        materials: &[SpringParams; 3],
    ) -> Result<Model> {
        let n = self.positions.len();
        let sides: usize = self.faces.iter().map(|f| f.corners().len()).sum();
        let quads = self.faces.iter().filter(|f| f.quad).count();
        let triangles = self.faces.len() + quads;
        // At most one stretch and two bend springs per side, two shear
        // springs per quad.
        let springs = 3 * sides + 2 * quads;
        budget::check_host(
            budget::model_bytes(n as u64, springs as u64, triangles as u64),
            || format!("the mesh cloth's model ({n} particles, up to {springs} springs)"),
        )?;
        let rest: Vec<DVec3> = self.positions.iter().map(|&p| placement.apply(p)).collect();
        let pinned = pinned(pins, &rest)?;
        let triangles: Vec<[u32; 3]> = self.faces.iter().flat_map(|f| f.triangles()).collect();
        let mut lumped = vec![0.0; n];
        for t in &triangles {
            let [a, b, c] = t.map(|p| rest[p as usize]);
            let third = area(a.to_array(), b.to_array(), c.to_array()) / 3.0;
            for &p in t {
                lumped[p as usize] += third;
            }
        }
        let total: f64 = lumped.iter().sum();
        let masses = lumped.iter().map(|a| mass * (a / total)).collect();
        let mut springs = Vec::new();
        for (kind, pairs) in SpringKind::ALL.into_iter().zip(spring_pairs(self)) {
            if materials[kind.index()].stiffness > 0.0 {
                springs.extend(
                    pairs
                        .into_iter()
                        .map(|(i, j)| Spring::at_rest(&rest, i, j, kind)),
                );
            }
        }
        Model::from_parts(rest, masses, pinned, springs, triangles)
    }
}

/// The pin flag of each particle at `rest`: vertex indices and boxes;
/// a grid's corner and edge names are refused.
fn pinned(pins: &[Pin], rest: &[DVec3]) -> Result<Vec<bool>> {
    let n = rest.len();
    let mut pinned = vec![false; n];
    for (k, pin) in pins.iter().enumerate() {
        let key = format!("cloth.pins[{k}]");
        match *pin {
            Pin::Index(i) if i < n => pinned[i] = true,
            Pin::Region(_) => {
                pin.check_region(&key)?;
                let mut any = false;
                for (p, &x) in rest.iter().enumerate() {
                    if pin.contains(x) {
                        pinned[p] = true;
                        any = true;
                    }
                }
                if !any {
                    return Err(pin.empty_region(&key));
                }
            }
            _ => {
                return Err(Error::InvalidParameter {
                    key,
                    allowed: format!(
                        "on a mesh cloth, a vertex index below {n} (0-based, the file's \
                         vertex order) or {{ box = [[x0, y0, z0], [x1, y1, z1]] }}; corner \
                         and edge names are for grid cloths"
                    ),
                    got: pin.to_string(),
                })
            }
        }
    }
    Ok(pinned)
}

impl MeshCloth {
    /// Refuses a scale that is not positive and finite, and what
    /// [`MeshCloth::model`] would refuse of `spec` (origin, mass, pins).
    pub fn validate(&self, spec: &ClothSpec) -> Result<()> {
        check(
            "cloth.scale",
            self.scale,
            self.scale > 0.0,
            "> 0 (a factor)",
        )?;
        check_position("cloth.origin", spec.origin)?;
        check("cloth.mass", spec.mass, spec.mass > 0.0, "> 0 (kg, total)")?;
        let rest = self.rest_positions(spec);
        self.check_scale(&rest)?;
        pinned(&spec.pins, &rest).map(|_| ())
    }

    /// Refuses a scale whose placed mesh (`rest`) the solvers cannot
    /// hold: a vertex beyond ±[`MAX_COORDINATE`], a face side below
    /// [`MIN_SIDE`] or whose ends are one `f32` point (one point on the
    /// GPU), a triangle below [`MIN_AREA`].
    fn check_scale(&self, rest: &[DVec3]) -> Result<()> {
        let refuse = |allowed: String| Error::InvalidParameter {
            key: "cloth.scale".to_string(),
            allowed,
            got: format_number(self.scale),
        };
        let far = |x: &DVec3| !x.is_finite() || x.abs().max_element() > MAX_COORDINATE;
        if let Some(v) = rest.iter().position(far) {
            return Err(refuse(format!(
                "a factor that keeps every vertex within ±1e18 m of the world's origin (the \
                 GPU holds positions as f32; vertex {v} would be at {})",
                point(rest[v])
            )));
        }
        for face in &self.mesh.faces {
            let c = face.corners();
            for k in 0..c.len() {
                let (i, j) = (c[k], c[(k + 1) % c.len()]);
                let (a, b) = (rest[i as usize], rest[j as usize]);
                let side = a.distance(b);
                if side < MIN_SIDE || a.as_vec3() == b.as_vec3() {
                    return Err(refuse(format!(
                        "a factor that makes every face side at least 1e-18 m long (below, \
                         a length squared is no normal f32) and its ends distinct f32 points \
                         (else they are one point on the GPU); {}: vertices {i} and {j} would \
                         be {} m apart, at {} and {}",
                        self.mesh.where_face(face),
                        format_number(side),
                        point(a),
                        point(b)
                    )));
                }
            }
            for t in face.triangles() {
                let [a, b, c] = t.map(|p| rest[p as usize].to_array());
                let area = area(a, b, c);
                if area < MIN_AREA {
                    return Err(refuse(format!(
                        "a factor that gives every triangle at least {} m², the smallest \
                         normal f32; {}: triangle {t:?} would have {} m²",
                        format_number(MIN_AREA),
                        self.mesh.where_face(face),
                        format_number(area)
                    )));
                }
            }
        }
        Ok(())
    }

    /// The vertices where `spec` and this cloth's `scale` put them \[m\].
    pub fn rest_positions(&self, spec: &ClothSpec) -> Vec<DVec3> {
        let placement = self.placement(spec);
        self.mesh
            .positions
            .iter()
            .map(|&p| placement.apply(p))
            .collect()
    }

    /// Where `spec` (its `origin`) and this cloth's `scale` put the mesh.
    pub fn placement(&self, spec: &ClothSpec) -> Placement {
        Placement {
            scale: self.scale,
            origin: spec.origin,
        }
    }

    /// The model: [`Mesh::model`] with `spec`'s origin, mass and pins.
    pub fn model(&self, spec: &ClothSpec, materials: &[SpringParams; 3]) -> Result<Model> {
        self.validate(spec)?;
        self.mesh
            .model(self.placement(spec), spec.mass, &spec.pins, materials)
    }
}
