//! A live window on a scene: the GPU cloth embedded as a game embeds it
//! (see `docs/embedding.md`), with a camera to turn, the cloth to grab and
//! drag, and the integrators to switch between while it runs.
//!
//! `cargo run --release --example viewer [SCENE]` (a built-in name or a
//! scene file; default `hanging`). Controls: left-drag the cloth to pull
//! it, left-drag elsewhere or right-drag to turn the camera, the wheel to
//! zoom, space to pause, `.` or N to step one frame, 1/2/3 for the
//! explicit/implicit/semi-implicit integrator, R to start over, Esc to
//! quit. `--frames N --screenshot FILE.png` runs N frames and saves the
//! last (headless under Xvfb, for tests and CI); `--drag X0,Y0:X1,Y1`
//! pulls the cloth from one pixel to another over the first half of them.

mod handover;
mod host;
mod orbit;
mod pick;
mod sim;
mod view;

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context as _;
use clap::Parser;
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, KeyEvent, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use wgcloth::glam::Vec2;
use wgcloth::Scene;

use host::Host;
use view::View;

/// Frame rate the cloth is stepped for [frames/s]: each frame advances it
/// 1/FPS seconds of simulated time (a slower device shows slow motion).
const FPS: f64 = 60.0;
/// The window's starting size \[pixels\].
const WINDOW: (u32, u32) = (800, 600);
/// Pixels one wheel "line" counts as, for touchpads that scroll in pixels.
const PIXELS_PER_NOTCH: f32 = 40.0;

/// The viewer's command line.
#[derive(Parser, Debug)]
#[command(about = "A live window on a wgcloth scene")]
struct Options {
    /// A built-in scene name or a scene file.
    #[arg(default_value = "hanging")]
    scene: String,
    /// Run this many frames (at least 1), then quit.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// Save the last frame as a PNG here (needs --frames).
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Pull the cloth from pixel X0,Y0 to X1,Y1 over the first half of the
    /// frames, and hold it there (needs --frames).
    #[arg(long, requires = "frames", value_parser = parse_drag, value_name = "X0,Y0:X1,Y1")]
    drag: Option<(Vec2, Vec2)>,
    /// Take the screenshot from the frame redrawn offscreen, even where
    /// the swap chain can be copied (the fallback path, for its test).
    #[arg(long, hide = true, requires = "screenshot")]
    offscreen_screenshot: bool,
}

/// `X0,Y0:X1,Y1` in pixels.
fn parse_drag(text: &str) -> Result<(Vec2, Vec2), String> {
    let point = |p: &str| -> Option<Vec2> {
        let (x, y) = p.split_once(',')?;
        let v = Vec2::new(x.trim().parse().ok()?, y.trim().parse().ok()?);
        v.is_finite().then_some(v)
    };
    text.split_once(':')
        .and_then(|(a, b)| Some((point(a)?, point(b)?)))
        .ok_or_else(|| format!("`{text}` is not X0,Y0:X1,Y1 (pixels, e.g. 400,200:600,250)"))
}

fn main() -> anyhow::Result<()> {
    // Before any thread exists: quiets Mesa's complaint about an unset
    // XDG_RUNTIME_DIR (Linux hosts).
    wgcloth::gpu::quiet_mesa();
    let options = Options::parse();
    let scene = Scene::resolve(&options.scene)?;
    let event_loop = EventLoop::new().context(
        "opening the window system (on Linux: is DISPLAY set? headless, run under xvfb-run)",
    )?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        options,
        scene,
        view: None,
        error: None,
    };
    event_loop.run_app(&mut app)?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// The application: its options until the window exists, then the view.
struct App {
    options: Options,
    scene: Scene,
    view: Option<View>,
    /// What stopped it.
    error: Option<anyhow::Error>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.view.is_some() {
            return;
        }
        match self.open(event_loop) {
            Ok(view) => self.view = Some(view),
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(view) = self.view.as_mut() else {
            return;
        };
        let result = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                Ok(())
            }
            WindowEvent::Resized(size) => {
                view.resize(size.width, size.height);
                Ok(())
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key,
                        state: ElementState::Pressed,
                        ..
                    },
                ..
            } => view.key(event_loop, &logical_key),
            WindowEvent::CursorMoved { position, .. } => {
                view.cursor_to(Vec2::new(position.x as f32, position.y as f32))
            }
            WindowEvent::MouseInput { state, button, .. } => view.button(button, state),
            WindowEvent::MouseWheel { delta, .. } => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(PhysicalPosition { y, .. }) => {
                        y as f32 / PIXELS_PER_NOTCH
                    }
                };
                view.zoom(notches);
                Ok(())
            }
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.fail(event_loop, e);
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(view) = &self.view {
            view.window().request_redraw();
        }
    }
}

impl App {
    fn open(&self, event_loop: &ActiveEventLoop) -> anyhow::Result<View> {
        let attributes = Window::default_attributes()
            .with_title("wgcloth viewer")
            .with_inner_size(PhysicalSize::new(WINDOW.0, WINDOW.1));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .context("opening the window")?,
        );
        let (host, sim) = Host::new(
            Arc::clone(&window),
            &self.scene,
            self.options.offscreen_screenshot,
        )?;
        if self.options.screenshot.is_some() {
            host.check_screenshot()?;
        }
        println!(
            "{} on {} (screenshots {})",
            self.scene.name,
            host.adapter,
            if host.copies_swap_chain() {
                "copy the swap chain"
            } else {
                "redraw offscreen"
            }
        );
        Ok(View::new(window, host, sim))
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let Some(view) = self.view.as_mut() else {
            return Ok(());
        };
        let frames = view.frames();
        let last = self.options.frames.is_some_and(|n| frames + 1 >= n);
        if let Some((from, to)) = self.options.drag {
            view.scripted_drag(frames, self.options.frames.unwrap_or(1), from, to)?;
        }
        let screenshot = self.options.screenshot.as_deref().filter(|_| last);
        if view.frame(screenshot)? && last {
            if let Some(path) = screenshot {
                println!("wrote {} after {} frames", path.display(), view.frames());
            }
            event_loop.exit();
        }
        Ok(())
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }
}
