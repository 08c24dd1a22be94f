//! Rough plastic (Mitsuba's `roughplastic`): a rough dielectric coating over a Lambertian
//! base, two-sided like the diffuse BSDF (the scene loaders make it one-sided where Mitsuba's
//! is).
//!
//! In the local frame, with `m = normalize(wo + wi)`, `eta` = index inside / outside:
//! * the coating reflects `F(wo.m, eta) D(m) G1(wo) G1(wi) / (4 cos_o cos_i)` times the
//!   specular reflectance (Mitsuba's separable masking-shadowing, not the height-correlated
//!   `G2` of the rough conductor, so that the images agree with Mitsuba's);
//! * the base is seen through the coating twice: `rho / (1 - R_int) t(cos_o) t(cos_i) /
//!   (pi eta^2)`, where `t(cos)` is the energy the rough interface transmits (its refraction
//!   lobe's directional albedo), `R_int = 2 ∫ A_int(mu) mu dmu` the coating's diffuse
//!   reflectance from inside (`A_int` the reflection lobe's albedo with `1 / eta`), and
//!   `rho / (1 - R_int)` sums the light bounced between base and coating; with `nonlinear`,
//!   `rho / (1 - rho R_int)` instead. `t` is tabulated at 64 cosines and interpolated
//!   linearly, `R_int` is the cosine-weighted mean over the same cosines, both as Mitsuba 3
//!   computes them (Gauss-Legendre quadratures over visible normals, 32 x 32 nodes outside and
//!   128 x 128 inside), once per process for each coating.
//!
//! Sampling picks the coating with probability `(1 - t(cos_o)) w / ((1 - t(cos_o)) w +
//! t(cos_o) (1 - w))`, `w` the specular reflectance's mean over the sum of both means, then
//! a visible normal; else a cosine-weighted direction. The density is the mixture's.

use super::fresnel;
use super::microfacet::{Distribution, Microfacet, Smith, flip_z, reflect, refract};
use super::plastic::{base_reflectance, specular_weight};
use super::{LocalSample, diffuse};
use crate::math::{INV_PI, Spectrum};
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::{Arc, Mutex};

/// Cosines at which the coating's transmittance is tabulated (Mitsuba's resolution).
const TABLE: usize = 64;

/// Gauss-Legendre nodes per axis of the albedo quadratures (Mitsuba's): from outside (eta
/// > 1) and from inside, where total internal reflection makes the integrand less smooth.
const NODES_OUTSIDE: usize = 32;
const NODES_INSIDE: usize = 128;

/// The coating's precomputed terms.
#[derive(Debug, PartialEq)]
struct Tables {
    /// `t(cos)` at cosines `i / 63`.
    transmittance: [f32; TABLE],
    /// `R_int`.
    internal_reflectance: f32,
}

/// A rough plastic's parameters and its precomputed coating terms.
#[derive(Debug, Clone, PartialEq)]
pub struct RoughPlastic {
    /// Reflectance of the Lambertian base.
    pub diffuse: Spectrum,
    /// The base's reflectance as a texture, in place of `diffuse` (set by
    /// [`RoughPlastic::with_diffuse_texture`]).
    pub diffuse_texture: Option<Arc<Texture>>,
    /// Scale of the coating's reflection.
    pub specular: Spectrum,
    /// Index inside over index outside.
    pub eta: f32,
    /// Roughness of the coating.
    pub alpha: f32,
    /// The coating's microfacet distribution.
    pub distribution: Distribution,
    /// Whether the base's reflectance enters the interreflection sum (see the module docs).
    pub nonlinear: bool,
    /// `t(cos)` and `R_int`.
    tables: Arc<Tables>,
    /// `w`: the specular reflectance's share of both means.
    specular_weight: f32,
}

impl RoughPlastic {
    /// A rough plastic; `alpha` is clamped as for every microfacet BSDF.
    pub fn new(
        diffuse: Spectrum,
        specular: Spectrum,
        eta: f32,
        alpha: f32,
        distribution: Distribution,
        nonlinear: bool,
    ) -> RoughPlastic {
        let alpha = super::microfacet::clamp_alpha(alpha);
        let tables = tables(distribution, alpha, eta);

        RoughPlastic {
            diffuse,
            diffuse_texture: None,
            specular,
            eta,
            alpha,
            distribution,
            nonlinear,
            tables,
            specular_weight: specular_weight(diffuse.element_sum() / 3.0, specular),
        }
    }

