//! Cloth meshes from Wavefront OBJ and glTF 2.0 files: the file's vertices
//! and faces, checked, then turned into a [`Model`](crate::Model) (see
//! [`Mesh::model`]).
//!
//! # What a mesh file gives
//!
//! - **Vertices** in file order: particle `i` is the file's vertex `i`
//!   (0-based; in an OBJ the `v` lines in order, in glTF the elements of the
//!   chosen primitive's `POSITION` accessor).
//! - **Faces**: triangles, and in an OBJ quads (four corners). Each face's
//!   sides get stretch springs; a quad's two diagonals get shear springs,
//!   and it is drawn (and catches wind) as two triangles. Bend springs join
//!   what lies on either side of each edge shared by two faces (see
//!   [`Mesh::model`]).
//!
//! # What is refused
//!
//! Nothing is built from a mesh that has a face index out of range, a
//! degenerate (zero-area) face, the same face twice, a non-finite
//! coordinate, no faces, an edge shared by more than two faces
//! (non-manifold: a spring graph could be built, but such a mesh is almost
//! always a modelling mistake, and a sheet of cloth is a 2-manifold), a
//! vertex in no face (it would have no area and so no mass), or more than
//! [`MAX_PARTICLES`] vertices. Each error names the file and the OBJ line or
//! the glTF JSON path.

mod gltf;
mod obj;
mod topology;
mod uri;

use std::io::Read as _;
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};

use crate::error::{Error, Result};
use crate::model::MAX_PARTICLES;

/// Largest mesh file read \[bytes\]: an OBJ of [`MAX_PARTICLES`] vertices
/// and twice as many triangles is about 1 GiB of text, so a larger file
/// cannot be a cloth this crate can hold, and a wrong path (a disk image,
/// `/dev/zero` behind a link) is refused before it is read.
pub const MAX_MESH_BYTES: u64 = 1 << 30;

/// A face's area below this fraction of its longest side squared is taken
/// as zero: the cross product of two sides rounds to noise there (its
/// relative rounding error is ~1e-16 in `f64`), so the face has no usable
/// normal or area.
const DEGENERATE_AREA: f64 = 1e-12;

/// The least texture area of a triangle, relative to the product of two
/// of its texture edges' lengths (the sine of the angle between them), for
/// its warp to be defined: below it the texture coordinates lie on a line
/// up to rounding, and `∂x/∂u` divides by nothing.
const TEXTURE_AREA: f64 = 1e-9;

/// One face: a triangle or (OBJ only) a quad, corners in the file's order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Face {
    /// Vertex indices (0-based); the fourth is unused for a triangle.
    pub corners: [u32; 4],
    /// Whether the face is a quad.
    pub quad: bool,
    /// Where the face is in the file: its OBJ line (1-based) or its glTF
    /// triangle number (0-based, in index order).
    pub at: usize,
}

impl Face {
    /// The face's corners, three or four.
    pub fn corners(&self) -> &[u32] {
        &self.corners[..if self.quad { 4 } else { 3 }]
    }

    /// The triangles the face is drawn as and catches wind with: itself,
    /// or a quad `a b c d` as `a b c` and `a c d`.
    pub fn triangles(&self) -> impl Iterator<Item = [u32; 3]> {
        let [a, b, c, d] = self.corners;
        let second = self.quad.then_some([a, c, d]);
        std::iter::once([a, b, c]).chain(second)
    }
}

/// How the faces of a file are named in messages.
#[derive(Clone, Debug, PartialEq, Eq)]
enum FacePlace {
    /// By OBJ line.
    Obj,
    /// By triangle of a glTF primitive, `meshes[m].primitives[p]`.
    Gltf(String),
    /// By triangle of a host's own mesh ([`Mesh::from_triangles`]).
    Triangles,
}

