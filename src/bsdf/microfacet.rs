//! Microfacet distributions: GGX / Trowbridge-Reitz ([`Ggx`]) and Beckmann ([`Beckmann`]),
//! isotropic or anisotropic, and [`Microfacet`], the one a rough BSDF was given
//! ([`Distribution`]); a BSDF's roughness, perhaps textured or anisotropic, is an [`super::Alpha`]
//! (`roughness.rs`).
//!
//! Anisotropic distributions have roughness `alpha_x` along the shading frame's `s` axis
//! (Mitsuba's `alpha_u`, along the surface's `dp/du`) and `alpha_y` along `t` (`alpha_v`).
//! Every formula below is the isotropic one of the stretched configuration: a slope (x, y)
//! of the distribution is (x / alpha_x, y / alpha_y) of the one with alpha = 1 (Heitz 2014),
//! so `tan^2(theta_m) / alpha^2` reads `tan^2(theta_m) (cos^2 phi / alpha_x^2 + sin^2 phi /
//! alpha_y^2)`, the `alpha^2` before it `alpha_x alpha_y`, and Smith's `alpha tan(theta)`
//! `tan(theta) sqrt(alpha_x^2 cos^2 phi + alpha_y^2 sin^2 phi)`. With equal roughnesses the
//! code computes the isotropic expressions bit for bit.
//!
//! GGX:
//! Everything here works in the local shading frame (`z` = macro-surface normal) with the
//! directions in the **upper** hemisphere: callers mirror a configuration with `wo.z < 0`
//! through the `z = 0` plane first (the distribution is symmetric under that mirror).
//!
//! * `D(m) = 1 / (pi alpha^2 cos^4(theta_m) (1 + tan^2(theta_m) / alpha^2)^2)`, normalised
//!   so that the projected area `∫ D(m) cos(theta_m) dm` is 1.
//! * Smith `Lambda(w) = (sqrt(1 + alpha^2 tan^2(theta)) - 1) / 2`, `G1 = 1 / (1 + Lambda)`.
//! * `G2` is the **height-correlated** Smith form `1 / (1 + Lambda(wo) + Lambda(wi))` (Heitz
//!   2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs"). It is
//!   exact for reflection under the Smith assumptions. For transmission the same expression
//!   is used, as pbrt-v4 and Cycles do; the exact height-correlated transmission term is
//!   `B(1 + Lambda(wo), 1 + Lambda(wi))` (a Beta function, since the two directions look at
//!   the surface from opposite sides), which is smaller, so ours transmits slightly more at
//!   rough, grazing configurations. It is symmetric in its arguments, so reciprocity holds.
//! * Visible-normal sampling by spherical caps (Dupuy & Benyoub 2023, "Sampling Visible GGX
//!   Normals with Spherical Caps"), exact for the density
//!   `D_wo(m) = G1(wo) max(0, wo.m) D(m) / wo.z` (Heitz 2018).
//!
//! `alpha` is clamped to at least [`MIN_ALPHA`] so that every density stays finite in `f32`
//! (the peak of `D` is `1 / (pi alpha^2)`, 3.2e7 at the minimum).

use crate::math::PI;
use glam::{Vec2, Vec3};

/// Smallest roughness used; smaller (or NaN) values are raised to it.
pub const MIN_ALPHA: f32 = 1e-4;

/// Clamps a roughness to `[MIN_ALPHA, inf)`; NaN becomes `MIN_ALPHA`.
#[inline]
pub fn clamp_alpha(alpha: f32) -> f32 {
    // `f32::max` returns the non-NaN operand.
    alpha.max(MIN_ALPHA)
}

/// GGX distribution of roughness `alpha_x` along x and `alpha_y` along y (the "alpha" of
/// Walter et al.; isotropic when equal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ggx {
    alpha_x: f32,
    alpha_y: f32,
    /// `alpha_y / alpha_x` and its inverse (exactly 1 when isotropic), for [`stretched`].
    ratio: (f32, f32),
}

