//! Embedding the GPU cloth in a host that renders on its own: the pattern a
//! game uses. The host owns the device, its render target and its frame
//! loop; every frame it records the solver's steps, the normals pass and
//! its own render pass (drawing the cloth straight from the solver's vertex
//! buffers) into one encoder and submits once. Nothing of the mesh crosses
//! to the host. At the end it reads the last frame back and writes one PNG.
//!
//! `cargo run --release --example embed [OUT.png]` (default `out/embed.png`).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use wgcloth::glam::Vec3;
use wgcloth::render::{self, Camera, FrameTarget, Renderer, RendererFormats};
use wgcloth::{GpuContext, GpuSolver, Scene};

/// Frames the host renders.
const FRAMES: u32 = 30;
/// Its frame rate [frames/s]: each frame advances the cloth 1/FPS seconds.
const FPS: f64 = 30.0;
/// Its window size [pixels].
const SIZE: (u32, u32) = (320, 240);
/// How far the host drags a pinned corner each frame [m]: 6 cm over the
/// run, a visible tug that keeps the cloth in the camera's frame.
const DRAG_PER_FRAME: f32 = 0.002;

fn main() -> anyhow::Result<()> {
    // Before any thread exists: quiets Mesa's complaint about an unset
    // XDG_RUNTIME_DIR (Linux hosts).
    wgcloth::gpu::quiet_mesa();
    let out = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("out/embed.png"), PathBuf::from);
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // The host's device: here wgcloth's convenience opener; a game passes
    // the device it already has.
    let context = GpuContext::new(None)?;
    run(&context.device, &context.queue, &out)?;
    println!(
        "wrote {} ({FRAMES} frames on {})",
        out.display(),
        context.describe()
    );
    Ok(())
}

/// The host's frame loop on a device it owns; writes the last frame to
/// `out` and returns the camera it drew with.
pub fn run(device: &wgpu::Device, queue: &wgpu::Queue, out: &Path) -> anyhow::Result<Camera> {
    // The cloth: a built-in scene's model and parameters.
    let scene = Scene::builtin("hanging")?;
    let model = scene.model()?;
    // The solver borrows the host's device; it owns only its buffers.
    let mut solver = GpuSolver::new(device, queue, &model, &scene.params)?;
    // How many solver steps make one frame interval.
    let steps = render::steps_per_frame(FPS, scene.params.dt)?;
    // A camera that frames the cloth (a game has its own).
    let (width, height) = SIZE;
    let camera = Camera::framing(&model, &scene.params, width as f32 / height as f32);
    // The formats of the host's targets: a game passes its swap chain's
    // colour format (often `Bgra8UnormSrgb`) and its depth buffer's. Here
    // the offscreen default, read back into a PNG below.
    let formats = RendererFormats::default();
    // The pipelines and the collider meshes, built once for those formats.
    let renderer = Renderer::with_formats(device, queue, &scene.params, &camera, formats)?;
    // The host's own offscreen target (a game's would be the swap-chain
    // texture and its depth buffer).
    let target = FrameTarget::with_formats(device, width, height, formats);
    // A pinned corner [m], as glam's `Vec3`: the vector type a Bevy or wgpu
    // host already holds.
    let corner = model.rest_positions[0].as_vec3();

    for frame in 0..FRAMES {
        // The game drags the corner (from the next recorded step on).
        solver.set_position(0, corner + Vec3::X * DRAG_PER_FRAME * frame as f32)?;
        // One encoder per frame...
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("embed.frame"),
        });
        // ...into which the solver records this frame's steps (one compute
        // pass, no submit, no read-back)...
        solver.encode_steps(&mut encoder, steps);
        // ...and the vertex normals the lighting needs...
        solver.encode_normals(&mut encoder);
        {
            // ...then the host's own render pass on its own target's views
            // (cleared to the background; a game clears to its own sky and
            // draws its own objects in the same pass)...
            let mut pass =
                renderer.begin_pass(&mut encoder, &target.color_view, &target.depth_view);
            // ...in which the cloth is drawn from the solver's position,
            // normal and index buffers.
            renderer.draw(&mut pass, &solver);
        }
        // One submit per frame: steps, normals and drawing in order.
        queue.submit([encoder.finish()]);
    }
    // Once, at the end: did the simulation stay finite? (A game would check
    // every few frames; it is one small read-back.) The same `StepStats`
    // the CPU solver's steps return.
    let stats = solver.check()?;
    // CG iterations only mean something for the implicit integrator.
    match scene.params.integrator {
        wgcloth::Integrator::Implicit => println!(
            "{} steps, {} CG iterations in the last",
            stats.steps, stats.cg_iterations
        ),
        _ => println!("{} steps", stats.steps),
    }
    // Read the last frame back and write it as a PNG.
    let rgba = render::read_rgba(device, queue, &target.color)?;
    render::write_png(&render::Frame {
        path: out.to_path_buf(),
        width,
        height,
        rgba,
    })?;
    Ok(camera)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The example runs on the test adapter (lavapipe in CI; a missing
    /// adapter fails) and writes a PNG of its size that shows the cloth
    /// over the background.
    #[test]
    fn embed_writes_a_frame() -> anyhow::Result<()> {
        let context = GpuContext::new(None).context("the example needs an adapter")?;
        let dir = std::env::temp_dir().join(format!("wgcloth-embed-{}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        let out = dir.join("embed.png");
        run(&context.device, &context.queue, &out)?;
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out)?));
        let mut reader = decoder.read_info()?;
        let mut rgba = vec![0; reader.output_buffer_size().context("PNG size")?];
        let info = reader.next_frame(&mut rgba)?;
        assert_eq!((info.width, info.height), SIZE);
        assert_eq!(
            &rgba[..4],
            &render::BACKGROUND,
            "the top-left corner is sky"
        );
        let not_background = rgba.chunks(4).filter(|p| *p != render::BACKGROUND).count();
        assert!(
            not_background > rgba.len() / 4 / 20,
            "only {not_background} pixels drawn"
        );
        std::fs::remove_dir_all(&dir)?;
        Ok(())
    }
}