/// A mesh as its file gives it: positions in the file's units and order,
/// faces in file order. Built only by [`Mesh::load`] and [`Mesh::parse`],
/// which check it (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Vertex positions, file order, in the file's units.
    pub positions: Vec<DVec3>,
    /// Faces, file order.
    pub faces: Vec<Face>,
    /// The normals and texture coordinates the file gives, if any: a cloth
    /// ignores them, a [render mesh](crate::render_mesh) draws with them.
    pub attributes: Attributes,
    place: FacePlace,
}

/// Normals and texture coordinates as a file gives them: two pools and,
/// for each corner of each face, an index into each (or [`Attributes::NONE`]).
/// An OBJ's `vn` and `vt` lines and its corners' `v/vt/vn`; a glTF
/// primitive's `NORMAL` and `TEXCOORD_0`, one per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Attributes {
    /// Normals, as the file gives them (not normalised).
    pub normals: Vec<DVec3>,
    /// Texture coordinates `(u, v)`.
    pub uvs: Vec<[f64; 2]>,
    /// For each face, each corner's `[uv, normal]` indices into the pools
    /// (empty when the file gives neither).
    pub corners: Vec<[[u32; 2]; 4]>,
}

impl Attributes {
    /// A corner without this attribute.
    pub const NONE: u32 = u32::MAX;
}

impl Mesh {
    /// Reads, parses and checks a mesh file: `.obj`, `.gltf` or `.glb`;
    /// `mesh_name` picks a glTF mesh by name (the first one without).
    /// External glTF buffers are read relative to the file's folder and
    /// only from it: an absolute `uri`, a `..` that climbs out of it and a
    /// symbolic link that points out of it are refused (a mesh reads only
    /// its own files).
    pub fn load(path: &Path, mesh_name: Option<&str>) -> Result<Mesh> {
        let fail = |message: String| Error::Mesh {
            path: path.to_path_buf(),
            message,
        };
        let bytes = read_mesh_bytes(path).map_err(fail)?;
        let folder = path.parent().unwrap_or(Path::new("")).to_path_buf();
        Mesh::parse(&bytes, path, mesh_name, &|uri| {
            read_mesh_bytes(&uri::resolve(&folder, uri)?)
        })
    }

    /// Parses and checks a mesh from its bytes; `path` names it in messages
    /// and its extension gives the format; `external` reads a glTF buffer
    /// `uri` (or says why not).
    pub fn parse(
        bytes: &[u8],
        path: &Path,
        mesh_name: Option<&str>,
        external: &dyn Fn(&str) -> std::result::Result<Vec<u8>, String>,
    ) -> Result<Mesh> {
        let fail = |message: String| Error::Mesh {
            path: path.to_path_buf(),
            message,
        };
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let mesh = match extension.as_deref() {
            Some("obj") => {
                if mesh_name.is_some() {
                    return Err(fail(
                        "`cloth.mesh_name` picks a mesh of a glTF file; an OBJ file's \
                         vertices and faces all make the cloth"
                            .to_string(),
                    ));
                }
                obj::parse(bytes)
            }
            Some("gltf" | "glb") => gltf::parse(bytes, mesh_name, external),
            _ => Err(format!(
                "unknown mesh format `{}`: the file name must end in .obj (Wavefront OBJ), \
                 .gltf or .glb (glTF 2.0)",
                extension.unwrap_or_default()
            )),
        }
        .map_err(fail)?;
        mesh.check().map_err(fail)?;
        Ok(mesh)
    }

