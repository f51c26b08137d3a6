//! The render world's part: the cloths live on Bevy's render device in one
//! [`GpuBatch`] per time step; each frame their steps, normals and the
//! vertex-writing pass are recorded into Bevy's own command encoder at the
//! start of its render graph (no submit of ours), and Bevy's pipelines draw
//! the meshes they wrote. Only [`ClothReadback`](crate::ClothReadback)
//! cloths are read back.

mod write;

use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex, PoisonError};

use bevy::prelude::*;
use bevy::render::mesh::allocator::MeshAllocator;
use bevy::render::mesh::RenderMesh;
use bevy::render::render_asset::RenderAssets;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue};
use bevy::render::Extract;
use wgcloth::gpu::{ClothId, DrawRange, GpuBatch, GpuKernels, GpuRenderMesh, SkinLayout};
use wgcloth::params::{Capsule, Sphere};
use wgcloth::render_mesh::Embedding;
use wgcloth::sdf::{DistanceGrid, MeshCollider, MeshPose};
use wgcloth::PinTarget;

use crate::components::{
    CapsuleCollider, Cloth, ClothGravity, ClothMeshCollider, ClothReadback, ClothRenderMesh,
    ClothSlot, ClothState, ClothWind, SphereCollider,
};
use crate::main_world::{BakedMesh, ClothClock, PinTargets, Report, Reports};
pub(crate) use write::SOURCE as WRITE_VERTICES_WGSL;
use write::{vertex_words, WriteBinding, WritePipeline};

/// One cloth as the main world has it this frame.
#[derive(Clone, Debug)]
struct ExtractedCloth {
    entity: Entity,
    cloth: Cloth,
    mesh: AssetId<Mesh>,
    pins: Vec<PinTarget>,
    readback: bool,
}

/// One render mesh as the main world has it this frame.
#[derive(Clone, Debug)]
struct ExtractedSkin {
    entity: Entity,
    cloth: Entity,
    embedding: Arc<Embedding>,
    mesh: AssetId<Mesh>,
}

/// A collider's pose this frame: a sphere's centre, or a capsule's ends
/// \[m\] (equal for a sphere).
#[derive(Clone, Copy, Debug, PartialEq)]
struct ColliderPose {
    ends: [Vec3; 2],
    radius: f32,
    friction: f32,
}

/// A mesh collider's grid and pose this frame.
#[derive(Clone, Debug)]
struct MeshBody {
    grid: Arc<DistanceGrid>,
    /// Its frame's origin \[m\] and orientation.
    at: Place,
    friction: f32,
    thickness: f32,
}

/// A mesh collider's position \[m\] and orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Place {
    position: Vec3,
    rotation: Quat,
}

/// Where a mesh collider no longer there is parked \[m\]: far from any
/// cloth (a cloth keeps the grids it was built with).
const PARKED: wgcloth::glam::DVec3 = wgcloth::glam::DVec3::new(0.0, -1.0e5, 0.0);

/// What the render world takes from the main world each frame.
#[derive(Resource, Default, Debug)]
pub(crate) struct Extracted {
    cloths: Vec<ExtractedCloth>,
    skins: Vec<ExtractedSkin>,
    spheres: Vec<(Entity, ColliderPose)>,
    capsules: Vec<(Entity, ColliderPose)>,
    meshes: Vec<(Entity, MeshBody)>,
    /// A mesh collider waits for its grid (new cloths wait for it).
    meshes_pending: bool,
    steps: HashMap<u64, u32>,
    gravity: Option<Vec3>,
    wind: Option<ClothWind>,
}

/// Copies this frame's cloths, clocks, gravity and wind.
#[expect(clippy::type_complexity, reason = "a cloth's components")]
pub(crate) fn extract(
    mut extracted: ResMut<Extracted>,
    cloths: Extract<
        Query<(
            Entity,
            &Cloth,
            &Mesh3d,
            Option<&PinTargets>,
            Has<ClothReadback>,
        )>,
    >,
    clock: Extract<Res<ClothClock>>,
    gravity: Extract<Option<Res<ClothGravity>>>,
    wind: Extract<Option<Res<ClothWind>>>,
) {
    let extracted = &mut *extracted;
    extracted.cloths.clear();
    extracted
        .cloths
        .extend(
            cloths
                .iter()
                .map(|(entity, cloth, mesh, pins, readback)| ExtractedCloth {
                    entity,
                    cloth: cloth.clone(),
                    mesh: mesh.id(),
                    pins: pins.map(|p| p.0.clone()).unwrap_or_default(),
                    readback,
                }),
        );
    extracted.steps.clone_from(&clock.steps);
    extracted.gravity = gravity.as_ref().map(|g| g.0);
    extracted.wind = wind.as_deref().copied();
}

