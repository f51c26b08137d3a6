//! A scene to numbered PNG frames: one submit per frame (its steps, its
//! normals, its render pass and the copy to a staging buffer), read back a
//! few frames behind the device and written by [`PngWriter`]'s thread.

use std::ops::ControlFlow;
use std::path::PathBuf;

use super::png_writer::{self, frame_name, Frame, PngWriter};
use super::{Camera, FrameTarget, Renderer, COLOR_FORMAT, DEPTH_FORMAT};
use crate::budget;
use crate::error::{Error, Result};
use crate::gpu::{guarded, readback, GpuKernels, GpuSolver, StepPath};
use crate::scene::animation::Animation;
use crate::scene::Scene;

/// Staging buffers in rotation, and so frames in flight between two status
/// checks: the device renders these while the writer encodes the previous
/// ones, and a blow-up is caught before any of them is written.
pub const STAGING_BUFFERS: usize = 3;

/// `wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`: a texture-to-buffer copy's rows
/// start at multiples of this many bytes.
const ROW_ALIGNMENT: u32 = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;

/// A quotient `(1/fps) / dt` within this relative distance of a whole
/// number counts as that number (1/30 s at dt = 1/120 s is 4 steps, not 5).
const WHOLE_STEPS_TOLERANCE: f64 = 1e-9;

/// Most steps one frame may record (one submit): bounds the command buffer.
pub const MAX_STEPS_PER_FRAME: u32 = 100_000;

/// What [`render_frames`] renders.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameOptions {
    /// Image width \[pixels\].
    pub width: u32,
    /// Image height \[pixels\].
    pub height: u32,
    /// Frames to write; frame `k` shows the cloth after `k` frame intervals.
    pub frames: u32,
    /// Solver steps between two frames (see [`steps_per_frame`]).
    pub steps_per_frame: u32,
    /// The folder the frames go to (it must exist).
    pub dir: PathBuf,
    /// [`render_scene`] only: colour the cloth by strain
    /// ([`Renderer::show_strain`]).
    pub strain: bool,
}

/// Steps per frame: `ceil((1/fps) / dt)`, so a frame covers at least
/// `1/fps` seconds (a quotient within 1e-9 of a whole number counts as it).
pub fn steps_per_frame(fps: f64, dt: f64) -> Result<u32> {
    let invalid = |allowed: &str, got: String| Error::InvalidParameter {
        key: "fps".into(),
        allowed: allowed.into(),
        got,
    };
    if !(fps.is_finite() && fps > 0.0) {
        return Err(invalid(
            "a finite number > 0 of frames per second",
            crate::params::format_number(fps),
        ));
    }
    let q = 1.0 / fps / dt;
    let steps = if (q - q.round()).abs() <= WHOLE_STEPS_TOLERANCE * q.round() {
        q.round()
    } else {
        q.ceil()
    };
    if steps > f64::from(MAX_STEPS_PER_FRAME) {
        return Err(invalid(
            &format!("at most {MAX_STEPS_PER_FRAME} steps per frame (1/fps ÷ dt)"),
            format!(
                "{} (dt = {} s: {} steps)",
                crate::params::format_number(fps),
                crate::params::format_number(dt),
                crate::params::format_number(steps)
            ),
        ));
    }
    Ok((steps as u32).max(1))
}

/// Renders `options.frames` frames of `solver` (which it steps) with
/// `renderer` into `options.dir`, calling `progress(done)` as each frame
/// is read back. The device's status and the divergence rule
/// ([`crate::diagnostics::Divergence`]) are checked every
/// [`STAGING_BUFFERS`] frames and at the last; a blow-up stops the run with
/// [`Error::NonFinite`] or [`Error::Diverged`] (naming the step) before the
/// frames rendered since the last good check are written. `progress` returning
/// [`ControlFlow::Break`] stops the run with [`Error::Interrupted`]: the
/// frames read back by then are written whole, no later one is started.
/// Returns the frames written. `renderer` must draw into [`COLOR_FORMAT`]
/// (the PNGs' byte order and encoding; its depth format may be any):
/// another is an [`Error::InvalidParameter`].
pub fn render_frames(
    device: &wgpu::Device,
    solver: &mut GpuSolver,
    renderer: &Renderer,
    options: &FrameOptions,
    progress: impl FnMut(u32) -> ControlFlow<()>,
) -> Result<u32> {
    render_animated_frames(device, solver, renderer, options, None, progress)
}

