//! The window's state and what the keys and the mouse do to it: the
//! camera, the grab, pause and single steps, the integrator switch.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::bail;
use winit::event::{ElementState, MouseButton};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::{Key, NamedKey};
use winit::window::Window;

use wgcloth::glam::Vec2;
use wgcloth::render::{self, Camera};
use wgcloth::Integrator;

use crate::host::Host;
use crate::orbit::Orbit;
use crate::pick::{self, Ray};
use crate::sim::Sim;
use crate::FPS;

/// How far from the cursor's ray a particle can be grabbed [fraction of
/// the scene's framing radius]: 3.5 cm on `hanging`, about one of its
/// particle spacings.
const PICK_RADIUS: f32 = 0.04;
/// How often the title's rates are refreshed.
const TITLE_EVERY: Duration = Duration::from_millis(500);

/// The mouse's left or right button held: turning the camera or dragging
/// a particle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Held {
    /// The camera turns with the mouse.
    Turning,
    /// A particle follows the cursor.
    Dragging,
}

/// A window with its device and cloth.
pub struct View {
    window: Arc<Window>,
    host: Host,
    sim: Sim,
    orbit: Orbit,
    camera: Camera,
    cursor: Vec2,
    held: Option<Held>,
    paused: bool,
    /// Frames to step while paused (the step key).
    single_steps: u32,
    /// Why the cloth stopped, shown in the title.
    stopped: Option<String>,
    frames: u32,
    /// Frames and solver steps since the title was refreshed.
    rate: (Instant, u32, u64),
}

impl View {
    /// The view of `sim` in `window`, from the scene's own camera.
    pub fn new(window: Arc<Window>, host: Host, sim: Sim) -> View {
        let orbit = Orbit::of(&sim.scene, sim.model(), host.aspect());
        let camera = orbit.camera(&sim.scene, sim.model(), host.aspect());
        View {
            window,
            host,
            sim,
            orbit,
            camera,
            cursor: Vec2::ZERO,
            held: None,
            paused: false,
            single_steps: 0,
            stopped: None,
            frames: 0,
            rate: (Instant::now(), 0, 0),
        }
    }

    /// The window.
    pub fn window(&self) -> &Window {
        &self.window
    }

    /// Frames shown so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// The window's size changed to `width` × `height` \[pixels\].
    pub fn resize(&mut self, width: u32, height: u32) {
        self.host.resize(width, height);
        self.refresh_camera();
    }

    /// The wheel turned by `notches` (> 0: away from the user, zooming in).
    pub fn zoom(&mut self, notches: f32) {
        self.orbit.zoom(notches);
        self.refresh_camera();
    }

    /// Steps and draws one frame (see [`Host::frame`]).
    pub fn frame(&mut self, screenshot: Option<&Path>) -> anyhow::Result<bool> {
        let run = self.stopped.is_none() && (!self.paused || self.single_steps > 0);
        let steps = if run {
            render::steps_per_frame(FPS, self.sim.dt())?
        } else {
            0
        };
        if !self
            .host
            .frame(&mut self.sim, &self.camera, steps, screenshot)?
        {
            return Ok(false);
        }
        self.frames += 1;
        if run {
            self.single_steps = self.single_steps.saturating_sub(1);
            if let Err(e) = self.sim.check_now_and_then() {
                self.stopped = Some(e.to_string());
            }
        }
        self.rate.1 += 1;
        self.rate.2 += u64::from(steps);
        self.title();
        Ok(true)
    }

    /// Scene, integrator, rates and state in the window's title.
    fn title(&mut self) {
        let (since, frames, steps) = self.rate;
        let seconds = since.elapsed();
        if seconds < TITLE_EVERY {
            return;
        }
        let s = seconds.as_secs_f64();
        let state = match (&self.stopped, self.paused) {
            (Some(why), _) => format!(" — stopped: {why} (R starts over)"),
            (None, true) => " — paused".to_string(),
            (None, false) => String::new(),
        };
        self.window.set_title(&format!(
            "{} — {} — {:.0} fps — {:.0} steps/s{state}",
            self.sim.scene.name,
            self.sim.scene.params.integrator,
            f64::from(frames) / s,
            steps as f64 / s,
        ));
        self.rate = (Instant::now(), 0, 0);
    }

