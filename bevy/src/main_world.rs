//! The main world's part, all on the CPU: meshes for new cloths, the
//! fixed-step clocks, where each moving pin is to be, the mesh colliders'
//! grids (baked once per mesh), and the reports the render world sends
//! back (slots, read-backs, failures).

use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex, PoisonError};

use bevy::prelude::*;
use wgcloth::sdf::DistanceGrid;
use wgcloth::PinTarget;

use crate::components::{
    triangle_mesh, Cloth, ClothFailed, ClothMeshCollider, ClothPins, ClothRenderMesh, ClothSlot,
    ClothState, ClothStepping,
};

/// The fixed-step clocks: one per time step `dt` (keyed by its bits), as
/// the cloths of one time step share a batch and step together.
#[derive(Resource, Default, Debug)]
pub(crate) struct ClothClock {
    /// Simulated time owed to each time step \[s\] (less than one step
    /// after each frame).
    accumulated: HashMap<u64, f64>,
    /// Steps each time step runs this frame.
    pub(crate) steps: HashMap<u64, u32>,
}

/// The steps a clock with `owed` seconds of simulated time runs at time
/// step `dt` \[s\], and what it still owes after them.
pub(crate) fn whole_steps(owed: f64, dt: f64) -> (u32, f64) {
    // `owed < dt` except right after a frame; the cast saturates.
    let steps = (owed / dt).floor().max(0.0) as u32;
    (steps, owed - f64::from(steps) * dt)
}

/// Advances every time step's clock by this frame (see [`ClothStepping`]).
pub(crate) fn advance_clock(
    time: Res<Time>,
    stepping: Res<ClothStepping>,
    mut clock: ResMut<ClothClock>,
    cloths: Query<&Cloth>,
) {
    let dts: HashSet<u64> = cloths.iter().map(|c| c.params().dt.to_bits()).collect();
    clock.accumulated.retain(|bits, _| dts.contains(bits));
    clock.steps.clear();
    for bits in dts {
        let dt = f64::from_bits(bits);
        let steps = match *stepping {
            ClothStepping::Paused => 0,
            ClothStepping::StepsPerFrame(n) => n,
            ClothStepping::RealTime => {
                let frame = time.delta_secs_f64();
                let owed = clock.accumulated.entry(bits).or_insert(0.0);
                let (steps, left) = whole_steps(*owed + frame, dt);
                *owed = left;
                steps
            }
        };
        clock.steps.insert(bits, steps);
    }
}

/// Gives a cloth without a mesh the mesh of its rest shape.
pub(crate) fn attach_meshes(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    cloths: Query<(Entity, &Cloth), Without<Mesh3d>>,
) {
    for (entity, cloth) in &cloths {
        commands
            .entity(entity)
            .insert(Mesh3d(meshes.add(cloth.mesh())));
    }
}

/// Gives a render mesh without a mesh the mesh it embeds.
pub(crate) fn attach_render_meshes(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    skins: Query<(Entity, &ClothRenderMesh), Without<Mesh3d>>,
) {
    for (entity, skin) in &skins {
        commands
            .entity(entity)
            .insert(Mesh3d(meshes.add(skin.mesh())));
    }
}

/// Each pinned particle's place in its anchor's frame \[m\], fixed when the
/// plugin first saw the pins.
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct PinOffsets {
    anchor: Option<Entity>,
    offsets: Vec<(usize, Vec3)>,
}

/// Where each moving pin is to be at the end of this frame's steps \[m\].
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct PinTargets(pub(crate) Vec<PinTarget>);

/// Resolves every [`ClothPins`] to this frame's targets: the anchor's
/// pose now, applied to each particle's offset in the anchor's frame.
pub(crate) fn resolve_pins(
    mut commands: Commands,
    cloths: Query<(Entity, &Cloth, &ClothPins, Option<&PinOffsets>)>,
    anchors: Query<&GlobalTransform>,
    mut failed: MessageWriter<ClothFailed>,
) {
    for (entity, cloth, pins, offsets) in &cloths {
        let Ok(anchor) = anchors.get(pins.anchor) else {
            // The anchor is gone: the pins stay where they were last sent.
            commands.entity(entity).remove::<PinTargets>();
            continue;
        };
        let fresh = offsets.is_none_or(|o| o.anchor != Some(pins.anchor));
        let offsets = if fresh {
            match pin_offsets(cloth, pins, anchor) {
                Ok(o) => {
                    commands.entity(entity).insert(o.clone());
                    o
                }
                Err(message) => {
                    failed.write(ClothFailed { entity, message });
                    commands.entity(entity).remove::<ClothPins>();
                    continue;
                }
            }
        } else {
            match offsets {
                Some(o) => o.clone(),
                None => continue,
            }
        };
        let targets = offsets
            .offsets
            .iter()
            .map(|&(particle, local)| PinTarget {
                particle,
                position: anchor.transform_point(local),
            })
            .collect();
        commands.entity(entity).insert(PinTargets(targets));
    }
}