    /// The plastic with its base's reflectance looked up in `texture` at the point's texture
    /// coordinates; the lobe choice takes the texture's mean as Mitsuba's does.
    pub fn with_diffuse_texture(mut self, texture: Arc<Texture>) -> RoughPlastic {
        self.specular_weight = specular_weight(texture.mean().element_sum() / 3.0, self.specular);
        self.diffuse_texture = Some(texture);
        self
    }

    /// The base's reflectance at texture coordinates `uv`.
    #[inline]
    fn diffuse_at(&self, uv: Vec2) -> Spectrum {
        base_reflectance(self.diffuse, &self.diffuse_texture, uv)
    }

    /// The base's largest reflectance anywhere (for roulette).
    pub fn diffuse_max(&self) -> f32 {
        match &self.diffuse_texture {
            Some(t) => t.max(),
            None => self.diffuse.max_element(),
        }
    }

    /// `t(cos)`, linearly interpolated.
    fn t(&self, cos: f32) -> f32 {
        let x = cos.clamp(0.0, 1.0) * (TABLE - 1) as f32;
        let i = (x as usize).min(TABLE - 2);
        let w = x - i as f32;
        let t = &self.tables.transmittance;
        (1.0 - w) * t[i] + w * t[i + 1]
    }

    /// The probability of sampling the coating for `cos_o`.
    fn p_coating(&self, cos_o: f32) -> f32 {
        let t = self.t(cos_o);
        let w = self.specular_weight;
        let (s, d) = ((1.0 - t) * w, t * (1.0 - w));
        if s + d > 0.0 { s / (s + d) } else { 0.0 }
    }

    fn microfacet(&self) -> Microfacet {
        Microfacet::new(self.distribution, self.alpha)
    }

    /// The base's value: `rho / (1 - R_int) t_o t_i / (pi eta^2)` (or the nonlinear sum).
    fn base(&self, cos_o: f32, cos_i: f32, uv: Vec2) -> Spectrum {
        let r = self.tables.internal_reflectance;
        let diffuse = self.diffuse_at(uv);
        let rho = if self.nonlinear {
            diffuse / (Spectrum::ONE - diffuse * r)
        } else {
            diffuse / (1.0 - r)
        };
        rho * (INV_PI * self.t(cos_o) * self.t(cos_i) / (self.eta * self.eta))
    }
}

/// What the coating does to light arriving at cosine `cos`, as its lobes are sampled (visible
/// normals `m` over the unit square, Gauss-Legendre nodes `rule`): `(reflected,
/// transmitted)` = `(E[F(wo.m) G1(wi)], E[(1 - F(wo.m)) G1(wt)])`, `wi` the reflection and `wt`
/// the refraction of `wo` about `m` (each 0 where it leaves on the wrong side).
fn coating(mf: Microfacet, eta: f32, cos: f32, rule: &[(f64, f64)]) -> (f64, f64) {
    let wo = Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos);
    let (mut reflected, mut transmitted) = (0.0f64, 0.0f64);
    for &(xa, wa) in rule {
        let row = mf.visible_row(wo, xa as f32);
        for &(xb, wb) in rule {
            let Some(m) = row.sample(xb as f32) else {
                continue;
            };
            let weight = wa * wb;
            let cos_o = wo.dot(m);
            let (f, cos_t, eta_r) = fresnel::dielectric(cos_o, eta);
            let wi = reflect(wo, m);
            if wi.z > 0.0 {
                reflected += weight * (f * mf.g1(wi)) as f64;
            }
            if f < 1.0 {
                let wt = refract(wo, m, cos_o, cos_t, eta_r);
                if wt.z < 0.0 {
                    transmitted += weight * ((1.0 - f) * mf.g1(wt)) as f64;
                }
            }
        }
    }
    (reflected, transmitted)
}

/// `n` Gauss-Legendre nodes and weights mapped to [0, 1] (weights summing to 1), by Newton's
/// iteration on the Legendre polynomial.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (1..=n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 - 0.25) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0f64, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    (p0, p1) = (p1, p2);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / dp;
                x -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            (0.5 * x + 0.5, 0.5 * w)
        })
        .collect()
}

