//! `wgcloth render`: simulate a scene on the GPU and write each frame as a
//! PNG (see "Rendering" in `docs/cli.md`). With no arguments at all, `wgcloth`
//! renders the `hanging` scene with these defaults.

use std::io::Write as _;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use wgcloth::atomic_file;
use wgcloth::gpu::{pipeline_cache, GpuContext};
use wgcloth::render::{self, FrameOptions};
use wgcloth::Scene;

use super::run::WHOLE_STEPS_TOLERANCE;
use super::{interrupt, RenderArgs, UsageError, DEFAULT_FPS};
use wgcloth::params::format_number;

/// Runs `wgcloth render`.
pub fn render(args: &RenderArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    interrupt::install();
    let mut scene = Scene::resolve(&args.scene)?;
    if let Some(integrator) = args.integrator {
        scene.params.integrator = integrator.into();
    }
    scene
        .params
        .validate()
        .context("the command-line options make the scene invalid")?;
    let steps_per_frame = frame_steps(args.fps, scene.params.dt)?;
    let mut context = GpuContext::new(args.adapter.as_deref())?;
    if let Some(dir) = pipeline_cache::default_dir() {
        context.keep_pipelines(&dir);
    }
    let (width, height) = args.size;
    // Before the output folder is touched.
    render::check_image(&context.device, width, height)
        .with_context(|| format!("--size {width}x{height}"))?;
    prepare_dir(&args.out, args.overwrite)?;
    let options = FrameOptions {
        width,
        height,
        frames: args.frames,
        steps_per_frame,
        dir: args.out.clone(),
        strain: args.strain,
    };
    note!(
        "rendering `{}` on {}: {} frames of {width}×{height}, {steps_per_frame} steps each",
        scene.name,
        context.describe(),
        args.frames,
    );
    let mut done = 0;
    let kernels = context.kernels();
    let written =
        render::render_scene_with_kernels(kernels, &context.queue, &scene, &options, |n| {
            done = n;
            progress(n, args.frames, started);
            if interrupt::requested() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
    note!("");
    if let Err(e) = context.save_pipelines() {
        note!("note: compiled pipelines not kept for the next run: {e}");
    }
    let written = match written.and_then(|n| context.check().map(|()| n)) {
        Err(wgcloth::Error::Interrupted) => {
            return Err(
                anyhow::Error::new(wgcloth::Error::Interrupted).context(format!(
                    "stopped after {done} of {} frames (every frame file in {} is whole)",
                    args.frames,
                    args.out.display()
                )),
            )
        }
        written => written?,
    };
    outln!(
        "wrote {written} frames to {} ({}…{}), {:.1} s simulated in {:.2} s",
        args.out.display(),
        render::frame_name(0),
        render::frame_name(written.saturating_sub(1)),
        f64::from(written.saturating_sub(1)) * f64::from(steps_per_frame) * scene.params.dt,
        started.elapsed().as_secs_f64(),
    )
}

/// Creates `dir` if needed. Frames of an earlier run are never mixed with
/// new ones: they are refused, or removed first with `--overwrite`, once
/// [`atomic_file::probe_dir`] has written in `dir` (so that a folder where
/// no frame can be written keeps its old ones).
fn prepare_dir(dir: &Path, overwrite: bool) -> anyhow::Result<()> {
    let old = render::existing_frames(dir)?;
    if !old.is_empty() {
        if !overwrite {
            return Err(UsageError(format!(
                "{} already holds {} frame file(s) (frame_*.png) from an earlier run; \
                 pass --overwrite to replace them, or choose another --out",
                dir.display(),
                old.len()
            ))
            .into());
        }
        atomic_file::probe_dir(dir)?;
        let removed = render::remove_frames(dir)
            .context("--overwrite removes only regular files, and removed none")?;
        note!(
            "--overwrite: removed {removed} old frame file(s) from {}",
            dir.display()
        );
    }
    std::fs::create_dir_all(dir).map_err(|source| wgcloth::Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    Ok(())
}

/// One `\r`-rewritten line on stderr: frames done and their rate.
fn progress(done: u32, total: u32, started: Instant) {
    let rate = f64::from(done) / started.elapsed().as_secs_f64().max(1e-9);
    let width = 30;
    let filled = (done as usize * width)
        .checked_div(total as usize)
        .unwrap_or(width);
    note_part!(
        "\r[{}{}] {done}/{total} frames, {rate:.1} frames/s",
        "#".repeat(filled),
        " ".repeat(width - filled)
    );
    let _ = std::io::stderr().flush();
}

/// `--size WxH`: two whole numbers ≥ 1.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT (e.g. 640x480), got `{s}`"))?;
    let side = |v: &str| -> Result<u32, String> {
        match v.trim().parse::<u32>() {
            Ok(n) if n >= 1 => Ok(n),
            _ => Err(format!("`{v}` is not a whole number of pixels ≥ 1")),
        }
    };
    Ok((side(w)?, side(h)?))
}

/// `--fps`: a finite number > 0.
pub fn parse_fps(s: &str) -> Result<f64, String> {
    let f: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if f.is_finite() && f > 0.0 {
        Ok(f)
    } else {
        Err(format!(
            "must be a finite number > 0 of frames per second, got {}",
            wgcloth::params::format_number(f)
        ))
    }
}

/// Steps per frame for `--fps fps` at time step `dt` \[s\] (`render`'s
/// frames, `run`'s character poses): [`render::steps_per_frame`], but an
/// `fps` above `1/dt` is refused, naming both, rather than its frames
/// drawn a step apart instead of `1/fps` apart. Without `--fps`:
/// [`DEFAULT_FPS`], or `1/dt` (a frame a step) for a longer step.
pub fn frame_steps(fps: Option<f64>, dt: f64) -> Result<u32, UsageError> {
    let fps = fps.unwrap_or(DEFAULT_FPS.min(1.0 / dt));
    if 1.0 / fps / dt < 1.0 - WHOLE_STEPS_TOLERANCE {
        return Err(UsageError(format!(
            "--fps: must be at most 1/dt = {} frames per second (dt = {} s: a frame is at \
             least one step), got {}",
            format_number(1.0 / dt),
            format_number(dt),
            format_number(fps)
        )));
    }
    render::steps_per_frame(fps, dt).map_err(|e| UsageError(format!("--fps: {e}")))
}

/// The default `--out`.
pub fn default_out() -> PathBuf {
    PathBuf::from("out")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("640x480"), Ok((640, 480)));
        assert_eq!(parse_size("8X6"), Ok((8, 6)));
        for bad in ["640", "0x10", "ax3", "-1x2"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_frame_is_at_least_a_step() {
        assert_eq!(frame_steps(Some(100.0), 0.01).ok(), Some(1));
        assert_eq!(frame_steps(Some(30.0), 0.001).ok(), Some(34));
        assert_eq!(frame_steps(None, 0.001).ok(), Some(34));
        assert_eq!(
            frame_steps(None, 0.1).ok(),
            Some(1),
            "a step longer than a frame"
        );
        let e = frame_steps(Some(1000.0), 0.01).expect_err("a frame shorter than a step");
        assert!(
            e.0.contains("at most 1/dt = 100 frames per second"),
            "{}",
            e.0
        );
        assert!(e.0.contains("got 1000"), "{}", e.0);
    }

    #[test]
    fn fps_must_be_positive() {
        assert_eq!(parse_fps("30"), Ok(30.0));
        for bad in ["0", "-1", "inf", "x"] {
            assert!(parse_fps(bad).is_err(), "{bad}");
        }
    }
}