    /// A mesh a host already holds (a game engine's mesh asset): vertex
    /// positions in the host's units and triangles of 0-based indices,
    /// checked as a file's mesh is. `what` names the mesh in messages (the
    /// `path` of [`Error::Mesh`]), which name its triangles by number.
    pub fn from_triangles(
        what: &str,
        positions: Vec<DVec3>,
        triangles: &[[u32; 3]],
    ) -> Result<Mesh> {
        let fail = |message: String| Error::Mesh {
            path: PathBuf::from(what),
            message,
        };
        if positions.len() > MAX_PARTICLES {
            return Err(fail(too_many_vertices(positions.len())));
        }
        if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
            return Err(fail(format!(
                "vertex {v}: position {} is not finite",
                positions[v]
            )));
        }
        let mut faces = Vec::with_capacity(triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&bad) = tri.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(fail(format!(
                    "triangle {t}: vertex index {bad} is out of range: the mesh has {} vertices",
                    positions.len()
                )));
            }
            faces.push(Face {
                corners: [tri[0], tri[1], tri[2], 0],
                quad: false,
                at: t,
            });
        }
        let mesh = Mesh {
            positions,
            faces,
            attributes: Attributes::default(),
            place: FacePlace::Triangles,
        };
        mesh.check().map_err(fail)?;
        Ok(mesh)
    }

    /// Number of vertices (particles).
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Where face `f` is, for a message: `line 12` or
    /// `meshes[0].primitives[0], triangle 3`.
    pub(crate) fn where_face(&self, f: &Face) -> String {
        match &self.place {
            FacePlace::Obj => format!("line {}", f.at),
            FacePlace::Gltf(primitive) => format!("{primitive}, triangle {}", f.at),
            FacePlace::Triangles => format!("triangle {}", f.at),
        }
    }

    /// Each face's warp for the rest positions `rest` (the vertices, as
    /// placed): the unit direction in which its texture coordinate `u`
    /// grows (`∂x/∂u` of its first drawing triangle, or a quad's second
    /// where the first spans no texture area). Says why not, naming the
    /// face, where a face has no texture coordinates or its texture
    /// coordinates span no area.
    pub fn warp_directions(&self, rest: &[DVec3]) -> std::result::Result<Vec<DVec3>, String> {
        let mut out = Vec::with_capacity(self.faces.len());
        for (f, face) in self.faces.iter().enumerate() {
            let uvs = self.attributes.corners.get(f).map(|c| c.map(|[uv, _]| uv));
            let uv = |k: usize| {
                uvs.and_then(|c| self.attributes.uvs.get(c[k] as usize))
                    .map(|&[u, v]| DVec2::new(u, v))
            };
            let corners = face.corners();
            let Some(uv) = (0..corners.len()).map(uv).collect::<Option<Vec<_>>>() else {
                return Err(format!(
                    "texture coordinates on every face, u along the warp and v along the weft: \
                     {} has none",
                    self.where_face(face)
                ));
            };
            let x = |k: usize| rest[corners[k] as usize];
            let triangles: &[[usize; 3]] = if face.quad {
                &[[0, 1, 2], [0, 2, 3]]
            } else {
                &[[0, 1, 2]]
            };
            let warp = triangles.iter().find_map(|&[a, b, c]| {
                let (e1, e2) = (x(b) - x(a), x(c) - x(a));
                let (t1, t2) = (uv[b] - uv[a], uv[c] - uv[a]);
                let det = t1.perp_dot(t2);
                let scale = t1.length() * t2.length();
                // ∂x/∂u: the edges' change per unit u at constant v.
                (det.abs() > TEXTURE_AREA * scale)
                    .then(|| ((e1 * t2.y - e2 * t1.y) / det).normalize_or_zero())
                    .filter(|w| *w != DVec3::ZERO)
            });
            match warp {
                Some(w) => out.push(w),
                None => {
                    return Err(format!(
                        "texture coordinates that span an area on every face (u along the warp, \
                         v along the weft): {}'s lie on a line",
                        self.where_face(face)
                    ))
                }
            }
        }
        Ok(out)
    }

    /// Refuses what the parsers cannot see face by face: no faces,
    /// degenerate and duplicate faces, non-manifold edges and vertices in
    /// no face. (Indices and coordinates are checked while parsing, where
    /// their line or element is known.)
    fn check(&self) -> std::result::Result<(), String> {
        if self.faces.is_empty() {
            return Err("has no faces: a cloth needs at least one triangle or quad \
                        (OBJ `f` lines, a glTF primitive of mode 4, triangles)"
                .to_string());
        }
        for f in &self.faces {
            if let Some(why) = self.degenerate(f) {
                return Err(format!(
                    "{}: degenerate face {:?}: {why}; remove it or move its vertices apart",
                    self.where_face(f),
                    f.corners()
                ));
            }
        }
        let mut sorted: Vec<([u32; 4], usize)> = self
            .faces
            .iter()
            .enumerate()
            .map(|(k, f)| {
                let mut key = [u32::MAX; 4];
                key[..f.corners().len()].copy_from_slice(f.corners());
                key.sort_unstable();
                (key, k)
            })
            .collect();
        sorted.sort_unstable();
        if let Some(w) = sorted.windows(2).find(|w| w[0].0 == w[1].0) {
            let (a, b) = (&self.faces[w[0].1], &self.faces[w[1].1]);
            return Err(format!(
                "{} and {}: the same face twice (vertices {:?}); remove one",
                self.where_face(a),
                self.where_face(b),
                a.corners()
            ));
        }
        topology::check_manifold(self)?;
        let mut used = vec![false; self.positions.len()];
        for f in &self.faces {
            for &c in f.corners() {
                used[c as usize] = true;
            }
        }
        if let Some(v) = used.iter().position(|u| !u) {
            let unused = used.iter().filter(|u| !**u).count();
            return Err(format!(
                "vertex {v} (0-based) is in no face ({unused} such vertices): it would have no \
                 area and so no mass; remove the unused vertices"
            ));
        }
        Ok(())
    }

    /// Why face `f` is degenerate, if it is: a corner repeated, or a
    /// triangle of it with no area.
    fn degenerate(&self, f: &Face) -> Option<String> {
        let corners = f.corners();
        for (k, a) in corners.iter().enumerate() {
            if corners[k + 1..].contains(a) {
                return Some(format!("vertex {a} appears twice"));
            }
        }
        f.triangles().find_map(|t| {
            let [a, b, c] = t.map(|p| self.positions[p as usize]);
            // Measured on the triangle shrunk by its largest coordinate, so
            // that the test is the same at any scale: at 1e200 the area
            // itself overflows, at 1e-200 it underflows.
            let unit = a.abs().max(b.abs()).max(c.abs()).max_element();
            let [a, b, c] = [a, b, c].map(|p| (p / unit).to_array());
            let (area, longest) = (area(a, b, c), longest_side(a, b, c));
            // Written so that NaN (all three corners at the origin, where
            // unit = 0) is degenerate too.
            let has_area = area > DEGENERATE_AREA * longest * longest;
            (!has_area).then(|| format!("triangle {t:?} has zero area (its corners are in a line)"))
        })
    }
}

