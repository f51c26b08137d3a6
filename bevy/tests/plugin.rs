//! The plugin in a headless Bevy app (no window: Bevy's render device on
//! the test adapter, lavapipe in CI), driven frame by frame with a fixed
//! number of steps a frame: the cloth it steps is the standalone solver's
//! bit for bit, a collider moved by a system pushes the cloth (a sphere,
//! and a mesh collider baked from a Bevy mesh), a despawned cloth's slot
//! is reused, and a render mesh's vertices in Bevy's vertex slab are the
//! CPU twin's skinning of the cloth read back (its texture coordinates
//! untouched).

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
    app_with(steps, |_| {})
}

/// [`app`], with `before_finish` run on it before its plugins finish
/// (when the render world makes its resources from their settings).
fn app_with(steps: u32, before_finish: impl FnOnce(&mut App)) -> App {
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
    before_finish(&mut app);
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

// The render-mesh tests share the core's two-layer render mesh.
#[path = "../../tests/gpu_common/layers.rs"]
mod layers;

/// What [`read_slab`] saw of the probed mesh in the render world: its
/// slice of the vertex slab, and the word offsets of its position, normal
/// and texture coordinates and its stride.
#[derive(Clone, Debug, Default)]
struct Slab {
    words: Vec<f32>,
    stride: usize,
    position: usize,
    normal: usize,
    uv: usize,
}

/// The mesh whose slab slice [`read_slab`] reads, and what it read.
type Probed = (Option<AssetId<Mesh>>, Option<Slab>);

/// [`Probed`], shared by both worlds.
#[derive(Resource, Clone, Default)]
struct Probe(std::sync::Arc<Mutex<Probed>>);

/// Reads the probed mesh's vertices out of Bevy's vertex slab after the
/// frame was submitted (the slabs have `COPY_SRC` in this test).
fn read_slab(
    probe: Res<Probe>,
    allocator: Res<bevy::render::mesh::allocator::MeshAllocator>,
    meshes: Res<bevy::render::render_asset::RenderAssets<bevy::render::mesh::RenderMesh>>,
    device: Res<bevy::render::renderer::RenderDevice>,
    queue: Res<bevy::render::renderer::RenderQueue>,
) {
    let mut probe = probe.0.lock().unwrap_or_else(PoisonError::into_inner);
    let Some(id) = probe.0 else { return };
    let (Some(slice), Some(mesh)) = (allocator.mesh_vertex_slice(&id), meshes.get(id)) else {
        return;
    };
    let layout = mesh.layout.0.layout();
    let word = |attribute: bevy::mesh::MeshVertexAttribute| {
        let at = mesh
            .layout
            .0
            .attribute_ids()
            .iter()
            .position(|a| *a == attribute.id);
        at.map_or(usize::MAX, |i| layout.attributes[i].offset as usize / 4)
    };
    let stride = layout.array_stride;
    let start = u64::from(slice.range.start) * stride;
    let size = u64::from(slice.range.end - slice.range.start) * stride;
    let queue: &wgpu::Queue = &queue;
    let Ok(bytes) = wgcloth::gpu::readback::read_buffers(
        device.wgpu_device(),
        queue,
        &[(slice.buffer, start, size)],
    ) else {
        return;
    };
    probe.1 = Some(Slab {
        words: bytemuck::pod_collect_to_vec(&bytes[0]),
        stride: stride as usize / 4,
        position: word(Mesh::ATTRIBUTE_POSITION),
        normal: word(Mesh::ATTRIBUTE_NORMAL),
        uv: word(Mesh::ATTRIBUTE_UV_0),
    });
}

/// How far the plugin's skinned positions \[m\] and normals may be from the
/// CPU twin's on the cloth read back from the same frame: the twin is the
/// kernel operation for operation, and the device's vertex normals differ
/// from the twin's by an ulp or two where it fuses a multiply-add
/// (kernel_twins' `normals_matches_its_twin`), which moves a vertex by that
/// ulp times its offset and turns its normal by a few ulps (about 1e-7).
/// 1e-5 is a hundred times that, and a thousand times below a vertex
/// written one vertex over (the layers' spacing is centimetres) or a
/// render mesh left at rest (it falls tens of centimetres).
const SKIN_TOLERANCE: f32 = 1e-5;
/// Frames of the render-mesh test: 0.3 s of the hanging cloth's 1 ms
/// steps, in which its free edge falls about 0.4 m.
const RENDER_MESH_FRAMES: u64 = 30;
/// The least distance the render mesh's lowest-falling vertex must have
/// fallen from rest \[m\], so that a mesh never written fails the test.
const MIN_FALL: f32 = 0.05;

#[test]
fn a_render_mesh_follows_its_cloth_in_the_meshs_own_layout() -> anyhow::Result<()> {
    use wgcloth::real::Vec3 as V;
    use wgcloth_bevy::ClothRenderMesh;
    let _one = ONE_APP.lock().unwrap_or_else(PoisonError::into_inner);
    let scene = Scene::builtin("hanging")?;
    let cloth = Cloth::from_scene(&scene)?;
    let (render, _) = layers::embedded(cloth.model());
    // As a Bevy mesh with texture coordinates, which the pass must leave
    // as they are (a vertex of 8 words: position, normal, uv).
    let mut mesh = ClothRenderMesh::new(
        Entity::PLACEHOLDER,
        &cloth,
        render.clone(),
        layers::MAX_DISTANCE,
    )?
    .mesh();
    let n = render.vertex_count();
    let uvs: Vec<[f32; 2]> = (0..n).map(|i| [i as f32, -(i as f32)]).collect();
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uvs.clone());

    let probe = Probe::default();
    let mut app = app_with(STEPS_PER_FRAME, |app| {
        app.insert_resource(probe.clone());
        let render_app = app.sub_app_mut(bevy::render::RenderApp);
        render_app
            .world_mut()
            .resource_mut::<bevy::render::mesh::allocator::MeshAllocatorSettings>()
            .extra_buffer_usages |= wgpu::BufferUsages::COPY_SRC;
        render_app.insert_resource(probe.clone()).add_systems(
            bevy::render::Render,
            read_slab.in_set(bevy::render::RenderSystems::Cleanup),
        );
    });
    let c = app.world_mut().spawn((cloth.clone(), ClothReadback)).id();
    let skin = ClothRenderMesh::from_mesh(c, &cloth, &mesh, layers::MAX_DISTANCE)?;
    let handle = app.world_mut().resource_mut::<Assets<Mesh>>().add(mesh);
    probe.0.lock().unwrap_or_else(PoisonError::into_inner).0 = Some(handle.id());
    app.world_mut().spawn((skin.clone(), Mesh3d(handle)));
    let steps = u64::from(STEPS_PER_FRAME) * RENDER_MESH_FRAMES;
    let state = state_after(&mut app, c, steps, STEPS_PER_FRAME)?;
    // Paused now: a few more frames skin the same cloth again.
    for _ in 0..3 {
        app.update();
    }
    let slab = probe
        .0
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .1
        .clone();
    let slab = Context::context(slab, "the render world never read the render mesh's slab")?;
    assert_eq!(slab.stride, 8, "{slab:?}");
    assert_eq!(slab.words.len(), n * slab.stride);

    let x: Vec<V<f32>> = state
        .positions
        .iter()
        .map(|p| V::new(p.x, p.y, p.z))
        .collect();
    let (p, nn) = wgcloth::cpu::skin::skin(cloth.model(), &x, skin.embedding());
    let mut worst = 0.0f32;
    let mut fell = 0.0f32;
    for k in 0..n {
        let v = &slab.words[k * slab.stride..(k + 1) * slab.stride];
        let at = |w: usize| Vec3::new(v[w], v[w + 1], v[w + 2]);
        let (gp, gn) = (at(slab.position), at(slab.normal));
        worst = worst
            .max(gp.distance(Vec3::new(p[k].x, p[k].y, p[k].z)))
            .max(gn.distance(Vec3::new(nn[k].x, nn[k].y, nn[k].z)));
        fell = fell.max(render.positions[k].y as f32 - gp.y);
        assert_eq!(
            [v[slab.uv], v[slab.uv + 1]],
            uvs[k],
            "vertex {k}'s texture coordinates were overwritten"
        );
    }
    assert!(
        worst <= SKIN_TOLERANCE,
        "the plugin's render mesh is {worst} from the CPU twin's (at most {SKIN_TOLERANCE})"
    );
    assert!(
        fell >= MIN_FALL,
        "the render mesh fell {fell} m from rest (at least {MIN_FALL} m): it is not following"
    );
    Ok(())
}

