//! The frame a BSDF is evaluated in (shading and geometric normals, texture coordinates),
//! and the two rules every BSDF applies with it: which side of the geometric normal a pair
//! of directions must be on, and Veach's adjoint correction for shading normals.

use super::TransportMode;
use crate::math::Frame;
use glam::{Vec2, Vec3};

/// The surface frame a BSDF is evaluated in.
#[derive(Debug, Clone, Copy)]
pub struct ShadingFrame {
    /// Shading frame, `frame.n` is the shading normal.
    pub frame: Frame,
    /// Geometric normal (front side of the shape).
    pub ng: Vec3,
    /// Texture coordinates of the point (zero where no texture looks at them).
    pub uv: Vec2,
}

impl ShadingFrame {
    /// The frame around shading normal `ns`, with geometric normal `ng`.
    pub fn new(ns: Vec3, ng: Vec3) -> ShadingFrame {
        ShadingFrame {
            frame: Frame::from_z(ns),
            ng,
            uv: Vec2::ZERO,
        }
    }

    /// The same frame at texture coordinates `uv`.
    pub fn with_uv(self, uv: Vec2) -> ShadingFrame {
        ShadingFrame { uv, ..self }
    }

    /// The frame with first tangent `s` as a stored path vertex keeps it
    /// ([`crate::path::Vertex::tangent`]: a frame's `s` axis, unit and across the normal, or
    /// zero for the frame around the normal): the frame the vertex was evaluated in, bit for
    /// bit.
    pub fn with_stored_tangent(self, s: Vec3) -> ShadingFrame {
        if s == Vec3::ZERO {
            return self;
        }
        let n = self.frame.n;
        ShadingFrame {
            frame: Frame {
                s,
                t: n.cross(s),
                n,
            },
            ..self
        }
    }

    /// The frame turned about its normal so that its `s` axis follows tangent `dp_du` (the
    /// surface's derivative by `u`), as Mitsuba's shading frame does: `dp_du` without its
    /// part along the normal, normalised, and `t = n x s`. Unchanged where `dp_du` has no
    /// part across the normal (a degenerate parameterisation, a pole).
    pub fn with_tangent(self, dp_du: Vec3) -> ShadingFrame {
        let n = self.frame.n;
        self.with_stored_tangent((dp_du - n * n.dot(dp_du)).normalize_or_zero())
    }
}

/// Reflection needs `wo`, `wi` on one side of `ng`; transmission on opposite sides.
#[inline]
pub(super) fn geometry_agrees(sf: &ShadingFrame, wo: Vec3, wi: Vec3, transmission: bool) -> bool {
    let (a, b) = (wo.dot(sf.ng), wi.dot(sf.ng));
    if a == 0.0 || b == 0.0 {
        return false;
    }
    ((a * b) < 0.0) == transmission
}

/// Veach's adjoint BSDF correction for shading normals in importance mode (thesis eq. 5.19):
/// `|wo.ns| |wi.ng| / (|wo.ng| |wi.ns|)`. 1 in radiance mode or when ns == ng.
#[inline]
pub(super) fn shading_correction(
    sf: &ShadingFrame,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> f32 {
    if mode == TransportMode::Radiance || sf.frame.n == sf.ng {
        return 1.0;
    }
    let num = wo.dot(sf.frame.n).abs() * wi.dot(sf.ng).abs();
    let den = wo.dot(sf.ng).abs() * wi.dot(sf.frame.n).abs();
    if den == 0.0 { 0.0 } else { num / den }
}