    /// A key was pressed: quit, pause, step, reset or switch integrators.
    pub fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) -> anyhow::Result<()> {
        let integrator = |i| Some(i);
        let switch = match key.as_ref() {
            Key::Named(NamedKey::Escape) => {
                event_loop.exit();
                None
            }
            Key::Named(NamedKey::Space) => {
                self.paused = !self.paused;
                None
            }
            Key::Character(c) => match c.to_lowercase().as_str() {
                "." | "n" => {
                    self.paused = true;
                    self.single_steps += 1;
                    None
                }
                "r" => {
                    self.held = None;
                    self.stopped = None;
                    self.sim.reset()?;
                    None
                }
                "1" => integrator(Integrator::Explicit),
                "2" => integrator(Integrator::Implicit),
                "3" => integrator(Integrator::SemiImplicit),
                _ => None,
            },
            _ => None,
        };
        if let Some(i) = switch.filter(|i| *i != self.sim.scene.params.integrator) {
            // A scene the new integrator refuses keeps running as it was.
            match self.sim.switch(i) {
                Ok(()) => self.stopped = None,
                Err(e) => eprintln!("staying with {}: {e:#}", self.sim.scene.params.integrator),
            }
        }
        // Show the change at once.
        self.rate.0 = self.rate.0.checked_sub(TITLE_EVERY).unwrap_or(self.rate.0);
        Ok(())
    }

    /// A mouse button went down or up: a left press on the cloth grabs it,
    /// anywhere else (or a right press) turns the camera.
    pub fn button(&mut self, button: MouseButton, state: ElementState) -> anyhow::Result<()> {
        match (button, state) {
            (MouseButton::Left, ElementState::Pressed) if self.held.is_none() => {
                self.held = Some(if self.grab_at(self.cursor)? {
                    Held::Dragging
                } else {
                    Held::Turning
                });
            }
            (MouseButton::Right, ElementState::Pressed) if self.held.is_none() => {
                self.held = Some(Held::Turning);
            }
            (MouseButton::Left | MouseButton::Right, ElementState::Released) => self.let_go()?,
            _ => {}
        }
        Ok(())
    }

    /// Ends a turn or a drag: a dragged particle is released.
    fn let_go(&mut self) -> anyhow::Result<()> {
        if self.held.take() == Some(Held::Dragging) {
            self.sim.release()?;
        }
        Ok(())
    }

    /// The cursor moved to `cursor` \[pixels\]: turns the camera or drags
    /// the held particle.
    pub fn cursor_to(&mut self, cursor: Vec2) -> anyhow::Result<()> {
        let moved = cursor - self.cursor;
        self.cursor = cursor;
        match self.held {
            Some(Held::Turning) => {
                self.orbit.turn(moved);
                self.refresh_camera();
            }
            Some(Held::Dragging) => self.drag_to_cursor(),
            None => {}
        }
        Ok(())
    }

    /// Picks the particle under `pixel` (one read-back of the positions)
    /// and holds it; `false` if none is near enough or the cloth blew up.
    fn grab_at(&mut self, pixel: Vec2) -> anyhow::Result<bool> {
        let Some(ray) = self.ray(pixel) else {
            return Ok(false);
        };
        let positions = match self.sim.positions() {
            Ok(positions) => positions,
            Err(e) => {
                // The state stopped being finite since the last check.
                self.stopped = Some(e.to_string());
                return Ok(false);
            }
        };
        let Some(p) = pick::nearest(&positions, &ray, PICK_RADIUS * self.camera.radius) else {
            return Ok(false);
        };
        self.sim.grab(p, positions[p]);
        Ok(true)
    }

    /// Moves the held particle's target under the cursor, at the depth it
    /// was grabbed at.
    fn drag_to_cursor(&mut self) {
        let forward = (self.camera.target - self.camera.eye).normalize_or_zero();
        let Some(grab) = self.sim.grab else {
            return;
        };
        if let Some(target) = self
            .ray(self.cursor)
            .and_then(|ray| pick::drag_target(&ray, grab.target, forward))
        {
            self.sim.pull_to(target);
        }
    }

    /// The `--drag` script at `frame` of `frames`: press at `from`, move
    /// towards `to` over the first half, then hold.
    pub fn scripted_drag(
        &mut self,
        frame: u32,
        frames: u32,
        from: Vec2,
        to: Vec2,
    ) -> anyhow::Result<()> {
        if frame == 0 {
            self.cursor = from;
            self.button(MouseButton::Left, ElementState::Pressed)?;
            if self.held != Some(Held::Dragging) {
                bail!("--drag: no particle under pixel {},{}", from.x, from.y);
            }
        }
        let t = (frame as f32 / (frames / 2).max(1) as f32).min(1.0);
        self.cursor_to(from.lerp(to, t))
    }

    fn ray(&self, pixel: Vec2) -> Option<Ray> {
        let (w, h) = self.host.size();
        Ray::through_pixel(&self.camera.view_proj, pixel, Vec2::new(w as f32, h as f32))
    }

    fn refresh_camera(&mut self) {
        self.camera = self
            .orbit
            .camera(&self.sim.scene, self.sim.model(), self.host.aspect());
    }
}