/// The offsets of `pins` from the cloth's rest positions and the anchor's
/// pose now; an index beyond the cloth is an error naming it.
fn pin_offsets(
    cloth: &Cloth,
    pins: &ClothPins,
    anchor: &GlobalTransform,
) -> Result<PinOffsets, String> {
    let model = cloth.model();
    let particles: Vec<usize> = if pins.particles.is_empty() {
        (0..model.particle_count())
            .filter(|&p| model.pinned[p])
            .collect()
    } else {
        pins.particles.clone()
    };
    let to_local = anchor.affine().inverse();
    let offsets = particles
        .into_iter()
        .map(|p| match model.rest_positions.get(p) {
            Some(rest) => Ok((p, to_local.transform_point3(rest.as_vec3()))),
            None => Err(format!(
                "ClothPins: particle {p} is beyond the cloth's {} particles",
                model.particle_count()
            )),
        })
        .collect::<Result<_, _>>()?;
    Ok(PinOffsets {
        anchor: Some(pins.anchor),
        offsets,
    })
}

/// What the render world tells the main world.
#[derive(Debug)]
pub(crate) enum Report {
    /// The cloth is on the device, in this slot.
    Slot(Entity, ClothSlot),
    /// A read-back.
    State(Entity, ClothState),
    /// The cloth failed (see [`ClothFailed`]).
    Failed(Entity, String),
}

/// The reports' mailbox, shared by both worlds (the render world may run
/// on a thread of its own).
#[derive(Resource, Clone, Default, Debug)]
pub(crate) struct Reports(Arc<Mutex<Vec<Report>>>);

impl Reports {
    /// Posts a report for the main world's next frame.
    pub(crate) fn post(&self, report: Report) {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(report);
    }

    fn take(&self) -> Vec<Report> {
        std::mem::take(&mut *self.0.lock().unwrap_or_else(PoisonError::into_inner))
    }
}

/// Delivers the render world's reports: [`ClothSlot`] and [`ClothState`]
/// components on cloths that still exist, [`ClothFailed`] messages (also
/// logged as errors).
pub(crate) fn receive_reports(
    mut commands: Commands,
    reports: Res<Reports>,
    mut failed: MessageWriter<ClothFailed>,
) {
    for report in reports.take() {
        match report {
            Report::Slot(entity, slot) => {
                if let Ok(mut e) = commands.get_entity(entity) {
                    e.try_insert(slot);
                }
            }
            Report::State(entity, state) => {
                if let Ok(mut e) = commands.get_entity(entity) {
                    e.try_insert(state);
                }
            }
            Report::Failed(entity, message) => {
                error!("cloth {entity}: {message}");
                failed.write(ClothFailed { entity, message });
            }
        }
    }
}

/// What a mesh collider's grid was baked from: the mesh asset, the
/// resolution and the thickness (its bits).
pub(crate) type BakeKey = (AssetId<Mesh>, u32, u32);

fn bake_key(c: &ClothMeshCollider) -> BakeKey {
    (c.mesh.id(), c.resolution, c.thickness.to_bits())
}

/// A mesh collider's baked grid (`None`: the bake failed, reported once).
#[derive(Component, Clone, Debug)]
pub(crate) struct BakedMesh {
    pub(crate) key: BakeKey,
    pub(crate) grid: Option<Arc<DistanceGrid>>,
}

impl BakedMesh {
    /// Whether this is the bake of `collider` as it is now.
    pub(crate) fn is_of(&self, collider: &ClothMeshCollider) -> bool {
        self.key == bake_key(collider)
    }
}

/// The grids baked so far, by what they were baked from: colliders of one
/// mesh share one.
#[derive(Resource, Default, Debug)]
pub(crate) struct MeshGrids(HashMap<BakeKey, Arc<DistanceGrid>>);

/// Bakes each mesh collider whose grid is missing or stale once its mesh
/// asset is loaded (a cached grid when there is one); forgets grids no
/// collider uses.
pub(crate) fn bake_mesh_colliders(
    mut commands: Commands,
    meshes: Res<Assets<Mesh>>,
    mut grids: ResMut<MeshGrids>,
    colliders: Query<(Entity, &ClothMeshCollider, Option<&BakedMesh>)>,
    mut failed: MessageWriter<ClothFailed>,
) {
    let used: HashSet<BakeKey> = colliders.iter().map(|(_, c, _)| bake_key(c)).collect();
    grids.0.retain(|k, _| used.contains(k));
    for (entity, collider, baked) in &colliders {
        if baked.is_some_and(|b| b.is_of(collider)) {
            continue;
        }
        let key = bake_key(collider);
        let grid = match grids.0.get(&key) {
            Some(grid) => Some(grid.clone()),
            None => {
                let Some(mesh) = meshes.get(&collider.mesh) else {
                    continue; // not loaded yet
                };
                match bake(mesh, collider) {
                    Ok(grid) => {
                        let grid = Arc::new(grid);
                        grids.0.insert(key, grid.clone());
                        Some(grid)
                    }
                    Err(e) => {
                        let message = format!("ClothMeshCollider: {e}");
                        error!("mesh collider {entity}: {message}");
                        failed.write(ClothFailed { entity, message });
                        None
                    }
                }
            }
        };
        commands.entity(entity).insert(BakedMesh { key, grid });
    }
}

/// The signed-distance grid of `collider`'s `mesh`.
fn bake(mesh: &Mesh, collider: &ClothMeshCollider) -> wgcloth::Result<DistanceGrid> {
    let surface = triangle_mesh(mesh, true)?;
    wgcloth::sdf::bake(
        &surface,
        std::path::Path::new("the Bevy mesh"),
        "ClothMeshCollider",
        1.0,
        collider.resolution,
        f64::from(collider.thickness),
    )
}