/// `b − a`.
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
}

/// Euclidean length.
fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Area of the triangle `a b c` \[file units²\].
fn area(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let (u, v) = (sub(a, b), sub(a, c));
    0.5 * norm([
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ])
}

/// Longest side of the triangle `a b c`.
fn longest_side(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    norm(sub(a, b)).max(norm(sub(b, c))).max(norm(sub(c, a)))
}

/// The bytes of a mesh file, or what is wrong with the path (checked
/// before it is opened: opening a FIFO would block).
pub(crate) fn read_mesh_bytes(path: &Path) -> std::result::Result<Vec<u8>, String> {
    let cannot = |e: std::io::Error| format!("cannot read {}: {e}", path.display());
    let meta = std::fs::metadata(path).map_err(cannot)?;
    if !meta.is_file() {
        return Err(format!(
            "{} is not a regular file (a directory, device, FIFO or socket), not a mesh",
            path.display()
        ));
    }
    let too_large = || {
        format!(
            "{} is larger than {} GiB, the most a mesh file may hold",
            path.display(),
            MAX_MESH_BYTES >> 30
        )
    };
    if meta.len() > MAX_MESH_BYTES {
        return Err(too_large());
    }
    crate::budget::check_host(meta.len(), || format!("reading {}", path.display()))
        .map_err(|e| e.to_string())?;
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_MESH_BYTES + 1).read_to_end(&mut bytes))
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_MESH_BYTES {
        return Err(too_large());
    }
    Ok(bytes)
}

