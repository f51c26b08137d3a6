//! What a game puts on its entities and in its resources: the cloth, the
//! colliders and pins that drive it, the world's gravity and wind, how the
//! simulation clock advances, and the opt-in read-back.

use std::collections::HashMap;
use std::sync::Arc;

use bevy::asset::RenderAssetUsages;
use bevy::camera::visibility::NoFrustumCulling;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use wgcloth::glam::DVec3;
use wgcloth::mesh::Placement;
use wgcloth::model::Pin;
use wgcloth::render_mesh::{area_normals, Embedding, RenderMesh};
use wgcloth::{Model, Params, Scene};

/// A cloth the plugin simulates on Bevy's render device and draws through
/// the entity's mesh and material.
///
/// The solver works in world coordinates: the cloth's vertices are world
/// positions \[m\], so its entity stays at the identity transform (the
/// default this component requires). The plugin gives the entity a
/// [`Mesh3d`] of the cloth's rest shape (positions and normals, the
/// model's triangles) unless it has one; it adds no material: the game
/// adds a [`MeshMaterial3d`] of its choice (a double-sided
/// [`StandardMaterial`] suits cloth). Frustum culling is off for the
/// cloth ([`NoFrustumCulling`]): the mesh's bounds at rest say nothing of
/// where the simulated cloth is.
///
/// Cloths with the same time step `params.dt` share one
/// [`wgcloth::gpu::GpuBatch`] and one fixed-step clock
/// ([`ClothStepping`]); despawning the entity frees its slot.
#[derive(Component, Clone, Debug)]
#[require(Transform, Visibility, NoFrustumCulling)]
pub struct Cloth {
    model: Arc<Model>,
    params: Arc<Params>,
}

impl Cloth {
    /// A cloth of `model` stepped with `params`. Invalid parameters are
    /// refused here, naming the key, before anything reaches the device.
    pub fn new(model: Model, params: Params) -> wgcloth::Result<Cloth> {
        params.validate()?;
        Ok(Cloth {
            model: Arc::new(model),
            params: Arc::new(params),
        })
    }

    /// The cloth of a wgcloth scene (a built-in name's or a file's:
    /// [`Scene::builtin`], [`Scene::load`]) with the scene's parameters.
    pub fn from_scene(scene: &Scene) -> wgcloth::Result<Cloth> {
        Cloth::new(scene.model()?, scene.params.clone())
    }

    /// A cloth of a Bevy mesh: a triangle list whose vertex positions are
    /// world positions \[m\] at rest, each vertex a particle (in order, so
    /// the game may keep drawing the mesh it has, UVs and all), `mass`
    /// \[kg\] spread by lumped area, `pins` as a scene's, springs from the
    /// faces with `params.springs` (as for a mesh file: see wgcloth's
    /// `Mesh::model`). The mesh is checked as a mesh file is (no degenerate
    /// or repeated faces, a manifold, every vertex in a face); an error
    /// names the triangle. A mesh split at UV seams has separate vertices
    /// there, so it is torn along them: weld it first.
    pub fn from_mesh(
        mesh: &Mesh,
        mass: f64,
        pins: &[Pin],
        params: Params,
    ) -> wgcloth::Result<Cloth> {
        let mesh = triangle_mesh(mesh, false)?;
        let placement = Placement {
            scale: 1.0,
            origin: DVec3::ZERO,
        };
        let model = mesh.model(placement, mass, pins, &params.springs)?;
        Cloth::new(model, params)
    }

    /// The particles, springs, triangles and pins.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The simulation parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The Bevy mesh of the cloth at rest: a triangle list with one vertex
    /// per particle, in particle order (positions \[m\] and smooth
    /// normals), which the plugin overwrites on the GPU each frame.
    pub fn mesh(&self) -> Mesh {
        let positions: Vec<[f32; 3]> = self
            .model
            .rest_positions
            .iter()
            .map(|p| p.as_vec3().to_array())
            .collect();
        let indices = self.model.triangles.iter().flatten().copied().collect();
        Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_indices(Indices::U32(indices))
        .with_computed_smooth_normals()
    }
}

