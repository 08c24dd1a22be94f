//! Shading normals from textures, as Mitsuba 3's BSDF adapters give them:
//!
//! * [`NormalMap::Tangent`] (`normalmap`): the texture's value `c` is the normal `2 c - 1` in
//!   the tangent frame of the interpolated normal and the first texture coordinate's tangent
//!   ([`perturbed_normal`]).
//! * [`NormalMap::Bump`] (`bumpmap`): the texture's luminance is a height over the surface,
//!   times `scale`; the normal is that of the surface displaced by it, to first order and
//!   ignoring how the base normal turns along the surface ([`bumped_normal`]). Only the height's
//!   variation matters: a constant offset changes nothing.
//!
//! Both turn the shading normal only: the geometry, and so visibility, stay as they were, and
//! every shading normal is kept on the geometric normal's side (where the map would tilt it
//! past, the interpolated normal is kept).

use crate::texture::Texture;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// A texture that turns a material's shading normal.
#[derive(Debug, Clone, PartialEq)]
pub enum NormalMap {
    /// A tangent-space normal map.
    Tangent(Arc<Texture>),
    /// A height field: the texture's luminance times `scale`.
    Bump {
        /// The height texture.
        height: Arc<Texture>,
        /// Multiplies the height (Mitsuba's `scale`, default 1).
        scale: f32,
    },
}

impl NormalMap {
    /// The shading normal at texture coordinates `uv` of a point with shading normal `ns`,
    /// geometric normal `ng` and position derivatives `dp_duv` by the texture coordinates.
    pub fn shading_normal(&self, uv: Vec2, ns: Vec3, ng: Vec3, dp_duv: [Vec3; 2]) -> Vec3 {
        match self {
            NormalMap::Tangent(t) => perturbed_normal(t.eval(uv), ns, ng, dp_duv[0]),
            NormalMap::Bump { height, scale } => {
                bumped_normal(height.gradient(uv) * *scale, ns, ng, dp_duv)
            }
        }
    }
}

/// The shading normal a normal map gives: `c` (the map's value, each channel in [0, 1])
/// mapped to `2 c - 1` in the frame of the shading normal `ns` and the tangent `dp_du`
/// projected perpendicular to it (its bitangent `ns x s`), as Mitsuba 3's `normalmap`. Where
/// the tangent is degenerate any perpendicular serves; where the result is not a direction or
/// leans to the back of the geometric normal `ng`, `ns` is kept (every shading normal lies on
/// `ng`'s side).
pub fn perturbed_normal(c: Vec3, ns: Vec3, ng: Vec3, dp_du: Vec3) -> Vec3 {
    let local = c * 2.0 - Vec3::ONE;
    let s = (dp_du - ns * ns.dot(dp_du))
        .try_normalize()
        .unwrap_or_else(|| ns.any_orthonormal_vector());
    let t = ns.cross(s);
    on_the_front(s * local.x + t * local.y + ns * local.z, ns, ng)
}

/// The shading normal a bump map gives, as Mitsuba 3's `bumpmap`: with `grad` the height's
/// gradient by the texture coordinates, the tangents of the displaced surface are
/// `dp_du + ns (grad.u - ns . dp_du)` and `dp_dv + ns (grad.v - ns . dp_dv)` (each tangent's
/// component along `ns` replaced by the height's slope), and the normal is their cross
/// product, turned to `ng`'s side. Where the tangents are degenerate or the result leans to
/// the back of `ng`, `ns` is kept.
pub fn bumped_normal(grad: Vec2, ns: Vec3, ng: Vec3, dp_duv: [Vec3; 2]) -> Vec3 {
    let [dp_du, dp_dv] = dp_duv;
    let du = dp_du + ns * (grad.x - ns.dot(dp_du));
    let dv = dp_dv + ns * (grad.y - ns.dot(dp_dv));
    let n = du.cross(dv);
    on_the_front(if n.dot(ng) < 0.0 { -n } else { n }, ns, ng)
}

/// `n` normalised if it is a direction on the front of `ng`, else `ns`.
fn on_the_front(n: Vec3, ns: Vec3, ng: Vec3) -> Vec3 {
    match n.try_normalize() {
        Some(n) if n.dot(ng) > 1e-4 => n,
        _ => ns,
    }
}