/// `(x^2 r + y^2 / r)` with `r` the ratio of the two roughnesses given: the stretched squared
/// length of a tangent vector (x, y) times `alpha_x alpha_y` (or divided by it), which is
/// `x^2 + y^2` exactly when the roughnesses are equal (`r` = 1).
#[inline]
fn stretched(x: f32, y: f32, r: f32, inv_r: f32) -> f32 {
    x * x * r + y * y * inv_r
}

impl Ggx {
    /// Isotropic; `alpha` is clamped with [`clamp_alpha`].
    pub fn new(alpha: f32) -> Ggx {
        Ggx::anisotropic(alpha, alpha)
    }

    /// Roughness `alpha_x` along x and `alpha_y` along y, each clamped with [`clamp_alpha`].
    pub fn anisotropic(alpha_x: f32, alpha_y: f32) -> Ggx {
        let (alpha_x, alpha_y) = (clamp_alpha(alpha_x), clamp_alpha(alpha_y));
        Ggx {
            alpha_x,
            alpha_y,
            ratio: (alpha_y / alpha_x, alpha_x / alpha_y),
        }
    }

    /// The roughness along x, as clamped (the roughness of an isotropic distribution).
    pub fn alpha(&self) -> f32 {
        self.alpha_x
    }

    /// Normal distribution `D(m)` for a unit `m`; zero for `m.z <= 0`.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let a2 = ax * ay;
        // cos^2 (1 + tan^2 / alpha^2) = cos^2 + sin^2 / alpha^2, without the tan.
        let t = stretched(m.x, m.y, self.ratio.0, self.ratio.1) / a2 + m.z * m.z;
        1.0 / (PI * a2 * t * t)
    }

    /// Smith's `Lambda(w)`; infinite at (or numerically at) the horizon. Uses `|w.z|`.
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let z2 = w.z * w.z;
        if z2 == 0.0 {
            return f32::INFINITY;
        }
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let a = ax * ay * stretched(w.x, w.y, self.ratio.1, self.ratio.0) / z2;
        if !a.is_finite() {
            return f32::INFINITY;
        }
        // (sqrt(1 + a) - 1) / 2 without the cancellation for small a.
        0.5 * a / (1.0 + (1.0 + a).sqrt())
    }

    /// Samples a visible normal for `wo` (upper hemisphere, unit) with density
    /// [`Smith::d_visible`]. `None` for the measure-zero draws where the construction
    /// degenerates.
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        // Stretch to the configuration of alpha = 1, where the visible normals are uniform on
        // the spherical cap z >= -wo_std.z, shifted by wo_std.
        let wo_std = Vec3::new(wo.x * ax, wo.y * ay, wo.z).normalize();
        let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
        let sin_t = (1.0 - z * z).max(0.0).sqrt();
        let (s, c) = crate::math::warp::sin_cos_turn(u.x);
        let h = Vec3::new(sin_t * c, sin_t * s, z) + wo_std;
        // Unstretch.
        let m = Vec3::new(h.x * ax, h.y * ay, h.z.max(0.0));
        let len = m.length();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let m = m / len;
        (m.z > 0.0).then_some(m)
    }
}

/// Which microfacet distribution a rough BSDF uses (Mitsuba's `distribution`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Distribution {
    /// GGX / Trowbridge-Reitz.
    #[default]
    Ggx,
    /// Beckmann.
    Beckmann,
}

/// Beckmann distribution of roughness `alpha_x` along x and `alpha_y` along y (the RMS
/// slope times sqrt 2; isotropic when equal).
///
/// * `D(m) = exp(-tan^2(theta_m) / alpha^2) / (pi alpha^2 cos^4(theta_m))`.
/// * Smith `Lambda(w) = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi))`, `a = 1 / (alpha
///   tan(theta))`, evaluated exactly (`math::special`), not by Walter et al.'s rational fit,
///   so that the visible-normal density integrates to one and matches the sampler.
/// * `G2` height-correlated, as for GGX.
/// * Visible normals: the slope of the stretched configuration (alpha = 1) is drawn from the
///   distribution of visible slopes (Heitz and d'Eon 2014): its x component by inverting the
///   CDF `1 + b + tan(theta) / sqrt(pi) exp(-erfinv(b)^2)` over `b = erf(x)` with safeguarded
///   Newton steps, its y component from the Gaussian; then rotated to `wo`'s azimuth and
///   unstretched.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beckmann {
    alpha_x: f32,
    alpha_y: f32,
    /// `alpha_y / alpha_x` and its inverse in f64 (exactly 1 when isotropic).
    ratio: (f64, f64),
}