/// The triangles of a Bevy `mesh` (a triangle list) as wgcloth's mesh,
/// checked as a mesh file is (an error names the triangle). `weld` merges
/// vertices at the same position (a collider's shape is its surface: Bevy's
/// primitives repeat a corner once per face for its normals and UVs); a
/// cloth's vertices are its particles, kept as they are.
pub(crate) fn triangle_mesh(mesh: &Mesh, weld: bool) -> wgcloth::Result<wgcloth::mesh::Mesh> {
    const WHAT: &str = "the Bevy mesh";
    let (mut positions, mut indices) = triangle_list(mesh, WHAT)?;
    if weld {
        let mut first: HashMap<[u64; 3], u32> = HashMap::new();
        let mut welded = Vec::new();
        let renumber: Vec<u32> = positions
            .iter()
            .map(|p| {
                *first
                    .entry(p.to_array().map(f64::to_bits))
                    .or_insert_with(|| {
                        welded.push(*p);
                        welded.len() as u32 - 1
                    })
            })
            .collect();
        for i in &mut indices {
            *i = renumber.get(*i as usize).copied().unwrap_or(u32::MAX);
        }
        positions = welded;
    }
    let triangles: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    wgcloth::mesh::Mesh::from_triangles(WHAT, positions, &triangles)
}

/// A detailed mesh that follows a [`Cloth`] (a garment over its coarse
/// simulation: a hem, a lining, thousands of vertices): each vertex is
/// embedded once, here, in the cloth's rest shape (its nearest cloth
/// triangle, a place on it and an offset along the normal), and each
/// frame one compute pass writes its positions and normals into the
/// entity's mesh from the cloth's as they lie on the device
/// (`wgcloth::gpu::GpuRenderMesh`). Bevy's pipelines draw the mesh with
/// the entity's own material; its texture coordinates, tangents and other
/// attributes are never touched.
///
/// The vertices are world positions \[m\] (the entity stays at the
/// identity transform, as a cloth's does). The plugin gives the entity a
/// [`Mesh3d`] of [`ClothRenderMesh::mesh`] unless it has one; a mesh of
/// its own must have the embedded mesh's vertices in its order, with
/// uncompressed `Float32x3` positions and normals. To draw only the
/// detailed mesh, give the cloth's entity [`Visibility::Hidden`] (it is
/// still simulated). A render mesh whose cloth is despawned or failed is
/// left where it was last drawn; one that cannot be bound is a
/// [`ClothFailed`] for its entity.
#[derive(Component, Clone, Debug)]
#[require(Transform, Visibility, NoFrustumCulling)]
pub struct ClothRenderMesh {
    cloth: Entity,
    mesh: Arc<RenderMesh>,
    embedding: Arc<Embedding>,
}

impl ClothRenderMesh {
    /// `mesh` embedded in `of` (the cloth entity `cloth`'s [`Cloth`]),
    /// refused where a vertex lies farther than `max_distance` \[m\] from
    /// the cloth at rest (the error names the vertex).
    pub fn new(
        cloth: Entity,
        of: &Cloth,
        mesh: RenderMesh,
        max_distance: f64,
    ) -> wgcloth::Result<ClothRenderMesh> {
        let embedding = Embedding::new(of.model(), &mesh, max_distance)?;
        Ok(ClothRenderMesh {
            cloth,
            mesh: Arc::new(mesh),
            embedding: Arc::new(embedding),
        })
    }

    /// The render meshes of a wgcloth scene (`[cloth] render_mesh`,
    /// `[[render_mesh]]`) over its cloth `of` (built by
    /// [`Cloth::from_scene`] from the same scene), in order; in a scene of
    /// several cloths (one `Cloth` of them all), each on the cloth its
    /// `cloth` key names.
    pub fn from_scene(
        cloth: Entity,
        of: &Cloth,
        scene: &Scene,
    ) -> wgcloth::Result<Vec<ClothRenderMesh>> {
        scene
            .render_meshes
            .iter()
            .map(|r| {
                let embedding = Embedding::on_cloth(of.model(), r.cloth, &r.mesh, r.max_distance)?;
                Ok(ClothRenderMesh {
                    cloth,
                    mesh: Arc::new(r.mesh.clone()),
                    embedding: Arc::new(embedding),
                })
            })
            .collect()
    }