/// Copies this frame's render meshes.
pub(crate) fn extract_render_meshes(
    mut extracted: ResMut<Extracted>,
    skins: Extract<Query<(Entity, &ClothRenderMesh, &Mesh3d)>>,
) {
    extracted.skins.clear();
    extracted
        .skins
        .extend(skins.iter().map(|(entity, r, mesh)| ExtractedSkin {
            entity,
            cloth: r.cloth(),
            embedding: r.shared_embedding().clone(),
            mesh: mesh.id(),
        }));
}

/// Copies this frame's collider poses (and mesh colliders' grids).
#[expect(clippy::type_complexity, reason = "one query per kind of collider")]
pub(crate) fn extract_colliders(
    mut extracted: ResMut<Extracted>,
    spheres: Extract<Query<(Entity, &SphereCollider, &GlobalTransform)>>,
    capsules: Extract<Query<(Entity, &CapsuleCollider, &GlobalTransform)>>,
    meshes: Extract<
        Query<(
            Entity,
            &ClothMeshCollider,
            Option<&BakedMesh>,
            &GlobalTransform,
        )>,
    >,
) {
    let extracted = &mut *extracted;
    extracted.spheres.clear();
    extracted
        .spheres
        .extend(spheres.iter().map(|(entity, s, at)| {
            let c = at.translation();
            let pose = ColliderPose {
                ends: [c, c],
                radius: s.radius,
                friction: s.friction,
            };
            (entity, pose)
        }));
    extracted.capsules.clear();
    extracted
        .capsules
        .extend(capsules.iter().map(|(entity, c, at)| {
            let half = Vec3::Y * c.half_length;
            let pose = ColliderPose {
                ends: [at.transform_point(-half), at.transform_point(half)],
                radius: c.radius,
                friction: c.friction,
            };
            (entity, pose)
        }));
    extracted.meshes.clear();
    extracted.meshes_pending = false;
    for (entity, c, baked, at) in &meshes {
        match baked.filter(|b| b.is_of(c)) {
            None => extracted.meshes_pending = true,
            Some(BakedMesh { grid: None, .. }) => {} // failed, reported
            Some(BakedMesh {
                grid: Some(grid), ..
            }) => {
                let (_, rotation, position) = at.to_scale_rotation_translation();
                extracted.meshes.push((
                    entity,
                    MeshBody {
                        grid: grid.clone(),
                        at: Place { position, rotation },
                        friction: c.friction,
                        thickness: c.thickness,
                    },
                ));
            }
        }
    }
}

/// The cloths of one time step: their batch and fixed-step clock.
#[derive(Debug)]
struct Group {
    batch: GpuBatch,
    /// The time step \[s\].
    dt: f64,
    /// Steps to record this frame.
    steps: u32,
    /// Where each collider entity was when this group last stepped.
    last_poses: HashMap<Entity, ColliderPose>,
    /// Where each mesh collider entity was when this group last stepped.
    last_places: HashMap<Entity, Place>,
    /// Collider entities were set on the cloths (so their absence must be
    /// set too).
    had_colliders: bool,
}

/// One cloth on the device.
#[derive(Debug)]
struct RenderCloth {
    group: u64,
    id: ClothId,
    mesh: AssetId<Mesh>,
    particles: u32,
    /// Particles the plugin pinned (the model left them free).
    pinned: HashSet<usize>,
    /// The mesh collider entities the cloth was built with, in order after
    /// its scene's own.
    mesh_entities: Vec<Entity>,
    /// Gravity and wind as last set (`None`: the cloth's own).
    gravity: Option<Vec3>,
    wind: Option<ClothWind>,
    readback: bool,
    write: WriteBinding,
}

/// Everything on the device, behind a lock: a batch is `Send` but not
/// `Sync`, and a resource must be both (the lock is never contended: the
/// render world's systems that take it run one after another).
#[derive(Resource, Default)]
pub(crate) struct ClothWorld(Mutex<Inner>);

