//! Picking and dragging in the picture: the ray under a pixel, the particle
//! nearest to it, and where the cursor puts a grabbed particle. Plain
//! geometry on the camera's view-projection matrix, so it is tested
//! without a window or a device.

use wgcloth::glam::{Mat4, Vec2, Vec3, Vec4};

/// A half-line from the eye into the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where it starts, on the near plane \[m\].
    pub origin: Vec3,
    /// Its direction (unit length).
    pub direction: Vec3,
}

impl Ray {
    /// The ray through `pixel` (x right, y down, origin at the top-left
    /// corner, as `Camera::project` returns) of a `size` image \[pixels\],
    /// seen through the column-major `view_proj` (wgpu's clip space, depth
    /// 0..1): the near-plane and far-plane points under the pixel, through
    /// the inverse matrix. `None` if the matrix cannot be inverted or the
    /// size is empty.
    pub fn through_pixel(view_proj: &[[f32; 4]; 4], pixel: Vec2, size: Vec2) -> Option<Ray> {
        if size.x <= 0.0 || size.y <= 0.0 {
            return None;
        }
        let m = Mat4::from_cols_array_2d(view_proj);
        if m.determinant() == 0.0 {
            return None;
        }
        let inverse = m.inverse();
        let ndc = Vec2::new(2.0 * pixel.x / size.x - 1.0, 1.0 - 2.0 * pixel.y / size.y);
        let unproject = |depth: f32| {
            let p = inverse * Vec4::new(ndc.x, ndc.y, depth, 1.0);
            p.truncate() / p.w
        };
        let (near, far) = (unproject(0.0), unproject(1.0));
        let direction = (far - near).try_normalize()?;
        near.is_finite().then_some(Ray {
            origin: near,
            direction,
        })
    }

    /// The distance along the ray of the point nearest to `p` \[m\]
    /// (negative: `p` is behind the origin).
    pub fn along(&self, p: Vec3) -> f32 {
        (p - self.origin).dot(self.direction)
    }

    /// The distance from `p` to the ray's line \[m\].
    pub fn distance(&self, p: Vec3) -> f32 {
        (p - self.origin - self.direction * self.along(p)).length()
    }

    /// Where the ray meets the plane through `point` with normal `normal`;
    /// `None` if it runs parallel to the plane or meets it behind its origin.
    pub fn hit_plane(&self, point: Vec3, normal: Vec3) -> Option<Vec3> {
        let facing = self.direction.dot(normal);
        if facing.abs() < f32::EPSILON {
            return None;
        }
        let t = (point - self.origin).dot(normal) / facing;
        (t >= 0.0).then(|| self.origin + self.direction * t)
    }
}

/// The index of the particle of `positions` \[m\] nearest to `ray`'s line
/// among those in front of its origin and within `radius` \[m\] of it; on
/// a tie, the one nearer the eye. `None` if there is none.
pub fn nearest(positions: &[Vec3], ray: &Ray, radius: f32) -> Option<usize> {
    positions
        .iter()
        .enumerate()
        .filter(|(_, p)| ray.along(**p) >= 0.0)
        .map(|(i, p)| (i, ray.distance(*p), ray.along(*p)))
        .filter(|(_, d, _)| *d <= radius)
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.2.total_cmp(&b.2)))
        .map(|(i, _, _)| i)
}

