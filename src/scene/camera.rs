//! Pinhole perspective camera (glTF convention: looks down local -z, +y up).

use super::geometry::Ray;
use glam::{DMat3, DVec2, Quat, Vec2, Vec3};

/// A perspective camera placed in the world.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Orientation; the camera looks along `rotation * -Z`.
    pub rotation: Quat,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Width over height of the frame the camera was made for (glTF's `aspectRatio`), which
    /// the viewer keeps by letterboxing; None: the frame follows the image.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aspect: Option<f32>,
}

impl Camera {
    /// A camera at `eye` looking at `target` with +y up.
    pub fn look_at(eye: Vec3, target: Vec3, yfov: f32) -> Self {
        let forward = (target - eye).normalize();
        let up = if forward.cross(Vec3::Y).length_squared() < 1e-8 { Vec3::Z } else { Vec3::Y };
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let rotation = Quat::from_mat3(&glam::Mat3::from_cols(right, up, -forward)).normalize();
        Self { position: eye, rotation, yfov, aspect: None }
    }

    /// A camera that frames the axis-aligned box [min, max] from its +z side, 20 degrees above
    /// the horizon, so that a model lying flat in a coordinate plane is never seen edge-on.
    pub fn framing(min: Vec3, max: Vec3, aspect: f32) -> Self {
        let yfov = 0.8f32;
        let center = 0.5 * (min + max);
        let radius = (0.5 * (max - min).length()).max(f32::MIN_POSITIVE);
        let half = 0.5 * yfov.min(2.0 * ((0.5 * yfov).tan() * aspect).atan());
        let distance = radius / half.sin();
        let (sin, cos) = 20f32.to_radians().sin_cos();
        Self::look_at(center + Vec3::new(0.0, sin, cos) * distance, center, yfov)
    }

    /// Generates primary rays for a `width` x `height` film.
    pub fn rays(&self, width: u32, height: u32) -> RayGenerator {
        let tan_y = (0.5 * self.yfov).tan();
        let aspect = width as f32 / height as f32;
        RayGenerator {
            origin: self.position,
            forward: self.rotation * -Vec3::Z,
            right: self.rotation * Vec3::X * (tan_y * aspect),
            up: self.rotation * Vec3::Y * tan_y,
            inv_size: Vec2::new(1.0 / width as f32, 1.0 / height as f32),
        }
    }
}

/// Precomputed camera basis scaled to the film.
#[derive(Clone, Copy, Debug)]
pub struct RayGenerator {
    origin: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    inv_size: Vec2,
}

impl RayGenerator {
    /// The ray through film position `film` (pixels, origin top-left, +y down).
    pub fn ray(&self, film: Vec2) -> Ray {
        let ndc = film * self.inv_size * 2.0 - Vec2::ONE;
        let d = self.forward + self.right * ndc.x - self.up * ndc.y;
        Ray { o: self.origin, d: d.normalize(), tmax: f32::INFINITY }
    }

    /// The film position whose ray (`ray`) passes through `p`, in f64: the inverse of `ray`
    /// up to its rounding. None for points not in front of the camera.
    pub fn film_position(&self, p: Vec3) -> Option<DVec2> {
        let basis = DMat3::from_cols(self.forward.as_dvec3(), self.right.as_dvec3(), -self.up.as_dvec3());
        // p - origin = c (forward + right x - up y): solve for (c, c x, c y).
        let [c, cx, cy] = (basis.inverse() * (p.as_dvec3() - self.origin.as_dvec3())).to_array();
        if c.is_nan() || c <= 0.0 {
            return None;
        }
        let ndc = DVec2::new(cx / c, cy / c);
        Some((ndc + DVec2::ONE) / (2.0 * self.inv_size.as_dvec2()))
    }

    /// The camera's position.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// Cosine between unit `d` and the camera's viewing direction.
    pub fn cos(&self, d: Vec3) -> f32 {
        d.dot(self.forward)
    }

    /// The film's area at distance 1 in front of the pinhole.
    fn film_area(&self) -> f32 {
        4.0 * self.right.length() * self.up.length()
    }

