//! A row of flags in a gusting wind: `--count N` copies of the built-in
//! `flag` scene (default 16) on poles, one batch on the GPU (same time
//! step), the wind a [`ClothWind`] resource a system varies. Orbit camera:
//! drag with the left button, scroll to zoom.
//!
//! `cargo run --release -p wgcloth-bevy --example flags [-- --count N
//! --frames F --screenshot FILE.png --headless]`. With `--frames` it prints
//! the median frame time of the frames after the first ten (for the speed
//! table in docs/performance.md); `--headless` renders offscreen with no
//! window or display (see examples/common), each frame waiting for the
//! device; `--paused` draws without stepping; `--standalone` steps
//! the same cloths for the same frames with wgcloth's own `GpuBatch` on a
//! device of its own (no Bevy, no drawing: one submit and wait a frame)
//! and prints its median frame time the same way.

mod common;

use std::time::{Duration, Instant};

use anyhow::Context;
use bevy::prelude::*;
use common::{Capture, Frames, Orbit};
use wgcloth::{GpuContext, Model, Params, Scene};
use wgcloth_bevy::{Cloth, ClothPlugin, ClothStepping, ClothWind};

/// Simulated time per frame with `--frames` \[s\].
const FRAME_SECONDS: f64 = 1.0 / 60.0;
/// Frames left out of the median: the first ones build pipelines.
const WARM_UP_FRAMES: usize = 10;
/// Distance between poles across the row and between rows \[m\].
const SPACING: (f64, f64) = (2.4, 2.2);

fn main() -> anyhow::Result<()> {
    let (mut count, mut standalone, mut paused) = (16u32, false, false);
    let capture = Capture::parse(std::env::args().skip(1), |arg, rest| {
        match arg {
            "--count" => {
                let n = Context::context(rest.next(), "--count needs a number of flags")?;
                let parsed = n.parse().ok().filter(|&n| (1..=4096).contains(&n));
                count = Context::with_context(parsed, || {
                    format!("--count {n}: a whole number from 1 to 4096")
                })?;
            }
            "--standalone" => standalone = true,
            "--paused" => paused = true,
            _ => return Ok(false),
        }
        Ok(true)
    })?;
    let scene = Scene::builtin("flag")?;
    let steps = wgcloth::render::steps_per_frame(1.0 / FRAME_SECONDS, scene.params.dt)?;
    let flags = (0..count)
        .map(|i| flag(&scene, i, count))
        .collect::<anyhow::Result<Vec<_>>>()?;
    if standalone {
        let frames = Context::context(capture.frames, "--standalone needs --frames F")?;
        return run_standalone(&flags, steps, frames);
    }
    let stepping = if paused {
        ClothStepping::Paused
    } else if capture.frames.is_some() {
        ClothStepping::StepsPerFrame(steps)
    } else {
        ClothStepping::RealTime
    };
    let wind = Context::context(scene.params.wind, "the flag scene has wind")?;
    let mut app = App::new();
    app.add_plugins((capture.default_plugins("wgcloth: flags"), ClothPlugin))
        .insert_resource(stepping)
        .insert_resource(Gusts {
            base: ClothWind {
                velocity: wind.velocity.as_vec3(),
                drag: wind.drag as f32,
                lift: wind.lift as f32,
            },
            fixed: capture.frames.is_some(),
        })
        .insert_resource(Flags(flags))
        .insert_resource(Label(format!(
            "bevy{}: {count} flags, {steps} steps a frame",
            match (capture.headless, paused) {
                (true, true) => " (headless, paused)",
                (true, false) => " (headless)",
                (false, true) => " (paused)",
                (false, false) => "",
            }
        )))
        .init_resource::<FrameTimes>()
        .add_systems(Startup, setup)
        .add_systems(Update, (gust, common::orbit_with_mouse))
        .add_systems(Last, time_frames);
    common::add_capture(&mut app, capture);
    let exit = app.run();
    match exit {
        AppExit::Success => Ok(()),
        AppExit::Error(code) => anyhow::bail!("the app exited with status {code}"),
    }
}

/// Flag `i` of `count`: the scene's cloth moved to its place in the rows.
fn flag(scene: &Scene, i: u32, count: u32) -> anyhow::Result<(Model, Params)> {
    let per_row = f64::from(count).sqrt().ceil() as u32;
    let (column, row) = (f64::from(i % per_row), f64::from(i / per_row));
    let mut scene = scene.clone();
    scene.cloths[0].spec.origin.x += column * SPACING.0;
    scene.cloths[0].spec.origin.z -= row * SPACING.1;
    Ok((scene.model()?, scene.params.clone()))
}

/// The cloths to spawn.
#[derive(Resource)]
struct Flags(Vec<(Model, Params)>);

/// The wind's mean and the clock of its gusts.
#[derive(Resource)]
struct Gusts {
    base: ClothWind,
    fixed: bool,
}

