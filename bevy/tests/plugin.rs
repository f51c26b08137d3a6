//! The plugin in a headless Bevy app (no window: Bevy's render device on
//! the test adapter, lavapipe in CI), driven frame by frame with a fixed
//! number of steps a frame: the cloth it steps is the standalone solver's
//! bit for bit, a collider moved by a system pushes the cloth (a sphere,
//! and a mesh collider baked from a Bevy mesh), and a despawned cloth's
//! slot is reused.

use std::sync::{Mutex, PoisonError};

use anyhow::Context;
use bevy::app::PluginsState;
use bevy::prelude::*;
use bevy::render::pipelined_rendering::PipelinedRenderingPlugin;
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;
use wgcloth::{GpuContext, GpuSolver, Scene};
use wgcloth_bevy::{
    Cloth, ClothMeshCollider, ClothPlugin, ClothReadback, ClothSlot, ClothState, ClothStepping,
    SphereCollider,
};

/// One Bevy app at a time: each opens its own device, and lavapipe's
/// threads are the machine's cores.
static ONE_APP: Mutex<()> = Mutex::new(());

/// Frames a test waits for the render world's answer before failing: the
/// reports arrive one frame after the frame that produced them, and the
/// first frames compile the pipelines.
const MAX_FRAMES: u32 = 200;

/// A headless app with the plugin: no window, no event loop, the render
/// world updated in the same thread as the main world (no pipelining, so
/// frame `k`'s steps are recorded in frame `k`), stepping `steps` a frame.
fn app(steps: u32) -> App {
    let mut app = App::new();
    app.add_plugins(
        DefaultPlugins
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                ..default()
            })
            .disable::<WinitPlugin>()
            .disable::<PipelinedRenderingPlugin>()
            .disable::<bevy::log::LogPlugin>(),
    )
    .add_plugins(ClothPlugin)
    .insert_resource(ClothStepping::StepsPerFrame(steps));
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    app
}

/// Runs frames until `done` returns a value (at most [`MAX_FRAMES`]).
fn frames_until<T>(
    app: &mut App,
    what: &str,
    mut done: impl FnMut(&mut World) -> Option<T>,
) -> anyhow::Result<T> {
    for _ in 0..MAX_FRAMES {
        app.update();
        if let Some(t) = done(app.world_mut()) {
            return Ok(t);
        }
    }
    anyhow::bail!("no {what} after {MAX_FRAMES} frames")
}

/// The read-back of `entity` once it has run `steps` steps, `per_frame` a
/// frame: the clock is paused as soon as the frame that reaches `steps` has
/// run (read-backs arrive a frame late), so it stops exactly there.
fn state_after(
    app: &mut App,
    entity: Entity,
    steps: u64,
    per_frame: u32,
) -> anyhow::Result<ClothState> {
    frames_until(app, &format!("state after {steps} steps"), |world| {
        let s = world.get::<ClothState>(entity)?.clone();
        if s.steps + u64::from(per_frame) >= steps {
            world.insert_resource(ClothStepping::Paused);
        }
        (s.steps >= steps).then_some(s)
    })
}

/// Steps a frame in the bit-for-bit test, and frames: 50 steps in five
/// frames, each a separate recording (as the standalone solver's).
const STEPS_PER_FRAME: u32 = 10;
const FRAMES: u64 = 5;

#[test]
fn plugin_steps_the_standalone_solvers_cloth_bit_for_bit() -> anyhow::Result<()> {
    let _one = ONE_APP.lock().unwrap_or_else(PoisonError::into_inner);
    let scene = Scene::builtin("hanging")?;
    let mut app = app(STEPS_PER_FRAME);
    let entity = app
        .world_mut()
        .spawn((Cloth::from_scene(&scene)?, ClothReadback))
        .id();
    let steps = u64::from(STEPS_PER_FRAME) * FRAMES;
    let state = state_after(&mut app, entity, steps, STEPS_PER_FRAME)?;
    assert_eq!(state.steps, steps, "the plugin ran {} steps", state.steps);

    let context = Context::context(GpuContext::new(None), "the test needs an adapter")?;
    let model = scene.model()?;
    let mut solver = GpuSolver::new(&context.device, &context.queue, &model, &scene.params)?;
    for _ in 0..FRAMES {
        let mut encoder = context.device.create_command_encoder(&Default::default());
        solver.encode_steps(&mut encoder, STEPS_PER_FRAME);
        context.queue.submit([encoder.finish()]);
    }
    let alone = solver.read_state()?;
    let differing = |a: &[Vec3], b: &[Vec3]| {
        a.iter()
            .zip(b)
            .position(|(a, b)| a.to_array().map(f32::to_bits) != b.to_array().map(f32::to_bits))
    };
    assert_eq!(state.positions.len(), alone.x.len());
    if let Some(p) = differing(&state.positions, &alone.x) {
        panic!(
            "particle {p}: the plugin's position {} is not the solver's {}",
            state.positions[p], alone.x[p]
        );
    }
    if let Some(p) = differing(&state.velocities, &alone.v) {
        panic!(
            "particle {p}: the plugin's velocity {} is not the solver's {}",
            state.velocities[p], alone.v[p]
        );
    }
    Ok(())
}