impl Beckmann {
    /// Isotropic; `alpha` is clamped with [`clamp_alpha`].
    pub fn new(alpha: f32) -> Beckmann {
        Beckmann::anisotropic(alpha, alpha)
    }

    /// Roughness `alpha_x` along x and `alpha_y` along y, each clamped with [`clamp_alpha`].
    pub fn anisotropic(alpha_x: f32, alpha_y: f32) -> Beckmann {
        let (alpha_x, alpha_y) = (clamp_alpha(alpha_x), clamp_alpha(alpha_y));
        let (x, y) = (alpha_x as f64, alpha_y as f64);
        Beckmann {
            alpha_x,
            alpha_y,
            ratio: (y / x, x / y),
        }
    }

    /// The roughness along x, as clamped (the roughness of an isotropic distribution).
    pub fn alpha(&self) -> f32 {
        self.alpha_x
    }

    /// Normal distribution `D(m)` for a unit `m`; zero for `m.z <= 0`.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (ax, ay) = (self.alpha_x as f64, self.alpha_y as f64);
        let a2 = ax * ay;
        let cos2 = (m.z as f64).powi(2);
        // tan^2 / alpha^2 with the stretch: (x^2 / alpha_x^2 + y^2 / alpha_y^2) / cos^2.
        let (r, inv_r) = self.ratio;
        let tan2 = ((m.x as f64).powi(2) * r + (m.y as f64).powi(2) * inv_r) / cos2;
        let e = (-tan2 / a2).exp();
        if e == 0.0 {
            return 0.0;
        }
        let v = e / (std::f64::consts::PI * a2 * cos2 * cos2);
        if v.is_finite() { v as f32 } else { 0.0 }
    }

    /// Smith's `Lambda(w)`; infinite at the horizon. Uses `|w.z|`.
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let z = (w.z as f64).abs();
        if z == 0.0 {
            return f32::INFINITY;
        }
        let (x2, y2) = ((w.x as f64).powi(2), (w.y as f64).powi(2));
        let tan = (x2 + y2).sqrt() / z;
        if tan == 0.0 {
            return 0.0;
        }
        // The roughness in w's azimuth: sqrt(alpha_x^2 cos^2 phi + alpha_y^2 sin^2 phi).
        let alpha = if self.alpha_x == self.alpha_y {
            self.alpha_x as f64
        } else {
            let (ax, ay) = (self.alpha_x as f64, self.alpha_y as f64);
            ((ax * ax * x2 + ay * ay * y2) / (x2 + y2)).sqrt()
        };
        let a = 1.0 / (alpha * tan);
        if a > 6.0 {
            // Lambda < 1e-17.
            return 0.0;
        }
        let inv_sqrt_pi = 0.5 * std::f64::consts::FRAC_2_SQRT_PI;
        let l = 0.5 * ((-a * a).exp() * inv_sqrt_pi / a - crate::math::special::erfc(a));
        l.max(0.0) as f32
    }

    /// What a visible slope of the distribution with alpha = 1, for an incident direction at
    /// `cos_theta` from the normal, takes from the first number `u1`: at normal incidence the
    /// radius of a Gaussian slope (Rayleigh), else the slope's x component in the plane of
    /// incidence (x towards the direction) by the CDF search of the type doc.
    fn slope_from_first(cos_theta: f64, u1: f32) -> FirstSlope {
        use crate::math::special::{erf, erf_inv};
        if cos_theta > 0.99999 {
            return FirstSlope::Radius((-(1.0 - u1 as f64).ln()).sqrt());
        }
        let u1 = (u1 as f64).max(1e-6);
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let tan_theta = sin_theta / cos_theta;
        let cot_theta = 1.0 / tan_theta;
        let inv_sqrt_pi = 0.5 * std::f64::consts::FRAC_2_SQRT_PI;
        // Search over b = erf(x) in [-1, erf(cot)]: the visible slopes end where the facet
        // turns away from the direction.
        let (mut lo, mut hi) = (-1.0f64, erf(cot_theta));
        let norm = 1.0 / (1.0 + hi + inv_sqrt_pi * tan_theta * (-cot_theta * cot_theta).exp());
        // First guess from a fit in theta (Jakob's), then Newton steps kept inside the bracket.
        let theta = cos_theta.acos();
        let fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
        let mut b = hi - (1.0 + hi) * (1.0 - u1).powf(fit);
        for _ in 0..100 {
            if !(b >= lo && b <= hi) {
                b = 0.5 * (lo + hi);
            }
            let x = erf_inv(b);
            let value = norm * (1.0 + b + inv_sqrt_pi * tan_theta * (-x * x).exp()) - u1;
            let derivative = norm * (1.0 - x * tan_theta);
            if value.abs() < 1e-6 {
                return FirstSlope::X(x);
            }
            if value > 0.0 {
                hi = b;
            } else {
                lo = b;
            }
            b -= value / derivative;
        }
        FirstSlope::X(erf_inv(b))
    }

    /// The visible slope (x, y) with alpha = 1 from its first part and the second number
    /// `u2`: at normal incidence the Gaussian slope's azimuth, else its y component (a
    /// Gaussian, independent of x).
    fn slope_from_second(first: FirstSlope, u2: f32) -> (f64, f64) {
        match first {
            FirstSlope::Radius(r) => {
                let phi = 2.0 * std::f64::consts::PI * u2 as f64;
                (r * phi.cos(), r * phi.sin())
            }
            FirstSlope::X(x) => {
                let u2 = (u2 as f64).max(1e-6);
                (x, crate::math::special::erf_inv(2.0 * u2 - 1.0))
            }
        }
    }

    /// The visible normals for `wo` (upper hemisphere, unit) and first number `u1`:
    /// [`Self::sample_visible`] as a function of the second number alone, the slope search
    /// done once (quadratures over the unit square call it once per row).
    pub fn visible_row(&self, wo: Vec3, u1: f32) -> BeckmannRow {
        let (ax, ay) = (self.alpha_x as f64, self.alpha_y as f64);
        // Stretch to alpha = 1.
        let (sx, sy, sz) = (wo.x as f64 * ax, wo.y as f64 * ay, wo.z as f64);
        let len = (sx * sx + sy * sy + sz * sz).sqrt();
        let (sx, sy, sz) = (sx / len, sy / len, sz / len);
        let sin_t = (sx * sx + sy * sy).sqrt();
        let (cos_phi, sin_phi) = if sin_t > 0.0 {
            (sx / sin_t, sy / sin_t)
        } else {
            (1.0, 0.0)
        };
        BeckmannRow {
            ax,
            ay,
            cos_phi,
            sin_phi,
            first: Self::slope_from_first(sz, u1),
        }
    }

    /// Samples a visible normal for `wo` (upper hemisphere, unit) with density
    /// [`Smith::d_visible`]; `None` where the construction degenerates.
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        self.visible_row(wo, u.x).sample(u.y)
    }
}

