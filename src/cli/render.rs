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
    let mut scene = Scene::resolve_until(&args.scene, &interrupt::requested)?;
    if let Some(integrator) = args.integrator {
        scene.params.integrator = integrator.into();
    }
    scene
        .params
        .validate()
        .context("the command-line options make the scene invalid")?;
    let steps_per_frame = frame_steps(args.fps, scene.params.dt)?;
    let frame_seconds = f64::from(steps_per_frame) * scene.params.dt;
    let frames = match (args.frames, args.seconds) {
        (Some(n), _) => n,
        (None, Some(t)) => frames_for(t, frame_seconds, "--seconds")?,
        (None, None) => frames_for(scene.duration, frame_seconds, "the scene's duration")?,
    };
    let out = args.out.clone().unwrap_or_else(|| default_out(&scene.name));
    let mut context = GpuContext::new(args.adapter.as_deref())?;
    if let Some(dir) = pipeline_cache::default_dir() {
        context.keep_pipelines(&dir);
    }
    let (width, height) = args.size;
    // Before the output folder is touched.
    render::check_image(&context.device, width, height)
        .with_context(|| format!("--size {width}x{height}"))?;
    let created = missing_folders(&out);
    prepare_dir(&out, args.overwrite)?;
    let options = FrameOptions {
        width,
        height,
        frames,
        steps_per_frame,
        dir: out.clone(),
        strain: args.strain,
    };
    note!(
        "rendering `{}` on {}: {frames} frames of {width}×{height}, {steps_per_frame} steps each, \
         to {}",
        scene.name,
        context.describe(),
        out.display(),
    );
    let mut done = 0;
    let kernels = context.kernels();
    let mut rate = Rate::default();
    let written = render::render_scene_on_path(
        kernels,
        &context.queue,
        &scene,
        &options,
        args.step_path.forced(),
        |n| {
            done = n;
            progress(n, frames, rate.frames_per_second(n));
            if interrupt::requested() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        },
    );
    note!("");
    if let Err(e) = context.save_pipelines() {
        note!("note: compiled pipelines not kept for the next run: {e}");
    }
    let written = match written.and_then(|n| context.check().map(|()| n)) {
        Err(e) if done == 0 && !matches!(e, wgcloth::Error::Interrupted) => {
            // Refused before any frame (the solver or the image refused the
            // scene on this device): as a refusal before the device opened,
            // it leaves no folder behind.
            remove_empty(&created);
            return Err(e.into());
        }
        Err(wgcloth::Error::Interrupted) => {
            return Err(
                anyhow::Error::new(wgcloth::Error::Interrupted).context(format!(
                    "stopped after {done} of {frames} frames (every frame file in {} is whole)",
                    out.display()
                )),
            )
        }
        written => written?,
    };
    outln!(
        "wrote {written} frames to {} ({}…{}), {:.1} s simulated in {:.2} s",
        out.display(),
        render::frame_name(0),
        render::frame_name(written.saturating_sub(1)),
        f64::from(written.saturating_sub(1)) * f64::from(steps_per_frame) * scene.params.dt,
        started.elapsed().as_secs_f64(),
    )
}

/// The folders `dir` and its ancestors that do not exist yet, `dir`
/// first: what [`prepare_dir`] creates.
fn missing_folders(dir: &Path) -> Vec<std::path::PathBuf> {
    dir.ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .take_while(|a| a.symlink_metadata().is_err())
        .map(Path::to_path_buf)
        .collect()
}

