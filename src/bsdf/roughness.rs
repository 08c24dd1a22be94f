//! A microfacet BSDF's roughness ([`Alpha`]): one number, two (anisotropic: along the shading
//! frame's two tangents), or a texture, turned into the distribution a point is evaluated
//! with ([`Alpha::microfacet`]).

use super::microfacet::{Distribution, Microfacet, clamp_alpha};
use glam::Vec2;

/// A microfacet BSDF's roughness: a number, two numbers (anisotropic), or a texture looked
/// up at the point (Mitsuba's textured `alpha`: the texture's luminance), each raised to at
/// least [`super::microfacet::MIN_ALPHA`].
#[derive(Debug, Clone, PartialEq)]
pub enum Alpha {
    /// The same roughness everywhere (already clamped).
    Constant(f32),
    /// Roughness `u` along the shading frame's `s` axis (the surface's `dp/du`) and `v`
    /// along `t` (Mitsuba's `alpha_u`, `alpha_v`; already clamped).
    Anisotropic {
        /// Roughness along `s`.
        u: f32,
        /// Roughness along `t`.
        v: f32,
    },
    /// The roughness at texture coordinates `uv` is the texture's luminance there.
    Texture(std::sync::Arc<crate::texture::Texture>),
}

impl From<f32> for Alpha {
    /// A constant roughness, clamped.
    fn from(alpha: f32) -> Alpha {
        Alpha::Constant(clamp_alpha(alpha))
    }
}

impl Alpha {
    /// Anisotropic roughness `u` along `s` and `v` along `t`, each clamped; a constant one
    /// where the two are equal.
    pub fn anisotropic(u: f32, v: f32) -> Alpha {
        let (u, v) = (clamp_alpha(u), clamp_alpha(v));
        if u == v {
            Alpha::Constant(u)
        } else {
            Alpha::Anisotropic { u, v }
        }
    }

    /// The distribution `kind` with this roughness at texture coordinates `uv`.
    #[inline]
    pub fn microfacet(&self, kind: Distribution, uv: Vec2) -> Microfacet {
        match self {
            Alpha::Constant(a) => Microfacet::new(kind, *a),
            Alpha::Anisotropic { u, v } => Microfacet::anisotropic(kind, *u, *v),
            Alpha::Texture(t) => {
                Microfacet::new(kind, clamp_alpha(crate::math::luminance(t.eval(uv))))
            }
        }
    }

    /// At most the smallest roughness anywhere (a texture's smallest channel value bounds its
    /// luminance from below): how close to a mirror the surface can be.
    pub fn smallest(&self) -> f32 {
        match self {
            Alpha::Constant(a) => *a,
            Alpha::Anisotropic { u, v } => u.min(*v),
            Alpha::Texture(t) => clamp_alpha(t.range().0),
        }
    }

    /// True if the roughness is looked up at the point's texture coordinates.
    pub fn is_textured(&self) -> bool {
        matches!(self, Alpha::Texture(_))
    }

    /// True if the roughness differs between the two tangent directions (the BSDF then
    /// needs the shading frame's tangent to follow the surface's `dp/du`).
    pub fn is_anisotropic(&self) -> bool {
        matches!(self, Alpha::Anisotropic { .. })
    }
}