/// Where the cursor's `ray` puts a particle grabbed at `grabbed` \[m\]: on
/// the plane through the grabbed point facing the camera (normal
/// `forward`, the eye's viewing direction), so the particle follows the
/// cursor at the depth it was grabbed. `None` if the ray misses the plane.
pub fn drag_target(ray: &Ray, grabbed: Vec3, forward: Vec3) -> Option<Vec3> {
    ray.hit_plane(grabbed, forward)
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgcloth::render::Camera;

    /// Pixel-to-ray-to-pixel round trips in f32 through a 4×4 inverse
    /// round to some 2e-4 pixels here; a hundredth of a pixel leaves fifty
    /// times that, and is far below what a cursor resolves.
    const PIXEL_TOLERANCE: f32 = 0.01;
    /// Distances in metres on a scene of about a metre: the f32
    /// unprojection rounds to under 1e-6 m here; 1e-4 m leaves a hundred
    /// times that and still tells a hit from the centimetres of a miss.
    const METRE_TOLERANCE: f32 = 1e-4;
    const SIZE: Vec2 = Vec2::new(640.0, 480.0);

    fn camera() -> Camera {
        Camera::orbit(Vec3::new(0.2, 0.5, -0.1), 0.8, SIZE.x / SIZE.y)
    }

    /// A point the camera projects to a pixel lies on the ray through that
    /// pixel, and the ray starts at the eye's side of it.
    #[test]
    fn a_projected_point_lies_on_the_ray_through_its_pixel() {
        let cam = camera();
        for p in [
            cam.target,
            cam.target + Vec3::new(0.3, -0.2, 0.1),
            cam.target + Vec3::new(-0.4, 0.3, -0.2),
        ] {
            let pixel = cam
                .project(p, SIZE.x as u32, SIZE.y as u32)
                .expect("in view");
            let ray = Ray::through_pixel(&cam.view_proj, pixel, SIZE).expect("invertible");
            assert!(
                ray.distance(p) < METRE_TOLERANCE,
                "{p} is {} m off",
                ray.distance(p)
            );
            assert!(ray.along(p) > 0.0);
            // The ray points away from the eye.
            let eye_side = (ray.origin - cam.eye).dot(ray.direction);
            assert!(eye_side > 0.0, "the ray starts behind the eye");
            let back = cam
                .project(
                    ray.origin + ray.direction * ray.along(p),
                    SIZE.x as u32,
                    SIZE.y as u32,
                )
                .expect("in view");
            assert!(
                (back - pixel).length() < PIXEL_TOLERANCE,
                "{back} vs {pixel}"
            );
        }
    }

    /// The centre pixel looks straight at the target.
    #[test]
    fn the_centre_pixel_looks_at_the_target() {
        let cam = camera();
        let ray = Ray::through_pixel(&cam.view_proj, SIZE / 2.0, SIZE).expect("invertible");
        let forward = (cam.target - cam.eye).normalize();
        assert!(ray.direction.dot(forward) > 1.0 - METRE_TOLERANCE);
        assert!(ray.distance(cam.target) < METRE_TOLERANCE);
    }

    #[test]
    fn a_singular_matrix_or_an_empty_image_has_no_ray() {
        let cam = camera();
        assert!(Ray::through_pixel(&[[0.0; 4]; 4], SIZE / 2.0, SIZE).is_none());
        assert!(Ray::through_pixel(&cam.view_proj, Vec2::ZERO, Vec2::ZERO).is_none());
    }

    /// Of particles near the line, the nearest to it wins; one beyond the
    /// radius or behind the origin is never picked.
    #[test]
    fn the_nearest_particle_within_the_radius_is_picked() {
        let ray = Ray {
            origin: Vec3::ZERO,
            direction: Vec3::Z,
        };
        let positions = [
            Vec3::new(0.05, 0.0, 1.0), // 5 cm off
            Vec3::new(0.0, 0.02, 2.0), // 2 cm off: the nearest
            Vec3::new(0.0, 0.0, -1.0), // on the line, behind the origin
            Vec3::new(0.5, 0.0, 1.0),  // beyond the radius
        ];
        assert_eq!(nearest(&positions, &ray, 0.1), Some(1));
        assert_eq!(nearest(&positions, &ray, 0.01), None);
        assert_eq!(nearest(&positions[2..], &ray, 0.1), None);
        // A tie goes to the particle nearer the eye.
        let stacked = [Vec3::new(0.0, 0.01, 3.0), Vec3::new(0.0, 0.01, 1.0)];
        assert_eq!(nearest(&stacked, &ray, 0.1), Some(1));
    }

    /// A dragged particle lands under the cursor, at the depth it was
    /// grabbed at (on the plane facing the camera).
    #[test]
    fn the_drag_target_is_under_the_cursor_at_the_grabbed_depth() {
        let cam = camera();
        let grabbed = cam.target + Vec3::new(0.1, -0.1, 0.0);
        let forward = (cam.target - cam.eye).normalize();
        let cursor = Vec2::new(500.0, 100.0);
        let ray = Ray::through_pixel(&cam.view_proj, cursor, SIZE).expect("invertible");
        let target = drag_target(&ray, grabbed, forward).expect("the plane faces the camera");
        assert!((target - grabbed).dot(forward).abs() < METRE_TOLERANCE);
        let pixel = cam
            .project(target, SIZE.x as u32, SIZE.y as u32)
            .expect("in view");
        assert!(
            (pixel - cursor).length() < PIXEL_TOLERANCE,
            "{pixel} vs {cursor}"
        );
        // A ray parallel to the plane never meets it.
        let sideways = Ray {
            origin: cam.eye,
            direction: forward.any_orthonormal_vector(),
        };
        assert!(drag_target(&sideways, grabbed, forward).is_none());
    }
}