    /// A Bevy mesh the game holds (a triangle list of world positions
    /// \[m\] at the cloth's rest shape; its normals and `UV_0` if it has
    /// them, else area-weighted normals), embedded as by
    /// [`ClothRenderMesh::new`]. Spawn it with a [`Mesh3d`] of that same
    /// mesh to keep its textures' attributes.
    pub fn from_mesh(
        cloth: Entity,
        of: &Cloth,
        mesh: &Mesh,
        max_distance: f64,
    ) -> wgcloth::Result<ClothRenderMesh> {
        ClothRenderMesh::new(cloth, of, render_mesh_of(mesh)?, max_distance)
    }

    /// The cloth entity the mesh follows.
    pub fn cloth(&self) -> Entity {
        self.cloth
    }

    /// Where each vertex lies on the cloth.
    pub fn embedding(&self) -> &Embedding {
        &self.embedding
    }

    /// The embedding, shared with the render world.
    pub(crate) fn shared_embedding(&self) -> &Arc<Embedding> {
        &self.embedding
    }

    /// The Bevy mesh at rest: positions \[m\], normals, texture
    /// coordinates where the mesh has them, its triangles; the plugin
    /// overwrites positions and normals on the GPU each frame.
    pub fn mesh(&self) -> Mesh {
        let f32x3 =
            |v: &[DVec3]| -> Vec<[f32; 3]> { v.iter().map(|p| p.as_vec3().to_array()).collect() };
        let mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, f32x3(&self.mesh.positions))
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, f32x3(&self.mesh.normals))
        .with_inserted_indices(Indices::U32(
            self.mesh.triangles.iter().flatten().copied().collect(),
        ));
        match &self.mesh.uvs {
            Some(uvs) => mesh.with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs.clone()),
            None => mesh,
        }
    }
}

/// A Bevy triangle-list `mesh` as a render mesh: its positions, its
/// normals (area-weighted where it has none) and `UV_0`, its triangles.
fn render_mesh_of(mesh: &Mesh) -> wgcloth::Result<RenderMesh> {
    const WHAT: &str = "the Bevy render mesh";
    let fail = |message: String| wgcloth::Error::Mesh {
        path: WHAT.into(),
        message,
    };
    let (positions, indices) = triangle_list(mesh, WHAT)?;
    let triangles: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    if let Some(t) = triangles
        .iter()
        .position(|t| t.iter().any(|&i| i as usize >= positions.len()))
    {
        return Err(fail(format!(
            "triangle {t}: {:?} names a vertex past the {} it has",
            triangles[t],
            positions.len()
        )));
    }
    let normals = match mesh.attribute(Mesh::ATTRIBUTE_NORMAL) {
        Some(VertexAttributeValues::Float32x3(n)) => n
            .iter()
            .map(|&n| Vec3::from(n).as_dvec3().normalize_or_zero())
            .collect(),
        _ => area_normals(&positions, &triangles),
    };
    let uvs = match mesh.attribute(Mesh::ATTRIBUTE_UV_0) {
        Some(VertexAttributeValues::Float32x2(t)) => Some(t.clone()),
        _ => None,
    };
    Ok(RenderMesh {
        name: WHAT.into(),
        source: (0..positions.len() as u32).collect(),
        positions,
        normals,
        uvs,
        triangles,
    })
}

