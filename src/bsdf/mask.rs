//! Opacity masks (Mitsuba's `mask`): a surface that is only partly there, e.g. a leaf cut out
//! of a quad by a texture.
//!
//! With opacity `a` at the point (a number, or a texture's luminance, clipped to [0, 1]), the
//! surface is the wrapped BSDF scaled by `a` beside a *null* lobe of weight `1 - a` that lets
//! light through unchanged: a delta transmission to `wi = -wo` with `f |cos| = 1 - a`.
//! Sampling picks the null lobe with probability `1 - a` (weight 1), else samples the wrapped
//! BSDF with its lobe number rescaled, its density times `a`; `eval` and `pdf` are `a` times
//! the wrapped BSDF's. This is Mitsuba 3's `mask`, whose null lobe is a delta lobe for its
//! integrators too: shadow rays and connections stop at a masked surface, and the light
//! behind it is reached through the null lobe, which counts as a bounce.
//!
//! A path through the null lobe is delta there (`paths::Vertex::delta`), as one through
//! smooth plastic's coating. A one-sided wrapped BSDF is black from the back: there the
//! share `a` is absorbed and the null lobe still lets `1 - a` through, as in Mitsuba.
//!
//! The functions are kept out of line for the reason given in `tinted.rs`.

use super::{Bsdf, BsdfSample, EvalPdfs, ShadingFrame, TransportMode};
use crate::math::{Spectrum, luminance};
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// Where a mask's opacity comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Opacity {
    /// The same everywhere, in [0, 1].
    Constant(f32),
    /// A texture's luminance at the point, clipped to [0, 1] (Mitsuba's `eval_1`).
    Texture(Arc<Texture>),
}

impl Opacity {
    /// The opacity at texture coordinates `uv`.
    #[inline]
    pub fn at(&self, uv: Vec2) -> f32 {
        match self {
            Opacity::Constant(a) => *a,
            Opacity::Texture(t) => luminance(t.eval(uv)).clamp(0.0, 1.0),
        }
    }

    /// The smallest and largest opacity anywhere.
    pub fn range(&self) -> (f32, f32) {
        match self {
            Opacity::Constant(a) => (*a, *a),
            // A luminance lies between the smallest and the largest channel.
            Opacity::Texture(t) => {
                let (lo, hi) = t.range();
                (lo.clamp(0.0, 1.0), hi.clamp(0.0, 1.0))
            }
        }
    }
}

/// A BSDF with an opacity mask.
#[derive(Debug, Clone, PartialEq)]
pub struct Mask {
    /// The surface where it is there (not itself a mask).
    pub inner: Bsdf,
    /// How much of it is there.
    pub opacity: Opacity,
    /// Whether `inner` is black seen from the back of the shape (Mitsuba's BSDFs without
    /// `twosided`); the null lobe works from both sides.
    pub inner_one_sided: bool,
    /// `inner.is_delta()`, kept so that [`Bsdf::is_delta`] need not call itself.
    pub(super) inner_delta: bool,
    /// Whether the opacity or `inner` reads texture coordinates.
    pub(super) textured: bool,
}

impl Mask {
    /// `inner` with opacity `opacity`; `inner_one_sided`: black from the back.
    pub fn new(inner: Bsdf, opacity: Opacity, inner_one_sided: bool) -> Mask {
        debug_assert!(!matches!(inner, Bsdf::Mask(_)));
        Mask {
            inner_delta: inner.is_delta(),
            textured: inner.is_textured() || matches!(opacity, Opacity::Texture(_)),
            inner,
            opacity,
            inner_one_sided,
        }
    }

    /// Whether the wrapped BSDF scatters light arriving from direction `w` (not when it is
    /// one-sided and `w` is on the back).
    #[inline]
    fn inner_seen_from(&self, sf: &ShadingFrame, w: Vec3) -> bool {
        !(self.inner_one_sided && w.dot(sf.ng) < 0.0)
    }

    /// The opacity at the frame's point, as the wrapped BSDF's share of `eval` and `pdf` from
    /// `w`: 0 where it is black from that side (the null lobe's `1 - a` is the same from
    /// both).
    #[inline]
    fn share_from(&self, sf: &ShadingFrame, w: Vec3) -> f32 {
        if self.inner_seen_from(sf, w) {
            self.opacity.at(sf.uv)
        } else {
            0.0
        }
    }
}