/// A vertex count over [`MAX_PARTICLES`], as a message.
fn too_many_vertices(count: impl std::fmt::Display) -> String {
    format!("has {count} vertices, but a cloth may have at most {MAX_PARTICLES} particles")
}

/// A scene's mesh cloth: the file and the mesh read from it, with the keys
/// that pick and place it.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshCloth {
    /// The mesh file as the scene names it (`cloth.mesh`, relative to the
    /// scene file's folder).
    pub path: PathBuf,
    /// The glTF mesh picked by name (`cloth.mesh_name`), if any.
    pub mesh_name: Option<String>,
    /// Factor applied to the file's coordinates before `origin` is added
    /// (`cloth.scale`, `> 0`).
    pub scale: f64,
    /// The mesh.
    pub mesh: Mesh,
}

pub use topology::Placement;

#[cfg(test)]
mod tests {
    use super::*;

    /// The OBJ text as a mesh, or its error message.
    fn obj(text: &str) -> std::result::Result<Mesh, String> {
        Mesh::parse(text.as_bytes(), Path::new("m.obj"), None, &|_| {
            Err("no buffers".to_string())
        })
        .map_err(|e| e.to_string())
    }

    /// A host's unit square as two triangles, and what `from_triangles`
    /// makes of it or says is wrong.
    fn square(triangles: &[[u32; 3]]) -> std::result::Result<Mesh, String> {
        let positions = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        Mesh::from_triangles("the host's mesh", positions, triangles).map_err(|e| e.to_string())
    }

    #[test]
    fn a_hosts_triangles_are_a_mesh_checked_as_a_files() {
        let mesh = square(&[[0, 1, 2], [0, 2, 3]]).expect("a square");
        assert_eq!((mesh.vertex_count(), mesh.faces.len()), (4, 2));
        let out = square(&[[0, 1, 2], [0, 2, 4]]).expect_err("index 4 of 4 vertices");
        assert!(
            out.contains("the host's mesh") && out.contains("triangle 1: vertex index 4"),
            "{out}"
        );
        let twice = square(&[[0, 1, 2], [2, 1, 0], [0, 2, 3]]).expect_err("a face twice");
        assert!(twice.contains("triangle 0 and triangle 1"), "{twice}");
        let unused = square(&[[0, 1, 2]]).expect_err("vertex 3 in no face");
        assert!(unused.contains("vertex 3"), "{unused}");
    }

    #[test]
    fn a_triangle_is_degenerate_or_not_whatever_its_scale() {
        for s in ["1e-200", "1e-5", "1", "1e200", "1e307"] {
            let right = format!("v 0 0 0\nv {s} 0 0\nv 0 {s} 0\nf 1 2 3\n");
            assert!(
                obj(&right).is_ok(),
                "right triangle at {s}: {:?}",
                obj(&right)
            );
            let line = format!("v 0 0 0\nv {s} 0 0\nv -{s} 0 0\nf 1 2 3\n");
            let e = obj(&line).err().unwrap_or_default();
            assert!(e.contains("zero area"), "line at {s}: {e}");
        }
        // Far from the origin the difference of the corners overflows
        // unless the triangle is shrunk first.
        let far = "v -1e308 -1e308 0\nv 1e308 -1e308 0\nv -1e308 1e308 0\nf 1 2 3\n";
        assert!(obj(far).is_ok(), "{:?}", obj(far));
    }

    #[test]
    fn a_face_index_too_long_for_any_integer_is_out_of_range() {
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -99999999999999999999/1\n")
            .err()
            .unwrap_or_default();
        assert!(
            e.contains("line 4: face corner -99999999999999999999 is out of range"),
            "{e}"
        );
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x3\n")
            .err()
            .unwrap_or_default();
        assert!(
            e.contains("`x3` does not start with a vertex number"),
            "{e}"
        );
    }
}
