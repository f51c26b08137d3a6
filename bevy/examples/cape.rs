//! The built-in `cape` scene in Bevy: a character of capsules jogs and
//! turns on its scripted path, and the cape sewn to its shoulders follows
//! through the plugin's moving pins while its capsules push the cloth. The
//! character is ordinary Bevy entities: each limb a capsule mesh with a
//! [`CapsuleCollider`], the body an entity the cape is pinned to. Lit by
//! Bevy's PBR (a shadow-casting sun), seen by an orbit camera (drag with
//! the left button, scroll to zoom).
//!
//! `cargo run --release -p wgcloth-bevy --example cape [-- --frames N
//! --screenshot FILE.png]`: with `--frames` it renders `N` frames at a
//! fixed 1/60 s of simulated time each (whatever the frame took) and
//! writes the last with Bevy's screenshot API, then exits; `--headless`
//! does it with no window or display (rendered offscreen).
//! The cape is drawn through the scene's detailed render mesh
//! (`scenes/cape_detail.obj`, a [`ClothRenderMesh`]: a hem and thousands
//! of vertices skinned on the GPU from the coarse simulation, whose own
//! mesh is hidden); `--coarse` draws the simulation's mesh instead.
//! `--check-pins` reads the cape back every frame and prints, for each
//! read-back, how far its pinned particles are from where the character's
//! pose at the cloth's simulated time puts them (`pins: steps S error E
//! m`): the cape test's proof that the pins follow the character.

mod common;

use anyhow::Context;
use bevy::prelude::*;
use common::{Capture, Frames, Orbit};
use wgcloth::scene::animation::Character;
use wgcloth::Scene;
use wgcloth_bevy::{
    CapsuleCollider, Cloth, ClothPins, ClothPlugin, ClothReadback, ClothRenderMesh, ClothState,
    ClothStepping,
};

/// Simulated time per frame with `--frames` \[s\]: the cape scene's 60
/// frames a second (four of its 1/240 s steps).
const FRAME_SECONDS: f64 = 1.0 / 60.0;

fn main() -> anyhow::Result<()> {
    let mut check_pins = false;
    let mut coarse = false;
    let capture = Capture::parse(std::env::args().skip(1), |arg, _| {
        Ok(match arg {
            "--check-pins" => {
                check_pins = true;
                true
            }
            "--coarse" => {
                coarse = true;
                true
            }
            _ => false,
        })
    })?;
    let mut scene = Scene::builtin("cape")?;
    let character = Context::context(scene.character.clone(), "the cape scene has a character")?;
    // The scene's parameters hold the character's capsules where it
    // starts; here its limbs are entities that carry them along, so the
    // cloth keeps only the scene's other capsules.
    let others = scene.params.capsules.len() - character.capsules.len();
    scene.params.capsules.truncate(others);
    let cloth = Cloth::from_scene(&scene)?;
    let stepping = match capture.frames {
        Some(_) => ClothStepping::StepsPerFrame(wgcloth::render::steps_per_frame(
            1.0 / FRAME_SECONDS,
            scene.params.dt,
        )?),
        None => ClothStepping::RealTime,
    };
    let mut app = App::new();
    app.add_plugins((capture.default_plugins("wgcloth: cape"), ClothPlugin))
        .insert_resource(stepping)
        .insert_resource(Walk {
            character,
            fixed: capture.frames.is_some(),
        })
        .insert_resource(Setup {
            cloth,
            scene,
            check_pins,
            coarse,
        })
        .add_systems(Startup, setup)
        .add_systems(Update, (walk, common::orbit_with_mouse));
    if check_pins {
        app.add_systems(Update, report_pins);
    }
    common::add_capture(&mut app, capture);
    match app.run() {
        AppExit::Success => Ok(()),
        AppExit::Error(code) => anyhow::bail!("the app exited with status {code}"),
    }
}

/// The character's script and the clock that plays it.
#[derive(Resource)]
struct Walk {
    character: Character,
    /// Fixed frames (`--frames`): the character's time is the frame's.
    fixed: bool,
}

/// What `setup` spawns.
#[derive(Resource)]
struct Setup {
    cloth: Cloth,
    scene: Scene,
    /// `--check-pins`: the cape is read back every frame.
    check_pins: bool,
    /// `--coarse`: the simulation's own mesh is drawn, not the scene's
    /// render meshes.
    coarse: bool,
}

/// The character's root entity (its pose is the script's).
#[derive(Component)]
struct Body;