#[test]
fn a_render_mesh_of_another_mesh_is_refused_by_name() -> anyhow::Result<()> {
    use wgcloth_bevy::{ClothFailed, ClothRenderMesh};
    let _one = ONE_APP.lock().unwrap_or_else(PoisonError::into_inner);
    let scene = Scene::builtin("hanging")?;
    let cloth = Cloth::from_scene(&scene)?;
    let (render, _) = layers::embedded(cloth.model());
    // Far from the cloth: refused when made, naming the vertex.
    let mut far = render.clone();
    far.positions[7].y += 1.0;
    let e = ClothRenderMesh::new(Entity::PLACEHOLDER, &cloth, far, layers::MAX_DISTANCE)
        .expect_err("a vertex a metre off")
        .to_string();
    assert!(e.contains("vertex 7"), "{e}");
    // Drawn through a mesh that is not the embedded one: a ClothFailed
    // for the render mesh's entity.
    let mut app = app(1);
    let c = app.world_mut().spawn(cloth.clone()).id();
    let skin = ClothRenderMesh::new(c, &cloth, render, layers::MAX_DISTANCE)?;
    let other = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Plane3d::default().mesh().size(1.0, 1.0).build());
    let r = app.world_mut().spawn((skin, Mesh3d(other))).id();
    let message = frames_until(&mut app, "a ClothFailed for the render mesh", |world| {
        world
            .resource_mut::<Messages<ClothFailed>>()
            .drain()
            .find(|f| f.entity == r)
            .map(|f| f.message)
    })?;
    assert!(message.contains("vertices"), "{message}");
    Ok(())
}
