//! What `flag` and `drape` share: a built-in scene to PNG frames through the
//! library API (the same calls `wgcloth render` makes).

use std::ops::ControlFlow;
use std::path::PathBuf;

use wgcloth::gpu::GpuContext;
use wgcloth::render::{self, FrameOptions};
use wgcloth::Scene;

/// Renders the built-in scene `name` for `seconds` of simulated time at 30
/// frames/s, 640 × 480, into `out/NAME/` (replacing the frames there).
pub fn render_builtin(name: &str, seconds: f64) -> anyhow::Result<()> {
    const FPS: f64 = 30.0;
    let scene = Scene::builtin(name)?;
    let dir = PathBuf::from("out").join(name);
    std::fs::create_dir_all(&dir)?;
    render::remove_frames(&dir)?;
    let options = FrameOptions {
        width: 640,
        height: 480,
        frames: (seconds * FPS).round() as u32 + 1,
        steps_per_frame: render::steps_per_frame(FPS, scene.params.dt)?,
        dir: dir.clone(),
        strain: false,
    };
    let context = GpuContext::new(None)?;
    let written = render::render_scene(&context.device, &context.queue, &scene, &options, |_| {
        ControlFlow::Continue(())
    })?;
    println!("wrote {written} frames of `{name}` to {}", dir.display());
    Ok(())
}
