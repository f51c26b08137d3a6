//! The viewer's camera: the scene's own framing, turned around its target
//! by dragging and moved in and out by the wheel. It goes through the
//! scene's `[camera]` choices (`Camera::for_scene`), so it frames exactly
//! what `wgcloth render` does until the user moves it.

use wgcloth::glam::Vec2;
use wgcloth::render::Camera;
use wgcloth::{Model, Scene};

/// How far one pixel of drag turns the camera \[deg/pixel\]: a drag across
/// an 800-pixel window turns it 200°.
const DEGREES_PER_PIXEL: f32 = 0.25;
/// How much one notch of the wheel moves the eye in or out [fraction of
/// the distance]: ten notches halve or double it, give or take.
const ZOOM_PER_NOTCH: f32 = 0.07;
/// The eye stays this far below the pole \[deg\]: the scene format allows
/// elevations up to ±89°.
const MAX_ELEVATION: f32 = 89.0;
/// The nearest the eye comes to the target [fraction of the starting
/// distance], and the farthest (as a multiple of it).
const ZOOM_RANGE: (f32, f32) = (0.05, 20.0);

/// Angles \[deg\] and distance \[m\] of the eye around the scene's target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    elevation: f32,
    azimuth: f32,
    distance: f32,
    start_distance: f32,
}

impl Orbit {
    /// Where the scene's camera starts.
    pub fn of(scene: &Scene, model: &Model, aspect: f32) -> Orbit {
        let camera = Camera::for_scene(scene, model, aspect);
        let offset = camera.eye - camera.target;
        let distance = offset.length();
        let dir = offset / distance;
        Orbit {
            elevation: dir.y.clamp(-1.0, 1.0).asin().to_degrees(),
            azimuth: dir.x.atan2(dir.z).to_degrees(),
            distance,
            start_distance: distance,
        }
    }

    /// Turns the eye by a drag of `pixels` (right: the eye moves left
    /// around the target, so the scene turns with the mouse).
    pub fn turn(&mut self, pixels: Vec2) {
        self.azimuth -= pixels.x * DEGREES_PER_PIXEL;
        self.elevation =
            (self.elevation + pixels.y * DEGREES_PER_PIXEL).clamp(-MAX_ELEVATION, MAX_ELEVATION);
    }

    /// Moves the eye in (`notches` > 0) or out.
    pub fn zoom(&mut self, notches: f32) {
        let (near, far) = ZOOM_RANGE;
        self.distance = (self.distance * (1.0 - ZOOM_PER_NOTCH).powf(notches))
            .clamp(near * self.start_distance, far * self.start_distance);
    }

    /// The camera for a view of width / height `aspect`.
    pub fn camera(&self, scene: &Scene, model: &Model, aspect: f32) -> Camera {
        let mut scene = scene.clone();
        scene.camera.elevation = Some(f64::from(self.elevation));
        scene.camera.azimuth = Some(f64::from(self.azimuth));
        scene.camera.distance = Some(f64::from(self.distance));
        Camera::for_scene(&scene, model, aspect)
    }
}