/// `a` times the wrapped BSDF's value.
#[inline(never)]
pub(super) fn eval(
    m: &Mask,
    sf: &ShadingFrame,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> Spectrum {
    let a = m.share_from(sf, wo);
    if a == 0.0 {
        return Spectrum::ZERO;
    }
    m.inner.eval(sf, wo, wi, mode) * a
}

/// `a` times the wrapped BSDF's density (the null lobe has none).
#[inline(never)]
pub(super) fn pdf(m: &Mask, sf: &ShadingFrame, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
    let a = m.share_from(sf, wo);
    if a == 0.0 {
        return 0.0;
    }
    m.inner.pdf(sf, wo, wi, mode) * a
}

/// The wrapped BSDF's value and densities, each times `a` (from the side each starts on).
#[inline(never)]
pub(super) fn eval_pdfs(
    m: &Mask,
    sf: &ShadingFrame,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> EvalPdfs {
    let (a_o, a_i) = (m.share_from(sf, wo), m.share_from(sf, wi));
    if a_o == 0.0 && a_i == 0.0 {
        return EvalPdfs::ZERO;
    }
    let e = m.inner.eval_pdfs(sf, wo, wi, mode);
    EvalPdfs {
        f: e.f * a_o,
        pdf_fwd: e.pdf_fwd * a_o,
        pdf_rev: e.pdf_rev * a_i,
    }
}

/// The null lobe with probability `1 - a`, else the wrapped BSDF's sample (`None` where it is
/// black from `wo`'s side: that share of the light is absorbed).
#[inline(never)]
pub(super) fn sample(
    m: &Mask,
    sf: &ShadingFrame,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
    mode: TransportMode,
) -> Option<BsdfSample> {
    let a = m.opacity.at(sf.uv);
    if u_lobe < a {
        if !m.inner_seen_from(sf, wo) {
            return None;
        }
        let mut s = m.inner.sample(sf, wo, u_lobe / a, u, mode)?;
        (s.f, s.pdf) = (s.f * a, s.pdf * a);
        return Some(s);
    }
    let wi = -wo;
    let cos = wi.dot(sf.frame.n).abs();
    if cos == 0.0 || wo.dot(sf.ng) == 0.0 {
        return None;
    }
    // f |cos| / pdf = 1: the light goes on unchanged.
    Some(BsdfSample {
        wi,
        f: Spectrum::splat((1.0 - a) / cos),
        pdf: 1.0 - a,
        weight: Spectrum::ONE,
        delta: true,
        transmission: true,
        eta: 1.0,
    })
}

/// Which delta lobes take `wo` to `wi`: the null lobe when `wi` is straight on (`wi . wo`
/// within rounding of -1, as a path's positions give it), the wrapped BSDF's otherwise, and
/// both for a thin dielectric, whose own transmission goes straight on too.
#[inline]
fn delta_lobes(m: &Mask, wo: Vec3, wi: Vec3) -> (bool, bool) {
    if wo.dot(wi) >= -1.0 + 1e-5 {
        return (false, true);
    }
    (true, matches!(m.inner, Bsdf::ThinDielectric { .. }))
}

/// The discrete probability of the delta lobes taking `wo` to `wi` ([`delta_lobes`]): the
/// null lobe's `1 - a`, and `a` times the wrapped BSDF's.
#[inline(never)]
pub(super) fn delta_lobe_probability(m: &Mask, sf: &ShadingFrame, wo: Vec3, wi: Vec3) -> f32 {
    let (null, inner) = delta_lobes(m, wo, wi);
    let mut p = if null { 1.0 - m.opacity.at(sf.uv) } else { 0.0 };
    if inner {
        p += m.share_from(sf, wo) * m.inner.delta_lobe_probability(sf, wo, wi);
    }
    p
}

/// `f |cos|` of the delta lobes taking `wo` to `wi`, the Dirac left out, split as
/// [`delta_lobe_probability`] splits them.
#[inline(never)]
pub(super) fn delta_value(m: &Mask, sf: &ShadingFrame, wo: Vec3, wi: Vec3) -> Spectrum {
    let (null, inner) = delta_lobes(m, wo, wi);
    let mut value = if null {
        Spectrum::splat(1.0 - m.opacity.at(sf.uv))
    } else {
        Spectrum::ZERO
    };
    if inner {
        value += m.inner.delta_value(sf, wo, wi) * m.share_from(sf, wo);
    }
    value
}

/// Roulette's continuation: at most the null lobe's weight plus the wrapped BSDF's share, at
/// the least and most opaque points of the mask.
#[inline(never)]
pub(super) fn continuation(m: &Mask) -> f32 {
    let (lo, hi) = m.opacity.range();
    ((1.0 - lo) + hi * m.inner.continuation()).min(1.0)
}
