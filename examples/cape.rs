//! A cape on a walking character, driven the way a game drives it: every
//! frame the host poses its character (here the `cape` scene's scripted
//! walk), hands the solver the capsules of the character's limbs with
//! their velocities and the targets of the pins sewn to its shoulders,
//! records the frame's steps, normals and drawing into one encoder, and
//! submits once. It prints where the character and the cape's hem are
//! every half second and writes the last frame as a PNG.
//!
//! `cargo run --release --example cape [OUT.png]` (default `out/cape.png`).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use wgcloth::render::{self, Camera, FrameTarget, Renderer, RendererFormats};
use wgcloth::{GpuContext, GpuSolver, Scene};

/// The host's frame rate [frames/s].
const FPS: f64 = 60.0;
/// How long it runs \[s\]: the scene's whole walk.
const SECONDS: f64 = 5.0;
/// Its window size [pixels].
const SIZE: (u32, u32) = (480, 360);

fn main() -> anyhow::Result<()> {
    // Before any thread exists: quiets Mesa's complaint about an unset
    // XDG_RUNTIME_DIR (Linux hosts).
    wgcloth::gpu::quiet_mesa();
    let out = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("out/cape.png"), PathBuf::from);
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let context = GpuContext::new(None)?;
    run(&context.device, &context.queue, &out)?;
    println!("wrote {}", out.display());
    Ok(())
}

/// The game's frame loop; writes the last frame to `out`.
fn run(device: &wgpu::Device, queue: &wgpu::Queue, out: &Path) -> anyhow::Result<()> {
    let scene = Scene::builtin("cape")?;
    let model = scene.model()?;
    let mut solver = GpuSolver::new(device, queue, &model, &scene.params)?;
    // The character's script, bound to this cloth's pins: a game would
    // pose its own skeleton instead and pass the same two things.
    let animation = scene
        .animation(&model)
        .context("the cape scene has a character")?;
    let steps = render::steps_per_frame(FPS, scene.params.dt)?;
    let frame_seconds = f64::from(steps) * scene.params.dt;
    let (width, height) = SIZE;
    let aspect = width as f32 / height as f32;
    let camera = Camera::for_scene(&scene, &model, aspect);
    let formats = RendererFormats::default();
    let renderer = Renderer::with_formats(device, queue, &scene.params, &camera, formats)?;
    let target = FrameTarget::with_formats(device, width, height, formats);
    // The cape's bottom corner particles (the hem's ends).
    let hem = [
        model.particle_count() - scene.cloths[0].spec.nx,
        model.particle_count() - 1,
    ];

    let frames = (SECONDS * FPS).round() as u32;
    for frame in 0..frames {
        let t = f64::from(frame) * frame_seconds;
        // 1. Per frame, the character's colliders and pins: the capsules
        //    where the limbs are now with the velocities that take them to
        //    where they will be at the frame's end (`set_capsules`), and
        //    where each pinned particle is to be at the frame's end
        //    (`set_pin_targets(targets, frame_seconds)`). The solver moves
        //    them along within the frame's steps, on the device.
        animation.apply(&mut solver, t, frame_seconds)?;
        // 2. One encoder: the frame's steps, the normals, the drawing.
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cape.frame"),
        });
        solver.encode_steps(&mut encoder, steps);
        solver.encode_normals(&mut encoder);
        // 3. The colliders drawn where they are at the frame's end, seen
        //    by a camera that follows the character (a game has its own).
        let (spheres, capsules) = solver.colliders();
        renderer.set_colliders(&spheres, &capsules);
        if let Some(camera) = Camera::following(&scene, &model, aspect, t + frame_seconds) {
            renderer.set_camera(&camera);
        }
        {
            let mut pass =
                renderer.begin_pass(&mut encoder, &target.color_view, &target.depth_view);
            renderer.draw(&mut pass, &solver);
        }
        // 4. One submit per frame.
        queue.submit([encoder.finish()]);
        // Twice a second (a read-back: a game would not), where things are.
        if (frame + 1) % (FPS as u32 / 2) == 0 {
            solver.check()?;
            let x = solver.read_state()?.x;
            let body = animation.character().pose(t + frame_seconds).position;
            println!(
                "t = {:.1} s: character at ({:.2}, {:.2}), hem at ({:.2}, {:.2}, {:.2}) and ({:.2}, {:.2}, {:.2})",
                t + frame_seconds,
                body.x,
                body.z,
                x[hem[0]].x,
                x[hem[0]].y,
                x[hem[0]].z,
                x[hem[1]].x,
                x[hem[1]].y,
                x[hem[1]].z,
            );
        }
    }
    solver.check()?;
    let rgba = render::read_rgba(device, queue, &target.color)?;
    render::write_png(&render::Frame {
        path: out.to_path_buf(),
        width,
        height,
        rgba,
    })?;
    Ok(())
}