/// The part of a Beckmann visible slope drawn from the first number.
#[derive(Debug, Clone, Copy)]
enum FirstSlope {
    /// Normal incidence: the radius of the Gaussian slope.
    Radius(f64),
    /// The slope's x component in the plane of incidence.
    X(f64),
}

/// [`Beckmann::visible_row`]: `wo`'s azimuth and stretch, and the slope's first part.
#[derive(Debug, Clone, Copy)]
pub struct BeckmannRow {
    ax: f64,
    ay: f64,
    cos_phi: f64,
    sin_phi: f64,
    first: FirstSlope,
}

impl BeckmannRow {
    /// The visible normal for second number `u2`.
    pub fn sample(&self, u2: f32) -> Option<Vec3> {
        let (x, y) = Beckmann::slope_from_second(self.first, u2);
        let (cos_phi, sin_phi) = (self.cos_phi, self.sin_phi);
        // Rotate to wo's azimuth, unstretch; the normal of slope (x, y) is (-x, -y, 1).
        let (rx, ry) = (cos_phi * x - sin_phi * y, sin_phi * x + cos_phi * y);
        let m = glam::DVec3::new(-rx * self.ax, -ry * self.ay, 1.0);
        let m = m / m.length();
        let m = Vec3::new(m.x as f32, m.y as f32, m.z as f32);
        (m.is_finite() && m.z > 0.0).then_some(m)
    }
}