fn setup(
    mut commands: Commands,
    flags: Res<Flags>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) -> Result {
    let pole = meshes.add(Cylinder::new(0.03, 2.2));
    let metal = materials.add(StandardMaterial {
        base_color: Color::srgb(0.7, 0.7, 0.72),
        metallic: 0.8,
        perceptual_roughness: 0.3,
        ..default()
    });
    let mut centre = Vec3::ZERO;
    for (i, (model, params)) in flags.0.iter().enumerate() {
        let top_left = model.rest_positions[0].as_vec3();
        centre += top_left / flags.0.len() as f32;
        commands.spawn((
            Mesh3d(pole.clone()),
            MeshMaterial3d(metal.clone()),
            Transform::from_xyz(top_left.x - 0.03, 1.1, top_left.z),
        ));
        let hue = (i as f32 * 47.0) % 360.0;
        commands.spawn((
            Cloth::new(model.clone(), params.clone())?,
            MeshMaterial3d(materials.add(StandardMaterial {
                base_color: Color::hsl(hue, 0.75, 0.5),
                perceptual_roughness: 0.8,
                double_sided: true,
                cull_mode: None,
                ..default()
            })),
        ));
    }
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(200.0, 200.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.35, 0.45, 0.30),
            perceptual_roughness: 0.95,
            ..default()
        })),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(-2.0, 6.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.insert_resource(GlobalAmbientLight {
        brightness: 400.0,
        ..default()
    });
    let across = (flags.0.len() as f32).sqrt().ceil() * SPACING.0 as f32;
    commands.spawn(
        Orbit {
            target: centre + Vec3::new(0.8, 0.0, 0.0),
            distance: 3.5 + 1.2 * across,
            elevation: 0.3,
            azimuth: 0.35,
        }
        .camera(),
    );
    Ok(())
}

/// Gusts: the wind's speed swells and drops by 40 % every few seconds.
fn gust(mut commands: Commands, gusts: Res<Gusts>, time: Res<Time>, frames: Res<Frames>) {
    let t = if gusts.fixed {
        frames.count as f32 * FRAME_SECONDS as f32
    } else {
        time.elapsed_secs()
    };
    let swell = 1.0 + 0.4 * (1.3 * t).sin() * (0.37 * t).cos();
    commands.insert_resource(ClothWind {
        velocity: gusts.base.velocity * swell,
        ..gusts.base
    });
}

/// Real durations of the frames.
#[derive(Resource, Default)]
struct FrameTimes(Vec<Duration>);

impl FrameTimes {
    fn median(&self) -> Option<Duration> {
        median(self.0.get(WARM_UP_FRAMES..)?.to_vec())
    }
}

fn median(mut times: Vec<Duration>) -> Option<Duration> {
    times.sort();
    times.get(times.len() / 2).copied()
}

/// What the timing line says the run was.
#[derive(Resource)]
struct Label(String);

/// Records each frame's real duration; at the last frame of a `--frames`
/// run prints the median (the app's world is gone once it exits).
fn time_frames(
    time: Res<Time<Real>>,
    capture: Res<Capture>,
    label: Res<Label>,
    mut times: ResMut<FrameTimes>,
) {
    times.0.push(time.delta());
    if Some(times.0.len()) == capture.frames.map(|n| n as usize) {
        if let Some(median) = times.median() {
            println!(
                "{}: median frame {:.2} ms",
                label.0,
                median.as_secs_f64() * 1e3
            );
        }
    }
}

/// The same cloths stepped by wgcloth alone: one `GpuBatch` on a device of
/// its own, `steps` steps and the normals a frame, one submit and a wait.
fn run_standalone(flags: &[(Model, Params)], steps: u32, frames: u32) -> anyhow::Result<()> {
    wgcloth::gpu::quiet_mesa();
    let context = GpuContext::new(None)?;
    let mut batch = wgcloth::gpu::GpuBatch::with_kernels(context.kernels(), &context.queue);
    for (model, params) in flags {
        batch.add(model, params)?;
    }
    let mut times = Vec::new();
    for _ in 0..frames {
        let start = Instant::now();
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("flags.standalone"),
            });
        batch.encode_steps(&mut encoder, steps);
        batch.encode_normals(&mut encoder);
        context.queue.submit([encoder.finish()]);
        let waited = context.device.poll(wgpu::PollType::wait_indefinitely());
        Context::context(waited, "waiting for the frame")?;
        times.push(start.elapsed());
    }
    batch.check()?;
    let median = Context::context(
        times.get(WARM_UP_FRAMES..).and_then(|t| median(t.to_vec())),
        "--standalone needs more than ten frames",
    )?;
    println!(
        "standalone: {} flags, {steps} steps a frame: median frame {:.2} ms",
        flags.len(),
        median.as_secs_f64() * 1e3
    );
    Ok(())
}