/// [`render_frames`] with `animation` (a scene's character) applied before
/// each frame's steps, as a game would: the colliders and pin targets of
/// the frame from its start time. Every frame draws the colliders where
/// they are at its end ([`GpuSolver::colliders`]).
pub fn render_animated_frames(
    device: &wgpu::Device,
    solver: &mut GpuSolver,
    renderer: &Renderer,
    options: &FrameOptions,
    animation: Option<&Animation>,
    progress: impl FnMut(u32) -> ControlFlow<()>,
) -> Result<u32> {
    render_filmed_frames(device, solver, renderer, options, animation, None, progress)
}

/// [`render_animated_frames`] with `camera_at(t)` the camera of the frame
/// at time `t` \[s\] (`None`: the renderer's camera throughout).
fn render_filmed_frames(
    device: &wgpu::Device,
    solver: &mut GpuSolver,
    renderer: &Renderer,
    options: &FrameOptions,
    animation: Option<&Animation>,
    camera_at: Option<&dyn Fn(f64) -> Option<Camera>>,
    mut progress: impl FnMut(u32) -> ControlFlow<()>,
) -> Result<u32> {
    let frame_seconds = f64::from(options.steps_per_frame) * solver.dt();
    let (width, height) = (options.width, options.height);
    let formats = renderer.formats();
    if formats.color != COLOR_FORMAT {
        return Err(Error::InvalidParameter {
            key: "RendererFormats::color".into(),
            allowed: format!("{COLOR_FORMAT:?} for PNG frames"),
            got: format!("{:?}", formats.color),
        });
    }
    let need = check_image(device, width, height)?;
    let row = padded_row(width);
    let (target, staging) = guarded(device, &image(width, height), Some(need), || {
        let staging: Vec<wgpu::Buffer> = (0..STAGING_BUFFERS)
            .map(|i| staging_buffer(device, &format!("wgcloth.render.staging{i}"), row, height))
            .collect();
        Ok((
            FrameTarget::with_formats(device, width, height, formats),
            staging,
        ))
    })?;
    let rule = solver.divergence_rule()?;
    let mut writer = PngWriter::spawn()?;
    let mut in_flight = Vec::with_capacity(STAGING_BUFFERS);
    for frame in 0..options.frames {
        let slot = frame as usize % STAGING_BUFFERS;
        let rx = guarded(device, &format!("rendering frame {frame}"), None, || {
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wgcloth.render.frame"),
            });
            if frame > 0 {
                if let Some(a) = animation {
                    a.apply(solver, f64::from(frame - 1) * frame_seconds, frame_seconds)?;
                }
                solver.encode_steps(&mut encoder, options.steps_per_frame);
            }
            let (spheres, capsules) = solver.colliders();
            renderer.set_colliders(&spheres, &capsules);
            if let Some(camera) = camera_at.and_then(|at| at(f64::from(frame) * frame_seconds)) {
                renderer.set_camera(&camera);
            }
            solver.encode_normals(&mut encoder);
            renderer.encode_frame(&mut encoder, solver, &target);
            copy_to_staging(&mut encoder, &target.color, &staging[slot], row);
            renderer.queue.submit([encoder.finish()]);
            let (tx, rx) = flume::bounded(1);
            staging[slot].map_async(wgpu::MapMode::Read, .., move |r| {
                let _ = tx.send(r);
            });
            Ok(rx)
        })?;
        in_flight.push((frame, slot, rx));
        if in_flight.len() < STAGING_BUFFERS && frame + 1 < options.frames {
            continue;
        }
        // Waits for the device; a blow-up (non-finite, or finite but past
        // a bound of the divergence rule) ends the run here, before the
        // frames in flight are written.
        solver.check()?;
        solver.check_divergence(&rule)?;
        for (frame, slot, rx) in in_flight.drain(..) {
            device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| Error::Gpu(format!("waiting for frame {frame}: {e}")))?;
            rx.recv()
                .map_err(|_| Error::Gpu(format!("frame {frame} was never mapped")))?
                .map_err(|e| Error::Gpu(format!("mapping frame {frame}: {e}")))?;
            let rgba = unpad(&staging[slot], row, width)
                .map_err(|e| Error::Gpu(format!("reading frame {frame}: {e}")))?;
            writer.send(Frame {
                path: options.dir.join(frame_name(frame)),
                width,
                height,
                rgba,
            })?;
            if progress(frame + 1).is_break() {
                // Dropping the writer writes the frames it was sent.
                return Err(Error::Interrupted);
            }
        }
    }
    writer.finish()
}