/// A rough BSDF's microfacet distribution: [`Ggx`] or [`Beckmann`] of one roughness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Microfacet {
    /// GGX.
    Ggx(Ggx),
    /// Beckmann.
    Beckmann(Beckmann),
}

impl Microfacet {
    /// The distribution `kind` of roughness `alpha` (clamped with [`clamp_alpha`]).
    pub fn new(kind: Distribution, alpha: f32) -> Microfacet {
        Microfacet::anisotropic(kind, alpha, alpha)
    }

    /// The distribution `kind` of roughness `alpha_x` along x and `alpha_y` along y.
    pub fn anisotropic(kind: Distribution, alpha_x: f32, alpha_y: f32) -> Microfacet {
        match kind {
            Distribution::Ggx => Microfacet::Ggx(Ggx::anisotropic(alpha_x, alpha_y)),
            Distribution::Beckmann => Microfacet::Beckmann(Beckmann::anisotropic(alpha_x, alpha_y)),
        }
    }

    /// A visible normal for `wo`, with density [`Smith::d_visible`].
    #[inline]
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        match self {
            Microfacet::Ggx(g) => g.sample_visible(wo, u),
            Microfacet::Beckmann(b) => b.sample_visible(wo, u),
        }
    }

    /// [`Self::sample_visible`] for `wo` and first number `u1` as a function of the second
    /// number: `visible_row(wo, u.x).sample(u.y)` is `sample_visible(wo, u)`, bit for bit,
    /// with Beckmann's slope search done once per row.
    pub fn visible_row(&self, wo: Vec3, u1: f32) -> VisibleRow {
        match self {
            Microfacet::Ggx(g) => VisibleRow::Ggx(*g, wo, u1),
            Microfacet::Beckmann(b) => VisibleRow::Beckmann(b.visible_row(wo, u1)),
        }
    }
}

/// [`Microfacet::visible_row`].
#[derive(Debug, Clone, Copy)]
pub enum VisibleRow {
    /// GGX's sampler with `wo` and the first number (nothing to precompute).
    Ggx(Ggx, Vec3, f32),
    /// Beckmann's, its slope search done.
    Beckmann(BeckmannRow),
}

impl VisibleRow {
    /// The visible normal for second number `u2`.
    #[inline]
    pub fn sample(&self, u2: f32) -> Option<Vec3> {
        match self {
            VisibleRow::Ggx(g, wo, u1) => g.sample_visible(*wo, Vec2::new(*u1, u2)),
            VisibleRow::Beckmann(row) => row.sample(u2),
        }
    }
}

/// The Smith microfacet model of a distribution: its `D` and `Lambda` give the masking terms
/// and the density of visible normals.
pub trait Smith {
    /// Normal distribution `D(m)` for a unit `m`; zero for `m.z <= 0`.
    fn d(&self, m: Vec3) -> f32;

    /// Smith's `Lambda(w)`; infinite at the horizon. Uses `|w.z|`.
    fn lambda(&self, w: Vec3) -> f32;

    /// Smith masking `G1(w) = 1 / (1 + Lambda(w))`.
    #[inline]
    fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing `G2 = 1 / (1 + Lambda(wo) + Lambda(wi))`.
    #[inline]
    fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// `(G1(wo), G2(wo, wi))` with `Lambda(wo)` evaluated once (what a BSDF's value and density
    /// need together).
    #[inline]
    fn g1_g2(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        let lo = self.lambda(wo);
        (1.0 / (1.0 + lo), 1.0 / (1.0 + lo + self.lambda(wi)))
    }

    /// Distribution of visible normals `D_wo(m) = G1(wo) max(0, wo.m) D(m) / |wo.z|`, a density
    /// over the solid angle of `m`. `wo` must be in the upper hemisphere.
    #[inline]
    fn d_visible(&self, wo: Vec3, m: Vec3) -> f32 {
        let cos_o = wo.z.abs();
        let wo_m = wo.dot(m);
        if cos_o == 0.0 || wo_m <= 0.0 {
            return 0.0;
        }
        let v = self.g1(wo) * wo_m * self.d(m) / cos_o;
        if v.is_finite() { v } else { 0.0 }
    }
}