#[derive(Default)]
struct Inner {
    kernels: Option<GpuKernels>,
    pipeline: Option<WritePipeline>,
    groups: HashMap<u64, Group>,
    cloths: HashMap<Entity, RenderCloth>,
    /// Cloths that failed to build, not retried while they exist.
    failed: HashSet<Entity>,
    skins: HashMap<Entity, Skin>,
    /// Render meshes that could not be bound, not retried while they exist.
    failed_skins: HashSet<Entity>,
}

/// A render mesh on the device, skinned from its cloth into its mesh.
#[derive(Debug)]
struct Skin {
    gpu: GpuRenderMesh,
    /// What it was built over: the embedding and where its cloth lies (a
    /// batch's buffers move when cloths are added).
    embedding: Arc<Embedding>,
    over: Over,
}

/// Where a cloth lies in its batch's buffers: its positions, normals and
/// index buffers, its first index and base vertex.
type Over = (wgpu::Buffer, wgpu::Buffer, wgpu::Buffer, u32, i32);

fn over(range: &DrawRange<'_>) -> Over {
    (
        range.positions.clone(),
        range.normals.clone(),
        range.index_buffer.clone(),
        range.indices.start,
        range.base_vertex,
    )
}

impl ClothWorld {
    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Builds new cloths, frees despawned ones, and sets gravity, wind,
/// colliders and pins for this frame's steps; binds each cloth's mesh.
pub(crate) fn prepare(
    world: Res<ClothWorld>,
    extracted: Res<Extracted>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    allocator: Res<MeshAllocator>,
    meshes: Res<RenderAssets<RenderMesh>>,
    reports: Res<Reports>,
) {
    let device = device.wgpu_device();
    let queue: &wgpu::Queue = &queue;
    let mut inner = world.lock();
    let inner = &mut *inner;
    if inner.pipeline.is_none() {
        match WritePipeline::new(device) {
            Ok(p) => inner.pipeline = Some(p),
            Err(message) => {
                for c in &extracted.cloths {
                    reports.post(Report::Failed(c.entity, message.clone()));
                }
                return;
            }
        }
    }
    let kernels = inner
        .kernels
        .get_or_insert_with(|| GpuKernels::new(device))
        .clone();

    // Despawned cloths free their slots.
    let present: HashSet<Entity> = extracted.cloths.iter().map(|c| c.entity).collect();
    inner.failed.retain(|e| present.contains(e));
    let gone: Vec<Entity> = inner
        .cloths
        .keys()
        .filter(|e| !present.contains(e))
        .copied()
        .collect();
    for entity in gone {
        if let Some(c) = inner.cloths.remove(&entity) {
            if let Some(group) = inner.groups.get_mut(&c.group) {
                if let Err(e) = group.batch.remove(c.id) {
                    reports.post(Report::Failed(entity, e.to_string()));
                }
            }
        }
    }
    let used: HashSet<u64> = inner.cloths.values().map(|c| c.group).collect();
    inner.groups.retain(|k, _| used.contains(k));

    for c in &extracted.cloths {
        if inner.cloths.contains_key(&c.entity)
            || inner.failed.contains(&c.entity)
            || extracted.meshes_pending
        {
            continue;
        }
        let params = c.cloth.params();
        let key = params.dt.to_bits();
        let group = inner.groups.entry(key).or_insert_with(|| Group {
            batch: GpuBatch::with_kernels(&kernels, queue),
            dt: params.dt,
            steps: 0,
            last_poses: HashMap::new(),
            last_places: HashMap::new(),
            had_colliders: false,
        });
        // The mesh collider entities join the scene's own.
        let mut params = params.clone();
        params
            .mesh_colliders
            .extend(extracted.meshes.iter().map(|(entity, body)| MeshCollider {
                path: format!("ClothMeshCollider {entity}").into(),
                grid: body.grid.clone(),
                position: body.at.position.as_dvec3(),
                rotation: unit(body.at.rotation),
                velocity: wgcloth::glam::DVec3::ZERO,
                angular_velocity: wgcloth::glam::DVec3::ZERO,
                friction: f64::from(body.friction),
                thickness: f64::from(body.thickness),
            }));
        match group.batch.add(c.cloth.model(), &params) {
            Ok(id) => {
                reports.post(Report::Slot(c.entity, ClothSlot { index: id.index() }));
                inner.cloths.insert(
                    c.entity,
                    RenderCloth {
                        group: key,
                        id,
                        mesh: c.mesh,
                        particles: c.cloth.model().particle_count() as u32,
                        pinned: HashSet::new(),
                        mesh_entities: extracted.meshes.iter().map(|(e, _)| *e).collect(),
                        gravity: None,
                        wind: None,
                        readback: false,
                        write: WriteBinding::new(device),
                    },
                );
            }
            Err(e) => {
                inner.failed.insert(c.entity);
                reports.post(Report::Failed(c.entity, e.to_string()));
            }
        }
    }

    for group in inner.groups.values_mut() {
        group.steps = 0;
    }
    for c in &extracted.cloths {
        let Some(cloth) = inner.cloths.get_mut(&c.entity) else {
            continue;
        };
        let Some(group) = inner.groups.get_mut(&cloth.group) else {
            continue;
        };
        cloth.readback = c.readback;
        cloth.mesh = c.mesh;
        let steps = extracted.steps.get(&cloth.group).copied().unwrap_or(0);
        group.steps = steps;
        if let Err(message) = set_scene(group, cloth, c, &extracted, steps) {
            reports.post(Report::Failed(c.entity, message));
        }
    }
    // The colliders' poses now are where the next frame's steps start.
    for group in inner.groups.values_mut() {
        if group.steps > 0 {
            group.last_poses = extracted
                .spheres
                .iter()
                .chain(&extracted.capsules)
                .copied()
                .collect();
            group.had_colliders = !group.last_poses.is_empty();
            group.last_places = extracted
                .meshes
                .iter()
                .map(|(entity, body)| (*entity, body.at))
                .collect();
        }
    }

    let Some(pipeline) = &inner.pipeline else {
        return;
    };
    for (entity, cloth) in &mut inner.cloths {
        let Some(group) = inner.groups.get(&cloth.group) else {
            continue;
        };
        let (Some(slice), Some(mesh)) = (
            allocator.mesh_vertex_slice(&cloth.mesh),
            meshes.get(cloth.mesh),
        ) else {
            continue; // not uploaded yet: drawn from the next frame
        };
        let bound = group
            .batch
            .draw_range(cloth.id)
            .map_err(|e| e.to_string())
            .and_then(|range| {
                let words = vertex_words(&mesh.layout, "the cloth's mesh")?;
                cloth.write.update(
                    device,
                    queue,
                    pipeline,
                    &range,
                    cloth.particles,
                    &slice,
                    words,
                )
            });
        if let Err(message) = bound {
            inner.failed.insert(*entity);
            reports.post(Report::Failed(*entity, message));
        }
    }
    let failed = &inner.failed;
    inner.cloths.retain(|e, _| !failed.contains(e));
    prepare_skins(inner, &extracted.skins, &allocator, &meshes, &reports);
}

/// Builds each render mesh over its cloth (again where the cloth moved in
/// its batch's buffers) and points it at its mesh's slice of the vertex
/// slab; frees those whose entity is gone.
fn prepare_skins(
    inner: &mut Inner,
    skins: &[ExtractedSkin],
    allocator: &MeshAllocator,
    meshes: &RenderAssets<RenderMesh>,
    reports: &Reports,
) {
    let present: HashSet<Entity> = skins.iter().map(|s| s.entity).collect();
    inner.skins.retain(|e, _| present.contains(e));
    inner.failed_skins.retain(|e| present.contains(e));
    for s in skins {
        if inner.failed_skins.contains(&s.entity) {
            continue;
        }
        let (Some(cloth), Some(slice), Some(mesh)) = (
            inner.cloths.get(&s.cloth),
            allocator.mesh_vertex_slice(&s.mesh),
            meshes.get(s.mesh),
        ) else {
            // The cloth is not built (or gone), or the mesh not uploaded:
            // not drawn this frame, or left where it was.
            inner.skins.remove(&s.entity);
            continue;
        };
        let Some(group) = inner.groups.get(&cloth.group) else {
            continue;
        };
        let bound = group
            .batch
            .draw_range(cloth.id)
            .map_err(|e| e.to_string())
            .and_then(|range| {
                // The mesh is checked before anything is built over it.
                let vertices = slice.range.end - slice.range.start;
                let want = s.embedding.vertex_count();
                if vertices as usize != want {
                    return Err(format!(
                        "the render mesh's mesh has {vertices} vertices; its embedding has \
                         {want} (the mesh must be the embedded one, in its order)"
                    ));
                }
                let (stride, position, normal) =
                    vertex_words(&mesh.layout, "the render mesh's mesh")?;
                let layout = SkinLayout {
                    stride,
                    position,
                    normal: Some(normal),
                    uv: None,
                };
                let here = over(&range);
                let stale = inner
                    .skins
                    .get(&s.entity)
                    .is_none_or(|k| !Arc::ptr_eq(&k.embedding, &s.embedding) || k.over != here);
                if stale {
                    let gpu = GpuRenderMesh::in_batch(
                        &group.batch,
                        cloth.id,
                        &s.embedding,
                        SkinLayout::POSITION_NORMAL,
                    )
                    .map_err(|e| e.to_string())?;
                    inner.skins.insert(
                        s.entity,
                        Skin {
                            gpu,
                            embedding: s.embedding.clone(),
                            over: here,
                        },
                    );
                }
                let offset = u64::from(slice.range.start) * u64::from(stride) * 4;
                match inner.skins.get_mut(&s.entity) {
                    Some(skin) => skin
                        .gpu
                        .write_into(slice.buffer, offset, layout)
                        .map_err(|e| e.to_string()),
                    None => Ok(()),
                }
            });
        if let Err(message) = bound {
            inner.skins.remove(&s.entity);
            inner.failed_skins.insert(s.entity);
            reports.post(Report::Failed(s.entity, message));
        }
    }
}

/// Sets one cloth's gravity, wind, colliders and pin targets for this
/// frame's `steps`.
fn set_scene(
    group: &mut Group,
    cloth: &mut RenderCloth,
    c: &ExtractedCloth,
    extracted: &Extracted,
    steps: u32,
) -> Result<(), String> {
    let params = c.cloth.params();
    let batch = &mut group.batch;
    let id = cloth.id;
    let error = |e: wgcloth::Error| e.to_string();
    if cloth.gravity != extracted.gravity {
        let g = extracted.gravity.map_or(params.gravity, |g| g.as_dvec3());
        batch.set_gravity(id, g).map_err(error)?;
        cloth.gravity = extracted.gravity;
    }
    if cloth.wind != extracted.wind {
        let wind = extracted.wind.map_or(params.wind, |w| Some(w.to_wind()));
        batch.set_wind(id, wind).map_err(error)?;
        cloth.wind = extracted.wind;
    }
    for t in &c.pins {
        if !c
            .cloth
            .model()
            .pinned
            .get(t.particle)
            .copied()
            .unwrap_or(true)
            && cloth.pinned.insert(t.particle)
        {
            batch.set_pinned(id, t.particle, true).map_err(error)?;
        }
    }
    if steps == 0 {
        return Ok(());
    }
    let frame_seconds = f64::from(steps) * group.dt;
    let colliders = !extracted.spheres.is_empty() || !extracted.capsules.is_empty();
    if colliders || group.had_colliders {
        // The scene's own colliders where they are now, then the
        // entities', from where they were when the group last stepped to
        // where they are now.
        let now = batch.time(id).map_err(error)?;
        let moving = |entity: &Entity, pose: &ColliderPose| {
            let from = group.last_poses.get(entity).unwrap_or(pose);
            let mid = |p: &ColliderPose| (p.ends[0] + p.ends[1]).as_dvec3() * 0.5;
            (from.ends, (mid(pose) - mid(from)) / frame_seconds)
        };
        let spheres: Vec<Sphere> = params
            .spheres
            .iter()
            .map(|s| Sphere {
                center: s.center + s.velocity * now,
                ..*s
            })
            .chain(extracted.spheres.iter().map(|(entity, pose)| {
                let (from, velocity) = moving(entity, pose);
                Sphere {
                    center: from[0].as_dvec3(),
                    radius: f64::from(pose.radius),
                    friction: f64::from(pose.friction),
                    velocity,
                }
            }))
            .collect();
        let capsules: Vec<Capsule> = params
            .capsules
            .iter()
            .map(|k| Capsule {
                a: k.a + k.velocity * now,
                b: k.b + k.velocity * now,
                ..*k
            })
            .chain(extracted.capsules.iter().map(|(entity, pose)| {
                let (from, velocity) = moving(entity, pose);
                Capsule {
                    a: from[0].as_dvec3(),
                    b: from[1].as_dvec3(),
                    radius: f64::from(pose.radius),
                    friction: f64::from(pose.friction),
                    velocity,
                }
            }))
            .collect();
        batch.set_spheres(id, &spheres).map_err(error)?;
        batch.set_capsules(id, &capsules).map_err(error)?;
    }
    if !cloth.mesh_entities.is_empty() {
        // The scene's own mesh colliders where they are now, then the
        // entities' from where they were when the group last stepped,
        // moving and turning to where they are now by the frame's end.
        let now = batch.time(id).map_err(error)?;
        let bodies: HashMap<Entity, Place> = extracted
            .meshes
            .iter()
            .map(|(entity, body)| (*entity, body.at))
            .collect();
        let poses: Vec<MeshPose> = params
            .mesh_colliders
            .iter()
            .map(|m| MeshPose {
                position: m.position + m.velocity * now,
                ..m.pose()
            })
            .chain(cloth.mesh_entities.iter().map(|entity| {
                let Some(to) = bodies.get(entity) else {
                    return MeshPose {
                        position: PARKED,
                        rotation: wgcloth::glam::DQuat::IDENTITY,
                        velocity: wgcloth::glam::DVec3::ZERO,
                        angular_velocity: wgcloth::glam::DVec3::ZERO,
                    };
                };
                let from = group.last_places.get(entity).unwrap_or(to);
                let turn = unit(to.rotation) * unit(from.rotation).inverse();
                // The shorter way round.
                let turn = if turn.w < 0.0 { -turn } else { turn };
                MeshPose {
                    position: from.position.as_dvec3(),
                    rotation: unit(from.rotation),
                    velocity: (to.position - from.position).as_dvec3() / frame_seconds,
                    angular_velocity: turn.to_scaled_axis() / frame_seconds,
                }
            }))
            .collect();
        batch.set_mesh_colliders(id, &poses).map_err(error)?;
    }
    if !c.pins.is_empty() {
        batch
            .set_pin_targets(id, &c.pins, frame_seconds)
            .map_err(error)?;
    }
    Ok(())
}

/// `rotation` in `f64`, normalised (an `f32` rotation's length is 1 only
/// to `f32` precision; wgcloth wants 1 to 1e-6).
fn unit(rotation: Quat) -> wgcloth::glam::DQuat {
    rotation.as_dquat().normalize()
}

/// Records every group's steps and normals and the vertex-writing pass
/// into Bevy's command encoder, at the start of its render graph: the
/// meshes are written before any view draws them, and Bevy submits it all
/// with the frame.
pub(crate) fn record(mut context: RenderContext, world: Res<ClothWorld>) {
    let mut inner = world.lock();
    if inner.cloths.is_empty() {
        return;
    }
    let encoder = context.command_encoder();
    for group in inner.groups.values_mut() {
        if group.steps > 0 {
            group.batch.encode_steps(encoder, group.steps);
            group.steps = 0;
        }
        group.batch.encode_normals(encoder);
    }
    let Some(pipeline) = &inner.pipeline else {
        return;
    };
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("wgcloth_bevy.write_vertices"),
        timestamp_writes: None,
    });
    for cloth in inner.cloths.values() {
        cloth.write.record(&mut pass, pipeline);
    }
    drop(pass);
    for skin in inner.skins.values() {
        skin.gpu.encode(encoder);
    }
}

/// Reads back the [`ClothReadback`] cloths after the frame was submitted.
pub(crate) fn read_back(world: Res<ClothWorld>, reports: Res<Reports>) {
    let inner = world.lock();
    for (entity, cloth) in &inner.cloths {
        if !cloth.readback {
            continue;
        }
        let Some(group) = inner.groups.get(&cloth.group) else {
            continue;
        };
        let state = group.batch.read_state(cloth.id).and_then(|s| {
            Ok(ClothState {
                steps: group.batch.steps_recorded(cloth.id)?,
                positions: s.x,
                velocities: s.v,
            })
        });
        reports.post(match state {
            Ok(state) => Report::State(*entity, state),
            Err(e) => Report::Failed(*entity, e.to_string()),
        });
    }
}
