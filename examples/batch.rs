//! Many cloths in one `GpuBatch`: six flags on their poles, each with its
//! own bending stiffness and wind, stepped together (one dispatch per step
//! for all six) and drawn straight from the batch's shared buffers, each
//! cloth with its own index range and base vertex. At the end the frame is
//! read back into one PNG.
//!
//! `cargo run --release --example batch [OUT.png]` (default
//! `out/batch.png`).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use wgcloth::glam::DVec3;
use wgcloth::gpu::GpuBatch;
use wgcloth::params::Wind;
use wgcloth::render::{self, Camera, FrameTarget, Renderer, RendererFormats};
use wgcloth::{GpuContext, Scene};

/// Where each flag's pole stands from the last one's [m]: room for a
/// 1.6 m flag and a gap.
const SPACING: (f64, f64) = (2.2, 1.5);
/// The bending stiffness of each column, as a multiple of the scene's.
const BEND: [f64; 3] = [0.2, 1.0, 5.0];
/// The wind of each row, as a multiple of the scene's.
const WIND: [f64; 2] = [0.5, 1.5];
/// Simulated time before the frame [s]: the flags have blown out.
const SECONDS: f64 = 2.0;
/// The image [pixels].
const SIZE: (u32, u32) = (640, 400);

fn main() -> anyhow::Result<()> {
    // Before any thread exists: quiets Mesa's complaint about an unset
    // XDG_RUNTIME_DIR (Linux hosts).
    wgcloth::gpu::quiet_mesa();
    let out = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("out/batch.png"), PathBuf::from);
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let context = GpuContext::new(None)?;
    let dispatches = run(&context, &out, SECONDS)?;
    let plural = if dispatches == 1.0 { "" } else { "es" };
    println!(
        "wrote {} ({} flags, {dispatches} dispatch{plural} per step, on {})",
        out.display(),
        BEND.len() * WIND.len(),
        context.describe()
    );
    Ok(())
}

/// Steps the flags for `seconds` of simulated time and writes the frame
/// to `out`; returns the batch's dispatches per step.
pub fn run(context: &GpuContext, out: &Path, seconds: f64) -> anyhow::Result<f64> {
    let (device, queue) = (&context.device, &context.queue);
    let flag = Scene::builtin("flag")?;
    let wind = flag.params.wind.context("the flag scene has wind")?;
    // One kernel library for every solver and batch on the device.
    let mut batch = GpuBatch::with_kernels(context.kernels(), queue);
    let mut ids = Vec::new();
    // The box round every flag at rest [m], for the camera.
    let (mut low, mut high) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for (row, wind_scale) in WIND.iter().enumerate() {
        for (col, bend_scale) in BEND.iter().enumerate() {
            let mut scene = flag.clone();
            scene.cloths[0].spec.origin +=
                DVec3::new(col as f64 * SPACING.0, row as f64 * SPACING.1, 0.0);
            scene.params.springs[2].stiffness *= bend_scale;
            scene.params.wind = Some(Wind {
                velocity: wind.velocity * *wind_scale,
                ..wind
            });
            // Each flag is a model of its own: sizes and meshes may differ too.
            let model = scene.model()?;
            for &x in &model.rest_positions {
                (low, high) = (low.min(x), high.max(x));
            }
            ids.push(batch.add(&model, &scene.params)?);
        }
    }
    let steps = (seconds / flag.params.dt).round() as u32;
    let mut encoder = device.create_command_encoder(&Default::default());
    // Every flag's steps, one dispatch per step for all of them.
    batch.encode_steps(&mut encoder, steps);
    let dispatches = batch.dispatches_per_step();
    batch.encode_normals(&mut encoder);

    // A camera on the middle of the flags, backed off to show them all
    // (and the cloths blown out beyond their rest box).
    let (width, height) = SIZE;
    let radius = 0.4 * (high - low).length() as f32;
    let camera = Camera::orbit(
        ((low + high) / 2.0).as_vec3(),
        radius,
        width as f32 / height as f32,
    );
    let formats = RendererFormats::default();
    let renderer = Renderer::with_formats(device, queue, &flag.params, &camera, formats)?;
    let target = FrameTarget::with_formats(device, width, height, formats);
    {
        let mut pass = renderer.begin_pass(&mut encoder, &target.color_view, &target.depth_view);
        for &id in &ids {
            // Each flag from the shared buffers: its indices, its first vertex.
            renderer.draw_batch_cloth(&mut pass, &batch.draw_range(id)?);
        }
        renderer.draw_colliders(&mut pass);
    }
    queue.submit([encoder.finish()]);
    // Did every flag stay finite? One read-back for all of them.
    for (id, stats) in batch.check()? {
        println!("flag {}: {} steps", id.index(), stats.steps);
    }
    let rgba = render::read_rgba(device, queue, &target.color)?;
    render::write_png(&render::Frame {
        path: out.to_path_buf(),
        width,
        height,
        rgba,
    })?;
    Ok(dispatches)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A short run's simulated time [s]: enough for the flags to move off
    /// their rest plane, short enough for a test on lavapipe.
    const TEST_SECONDS: f64 = 0.1;
    /// Pixels of cloth the frame shows at least: the six flags cover
    /// 37 800 on lavapipe; without the first (partly hidden behind the
    /// others in this view) 34 600 remain, so a frame missing a flag stays
    /// below this.
    const MIN_CLOTH_PIXELS: usize = 35_000;

    /// The example runs on the test adapter: its six flags share one
    /// dispatch per step, and each is drawn from the batch's buffers.
    #[test]
    fn batch_draws_six_flags_from_one_dispatch() -> anyhow::Result<()> {
        let context = GpuContext::new(None).context("the example needs an adapter")?;
        let dir = std::env::temp_dir().join(format!("wgcloth-batch-{}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        let out = dir.join("batch.png");
        let dispatches = run(&context, &out, TEST_SECONDS)?;
        assert_eq!(dispatches, 1.0, "one workgroup kernel for all six flags");
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out)?));
        let mut reader = decoder.read_info()?;
        let mut rgba = vec![0; reader.output_buffer_size().context("PNG size")?];
        let info = reader.next_frame(&mut rgba)?;
        assert_eq!((info.width, info.height), SIZE);
        let cloth = rgba.chunks(4).filter(|p| *p != render::BACKGROUND).count();
        assert!(cloth >= MIN_CLOTH_PIXELS, "{cloth} pixels of cloth");
        std::fs::remove_dir_all(&dir)?;
        Ok(())
    }
}