/// A Bevy triangle-list `mesh`'s positions \[m\] and indices (a whole
/// number of triangles); `what` names it in errors.
fn triangle_list(mesh: &Mesh, what: &str) -> wgcloth::Result<(Vec<DVec3>, Vec<u32>)> {
    let fail = |message: String| wgcloth::Error::Mesh {
        path: what.into(),
        message,
    };
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(fail(format!(
            "topology {:?}: a triangle list is needed",
            mesh.primitive_topology()
        )));
    }
    let positions: Vec<DVec3> = match mesh.attribute(Mesh::ATTRIBUTE_POSITION) {
        Some(VertexAttributeValues::Float32x3(p)) => {
            p.iter().map(|&p| Vec3::from(p).as_dvec3()).collect()
        }
        _ => return Err(fail("no Float32x3 positions".into())),
    };
    let indices: Vec<u32> = match mesh.indices() {
        Some(Indices::U32(i)) => i.clone(),
        Some(Indices::U16(i)) => i.iter().map(|&i| u32::from(i)).collect(),
        None => (0..positions.len() as u32).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(fail(format!(
            "{} indices is not a whole number of triangles",
            indices.len()
        )));
    }
    Ok((positions, indices))
}

/// A sphere collider: centred on its entity's [`GlobalTransform`]
/// translation. It pushes every cloth; its velocity is derived from how
/// the entity moved between the cloth's stepping frames.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct SphereCollider {
    /// Radius \[m\] (the entity's scale does not change it).
    pub radius: f32,
    /// Coulomb friction coefficient (dimensionless, `≥ 0`).
    pub friction: f32,
}

/// A capsule collider: the points within `radius` of the segment from
/// `-half_length` to `+half_length` along its entity's local Y axis (Bevy's
/// `Capsule3d` convention), placed by the entity's [`GlobalTransform`].
/// The solver moves a capsule without turning it within a frame: its
/// velocity is that of the segment's midpoint.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct CapsuleCollider {
    /// Radius \[m\].
    pub radius: f32,
    /// Half the segment's length \[m\], in the entity's local units.
    pub half_length: f32,
    /// Coulomb friction coefficient (dimensionless, `≥ 0`).
    pub friction: f32,
}

/// A mesh collider: the closed surface of a Bevy [`Mesh`] (a triangle
/// list; vertices at the same position are welded) in its entity's frame,
/// placed and turned by the entity's [`GlobalTransform`] (its scale is not
/// applied: the mesh is in metres). The plugin bakes the mesh once into
/// wgcloth's signed-distance grid (`wgcloth::sdf`, on the CPU, in the main
/// world: a fraction of a second at the default resolution), shared by
/// every collider of the same mesh, resolution and thickness. Its velocity
/// and angular velocity come from how the entity moved and turned between
/// the cloth's stepping frames; within a frame it moves without turning
/// (wgcloth's `set_mesh_colliders`).
///
/// A mesh collider acts on the cloths built after it was baked (a cloth
/// holds its mesh colliders' grids; the plugin holds back new cloths while
/// a mesh collider waits for its mesh asset); despawned, it stops acting.
/// A cloth takes at most 4 mesh colliders, its scene's included (more is a
/// [`ClothFailed`] for the cloth). A mesh that is not closed, or is wound
/// inconsistently, is a [`ClothFailed`] for the collider's entity.
#[derive(Component, Clone, Debug, PartialEq)]
#[require(Transform)]
pub struct ClothMeshCollider {
    /// The body's surface \[m\], in the entity's frame.
    pub mesh: Handle<Mesh>,
    /// Grid cells along the mesh's longest side (wgcloth's
    /// `[[collider]] resolution`, 4 to 512).
    pub resolution: u32,
    /// Coulomb friction coefficient (dimensionless, `≥ 0`).
    pub friction: f32,
    /// The distance the cloth keeps from the surface \[m\], `≥ 0`.
    pub thickness: f32,
}

impl ClothMeshCollider {
    /// A frictionless collider of `mesh` at wgcloth's default resolution
    /// (`wgcloth::sdf::DEFAULT_RESOLUTION` cells along its longest side).
    pub fn new(mesh: Handle<Mesh>) -> ClothMeshCollider {
        ClothMeshCollider {
            mesh,
            resolution: wgcloth::sdf::DEFAULT_RESOLUTION,
            friction: 0.0,
            thickness: 0.0,
        }
    }
}