/// Removes the folders of [`missing_folders`] again, deepest first, each
/// only while it is empty (`remove_dir` refuses a folder with anything in
/// it, so nothing a run wrote is lost).
fn remove_empty(created: &[std::path::PathBuf]) {
    for dir in created {
        if std::fs::remove_dir(dir).is_err() {
            break;
        }
    }
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

/// The frames since a frame was first read back, over the time since: a
/// running mean that settles, where frames per interval between two
/// read-backs jump (frames are read back a few at a time, and the first
/// waits for the pipelines).
#[derive(Default)]
struct Rate {
    /// The first frame read back, and when.
    first: Option<(u32, Instant)>,
}

impl Rate {
    /// The mean rate once `done` frames are read back [frames/s]; `None`
    /// until a second read-back gives an interval.
    fn frames_per_second(&mut self, done: u32) -> Option<f64> {
        let (first, since) = *self.first.get_or_insert((done, Instant::now()));
        let seconds = since.elapsed().as_secs_f64();
        (done > first && seconds >= RATE_SETTLES).then(|| f64::from(done - first) / seconds)
    }
}

/// The time a rate is measured over before it is shown [s]: frames are
/// read back a few at a time, so a rate over the first few milliseconds
/// says how many came back together, not how fast they are made.
const RATE_SETTLES: f64 = 0.5;

/// One `\r`-rewritten line on stderr: frames done and their rate.
fn progress(done: u32, total: u32, rate: Option<f64>) {
    let width = 30;
    let filled = (done as usize * width)
        .checked_div(total as usize)
        .unwrap_or(width);
    let rate = rate.map_or(String::new(), |r| format!(", {r:.1} frames/s"));
    note_part!(
        "\r[{}{}] {done}/{total} frames{rate}   ",
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

/// The default `--out`: `out/<scene>`, so that rendering another scene
/// after the quick start finds a folder of its own.
pub fn default_out(scene: &str) -> PathBuf {
    Path::new("out").join(scene)
}

/// The frames that cover `seconds` at `frame_seconds` a frame: frame 0 and
/// those up to the first at or after `seconds`. `what` names the source in
/// the error.
fn frames_for(seconds: f64, frame_seconds: f64, what: &str) -> Result<u32, UsageError> {
    let intervals = super::run::whole_ceil(seconds / frame_seconds);
    if intervals.is_nan() || intervals >= f64::from(u32::MAX) {
        return Err(UsageError(format!(
            "{what}: {} s at {} s a frame is more than {} frames",
            wgcloth::params::format_number(seconds),
            wgcloth::params::format_number(frame_seconds),
            u32::MAX
        )));
    }
    Ok(intervals as u32 + 1)
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
    fn frames_cover_the_time_asked() {
        // 2 s at 1/30 s a frame: frames 0 to 60, the last at t = 2 s.
        assert_eq!(frames_for(2.0, 1.0 / 30.0, "t").ok(), Some(61));
        // A time between frames takes the next frame.
        assert_eq!(frames_for(0.05, 0.034, "t").ok(), Some(3));
        assert_eq!(frames_for(0.0, 0.034, "t").ok(), Some(1));
        let e = frames_for(1e300, 0.034, "--seconds").err().map(|e| e.0);
        assert!(
            e.as_deref().is_some_and(|e| e.starts_with("--seconds")),
            "{e:?}"
        );
    }

    #[test]
    fn the_frame_rate_is_a_mean_since_the_first_frame() {
        let mut rate = Rate::default();
        assert_eq!(
            rate.frames_per_second(3),
            None,
            "one read-back: no interval"
        );
        assert_eq!(rate.frames_per_second(5), None, "too soon to say");
        std::thread::sleep(std::time::Duration::from_secs_f64(RATE_SETTLES));
        let r = rate.frames_per_second(6);
        // 3 frames in at least RATE_SETTLES: at most 6 frames/s.
        assert!(
            r.is_some_and(|r| r > 0.0 && r <= 3.0 / RATE_SETTLES),
            "{r:?}"
        );
    }

    #[test]
    fn fps_must_be_positive() {
        assert_eq!(parse_fps("30"), Ok(30.0));
        for bad in ["0", "-1", "inf", "x"] {
            assert!(parse_fps(bad).is_err(), "{bad}");
        }
    }
}
