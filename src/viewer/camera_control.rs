//! Camera controls: orbit, pan and dolly around a target, and fly (look and move), as pure
//! math on a roll-free yaw/pitch camera, so it can be tested without a window.

use crate::scene::camera::Camera;
use glam::{Quat, Vec2, Vec3};

/// Highest pitch magnitude: just short of straight up or down, where yaw degenerates.
const MAX_PITCH: f32 = std::f32::consts::FRAC_PI_2 - 1e-3;

/// A camera looking at `target` from `distance` away along the yaw/pitch direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraController {
    /// The point orbited around (and panned with).
    pub target: Vec3,
    /// Rotation about +y in radians; 0 looks along -z.
    pub yaw: f32,
    /// Elevation in radians; positive looks up.
    pub pitch: f32,
    /// Distance from the eye to the target.
    pub distance: f32,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// The frame's width over height, kept through moves (see `Camera::aspect`).
    pub aspect: Option<f32>,
    /// The camera this controller was made from, used exactly (roll included) until the
    /// first move, so that an untouched view renders the file's camera bit for bit.
    exact: Option<Camera>,
}

impl CameraController {
    /// The controller matching `camera` (its roll is dropped), with the target `distance` ahead.
    pub fn from_camera(camera: &Camera, distance: f32) -> Self {
        let f = (camera.rotation * -Vec3::Z).normalize();
        let pitch = f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH);
        let yaw = f.x.atan2(-f.z);
        let distance = distance.max(f32::MIN_POSITIVE);
        Self {
            target: camera.position + f * distance,
            yaw,
            pitch,
            distance,
            yfov: camera.yfov,
            aspect: camera.aspect,
            exact: Some(*camera),
        }
    }

    /// A controller framing the box [min, max] for an image of aspect `aspect`.
    pub fn framing(min: Vec3, max: Vec3, aspect: f32) -> Self {
        let cam = Camera::framing(min, max, aspect);
        Self::from_camera(&cam, (0.5 * (min + max) - cam.position).length())
    }

    /// Unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        Vec3::new(self.yaw.sin() * self.pitch.cos(), self.pitch.sin(), -self.yaw.cos() * self.pitch.cos())
    }

    /// Eye position.
    pub fn position(&self) -> Vec3 {
        self.target - self.forward() * self.distance
    }

    /// The camera this controller describes.
    pub fn camera(&self) -> Camera {
        if let Some(c) = self.exact {
            return Camera { yfov: self.yfov, aspect: self.aspect, ..c };
        }
        let rotation = Quat::from_rotation_y(-self.yaw) * Quat::from_rotation_x(self.pitch);
        Camera { position: self.position(), rotation, yfov: self.yfov, aspect: self.aspect }
    }

    fn right_up(&self) -> (Vec3, Vec3) {
        let r = Quat::from_rotation_y(-self.yaw) * Quat::from_rotation_x(self.pitch);
        (r * Vec3::X, r * Vec3::Y)
    }

    /// Orbits around the target by a mouse drag of `delta` pixels in a viewport `height` pixels high.
    pub fn orbit(&mut self, delta: Vec2, height: f32) {
        self.exact = None;
        let k = std::f32::consts::PI / height.max(1.0);
        self.yaw += delta.x * k;
        self.pitch = (self.pitch + delta.y * k).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Pans the view so that the point at the target's depth follows the mouse.
    pub fn pan(&mut self, delta: Vec2, height: f32) {
        self.exact = None;
        let world_per_pixel = 2.0 * self.distance * (0.5 * self.yfov).tan() / height.max(1.0);
        let (right, up) = self.right_up();
        self.target += (-right * delta.x + up * delta.y) * world_per_pixel;
    }

    /// Moves towards (positive `steps`) or away from the target; never reaches it.
    pub fn dolly(&mut self, steps: f32) {
        self.exact = None;
        self.distance = (self.distance * 0.9f32.powf(steps)).max(1e-6 * self.distance.max(1e-30));
    }

    /// Looks around from a fixed eye (fly mode) by a mouse drag of `delta` pixels.
    pub fn look(&mut self, delta: Vec2, height: f32) {
        let eye = self.position();
        self.orbit(-delta, height);
        self.target = eye + self.forward() * self.distance;
    }

    /// Moves eye and target together along `local` (x right, y up, z forward) by `amount`.
    pub fn fly(&mut self, local: Vec3, amount: f32) {
        self.exact = None;
        let (right, up) = self.right_up();
        let d = right * local.x + up * local.y + self.forward() * local.z;
        self.target += d.normalize_or_zero() * amount;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn controller() -> CameraController {
        CameraController {
            target: Vec3::new(1.0, 2.0, 3.0),
            yaw: 0.4,
            pitch: -0.3,
            distance: 5.0,
            yfov: 0.8,
            aspect: None,
            exact: None,
        }
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-4
    }

    #[test]
    fn camera_round_trips_and_looks_at_the_target() {
        let c = controller();
        let cam = c.camera();
        assert!(close(cam.rotation * -Vec3::Z, c.forward()));
        assert!(close(cam.position + c.forward() * c.distance, c.target));
        assert!((cam.rotation * Vec3::X).y.abs() < 1e-6, "no roll");
        let back = CameraController::from_camera(&cam, c.distance);
        assert!(close(back.target, c.target) && (back.yaw - c.yaw).abs() < 1e-5 && (back.pitch - c.pitch).abs() < 1e-5);
        let default = CameraController::from_camera(&Camera::look_at(Vec3::ZERO, -Vec3::Z, 1.0), 1.0);
        assert!(default.yaw.abs() < 1e-6 && default.pitch.abs() < 1e-6);
    }

    #[test]
    fn an_untouched_file_camera_is_used_exactly_until_moved() {
        let rolled = Camera {
            position: Vec3::new(0.278, 0.273, -0.8),
            rotation: Quat::from_rotation_y(std::f32::consts::PI) * Quat::from_rotation_z(0.2),
            yfov: 0.69,
            aspect: Some(1.5),
        };
        let mut c = CameraController::from_camera(&rolled, 1.0);
        assert_eq!(c.camera(), rolled);
        c.orbit(Vec2::new(1.0, 0.0), 100.0);
        assert_ne!(c.camera().rotation, rolled.rotation);
        assert!((c.camera().rotation * Vec3::X).y.abs() < 1e-6, "moving drops the roll");
    }

    #[test]
    fn orbit_keeps_target_and_distance_and_clamps_pitch() {
        let mut c = controller();
        c.orbit(Vec2::new(120.0, 40.0), 600.0);
        assert_eq!((c.target, c.distance), (controller().target, 5.0));
        assert!(close(c.position() + c.forward() * 5.0, c.target));
        assert!((c.yaw - (0.4 + 120.0 * std::f32::consts::PI / 600.0)).abs() < 1e-6);
        c.orbit(Vec2::new(0.0, 1e6), 600.0);
        assert!(c.pitch <= MAX_PITCH && c.camera().rotation.is_finite());
    }

    #[test]
    fn pan_moves_target_in_the_image_plane_by_the_right_amount() {
        let mut c = controller();
        let before = c;
        c.pan(Vec2::new(300.0, 0.0), 600.0);
        let moved = c.target - before.target;
        assert!(moved.dot(before.forward()).abs() < 1e-5, "stays in the image plane");
        let expected = 300.0 * 2.0 * 5.0 * (0.4f32).tan() / 600.0;
        assert!((moved.length() - expected).abs() < 1e-4);
        assert!(moved.dot(before.camera().rotation * Vec3::X) < 0.0, "dragging right moves the scene right");
        assert_eq!((c.yaw, c.pitch, c.distance), (before.yaw, before.pitch, before.distance));
    }

    #[test]
    fn dolly_approaches_without_reaching_the_target() {
        let mut c = controller();
        c.dolly(1.0);
        assert!((c.distance - 4.5).abs() < 1e-5);
        c.dolly(-1.0);
        assert!((c.distance - 5.0).abs() < 1e-5);
        c.dolly(1e4);
        assert!(c.distance > 0.0 && c.camera().position.is_finite());
    }

    #[test]
    fn look_keeps_the_eye_and_fly_moves_eye_and_target_together() {
        let mut c = controller();
        let eye = c.position();
        c.look(Vec2::new(50.0, -20.0), 600.0);
        assert!(close(c.position(), eye));
        assert!(c.yaw != controller().yaw);
        let (eye, target) = (c.position(), c.target);
        c.fly(Vec3::Z, 2.0);
        assert!(close(c.position() - eye, c.forward() * 2.0) && close(c.target - target, c.forward() * 2.0));
    }

    #[test]
    fn framing_sees_the_whole_box() {
        let c = CameraController::framing(Vec3::new(-1.0, -2.0, -3.0), Vec3::new(3.0, 2.0, 1.0), 1.5);
        assert!(close(c.target, Vec3::new(1.0, 0.0, -1.0)));
        let radius = 0.5 * Vec3::new(4.0, 4.0, 4.0).length();
        assert!(c.distance * (0.5 * c.yfov).sin() >= radius - 1e-4);
    }
}