/// The pushing sphere's radius \[m\].
const SPHERE_RADIUS: f32 = 0.2;
/// Where it starts, under the middle of the cloth (which rests at y = 1 m)
/// \[m\], and how fast it rises \[m/s\].
const SPHERE_START: Vec3 = Vec3::new(0.0, 0.6, 0.0);
const SPHERE_RISE: f32 = 1.0;
/// Steps a frame in the collider test: 1/60 s at the scene's 1 ms step.
const PUSH_STEPS_PER_FRAME: u32 = 17;
/// Frames the sphere rises: 0.51 s, to a top 1.31 m above the start.
const PUSH_FRAMES: u32 = 30;
/// How far above the same cloth without the sphere the cloth's middle
/// must end \[m\]: without it the middle sags below the pinned corners'
/// 1 m; with it the middle rides on the sphere's top, 1.31 m up.
const MIN_PUSH: f32 = 0.2;
/// How deep a particle may be inside the sphere \[m\]: contact acts at the
/// end of each step, and the sphere rises 1 mm a step.
const CONTACT_TOLERANCE: f32 = 0.005;
/// How deep a particle may be inside the mesh collider's cube \[m\]: the
/// sphere's allowance plus one cell of its grid (the cube's 0.4 m side at
/// the default 64 cells is 6.25 mm a cell), within which the trilinear
/// field rounds the cube's edges.
const MESH_CONTACT_TOLERANCE: f32 = CONTACT_TOLERANCE + 0.00625;

/// A collider that rises under the cloth.
#[derive(Component)]
struct Rising;

/// What pushes the cloth from below in [`pushed`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum Pusher {
    Nothing,
    /// A [`SphereCollider`] of radius [`SPHERE_RADIUS`].
    Sphere,
    /// A [`ClothMeshCollider`] of a Bevy cube of half-side [`SPHERE_RADIUS`].
    Cube,
}

/// Raises every [`Rising`] collider at [`SPHERE_RISE`] for the frame's
/// simulated time (none once the cloth is paused).
fn rise(stepping: Res<ClothStepping>, mut spheres: Query<&mut Transform, With<Rising>>) {
    let ClothStepping::StepsPerFrame(steps) = *stepping else {
        return;
    };
    let frame_seconds = steps as f32 * 0.001;
    for mut at in &mut spheres {
        at.translation.y += SPHERE_RISE * frame_seconds;
    }
}

/// The cloth's particles after [`PUSH_FRAMES`] frames, with the rising
/// `pusher`, and the pusher's centre at the end.
fn pushed(pusher: Pusher) -> anyhow::Result<(Vec<Vec3>, Vec3)> {
    let scene = Scene::builtin("hanging")?;
    let mut app = app(PUSH_STEPS_PER_FRAME);
    app.add_systems(Update, rise);
    let start = (Rising, Transform::from_translation(SPHERE_START));
    let sphere = match pusher {
        Pusher::Nothing => None,
        Pusher::Sphere => {
            let collider = SphereCollider {
                radius: SPHERE_RADIUS,
                friction: 0.0,
            };
            Some(app.world_mut().spawn((collider, start)).id())
        }
        Pusher::Cube => {
            let cube = Cuboid::from_length(2.0 * SPHERE_RADIUS).mesh().build();
            let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(cube);
            let collider = ClothMeshCollider::new(mesh);
            Some(app.world_mut().spawn((collider, start)).id())
        }
    };
    let cloth = app
        .world_mut()
        .spawn((Cloth::from_scene(&scene)?, ClothReadback))
        .id();
    let steps = u64::from(PUSH_STEPS_PER_FRAME) * u64::from(PUSH_FRAMES);
    let state = state_after(&mut app, cloth, steps, PUSH_STEPS_PER_FRAME)?;
    let centre = match sphere {
        Some(e) => {
            Context::context(app.world().get::<GlobalTransform>(e), "the sphere")?.translation()
        }
        None => Vec3::ZERO,
    };
    Ok((state.positions, centre))
}