/// `the W×H image`, as errors name it.
fn image(width: u32, height: u32) -> String {
    format!("the {width}×{height} image")
}

/// Refuses, before anything is allocated, an image `device` cannot render
/// or the host cannot hold: a side beyond `max_texture_dimension_2d`, a
/// staging buffer beyond `max_buffer_size`, or more memory than the host
/// has (counting, on a CPU adapter, the device's: see
/// [`budget::host_need`]). Returns the device
/// bytes the image needs \[bytes\]: its colour and depth textures and
/// [`STAGING_BUFFERS`] staging buffers. The host holds, besides, the
/// frames queued for the PNG writer, the one it encodes and the one being
/// read back, `width × height × 4` bytes each.
pub fn check_image(device: &wgpu::Device, width: u32, height: u32) -> Result<u64> {
    let limits = device.limits();
    let max = limits.max_texture_dimension_2d;
    for (side, what) in [(width, "width"), (height, "height")] {
        if side == 0 || side > max {
            return Err(Error::DeviceLimit {
                what: format!("the image's {what} (pixels)"),
                limit: "max_texture_dimension_2d",
                available: max.into(),
                needed: side.into(),
            });
        }
    }
    let pixels = u64::from(width) * u64::from(height);
    let staging = u64::from(padded_row(width)) * u64::from(height);
    if staging > limits.max_buffer_size {
        return Err(Error::DeviceLimit {
            what: "a read-back of the image (bytes)".into(),
            limit: "max_buffer_size",
            available: limits.max_buffer_size,
            needed: staging,
        });
    }
    let texel = |format: wgpu::TextureFormat| u64::from(format.block_copy_size(None).unwrap_or(4));
    let device_bytes =
        pixels * (texel(COLOR_FORMAT) + texel(DEPTH_FORMAT)) + STAGING_BUFFERS as u64 * staging;
    let frames_on_host = (png_writer::QUEUE + 2) as u64;
    budget::check_gpu_host(device, frames_on_host * pixels * 4, device_bytes, || {
        image(width, height)
    })?;
    Ok(device_bytes)
}

/// Renders `scene` from its start: builds its model, a solver, a camera
/// that frames it (and follows a scene's character:
/// [`Camera::following`]) and a renderer on the host's device, then runs
/// [`render_frames`]. The image is checked ([`check_image`]) before the
/// scene is built.
pub fn render_scene(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    options: &FrameOptions,
    progress: impl FnMut(u32) -> ControlFlow<()>,
) -> Result<u32> {
    let kernels = GpuKernels::new(device);
    render_scene_with_kernels(&kernels, queue, scene, options, progress)
}

/// [`render_scene`] on the device of `kernels`, whose pipelines the solver
/// shares (see [`GpuSolver::with_kernels`]).
pub fn render_scene_with_kernels(
    kernels: &GpuKernels,
    queue: &wgpu::Queue,
    scene: &Scene,
    options: &FrameOptions,
    progress: impl FnMut(u32) -> ControlFlow<()>,
) -> Result<u32> {
    render_scene_on_path(kernels, queue, scene, options, None, progress)
}