impl Smith for Ggx {
    #[inline]
    fn d(&self, m: Vec3) -> f32 {
        Ggx::d(self, m)
    }
    #[inline]
    fn lambda(&self, w: Vec3) -> f32 {
        Ggx::lambda(self, w)
    }
}

impl Smith for Beckmann {
    #[inline]
    fn d(&self, m: Vec3) -> f32 {
        Beckmann::d(self, m)
    }
    #[inline]
    fn lambda(&self, w: Vec3) -> f32 {
        Beckmann::lambda(self, w)
    }
}

impl Smith for Microfacet {
    #[inline]
    fn d(&self, m: Vec3) -> f32 {
        match self {
            Microfacet::Ggx(g) => g.d(m),
            Microfacet::Beckmann(b) => b.d(m),
        }
    }
    #[inline]
    fn lambda(&self, w: Vec3) -> f32 {
        match self {
            Microfacet::Ggx(g) => g.lambda(w),
            Microfacet::Beckmann(b) => b.lambda(w),
        }
    }
}

/// `w` mirrored through the tangent plane when `flip` (the two-sided microfacet BSDFs work
/// with `wo` in the upper hemisphere).
#[inline]
pub fn flip_z(w: Vec3, flip: bool) -> Vec3 {
    if flip { Vec3::new(w.x, w.y, -w.z) } else { w }
}

/// Mirror reflection of `wo` about `m`.
#[inline]
pub fn reflect(wo: Vec3, m: Vec3) -> Vec3 {
    2.0 * wo.dot(m) * m - wo
}

/// Refraction of `wo` (on the side of `m`, `cos_o = wo.m > 0`) through a facet with normal
/// `m`, given `cos_t = |wi.m|` and `eta` = n(other side) / n(side of wo).
#[inline]
pub fn refract(wo: Vec3, m: Vec3, cos_o: f32, cos_t: f32, eta: f32) -> Vec3 {
    -wo / eta + (cos_o / eta - cos_t) * m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_forms() {
        let g = Ggx::new(0.5);
        // D at the normal is 1 / (pi alpha^2).
        assert!((g.d(Vec3::Z) - 1.0 / (PI * 0.25)).abs() < 1e-5);
        assert_eq!(g.d(-Vec3::Z), 0.0);
        // Lambda at the normal is 0, G1 = 1; at theta = 45 deg, alpha tan = 0.5.
        assert_eq!(g.lambda(Vec3::Z), 0.0);
        let w = Vec3::new(1.0, 0.0, 1.0).normalize();
        let expected = ((1.0f32 + 0.25).sqrt() - 1.0) / 2.0;
        assert!((g.lambda(w) - expected).abs() < 1e-6);
        assert_eq!(g.lambda(Vec3::X), f32::INFINITY);
        assert_eq!(g.g1(Vec3::X), 0.0);
        assert!((g.g2(w, w) - 1.0 / (1.0 + 2.0 * expected)).abs() < 1e-6);
        // Clamping.
        assert_eq!(Ggx::new(0.0).alpha(), MIN_ALPHA);
        assert_eq!(Ggx::new(f32::NAN).alpha(), MIN_ALPHA);
    }

    #[test]
    fn refraction_obeys_snell() {
        let m = Vec3::new(0.2, -0.1, 1.0).normalize();
        let wo = Vec3::new(-0.5, 0.3, 0.8).normalize();
        let eta = 1.5;
        let cos_o = wo.dot(m);
        let sin2_t = (1.0 - cos_o * cos_o) / (eta * eta);
        let cos_t = (1.0 - sin2_t).sqrt();
        let wi = refract(wo, m, cos_o, cos_t, eta);
        assert!((wi.length() - 1.0).abs() < 1e-5);
        assert!((wi.dot(m) + cos_t).abs() < 1e-5);
        // The generalised half vector of the pair is m again.
        let h = (wo + eta * wi).normalize();
        assert!((h.dot(m).abs() - 1.0).abs() < 1e-5);
    }
}