/// The coating's tables for (distribution, alpha, eta), computed once per process: materials
/// that differ only in colour share them.
fn tables(distribution: Distribution, alpha: f32, eta: f32) -> Arc<Tables> {
    /// (distribution, alpha bits, eta bits): what the tables depend on.
    type Key = (Distribution, u32, u32);
    static CACHE: Mutex<Vec<(Key, Arc<Tables>)>> = Mutex::new(Vec::new());
    let key = (distribution, alpha.to_bits(), eta.to_bits());
    if let Some((_, t)) = CACHE.lock().unwrap().iter().find(|(k, _)| *k == key) {
        return t.clone();
    }
    let mf = Microfacet::new(distribution, alpha);
    let mu = |i: usize| (i as f32 / (TABLE - 1) as f32).max(1e-6);
    let (outside, inside) = (gauss_legendre(NODES_OUTSIDE), gauss_legendre(NODES_INSIDE));
    // Both tables at once, a cosine per task (the same numbers on any thread count).
    let pairs: Vec<(f32, f64)> = (0..TABLE)
        .into_par_iter()
        .map(|i| {
            let t = coating(mf, eta, mu(i), &outside).1 as f32;
            let r = coating(mf, 1.0 / eta, mu(i), &inside).0 * mu(i) as f64;
            (t, r)
        })
        .collect();
    let mut transmittance = [0.0; TABLE];
    for (t, &(v, _)) in transmittance.iter_mut().zip(&pairs) {
        *t = v;
    }
    let internal = pairs.iter().map(|&(_, r)| r).sum::<f64>() / TABLE as f64;
    let t = Arc::new(Tables {
        transmittance,
        internal_reflectance: (2.0 * internal) as f32,
    });
    CACHE.lock().unwrap().push((key, t.clone()));
    t
}

/// `(f, pdf)` of the pair in the local frame at texture coordinates `uv`, zero unless both
/// are strictly on one side; `f` only when `value` (densities alone skip it).
// `!(x > 0.0)` deliberately rejects NaN as well.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(super) fn eval_pdf(
    p: &RoughPlastic,
    wo: Vec3,
    wi: Vec3,
    value: bool,
    uv: Vec2,
) -> (Spectrum, f32) {
    const ZERO: (Spectrum, f32) = (Spectrum::ZERO, 0.0);
    if !(wo.z * wi.z > 0.0) {
        return ZERO;
    }
    let flip = wo.z < 0.0;
    let (wo, wi) = (flip_z(wo, flip), flip_z(wi, flip));
    let p_coating = p.p_coating(wo.z);
    let mut pdf = (1.0 - p_coating) * diffuse::pdf(wo, wi);
    let mut f = if value {
        p.base(wo.z, wi.z, uv)
    } else {
        Spectrum::ZERO
    };
    let h = wo + wi;
    let len = h.length();
    if len > 0.0 {
        let m = h / len;
        let wo_m = wo.dot(m);
        if wo_m > 0.0 {
            let mf = p.microfacet();
            let d = mf.d(m);
            let (g1_o, g1_i) = (mf.g1(wo), mf.g1(wi));
            let lobe_pdf = g1_o * d / (4.0 * wo.z);
            let f_unit = d * g1_o * g1_i / (4.0 * wo.z * wi.z);
            if lobe_pdf.is_finite() && f_unit.is_finite() {
                pdf += p_coating * lobe_pdf;
                if value {
                    f += p.specular * (fresnel::dielectric(wo_m, p.eta).0 * f_unit);
                }
            }
        }
    }
    if !(pdf > 0.0 && pdf.is_finite()) {
        return ZERO;
    }
    (f, pdf)
}

pub(super) fn sample(
    p: &RoughPlastic,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
    uv: Vec2,
) -> Option<LocalSample> {
    let flip = wo.z < 0.0;
    let wo_up = flip_z(wo, flip);
    let wi_up = if u_lobe < p.p_coating(wo_up.z) {
        let m = p.microfacet().sample_visible(wo_up, u)?;
        let wi = reflect(wo_up, m);
        if wi.z <= 0.0 {
            return None;
        }
        wi
    } else {
        diffuse::sample(Spectrum::ONE, wo_up, u)?.wi
    };
    let wi = flip_z(wi_up, flip);
    let (f, pdf) = eval_pdf(p, wo, wi, true, uv);
    LocalSample::glossy_reflection(wi, f, pdf)
}
