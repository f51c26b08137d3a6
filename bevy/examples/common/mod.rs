//! What the examples share: their command line (`--frames N`,
//! `--screenshot FILE.png`, `--headless`), the capture that writes the
//! last frame with Bevy's screenshot API and exits, and an orbit camera.
//!
//! `--headless` runs with no window and no display (no winit: Bevy's
//! schedule runner drives the frames): each camera renders into an
//! offscreen image of the window's size, the screenshot is taken of it,
//! and each frame waits for the device to finish it, so a frame's time is
//! its whole work (with a window, the swap chain's presents pace it).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context};
use bevy::app::ScheduleRunnerPlugin;
use bevy::camera::RenderTarget;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::input::mouse::{AccumulatedMouseMotion, AccumulatedMouseScroll};
use bevy::prelude::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::render::{Render, RenderApp, RenderSystems};
use bevy::window::{ExitCondition, PresentMode, WindowResolution};
use bevy::winit::WinitPlugin;

/// The window's size \[pixels\] (the screenshot's).
pub const WINDOW: (u32, u32) = (640, 480);

/// The shared part of an example's command line.
#[derive(Resource, Clone, Debug, Default)]
pub struct Capture {
    /// Frames to render before exiting (`None`: run until closed).
    pub frames: Option<u32>,
    /// Where the last frame goes.
    pub screenshot: Option<PathBuf>,
    /// No window (`--headless`): the cameras render offscreen.
    pub headless: bool,
}

impl Capture {
    /// Takes `--frames N` and `--screenshot FILE.png` from `args`, and
    /// hands every other argument to `other` (which returns whether it
    /// knew it, taking its value from the iterator).
    pub fn parse(
        args: impl IntoIterator<Item = String>,
        mut other: impl FnMut(&str, &mut dyn Iterator<Item = String>) -> anyhow::Result<bool>,
    ) -> anyhow::Result<Capture> {
        let mut capture = Capture::default();
        let mut args = args.into_iter();
        while let Some(arg) = args.next() {
            match arg.as_str() {
                "--frames" => {
                    let n = Context::context(args.next(), "--frames needs a number of frames")?;
                    let n: u32 = Context::with_context(n.parse::<u32>(), || {
                        format!("--frames {n}: a whole number ≥ 1")
                    })?;
                    if n == 0 {
                        bail!("--frames 0: a whole number ≥ 1");
                    }
                    capture.frames = Some(n);
                }
                "--screenshot" => {
                    let path = Context::context(args.next(), "--screenshot needs a FILE.png")?;
                    if !path.ends_with(".png") {
                        bail!("--screenshot {path}: the file must end in .png");
                    }
                    capture.screenshot = Some(PathBuf::from(path));
                }
                "--headless" => capture.headless = true,
                _ => {
                    if !other(&arg, &mut args)? {
                        bail!("unknown argument {arg:?}");
                    }
                }
            }
        }
        if capture.screenshot.is_some() && capture.frames.is_none() {
            bail!("--screenshot needs --frames N (the frame to capture)");
        }
        if capture.headless && capture.frames.is_none() {
            bail!("--headless needs --frames N (a run with no window ends by itself)");
        }
        Ok(capture)
    }

    /// Bevy's default plugins with the examples' window: a fixed size, and
    /// no vsync when capturing (frames as fast as they render); headless,
    /// no window and Bevy's schedule runner in a loop with no wait.
    pub fn default_plugins(&self, title: &str) -> bevy::app::PluginGroupBuilder {
        if self.headless {
            return DefaultPlugins
                .set(WindowPlugin {
                    primary_window: None,
                    exit_condition: ExitCondition::DontExit,
                    ..default()
                })
                .disable::<WinitPlugin>()
                .add(ScheduleRunnerPlugin::run_loop(Duration::ZERO));
        }
        DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: title.into(),
                resolution: WindowResolution::new(WINDOW.0, WINDOW.1),
                resizable: false,
                present_mode: if self.frames.is_some() {
                    PresentMode::AutoNoVsync
                } else {
                    PresentMode::AutoVsync
                },
                ..default()
            }),
            ..default()
        })
    }
}

/// Frames rendered so far, and whether the capture is written.
#[derive(Resource, Default, Debug)]
pub struct Frames {
    /// Frames whose `Update` has run.
    pub count: u32,
    /// The screenshot was asked for.
    asked: bool,
    /// It was written (or failed: `Some(false)`).
    written: Option<bool>,
}

/// The offscreen image the cameras render into with `--headless`.
#[derive(Resource, Clone, Debug)]
struct Offscreen(Handle<Image>);

/// Adds the capture: counting frames, asking for the screenshot at the
/// last one, and exiting once it is written (or at once without one);
/// headless, the offscreen target and the wait for each frame.
pub fn add_capture(app: &mut App, capture: Capture) {
    if capture.headless {
        let image = Image::new_target_texture(
            WINDOW.0,
            WINDOW.1,
            bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb,
            None,
        );
        let handle = app.world_mut().resource_mut::<Assets<Image>>().add(image);
        app.insert_resource(Offscreen(handle))
            .add_systems(PostStartup, target_offscreen);
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.add_systems(Render, wait_for_frame.in_set(RenderSystems::Cleanup));
        }
    }
    app.insert_resource(capture)
        .init_resource::<Frames>()
        .add_systems(Last, finish_capture);
}

