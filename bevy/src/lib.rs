//! wgcloth's GPU cloth in a Bevy game: [`ClothPlugin`].
//!
//! ```no_run
//! use bevy::prelude::*;
//! use wgcloth_bevy::{Cloth, ClothPlugin};
//!
//! fn main() {
//!     App::new()
//!         .add_plugins((DefaultPlugins, ClothPlugin))
//!         .add_systems(Startup, setup)
//!         .run();
//! }
//!
//! fn setup(mut commands: Commands, mut materials: ResMut<Assets<StandardMaterial>>) {
//!     let scene = wgcloth::Scene::builtin("flag").expect("a built-in scene");
//!     commands.spawn((
//!         Cloth::from_scene(&scene).expect("valid parameters"),
//!         MeshMaterial3d(materials.add(StandardMaterial {
//!             double_sided: true,
//!             cull_mode: None,
//!             ..default()
//!         })),
//!     ));
//!     commands.spawn((Camera3d::default(), Transform::from_xyz(0.8, 1.5, 4.0)));
//!     commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y)));
//! }
//! ```
//!
//! What runs where (docs/bevy.md has the whole story):
//! - the **main world** (`PostUpdate`, after transforms propagate) gives a
//!   new [`Cloth`] its mesh, advances the fixed-step clocks
//!   ([`ClothStepping`]), resolves moving pins ([`ClothPins`]) against
//!   their anchors' [`GlobalTransform`] and bakes mesh colliders' grids; in `PreUpdate` it receives what
//!   the render world reports ([`ClothSlot`], [`ClothState`],
//!   [`ClothFailed`]);
//! - the **render world** builds the cloths on Bevy's own `RenderDevice`
//!   and `RenderQueue` (one [`wgcloth::gpu::GpuBatch`] per time step),
//!   sets gravity, wind, colliders ([`SphereCollider`], [`CapsuleCollider`],
//!   [`ClothMeshCollider`]) and pins, and records the steps, the normals and a pass that writes
//!   them into each cloth's mesh, and the skinning pass of each
//!   [`ClothRenderMesh`] (a detailed mesh that follows a cloth), into Bevy's
//!   command encoder at the start of its render graph; Bevy's pipelines
//!   then draw the meshes as any other.
//!   Nothing is read back unless a cloth asks ([`ClothReadback`]).

#![deny(missing_docs)]

mod components;
mod main_world;
mod render;

use bevy::prelude::*;
use bevy::render::mesh::allocator::MeshAllocatorSettings;
use bevy::render::renderer::{RenderGraph, RenderGraphSystems};
use bevy::render::{ExtractSchedule, Render, RenderApp, RenderSystems};
use bevy::transform::TransformSystems;

pub use components::{
    CapsuleCollider, Cloth, ClothFailed, ClothGravity, ClothMeshCollider, ClothPins, ClothReadback,
    ClothRenderMesh, ClothSlot, ClothState, ClothStepping, ClothWind, SphereCollider,
};

/// The WGSL of the pass that writes a cloth's vertices into its mesh (for
/// validation in the tests).
#[doc(hidden)]
pub const WRITE_VERTICES_WGSL: &str = render::WRITE_VERTICES_WGSL;

/// Simulates every [`Cloth`] entity on Bevy's render device and draws it
/// through its mesh. Add it after Bevy's `DefaultPlugins` (it needs the
/// render and PBR plugins' resources).
#[derive(Debug, Default, Clone, Copy)]
pub struct ClothPlugin;

/// The main world's systems, in order.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub enum ClothSystems {
    /// `PreUpdate`: the render world's reports arrive.
    Receive,
    /// `PostUpdate`, after transform propagation: meshes, clocks, pins,
    /// mesh colliders' grids.
    Prepare,
}

impl Plugin for ClothPlugin {
    fn build(&self, app: &mut App) {
        let reports = main_world::Reports::default();
        app.init_resource::<ClothStepping>()
            .init_resource::<main_world::ClothClock>()
            .init_resource::<main_world::MeshGrids>()
            .insert_resource(reports.clone())
            .add_message::<ClothFailed>()
            .add_systems(
                PreUpdate,
                main_world::receive_reports.in_set(ClothSystems::Receive),
            )
            .add_systems(
                PostUpdate,
                (
                    main_world::attach_meshes,
                    main_world::attach_render_meshes,
                    main_world::advance_clock,
                    main_world::resolve_pins,
                    main_world::bake_mesh_colliders,
                )
                    .in_set(ClothSystems::Prepare)
                    .after(TransformSystems::Propagate),
            );
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        // The vertex-writing pass binds the mesh slabs as storage (read when
        // the allocator is made, once the device exists).
        render_app
            .world_mut()
            .get_resource_or_insert_with(MeshAllocatorSettings::default)
            .extra_buffer_usages |= wgpu::BufferUsages::STORAGE;
        render_app
            .insert_resource(reports)
            .init_resource::<render::Extracted>()
            .init_resource::<render::ClothWorld>()
            .add_systems(
                ExtractSchedule,
                (
                    render::extract,
                    render::extract_colliders,
                    render::extract_render_meshes,
                ),
            )
            .add_systems(
                Render,
                (
                    render::prepare.in_set(RenderSystems::PrepareResources),
                    render::read_back.in_set(RenderSystems::Cleanup),
                ),
            )
            .add_systems(
                RenderGraph,
                render::record.in_set(RenderGraphSystems::Begin),
            );
    }
}
