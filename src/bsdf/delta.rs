//! Delta lobes: which BSDFs have them, the probability with which [`Bsdf::sample`] picks
//! one, and a lobe's value with the Dirac left out (what a path through it contributes).

use super::{
    Bsdf, ShadingFrame, TransportMode, dielectric, fresnel, geometry_agrees, mask, plastic,
};
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

impl Bsdf {
    /// True if the BSDF has a delta lobe: every delta BSDF, smooth plastic and every mask
    /// (whose other lobes need not be). A path's vertex on such a surface is delta or not by the lobe the path
    /// takes there (`paths::Vertex::delta`), which a walk knows from its sample
    /// ([`BsdfSample::delta`](super::BsdfSample::delta)).
    #[inline]
    pub fn has_delta_lobe(&self) -> bool {
        self.is_delta() || matches!(self, Bsdf::Plastic(_) | Bsdf::Mask(_))
    }

    /// Discrete probability with which `sample` picks the delta lobe that takes `wo` to `wi`
    /// (`wi` being that lobe's direction): 1 for a mirror, F or 1 - F for a smooth dielectric;
    /// 0 for BSDFs without delta lobes. Path densities of delta vertices use it.
    #[inline]
    pub fn delta_lobe_probability(&self, sf: &ShadingFrame, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Conductor { .. } | Bsdf::FresnelConductor { .. } => 1.0,
            // The base is a conductor: one lobe when smooth (else the `_` arm: none).
            Bsdf::Tinted { .. } if self.is_delta() => 1.0,
            Bsdf::Dielectric { eta } => {
                let (wo_l, wi_l) = (sf.frame.to_local(wo), sf.frame.to_local(wi));
                let (f, _, _) = fresnel::dielectric(wo_l.z, *eta);
                if wo_l.z * wi_l.z > 0.0 { f } else { 1.0 - f }
            }
            Bsdf::ThinDielectric { eta } => {
                let (wo_l, wi_l) = (sf.frame.to_local(wo), sf.frame.to_local(wi));
                let r = dielectric::thin_reflectance(wo_l.z, *eta);
                if wo_l.z * wi_l.z > 0.0 { r } else { 1.0 - r }
            }
            Bsdf::Plastic(p) => {
                plastic::delta_probability(p, sf.frame.to_local(wo), sf.frame.to_local(wi))
            }
            Bsdf::Mask(m) => mask::delta_lobe_probability(m, sf, wo, wi),
            _ => 0.0,
        }
    }

    /// `f |cos(wi)|` of the delta lobe that takes `wo` to `wi` (`wi` being that lobe's
    /// direction), the Dirac left out (the measure of DESIGN.md §3), in radiance mode: a
    /// mirror's reflectance, a smooth dielectric's `F` or `1 - F` (over `eta^2` when
    /// refracting), smooth plastic's `F(cos_o)` times its specular reflectance; zero for
    /// BSDFs without delta lobes. A path's contribution uses it at its delta vertices.
    pub fn delta_value(&self, sf: &ShadingFrame, wo: Vec3, wi: Vec3) -> Spectrum {
        let n = sf.frame.n;
        let transmit = wo.dot(n) * wi.dot(n) < 0.0;
        if let Bsdf::Plastic(p) = self {
            if !geometry_agrees(sf, wo, wi, transmit) {
                return Spectrum::ZERO;
            }
            return plastic::delta_value(p, sf.frame.to_local(wo), sf.frame.to_local(wi));
        }
        if let Bsdf::Mask(m) = self {
            return mask::delta_value(m, sf, wo, wi);
        }
        if !self.is_delta() {
            return Spectrum::ZERO;
        }
        // The lobe `sample` picks with u_lobe 0 (reflection) or 1 (transmission).
        let u_lobe = if transmit { 1.0 } else { 0.0 };
        match self.sample(sf, wo, u_lobe, Vec2::ZERO, TransportMode::Radiance) {
            Some(bs) if bs.transmission == transmit => bs.f * bs.wi.dot(n).abs(),
            _ => Spectrum::ZERO,
        }
    }
}