/// Points every camera at the offscreen image.
fn target_offscreen(
    mut commands: Commands,
    offscreen: Res<Offscreen>,
    cameras: Query<Entity, With<Camera>>,
) {
    for camera in &cameras {
        commands
            .entity(camera)
            .insert(RenderTarget::from(offscreen.0.clone()));
    }
}

/// Waits for the device to finish the frame just submitted: with no swap
/// chain, nothing else keeps the frames from running ahead of the device.
fn wait_for_frame(device: Res<RenderDevice>) {
    if let Err(e) = device
        .wgpu_device()
        .poll(bevy::render::render_resource::PollType::wait_indefinitely())
    {
        error!("waiting for the frame: {e}");
    }
}

fn finish_capture(
    mut commands: Commands,
    capture: Res<Capture>,
    offscreen: Option<Res<Offscreen>>,
    mut frames: ResMut<Frames>,
    mut exit: MessageWriter<AppExit>,
) {
    frames.count += 1;
    let Some(last) = capture.frames else {
        return;
    };
    if let Some(written) = frames.written {
        exit.write(if written {
            AppExit::Success
        } else {
            AppExit::error()
        });
        return;
    }
    if frames.count < last {
        return;
    }
    let Some(path) = capture.screenshot.clone() else {
        exit.write(AppExit::Success);
        return;
    };
    if !frames.asked {
        frames.asked = true;
        let screenshot = match &offscreen {
            Some(image) => Screenshot::image(image.0.clone()),
            None => Screenshot::primary_window(),
        };
        commands.spawn(screenshot).observe(
            move |captured: On<ScreenshotCaptured>, mut frames: ResMut<Frames>| {
                let written = save(&captured.image, &path);
                if let Err(e) = &written {
                    error!("{e:#}");
                } else {
                    info!("wrote {}", path.display());
                }
                frames.written = Some(written.is_ok());
            },
        );
    }
}

/// Writes `image` as an RGBA PNG at `path` (wgcloth's writer: whole files
/// only, errors naming the path).
fn save(image: &Image, path: &std::path::Path) -> anyhow::Result<()> {
    let rgba = image
        .clone()
        .try_into_dynamic()
        .map_err(|e| anyhow::anyhow!("the screenshot's format: {e}"))?
        .to_rgba8();
    let (width, height) = rgba.dimensions();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Context::with_context(std::fs::create_dir_all(dir), || {
            format!("creating {}", dir.display())
        })?;
    }
    wgcloth::render::write_png(&wgcloth::render::Frame {
        path: path.to_path_buf(),
        width,
        height,
        rgba: rgba.into_raw(),
    })?;
    Ok(())
}

/// An orbit camera around a target: left-drag turns it, the wheel zooms.
#[derive(Component, Clone, Copy, Debug)]
pub struct Orbit {
    /// The point it looks at \[m\].
    pub target: Vec3,
    /// Distance from the target \[m\].
    pub distance: f32,
    /// Angle above the horizon \[rad\].
    pub elevation: f32,
    /// Angle about +y from +z \[rad\].
    pub azimuth: f32,
}

impl Orbit {
    /// The camera's transform.
    pub fn transform(&self) -> Transform {
        let (sin_e, cos_e) = self.elevation.sin_cos();
        let (sin_a, cos_a) = self.azimuth.sin_cos();
        let eye = self.target + self.distance * Vec3::new(cos_e * sin_a, sin_e, cos_e * cos_a);
        Transform::from_translation(eye).looking_at(self.target, Vec3::Y)
    }

    /// A camera entity's components for this orbit: ACES tone mapping
    /// (Bevy's default needs look-up tables this crate's features leave
    /// out).
    pub fn camera(self) -> impl Bundle {
        (
            Camera3d::default(),
            Tonemapping::AcesFitted,
            self.transform(),
            self,
        )
    }
}

/// Turns and zooms every [`Orbit`] camera with the mouse.
pub fn orbit_with_mouse(
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    scroll: Res<AccumulatedMouseScroll>,
    mut cameras: Query<(&mut Orbit, &mut Transform)>,
) {
    /// Radians per pixel dragged.
    const TURN: f32 = 0.005;
    /// Zoom factor per scroll unit.
    const ZOOM: f32 = 0.9;
    for (mut orbit, mut transform) in &mut cameras {
        if buttons.pressed(MouseButton::Left) {
            orbit.azimuth -= motion.delta.x * TURN;
            orbit.elevation = (orbit.elevation + motion.delta.y * TURN).clamp(-1.4, 1.4);
        }
        if scroll.delta.y != 0.0 {
            orbit.distance = (orbit.distance * ZOOM.powf(scroll.delta.y)).clamp(0.5, 50.0);
        }
        *transform = orbit.transform();
    }
}
