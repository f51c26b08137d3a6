//! Shared by the benches: the benchmark scene.

use std::time::{Duration, Instant};

use wgcloth::glam::DVec3;
use wgcloth::gpu::{GpuContext, GpuSolver};
use wgcloth::params::Integrator;
use wgcloth::Scene;

/// The `hanging` scene grown to `n × n` particles at constant particle
/// spacing and mass — every size has the same local dynamics and stays
/// stable at the same dt — without its ground (nothing to land on while
/// timing), for `integrator`: the scene's dt for explicit, the article's
/// 0.02 s for the other two.
pub fn grown_hanging(integrator: Integrator, n: usize) -> Scene {
    let Ok(mut scene) = Scene::builtin("hanging") else {
        panic!("the hanging scene is built in");
    };
    let grow = (n - 1) as f64 / (scene.cloth.nx - 1) as f64;
    scene.cloth.size = scene.cloth.size.map(|s| s * grow);
    scene.cloth.origin = DVec3::new(-scene.cloth.size[0] / 2.0, 1.0, -scene.cloth.size[1] / 2.0);
    scene.cloth.mass *= (n * n) as f64 / (scene.cloth.nx * scene.cloth.ny) as f64;
    scene.cloth.nx = n;
    scene.cloth.ny = n;
    scene.params.ground = None;
    scene.params.integrator = integrator;
    if integrator != Integrator::Explicit {
        scene.params.dt = 0.02;
    }
    scene
}

/// Wall time of `steps` GPU steps recorded into one encoder, one submit,
/// then a wait: criterion's `iter_custom` body for a GPU step.
#[allow(dead_code, reason = "cpu_step times no GPU")]
pub fn submit_and_wait(ctx: &GpuContext, g: &mut GpuSolver, steps: u64) -> Duration {
    let t = Instant::now();
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    g.encode_steps(&mut encoder, steps as u32);
    ctx.queue.submit([encoder.finish()]);
    if let Err(e) = ctx.device.poll(wgpu::PollType::wait_indefinitely()) {
        panic!("poll: {e}");
    }
    t.elapsed()
}