    /// The pinhole's importance for a ray leaving it along unit `d`, normalised over the
    /// whole film (pbrt-v4's `PerspectiveCamera::We`): 1 / (A cos^4 theta), A the film's area
    /// at distance 1; with the film position (pixels) the ray passes through. None outside
    /// the frame or behind the camera.
    pub fn importance(&self, d: Vec3) -> Option<(f32, Vec2)> {
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return None;
        }
        let film = self.film_position(self.origin + d)?.as_vec2();
        let size = Vec2::ONE / self.inv_size;
        if !(film.x >= 0.0 && film.y >= 0.0 && film.x < size.x && film.y < size.y) {
            return None;
        }
        Some((1.0 / (self.film_area() * cos.powi(4)), film))
    }

    /// Density per solid angle of the camera's rays along unit `d` (film positions uniform
    /// over the film): 1 / (A cos^3 theta) inside the frame, 0 outside.
    pub fn pdf_dir(&self, d: Vec3) -> f32 {
        match self.importance(d) {
            Some(_) => 1.0 / (self.film_area() * d.dot(self.forward).powi(3)),
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn importance_finds_the_film_position_of_a_ray_and_weighs_it_against_its_density() {
        // Each camera ray maps back to its film position; We cos / pdf_dir is 1 for every
        // ray, so the importance integrates to 1 over the frame (film positions uniform).
        let cam = Camera::look_at(Vec3::new(0.3, -1.0, 2.0), Vec3::new(0.0, 0.4, -1.0), 0.9);
        let rays = cam.rays(96, 64);
        let forward = cam.rotation * -Vec3::Z;
        for i in 0..200 {
            let film = Vec2::new((i % 20) as f32 * 4.8 + 0.3, (i / 20) as f32 * 6.4 + 0.2);
            let d = rays.ray(film).d;
            let (we, back) = rays.importance(d).expect("inside the frame");
            assert!((back - film).length() < 1e-3, "{film} -> {back}");
            let ratio = we * d.dot(forward) / rays.pdf_dir(d);
            assert!((ratio - 1.0).abs() < 1e-5, "{ratio}");
        }
        assert_eq!(rays.importance(-forward), None, "behind");
        assert_eq!(rays.pdf_dir(rays.ray(Vec2::new(-1.0, 10.0)).d), 0.0, "left of the frame");
    }

    #[test]
    fn look_at_points_the_centre_ray_at_the_target() {
        let cam = Camera::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 0.5, 0.0), 0.7);
        let ray = cam.rays(64, 48).ray(Vec2::new(32.0, 24.0));
        let want = (Vec3::new(-1.0, 0.5, 0.0) - Vec3::new(1.0, 2.0, 3.0)).normalize();
        assert!((ray.d - want).length() < 1e-5);
        let top = cam.rays(64, 48).ray(Vec2::new(32.0, 0.0));
        assert!((top.d.angle_between(ray.d) - 0.35).abs() < 1e-4, "half the vertical fov");
        assert!(top.d.y > ray.d.y, "film +y points down");
    }

    #[test]
    fn film_position_inverts_the_camera_ray() {
        let cam = Camera::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 0.5, 0.0), 0.7);
        let rays = cam.rays(640, 480);
        for (i, film) in [Vec2::new(0.0, 0.0), Vec2::new(639.75, 12.5), Vec2::new(320.3, 479.9)].into_iter().enumerate()
        {
            let ray = rays.ray(film);
            let p = ray.o + ray.d * (0.5 + 3.0 * i as f32);
            let back = rays.film_position(p).expect("in front");
            assert!((back - film.as_dvec2()).length() < 1e-3, "{film} came back as {back}");
        }
        assert_eq!(rays.film_position(rays.origin() - cam.rotation * -Vec3::Z), None, "behind the camera");
    }

    #[test]
    fn framing_keeps_the_bounds_in_view() {
        let (min, max) = (Vec3::new(-3.0, 0.0, -1.0), Vec3::new(5.0, 2.0, 1.0));
        let cam = Camera::framing(min, max, 2.0);
        let fwd = cam.rotation * -Vec3::Z;
        for corner in 0..8 {
            let c = Vec3::new(
                if corner & 1 == 0 { min.x } else { max.x },
                if corner & 2 == 0 { min.y } else { max.y },
                if corner & 4 == 0 { min.z } else { max.z },
            );
            let v = c - cam.position;
            assert!(v.dot(fwd) > 0.0, "in front");
            let up = cam.rotation * Vec3::Y;
            assert!(v.dot(up).abs() / v.dot(fwd) <= (0.5 * cam.yfov).tan() + 1e-4);
        }
    }
}
