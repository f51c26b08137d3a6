//! A camera that frames a scene on its own: it looks at the box the cloth
//! can reach from a fixed elevation and azimuth, far enough back that the
//! box's bounding sphere fits the view.

use glam::{Vec2, Vec3};

use crate::model::Model;
use crate::params::{Capsule, Params};
use crate::scene::Scene;

/// Vertical field of view [rad] (45°).
const FOV_Y: f32 = std::f32::consts::FRAC_PI_4;
/// Height of the eye above the target, as an angle [rad] (20°). With half
/// the 45° field of view above the axis, the top edge of the image looks
/// 2.5° above the horizon, so the sky (the background) always shows there.
const ELEVATION: f32 = 20.0 * std::f32::consts::PI / 180.0;
/// Direction of the eye around the vertical axis, from +z towards +x [rad]
/// (35°): the front of a cloth facing +z, seen a little from the side.
const AZIMUTH: f32 = 35.0 * std::f32::consts::PI / 180.0;
/// Margin around the bounding sphere (5 %).
const MARGIN: f32 = 1.05;

/// Where the eye is and what it sees, as angles [rad] and a distance \[m\].
#[derive(Clone, Copy, Debug)]
struct View {
    elevation: f32,
    azimuth: f32,
    fov_y: f32,
    distance: Option<f32>,
}

/// A perspective camera: where it is and its view-projection matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position \[m\].
    pub eye: Vec3,
    /// The point looked at \[m\].
    pub target: Vec3,
    /// Radius of the sphere the view is fitted to \[m\].
    pub radius: f32,
    /// Column-major view-projection matrix (clip space: wgpu's, depth in
    /// 0..1), as WGSL's `mat4x4<f32>` stores it.
    pub view_proj: [[f32; 4]; 4],
}

impl Camera {
    /// Frames `model` under `params`: the cloth's rest bounding box, grown
    /// downwards by the cloth's largest extent (room for it to fall or hang
    /// down) but not below the ground, plus the spheres, capsules and mesh colliders.
    pub fn framing(model: &Model, params: &Params, aspect: f32) -> Camera {
        Camera::framing_with(model, params, &[], aspect)
    }

    /// [`Camera::framing`] with `more` capsules in the frame too (where a
    /// scene's character goes).
    fn framing_with(model: &Model, params: &Params, more: &[Capsule], aspect: f32) -> Camera {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &model.rest_positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        lo[1] -= extent;
        if let Some(ground) = &params.ground {
            lo[1] = lo[1].max(ground.height);
        }
        let balls = params
            .spheres
            .iter()
            .map(|s| (s.center, s.radius))
            .chain(params.mesh_colliders.iter().map(|m| m.bounding_sphere()));
        let ends = params
            .capsules
            .iter()
            .chain(more)
            .flat_map(|c| [(c.a, c.radius), (c.b, c.radius)]);
        for (centre, radius) in balls.chain(ends) {
            for k in 0..3 {
                lo[k] = lo[k].min(centre[k] - radius);
                hi[k] = hi[k].max(centre[k] + radius);
            }
        }
        let target = [0, 1, 2].map(|k| (0.5 * (lo[k] + hi[k])) as f32);
        let half = [0, 1, 2].map(|k| (0.5 * (hi[k] - lo[k])) as f32);
        let radius = length(half).max(1e-3);
        Camera::orbit(Vec3::from_array(target), radius, aspect)
    }

    /// The scene's camera: the automatic framing of
    /// [`Camera::framing`] with the choices its `[camera]` table makes
    /// instead (target, distance, elevation, azimuth, field of view). A
    /// scene's character is framed at every key of its path.
    pub fn for_scene(scene: &Scene, model: &Model, aspect: f32) -> Camera {
        let path: Vec<Capsule> = scene
            .character
            .iter()
            .flat_map(|c| c.keys.iter().flat_map(|k| c.capsules_at(k.time)))
            .collect();
        let auto = Camera::framing_with(model, &scene.params, &path, aspect);
        let c = &scene.camera;
        let view = View {
            distance: c.distance.map(|d| d as f32),
            ..Camera::angles(scene)
        };
        let target = c.target.map_or(auto.target, |t| t.as_vec3());
        Camera::look(target, auto.radius, view, aspect)
    }