/// Asserts that the rising `pusher` lifts the cloth's middle by more than
/// [`MIN_PUSH`] and leaves no particle deeper than `tolerance` inside it,
/// `depth` giving a point's depth inside the pusher from its centre \[m\]:
/// its velocity reached the solver, so it is where the frames put it.
fn assert_pushes(
    pusher: Pusher,
    depth: impl Fn(Vec3) -> f32,
    tolerance: f32,
) -> anyhow::Result<()> {
    let _one = ONE_APP.lock().unwrap_or_else(PoisonError::into_inner);
    let (free, _) = pushed(Pusher::Nothing)?;
    let (pushed, centre) = pushed(pusher)?;
    // The cloth's middle particle (33 × 33 grid).
    let middle = free.len() / 2;
    let lift = pushed[middle].y - free[middle].y;
    assert!(
        lift > MIN_PUSH,
        "the {pusher:?} lifted the cloth's middle by {lift} m (at least {MIN_PUSH} m expected)"
    );
    let (p, deepest) = pushed
        .iter()
        .map(|x| depth(*x - centre))
        .enumerate()
        .fold((0, f32::MIN), |a, b| if b.1 > a.1 { b } else { a });
    assert!(
        deepest < tolerance,
        "particle {p} is {deepest} m inside the {pusher:?} at {centre}"
    );
    Ok(())
}

#[test]
fn a_collider_moved_by_a_system_pushes_the_cloth() -> anyhow::Result<()> {
    assert_pushes(
        Pusher::Sphere,
        |r| SPHERE_RADIUS - r.length(),
        CONTACT_TOLERANCE,
    )
}

#[test]
fn a_mesh_collider_moved_by_a_system_pushes_the_cloth() -> anyhow::Result<()> {
    // The depth inside a cube is the least distance to a face.
    assert_pushes(
        Pusher::Cube,
        |r| SPHERE_RADIUS - r.abs().max_element(),
        MESH_CONTACT_TOLERANCE,
    )
}

#[test]
fn despawning_a_cloth_frees_its_slot() -> anyhow::Result<()> {
    let _one = ONE_APP.lock().unwrap_or_else(PoisonError::into_inner);
    let scene = Scene::builtin("hanging")?;
    let cloth = Cloth::from_scene(&scene)?;
    let mut app = app(1);
    let a = app.world_mut().spawn(cloth.clone()).id();
    let b = app.world_mut().spawn(cloth.clone()).id();
    let slot = |world: &mut World, e: Entity| world.get::<ClothSlot>(e).copied();
    let (slot_a, slot_b) = frames_until(&mut app, "slots", |w| Some((slot(w, a)?, slot(w, b)?)))?;
    assert_ne!(slot_a, slot_b);
    app.world_mut().despawn(a);
    app.update();
    let c = app.world_mut().spawn(cloth).id();
    let slot_c = frames_until(&mut app, "the new cloth's slot", |w| slot(w, c))?;
    assert_eq!(slot_c, slot_a, "the new cloth did not take the freed slot");
    assert_eq!(
        slot(app.world_mut(), b),
        Some(slot_b),
        "the other cloth moved"
    );
    Ok(())
}

#[test]
fn the_vertex_writing_shader_is_valid_wgsl() -> anyhow::Result<()> {
    let module = naga::front::wgsl::parse_str(wgcloth_bevy::WRITE_VERTICES_WGSL)
        .map_err(|e| anyhow::anyhow!("{}", e.emit_to_string(wgcloth_bevy::WRITE_VERTICES_WGSL)))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    Ok(())
}

#[test]
fn a_bevy_mesh_is_a_cloth_with_a_particle_per_vertex() -> anyhow::Result<()> {
    use bevy::mesh::{Mesh, PrimitiveTopology};
    use wgcloth::model::Pin;
    let plane = Plane3d::default()
        .mesh()
        .size(1.0, 1.0)
        .subdivisions(4)
        .build();
    let cloth = Cloth::from_mesh(&plane, 0.3, &[Pin::Index(0)], wgcloth::Params::default())?;
    assert_eq!(cloth.model().particle_count(), plane.count_vertices());
    assert_eq!(
        cloth.model().triangles.len() * 3,
        plane.indices().map_or(0, |i| i.len())
    );
    let lines = Mesh::new(PrimitiveTopology::LineList, Default::default());
    let refused = Cloth::from_mesh(&lines, 0.3, &[], wgcloth::Params::default())
        .expect_err("a line list is no cloth")
        .to_string();
    assert!(refused.contains("triangle list"), "{refused}");
    Ok(())
}
