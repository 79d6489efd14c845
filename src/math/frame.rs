//! Orthonormal shading frame: world <-> local coordinates with the normal as +z.

use glam::Vec3;

/// An orthonormal basis whose `n` is the local +z axis.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Local +x.
    pub s: Vec3,
    /// Local +y.
    pub t: Vec3,
    /// Local +z (the normal).
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame around the unit vector `n` without branches on near-parallel axes
    /// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    /// The frame about the same normal whose +x is `axis` projected onto the tangent plane
    /// (+y = n x axis, right-handed); this frame if `axis` has no part in that plane.
    pub fn aligned(&self, axis: Vec3) -> Self {
        let s = (axis - self.n * self.n.dot(axis)).normalize_or_zero();
        if s == Vec3::ZERO {
            return *self;
        }
        Self { s, t: self.n.cross(s), n: self.n }
    }

    /// Expresses a world-space vector in this frame.
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Expresses a local vector in world space.
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.81).normalize()] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-6 && (f.t.length() - 1.0).abs() < 1e-6);
            assert!(f.s.dot(f.t).abs() < 1e-6 && f.s.dot(n).abs() < 1e-6);
            assert!(f.s.cross(f.t).dot(n) > 0.999, "right-handed");
            let v = Vec3::new(0.2, 0.7, -0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
            let a = f.aligned(Vec3::new(0.3, 0.9, -0.2));
            assert!(a.s.cross(a.t).dot(n) > 0.999 && a.s.dot(n).abs() < 1e-6 && (a.s.length() - 1.0).abs() < 1e-6);
            assert!((a.to_world(a.to_local(v)) - v).length() < 1e-6);
        }
    }
}