fn setup(
    mut commands: Commands,
    setup: Res<Setup>,
    walk: Res<Walk>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut exit: MessageWriter<AppExit>,
) {
    let skin = materials.add(StandardMaterial {
        base_color: Color::srgb(0.55, 0.58, 0.62),
        perceptual_roughness: 0.7,
        ..default()
    });
    let body = commands
        .spawn((Body, pose(&walk.character, 0.0), Visibility::default()))
        .id();
    // Each limb: a capsule mesh and collider along its segment, in the
    // character's frame.
    for c in &walk.character.capsules {
        let (a, b) = (c.a.as_vec3(), c.b.as_vec3());
        let half_length = (b - a).length() / 2.0;
        let along = (b - a).try_normalize().unwrap_or(Vec3::Y);
        let limb = commands
            .spawn((
                Mesh3d(meshes.add(Capsule3d::new(c.radius as f32, 2.0 * half_length))),
                MeshMaterial3d(skin.clone()),
                Transform::from_translation((a + b) / 2.0)
                    .with_rotation(Quat::from_rotation_arc(Vec3::Y, along)),
                CapsuleCollider {
                    radius: c.radius as f32,
                    half_length,
                    friction: c.friction as f32,
                },
            ))
            .id();
        commands.entity(body).add_child(limb);
    }
    // The cape, pinned to the body where it rests at the start.
    let red = materials.add(StandardMaterial {
        base_color: Color::srgb(0.75, 0.08, 0.06),
        perceptual_roughness: 0.85,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    let cape = commands
        .spawn((
            setup.cloth.clone(),
            MeshMaterial3d(red.clone()),
            ClothPins::all_to(body),
        ))
        .id();
    if setup.check_pins {
        commands.entity(cape).insert(ClothReadback);
    }
    // Drawn through its detailed meshes: the simulation's own is hidden.
    if !setup.coarse {
        match ClothRenderMesh::from_scene(cape, &setup.cloth, &setup.scene) {
            Ok(detailed) if !detailed.is_empty() => {
                commands.entity(cape).insert(Visibility::Hidden);
                for r in detailed {
                    commands.spawn((r, MeshMaterial3d(red.clone())));
                }
            }
            Ok(_) => {}
            Err(e) => {
                error!("the cape's render mesh: {e}");
                exit.write(AppExit::error());
            }
        }
    }
    // The ground at the scene's height.
    let ground = setup.scene.params.ground.map_or(0.0, |g| g.height) as f32;
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(20.0, 20.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.42, 0.45, 0.40),
            perceptual_roughness: 0.95,
            ..default()
        })),
        Transform::from_xyz(0.0, ground, 0.0),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(3.0, 6.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.insert_resource(GlobalAmbientLight {
        brightness: 400.0,
        ..default()
    });
    // The scene's own camera: it frames the whole walk.
    let camera = &setup.scene.camera;
    let orbit = Orbit {
        target: camera
            .target
            .map_or(Vec3::new(0.0, 1.0, 0.0), |t| t.as_vec3()),
        distance: camera.distance.unwrap_or(6.0) as f32,
        elevation: (camera.elevation.unwrap_or(18.0) as f32).to_radians(),
        azimuth: (camera.azimuth.unwrap_or(-50.0) as f32).to_radians(),
    };
    commands.spawn(orbit.camera());
}

/// The character's pose at `t` \[s\] as a transform.
fn pose(character: &Character, t: f64) -> Transform {
    let p = character.pose(t);
    Transform::from_translation(p.position.as_vec3()).with_rotation(p.rotation.as_quat())
}

/// Poses the character where it is at the end of this frame's cloth
/// steps, which is where the plugin takes the cape's pins: at the frame's
/// fixed end time with `--frames` (frame `k`, counted from 0, runs the
/// steps up to `(k + 1)` frames of simulated time), else at Bevy's virtual
/// time (which the cloth's fixed-step clock follows).
fn walk(
    walk: Res<Walk>,
    time: Res<Time>,
    frames: Res<Frames>,
    mut body: Query<&mut Transform, With<Body>>,
) {
    let t = if walk.fixed {
        f64::from(frames.count + 1) * FRAME_SECONDS
    } else {
        time.elapsed_secs_f64()
    };
    for mut transform in &mut body {
        *transform = pose(&walk.character, t);
    }
}

/// `--check-pins`: for each read-back of the cape, the largest distance of
/// a pinned particle from its place on the character posed at the cloth's
/// simulated time (its place in the character's frame is where it rests
/// at the start, as the plugin fixes it) \[m\]. The pins land on the
/// anchor's pose at the end of each frame's steps, so this is f32 rounding
/// unless the pins fall behind the character (or a frame's steps are
/// lost).
fn report_pins(walk: Res<Walk>, cloths: Query<(&Cloth, Ref<ClothState>)>) {
    let start = pose(&walk.character, 0.0).compute_affine().inverse();
    for (cloth, state) in &cloths {
        if !state.is_changed() {
            continue;
        }
        let model = cloth.model();
        let t = state.steps as f64 * cloth.params().dt;
        let now = pose(&walk.character, t).compute_affine();
        let error = (0..model.particle_count())
            .filter(|&p| model.pinned[p])
            .map(|p| {
                let local = start.transform_point3(model.rest_positions[p].as_vec3());
                let at = now.transform_point3(local);
                state
                    .positions
                    .get(p)
                    .map_or(f32::INFINITY, |x| x.distance(at))
            })
            .fold(0.0f32, f32::max);
        println!("pins: steps {} error {error} m", state.steps);
    }
}
