//! Orthonormal frames. `Frame::from_z(n)` builds a frame with `n` as its z axis (Duff et al.
//! 2017, "Building an Orthonormal Basis, Revisited"); local directions have `cos_theta = z`.

use glam::Vec3;

/// An orthonormal basis (s, t, n); local z is along `n`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// First tangent (local x).
    pub s: Vec3,
    /// Second tangent (local y).
    pub t: Vec3,
    /// Normal (local z).
    pub n: Vec3,
}

impl Frame {
    /// The frame with unit `n` as its z axis.
    pub fn from_z(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// World direction `v` in the frame's coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local direction `v` in world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_for_all_axes() {
        for n in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            -Vec3::Y,
            Vec3::new(1.0, 2.0, -3.0).normalize(),
        ] {
            let f = Frame::from_z(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(
                f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5 && f.t.dot(f.n).abs() < 1e-5
            );
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-5);
        }
    }
}
