//! A blend of two BSDFs (Mitsuba's `blendbsdf`): with weight `w` at the point (a number, or a
//! texture's luminance, clipped to [0, 1]), `f = (1 - w) f_first + w f_second`.
//!
//! Sampling picks the second BSDF with probability `w` (its lobe number rescaled, as
//! Mitsuba's does), else the first, and returns the blend's own value and density at the
//! direction drawn: the mixture density `(1 - w) p_first + w p_second`, so a sample's `pdf`
//! is `Bsdf::pdf` of its direction, as every technique's MIS needs. Both BSDFs are without
//! delta lobes (the loader refuses others): a blend is then a smooth BSDF like any other.
//!
//! The functions are kept out of line for the reason given in `tinted.rs`.

use super::{Bsdf, BsdfSample, EvalPdfs, ShadingFrame, TransportMode, mask::Opacity};
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

/// Two BSDFs mixed by a weight.
#[derive(Debug, Clone, PartialEq)]
pub struct Blend {
    /// Weighted by `1 - w`.
    pub first: Bsdf,
    /// Weighted by `w`.
    pub second: Bsdf,
    /// The weight `w` of the second BSDF.
    pub weight: Opacity,
}

impl Blend {
    /// `(1 - weight) first + weight second`; `None` if either has a delta lobe (or is itself a
    /// blend: nesting is left to the loader's error).
    pub fn new(first: Bsdf, second: Bsdf, weight: Opacity) -> Option<Blend> {
        let smooth = |b: &Bsdf| !b.has_delta_lobe();
        (smooth(&first) && smooth(&second)).then_some(Blend {
            first,
            second,
            weight,
        })
    }

    /// The two BSDFs' shares at the frame's point: `(1 - w, w)`.
    #[inline]
    fn shares(&self, sf: &ShadingFrame) -> (f32, f32) {
        let w = self.weight.at(sf.uv);
        (1.0 - w, w)
    }
}

/// `(1 - w) f_first + w f_second`.
#[inline(never)]
pub(super) fn eval(
    b: &Blend,
    sf: &ShadingFrame,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> Spectrum {
    let (s0, s1) = b.shares(sf);
    let mut f = Spectrum::ZERO;
    if s0 > 0.0 {
        f += b.first.eval(sf, wo, wi, mode) * s0;
    }
    if s1 > 0.0 {
        f += b.second.eval(sf, wo, wi, mode) * s1;
    }
    f
}

/// `(1 - w) p_first + w p_second`: the density of [`sample`].
#[inline(never)]
pub(super) fn pdf(b: &Blend, sf: &ShadingFrame, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
    let (s0, s1) = b.shares(sf);
    let mut p = 0.0;
    if s0 > 0.0 {
        p += b.first.pdf(sf, wo, wi, mode) * s0;
    }
    if s1 > 0.0 {
        p += b.second.pdf(sf, wo, wi, mode) * s1;
    }
    p
}

/// Value and densities in both directions, each the two BSDFs' mixed by their shares.
#[inline(never)]
pub(super) fn eval_pdfs(
    b: &Blend,
    sf: &ShadingFrame,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> EvalPdfs {
    let (s0, s1) = b.shares(sf);
    let mut out = EvalPdfs::ZERO;
    for (bsdf, share) in [(&b.first, s0), (&b.second, s1)] {
        if share > 0.0 {
            let e = bsdf.eval_pdfs(sf, wo, wi, mode);
            out.f += e.f * share;
            out.pdf_fwd += e.pdf_fwd * share;
            out.pdf_rev += e.pdf_rev * share;
        }
    }
    out
}

/// The second BSDF's sample with probability `w`, else the first's; the blend's value and
/// mixture density at the direction drawn.
#[inline(never)]
pub(super) fn sample(
    b: &Blend,
    sf: &ShadingFrame,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
    mode: TransportMode,
) -> Option<BsdfSample> {
    let (s0, s1) = b.shares(sf);
    let s = if u_lobe < s1 {
        b.second.sample(sf, wo, u_lobe / s1, u, mode)?
    } else {
        b.first.sample(sf, wo, (u_lobe - s1) / s0, u, mode)?
    };
    // Each BSDF's value and density at the direction, in one evaluation each.
    let (mut f, mut pdf) = (Spectrum::ZERO, 0.0);
    for (bsdf, share) in [(&b.first, s0), (&b.second, s1)] {
        if share > 0.0 {
            let (fi, pi) = bsdf.eval_pdf(sf, wo, s.wi, mode);
            f += fi * share;
            pdf += pi * share;
        }
    }
    let weight = f * (s.wi.dot(sf.frame.n).abs() / pdf);
    if !(weight.is_finite() && pdf > 0.0) || weight == Spectrum::ZERO {
        return None;
    }
    Some(BsdfSample {
        f,
        pdf,
        weight,
        ..s
    })
}

/// Roulette's continuation: the larger of the two BSDFs'.
pub(super) fn continuation(b: &Blend) -> f32 {
    b.first.continuation().max(b.second.continuation())
}