    /// The camera of frame time `t` \[s\] in a film of `scene`
    /// (`wgcloth render`): a scene whose character moves is followed —
    /// framed as at its first key (the cloth and the character's capsules
    /// there), the target moving with the character, from the `[camera]`
    /// table's angles and field of view — so that it fills the picture
    /// however far it runs; the table's target and distance, which frame
    /// the whole path for a still ([`Camera::for_scene`]), do not apply.
    /// `None` for a scene without a character.
    pub fn following(scene: &Scene, model: &Model, aspect: f32, t: f64) -> Option<Camera> {
        let character = scene.character.as_ref()?;
        let start = character.keys.first().map_or(0.0, |k| k.time);
        let here = character.capsules_at(start);
        let auto = Camera::framing_with(model, &scene.params, &here, aspect);
        let moved = character.pose(t).position - character.pose(start).position;
        let view = Camera::angles(scene);
        Some(Camera::look(
            auto.target + moved.as_vec3(),
            auto.radius,
            view,
            aspect,
        ))
    }

    /// The `[camera]` table's angles and field of view, the defaults where
    /// it has none; no distance.
    fn angles(scene: &Scene) -> View {
        let c = &scene.camera;
        let deg = |d: f64| (d as f32).to_radians();
        View {
            elevation: c.elevation.map_or(ELEVATION, deg),
            azimuth: c.azimuth.map_or(AZIMUTH, deg),
            fov_y: c.fov.map_or(FOV_Y, deg),
            distance: None,
        }
    }

    /// Looks at `target` from the fixed elevation and azimuth, far enough
    /// back that a sphere of `radius` \[m\] around it fits the view whose
    /// width / height is `aspect`.
    pub fn orbit(target: Vec3, radius: f32, aspect: f32) -> Camera {
        let view = View {
            elevation: ELEVATION,
            azimuth: AZIMUTH,
            fov_y: FOV_Y,
            distance: None,
        };
        Camera::look(target, radius, view, aspect)
    }

    /// Looks at `target` as `view` says; without a distance, far enough back
    /// that a sphere of `radius` \[m\] fits.
    fn look(target: Vec3, radius: f32, view: View, aspect: f32) -> Camera {
        let target = target.to_array();
        let half_y = 0.5 * view.fov_y;
        let half_x = (half_y.tan() * aspect).atan();
        let distance = view
            .distance
            .unwrap_or(MARGIN * radius / half_y.min(half_x).sin());
        let (elevation, azimuth) = (view.elevation, view.azimuth);
        let dir = [
            elevation.cos() * azimuth.sin(),
            elevation.sin(),
            elevation.cos() * azimuth.cos(),
        ];
        let eye = [0, 1, 2].map(|k| target[k] + distance * dir[k]);
        // The ground drawn around the scene reaches 3 radii from the target
        // (see `Renderer`): the far plane leaves room for it.
        let near = (distance - radius * 2.0).max(distance * 0.01);
        let far = distance + radius * 4.0;
        let proj = perspective(view.fov_y, aspect, near, far);
        Camera {
            eye: Vec3::from_array(eye),
            target: Vec3::from_array(target),
            radius,
            view_proj: mul(&proj, &look_at(eye, target)),
        }
    }

    /// Projects a point \[m\] to pixel coordinates (x right, y down, origin
    /// at the top-left corner) of a `width` × `height` image; `None` if it
    /// lies behind the eye or outside the depth range.
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<Vec2> {
        let m = &self.view_proj;
        let clip: [f32; 4] =
            [0, 1, 2, 3].map(|r| m[0][r] * p[0] + m[1][r] * p[1] + m[2][r] * p[2] + m[3][r]);
        if clip[3] <= 0.0 {
            return None;
        }
        let ndc = [clip[0] / clip[3], clip[1] / clip[3], clip[2] / clip[3]];
        if !(0.0..=1.0).contains(&ndc[2]) {
            return None;
        }
        Some(Vec2::new(
            (ndc[0] + 1.0) * 0.5 * width as f32,
            (1.0 - ndc[1]) * 0.5 * height as f32,
        ))
    }
}

fn length(v: [f32; 3]) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l = length(v);
    v.map(|c| c / l)
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Right-handed view matrix, y up (column-major).
fn look_at(eye: [f32; 3], target: [f32; 3]) -> [[f32; 4]; 4] {
    let f = normalize([0, 1, 2].map(|k| target[k] - eye[k]));
    let s = normalize(cross(f, [0.0, 1.0, 0.0]));
    let u = cross(s, f);
    [
        [s[0], u[0], -f[0], 0.0],
        [s[1], u[1], -f[1], 0.0],
        [s[2], u[2], -f[2], 0.0],
        [-dot(s, eye), -dot(u, eye), dot(f, eye), 1.0],
    ]
}