/// Pins of a cloth that follow an entity (a bone, a flagpole): each
/// pinned particle keeps the place in the anchor's frame where it was when
/// the plugin first saw the cloth, and moves with the anchor as a moving
/// pin (it reaches the anchor's pose of this frame at the end of the
/// frame's steps).
#[derive(Component, Clone, Debug, PartialEq)]
pub struct ClothPins {
    /// The entity the pins follow (needs a [`GlobalTransform`]).
    pub anchor: Entity,
    /// The particles, by index in the model; empty: every particle the
    /// model pins. A particle the model leaves free is pinned where it is.
    pub particles: Vec<usize>,
}

impl ClothPins {
    /// Every particle the model pins, following `anchor`.
    pub fn all_to(anchor: Entity) -> ClothPins {
        ClothPins {
            anchor,
            particles: Vec::new(),
        }
    }
}

/// Gravity \[m/s²\] for every cloth, replacing each cloth's own
/// `params.gravity` while the resource exists.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct ClothGravity(pub Vec3);

/// Wind for every cloth, replacing each cloth's own `params.wind` while
/// the resource exists.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct ClothWind {
    /// Air velocity \[m/s\].
    pub velocity: Vec3,
    /// Drag coefficient along the triangle normal \[kg/m³\] (`½ ρ C_d`).
    pub drag: f32,
    /// Lift coefficient \[kg/m³\].
    pub lift: f32,
}

impl ClothWind {
    /// The wgcloth form.
    pub(crate) fn to_wind(self) -> wgcloth::params::Wind {
        wgcloth::params::Wind {
            velocity: self.velocity.as_dvec3(),
            drag: f64::from(self.drag),
            lift: f64::from(self.lift),
        }
    }
}

/// How the simulation clock advances each frame. The solver's time step
/// is fixed (each cloth's `params.dt`); the frame rate is not.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub enum ClothStepping {
    /// Real time with an accumulator: each frame adds [`Time`]'s delta to
    /// the clock of each time step, runs the whole steps it holds and
    /// keeps the remainder for the next frame. It is Bevy's virtual time:
    /// pausing or slowing it pauses or slows the cloth, and its
    /// `max_delta` (0.25 s unless the game sets it) caps what one long
    /// frame (a hitch, a breakpoint) runs, so a slow frame does not make
    /// the next one slower. The cloth's simulated time stays within one
    /// step of `Time::elapsed`.
    #[default]
    RealTime,
    /// Exactly this many steps every frame, whatever the frame's duration:
    /// deterministic runs, tests and offline capture.
    StepsPerFrame(u32),
    /// No steps (the cloths keep their state and are still drawn).
    Paused,
}

/// Opt-in read-back: a cloth with this component has its positions and
/// velocities read back to the CPU after every frame's steps and stored in
/// its [`ClothState`]. One blocking copy a frame: for gameplay code that
/// needs the vertices (tests, picking, sound), never needed to draw.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct ClothReadback;

/// The state read back for a [`ClothReadback`] cloth, one frame behind the
/// frame that ran its steps.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct ClothState {
    /// Steps the cloth had run when it was read.
    pub steps: u64,
    /// Positions \[m\], in particle order.
    pub positions: Vec<Vec3>,
    /// Velocities \[m/s\].
    pub velocities: Vec<Vec3>,
}

/// Where the plugin holds a cloth: its slot in the batch of its time step
/// (slots of despawned cloths are reused). Inserted once the cloth is on
/// the device.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClothSlot {
    /// The slot ([`wgcloth::gpu::ClothId::index`]).
    pub index: u32,
}

/// A cloth the plugin could not build or step: the device refused it
/// (limits, memory), a setting was invalid (more than 16 colliders), or
/// its state stopped being finite; or a [`ClothMeshCollider`] whose mesh
/// could not be baked; or a [`ClothRenderMesh`] that could not be bound
/// to its mesh. The message is wgcloth's, for a user.
#[derive(Message, Clone, Debug)]
pub struct ClothFailed {
    /// The cloth's entity (or the mesh collider's, or the render mesh's).
    pub entity: Entity,
    /// What went wrong.
    pub message: String,
}