/// [`render_scene_with_kernels`] with the solver on step path `path`
/// ([`GpuSolver::with_step_path`]), or the solver's own choice for `None`
/// (`wgcloth render --step-path`).
pub fn render_scene_on_path(
    kernels: &GpuKernels,
    queue: &wgpu::Queue,
    scene: &Scene,
    options: &FrameOptions,
    path: Option<StepPath>,
    progress: impl FnMut(u32) -> ControlFlow<()>,
) -> Result<u32> {
    let device = kernels.device();
    check_image(device, options.width, options.height)?;
    let model = scene.model()?;
    // Before the solver: a render mesh's vertex far from the cloth is
    // refused before anything is allocated on the device.
    let embeddings = scene.embeddings(&model)?;
    let mut solver = match path {
        Some(path) => GpuSolver::with_step_path(kernels, queue, &model, &scene.params, path)?,
        None => GpuSolver::with_kernels(kernels, queue, &model, &scene.params)?,
    };
    // Frames are recorded ahead of the checks that would adapt the CG
    // budget, and a step the budget cut short would differ from the one
    // the other step path and the CPU take: every step gets the full
    // budget (past convergence an iteration's dispatches are empty).
    solver.tuning_mut().set_adaptive_cg_budget(false);
    let aspect = options.width as f32 / options.height as f32;
    let camera = Camera::for_scene(scene, &model, aspect);
    let renderer = guarded(device, "building the renderer", None, || {
        let mut renderer = Renderer::new(device, queue, &scene.params, &camera);
        if options.strain {
            renderer.show_strain(device, &model, &solver);
        }
        renderer.set_embeddings(&solver, &embeddings)?;
        renderer.set_cloth_colors(device, &model, &scene.cloth_colors());
        Ok(renderer)
    })?;
    let animation = scene.animation(&model);
    // A moving character is followed (see `Camera::following`).
    let follow = |t: f64| Camera::following(scene, &model, aspect, t);
    render_filmed_frames(
        device,
        &mut solver,
        &renderer,
        options,
        animation.as_ref(),
        Some(&follow),
        progress,
    )
}

/// Reads `texture`'s colour back now (blocking): tightly packed rows of 4
/// bytes per pixel in the texture's own order (RGBA for [`COLOR_FORMAT`],
/// BGRA for a `Bgra8*` format), top row first; a format of another texel
/// size is an [`Error::InvalidParameter`]. For tests and one-off pictures
/// (it goes through [`crate::gpu::readback`], one more copy);
/// [`render_frames`] pipelines its read-backs instead.
pub fn read_rgba(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<Vec<u8>> {
    let format = texture.format();
    if format.block_copy_size(None) != Some(4) || format.block_dimensions() != (1, 1) {
        return Err(Error::InvalidParameter {
            key: "read_rgba texture format".into(),
            allowed: "a format of 4 bytes per pixel".into(),
            got: format!("{format:?}"),
        });
    }
    let (width, height) = (texture.width(), texture.height());
    let row = padded_row(width);
    let size = u64::from(row) * u64::from(height);
    let rows = guarded(device, "a read-back of the image", Some(size), || {
        let rows = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wgcloth.render.read_rgba"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("wgcloth.render.read_rgba"),
        });
        copy_to_staging(&mut encoder, texture, &rows, row);
        queue.submit([encoder.finish()]);
        Ok(rows)
    })?;
    let padded = readback::read_buffers(device, queue, &[(&rows, 0, rows.size())])?;
    Ok(strip_padding(&padded[0], row, width))
}

/// Bytes per row of a staging copy: `width × 4` rounded up to
/// [`ROW_ALIGNMENT`].
fn padded_row(width: u32) -> u32 {
    (width * 4).div_ceil(ROW_ALIGNMENT) * ROW_ALIGNMENT
}

fn staging_buffer(device: &wgpu::Device, label: &str, row: u32, height: u32) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: u64::from(row) * u64::from(height),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    })
}

fn copy_to_staging(
    encoder: &mut wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    staging: &wgpu::Buffer,
    row: u32,
) {
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(texture.height()),
            },
        },
        texture.size(),
    );
}

/// The mapped `staging` buffer's rows without their padding; unmaps it.
fn unpad(staging: &wgpu::Buffer, row: u32, width: u32) -> Result<Vec<u8>, wgpu::MapRangeError> {
    let rgba = strip_padding(&staging.get_mapped_range(..)?, row, width);
    staging.unmap();
    Ok(rgba)
}

/// `width` pixels of each `row`-byte row.
fn strip_padding(padded: &[u8], row: u32, width: u32) -> Vec<u8> {
    padded
        .chunks(row as usize)
        .flat_map(|r| &r[..width as usize * 4])
        .copied()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_covers_at_least_its_interval() {
        assert_eq!(steps_per_frame(30.0, 0.001).ok(), Some(34));
        assert_eq!(steps_per_frame(30.0, 1.0 / 120.0).ok(), Some(4));
        assert_eq!(steps_per_frame(1000.0, 0.01).ok(), Some(1));
        assert!(steps_per_frame(0.0, 0.01).is_err());
        assert!(steps_per_frame(f64::NAN, 0.01).is_err());
        assert!(steps_per_frame(1e-9, 0.01).is_err());
    }
}
