//! Affine transforms of scene shapes: scale, then rotate about an axis, then translate; or any
//! affine 4x4 matrix.

use glam::{Affine3A, Mat3, Mat4, Quat, Vec3, Vec4};

/// An affine transform of points, vectors and normals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// The affine map of points.
    pub m: Affine3A,
    /// Inverse transpose of the linear part, for normals.
    pub normal_m: Mat3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform::IDENTITY
    }
}

impl Transform {
    /// The transform that changes nothing.
    pub const IDENTITY: Transform = Transform {
        m: Affine3A::IDENTITY,
        normal_m: Mat3::IDENTITY,
    };

    /// `translate * rotate(axis, degrees) * scale`.
    pub fn new(scale: Vec3, axis: Vec3, degrees: f32, translate: Vec3) -> Transform {
        let rot = if degrees != 0.0 {
            Quat::from_axis_angle(axis.normalize(), degrees.to_radians())
        } else {
            Quat::IDENTITY
        };
        let m = Affine3A::from_scale_rotation_translation(scale, rot, translate);
        let normal_m = Mat3::from(m.matrix3).inverse().transpose();
        Transform { m, normal_m }
    }

    /// The affine transform of a 4x4 matrix, or `None` when its last row is not (0, 0, 0, 1)
    /// (a projective transform), an entry is not finite or the linear part is singular.
    pub fn from_matrix(m: Mat4) -> Option<Transform> {
        if !m.is_finite() || m.row(3) != Vec4::W {
            return None;
        }
        let m = Affine3A::from_mat4(m);
        let linear = Mat3::from(m.matrix3);
        let det = linear.determinant();
        if !(det.is_normal() && det.abs().is_finite()) {
            return None;
        }
        let normal_m = linear.inverse().transpose();
        normal_m.is_finite().then_some(Transform { m, normal_m })
    }

    /// `self` applied after `inner` (an instance's placement after a member's own transform).
    pub fn after(&self, inner: &Transform) -> Transform {
        Transform {
            m: self.m * inner.m,
            normal_m: self.normal_m * inner.normal_m,
        }
    }

    /// The point `p` transformed.
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.m.transform_point3(p)
    }

    /// The vector `v` transformed (no translation).
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.m.transform_vector3(v)
    }

    /// The normal `n` transformed by the inverse transpose and normalised.
    pub fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal_m * n).normalize()
    }

    /// Whether the linear part flips handedness (then triangle winding must be flipped).
    pub fn flips_handedness(&self) -> bool {
        self.m.matrix3.determinant() < 0.0
    }

    /// The uniform scale factor, if the linear part is a similarity (rotation times a scalar).
    pub fn uniform_scale(&self) -> Option<f32> {
        let m = Mat3::from(self.m.matrix3);
        let (a, b, c) = (m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
        let s = (a + b + c) / 3.0;
        let tol = 1e-4 * s.max(1e-30);
        ((a - s).abs() < tol && (b - s).abs() < tol && (c - s).abs() < tol).then_some(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_then_rotate_then_translate() {
        let t = Transform::new(
            Vec3::new(2.0, 1.0, 1.0),
            Vec3::Y,
            90.0,
            Vec3::new(0.0, 0.0, 5.0),
        );
        // (1,0,0) -> scaled (2,0,0) -> rotated 90 deg about +y -> (0,0,-2) -> translated (0,0,3)
        let p = t.point(Vec3::X);
        assert!((p - Vec3::new(0.0, 0.0, 3.0)).length() < 1e-5, "{p}");
        assert!(t.uniform_scale().is_none());
    }

    #[test]
    fn from_matrix_equals_the_composed_transform() {
        let t = Transform::new(
            Vec3::new(2.0, 1.0, 3.0),
            Vec3::new(1.0, 1.0, 0.0),
            30.0,
            Vec3::new(0.5, -1.0, 5.0),
        );
        let m = Transform::from_matrix(Mat4::from(t.m)).unwrap();
        for p in [Vec3::X, Vec3::new(0.3, -2.0, 1.0)] {
            assert!((m.point(p) - t.point(p)).length() < 1e-5);
            assert!((m.normal(p) - t.normal(p)).length() < 1e-5);
        }
        let mut projective = Mat4::IDENTITY;
        projective.w_axis.w = 2.0;
        projective.x_axis.w = 1.0;
        assert!(Transform::from_matrix(projective).is_none());
        assert!(Transform::from_matrix(Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0))).is_none());
    }
}