/// Right-handed perspective projection to wgpu's clip space (depth 0..1),
/// column-major.
fn perspective(fov_y: f32, aspect: f32, near: f32, far: f32) -> [[f32; 4]; 4] {
    let f = 1.0 / (0.5 * fov_y).tan();
    let r = far / (near - far);
    [
        [f / aspect, 0.0, 0.0, 0.0],
        [0.0, f, 0.0, 0.0],
        [0.0, 0.0, r, -1.0],
        [0.0, 0.0, near * r, 0.0],
    ]
}

/// `a · b` for column-major matrices.
fn mul(a: &[[f32; 4]; 4], b: &[[f32; 4]; 4]) -> [[f32; 4]; 4] {
    let mut out = [[0.0; 4]; 4];
    for (c, col) in out.iter_mut().enumerate() {
        for (r, v) in col.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[k][r] * b[c][k]).sum();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_target_projects_to_the_centre_and_the_sphere_fits() {
        let cam = Camera::orbit(Vec3::new(1.0, 2.0, 3.0), 0.5, 4.0 / 3.0);
        let c = cam.project(cam.target, 640, 480).expect("in front");
        assert!(
            (c[0] - 320.0).abs() < 1e-2 && (c[1] - 240.0).abs() < 1e-2,
            "{c:?}"
        );
        for d in [Vec3::X * 0.5, Vec3::Y * 0.5, Vec3::Z * -0.5] {
            let q = cam.project(cam.target + d, 640, 480).expect("in front");
            assert!(
                (0.0..640.0).contains(&q[0]) && (0.0..480.0).contains(&q[1]),
                "{q:?}"
            );
        }
    }

    #[test]
    fn up_is_up_on_screen() {
        let cam = Camera::orbit(Vec3::ZERO, 1.0, 1.0);
        let low = cam
            .project(Vec3::new(0.0, -0.5, 0.0), 100, 100)
            .expect("in front");
        let high = cam
            .project(Vec3::new(0.0, 0.5, 0.0), 100, 100)
            .expect("in front");
        assert!(high[1] < low[1]);
    }

    #[test]
    fn a_running_character_is_followed_and_fills_the_picture() {
        let scene = Scene::builtin("cape").expect("built in");
        let model = scene.model().expect("valid");
        let aspect = 4.0 / 3.0;
        let still = Camera::for_scene(&scene, &model, aspect);
        let character = scene.character.as_ref().expect("the cape's character");
        for t in [0.0, 1.0, 2.0, 3.0, 4.0] {
            let cam = Camera::following(&scene, &model, aspect, t).expect("a character");
            let head = character.pose(t).world(glam::DVec3::new(0.0, 1.62, 0.0));
            let feet = character.pose(t).world(glam::DVec3::ZERO);
            let tall = |c: &Camera| {
                let top = c.project(head.as_vec3(), 640, 480).expect("head in view");
                let bottom = c.project(feet.as_vec3(), 640, 480).expect("feet in view");
                bottom[1] - top[1]
            };
            // Followed, the character stands over a third of the picture's
            // height at every time; the still camera, framing the whole
            // run, shows it smaller.
            let followed = tall(&cam);
            assert!(followed > 480.0 / 3.0, "t = {t}: {followed} px");
            assert!(followed > tall(&still), "t = {t}");
        }
        let hanging = Scene::builtin("hanging").expect("built in");
        let model = hanging.model().expect("valid");
        assert!(Camera::following(&hanging, &model, aspect, 1.0).is_none());
    }

    #[test]
    fn a_scene_camera_table_overrides_the_framing() {
        let mut scene = Scene::builtin("hanging").expect("built in");
        let model = scene.model().expect("valid");
        let auto = Camera::for_scene(&scene, &model, 4.0 / 3.0);
        assert_eq!(auto, Camera::framing(&model, &scene.params, 4.0 / 3.0));
        scene.camera.target = Some(glam::DVec3::new(0.0, 0.5, 0.0));
        scene.camera.distance = Some(3.0);
        scene.camera.elevation = Some(90.0 - 1.0);
        let cam = Camera::for_scene(&scene, &model, 4.0 / 3.0);
        assert_eq!(cam.target, Vec3::new(0.0, 0.5, 0.0));
        let d = cam.eye.distance(cam.target);
        assert!((d - 3.0).abs() < 1e-5, "distance {d}");
        // 89° elevation: the eye is nearly straight above the target.
        assert!(cam.eye[1] - cam.target[1] > 0.99 * 3.0, "{:?}", cam.eye);
    }
}
