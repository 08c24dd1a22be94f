//! Fresnel equations, and the reflectance models of conductors built on them.

use crate::math::Spectrum;

/// Unpolarised Fresnel reflectance of a dielectric interface.
///
/// `cos_i` is the cosine of the incident direction with the normal on the outside (front);
/// negative means the direction is inside. `eta` = index inside / index outside.
/// Returns (F, |cos_t|, eta_rel) with eta_rel = n_transmitted / n_incident; F = 1 on total
/// internal reflection.
pub fn dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32) {
    let (cos_i, eta) = if cos_i < 0.0 {
        (-cos_i, 1.0 / eta)
    } else {
        (cos_i, eta)
    };
    let cos_i = cos_i.min(1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, 0.0, eta);
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t, eta)
}

/// Unpolarised Fresnel reflectance of a conductor with complex index `eta + i k` (relative to
/// the outside medium), per RGB channel. `cos_i` is the cosine of the incident direction with
/// the normal; its sign is ignored (conductors are two-sided).
///
/// Closed form of the exact equations (e.g. pbrt-v3 `FrConductor`), evaluated in `f64`: with
/// `a^2 + b^2 = sqrt((eta^2 - k^2 - sin^2)^2 + 4 eta^2 k^2)` and `a^2 = (a^2 + b^2 + eta^2 -
/// k^2 - sin^2) / 2`,
/// `Rs = (a^2 + b^2 + cos^2 - 2 a cos) / (a^2 + b^2 + cos^2 + 2 a cos)`,
/// `Rp = Rs (cos^2 (a^2 + b^2) + sin^4 - 2 a cos sin^2) / (cos^2 (a^2 + b^2) + sin^4 + 2 a cos
/// sin^2)`, `F = (Rs + Rp) / 2`. With `k = 0` this is [`dielectric`] (including total
/// internal reflection for `eta < 1`).
pub fn conductor(cos_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    let c = (cos_i.abs().min(1.0)) as f64;
    let channel = |eta: f32, k: f32| -> f32 {
        let (eta, k) = (eta as f64, k as f64);
        let cos2 = c * c;
        let sin2 = 1.0 - cos2;
        let (eta2, k2) = (eta * eta, k * k);
        let t0 = eta2 - k2 - sin2;
        let a2_plus_b2 = (t0 * t0 + 4.0 * eta2 * k2).sqrt();
        let t1 = a2_plus_b2 + cos2;
        let a = (0.5 * (a2_plus_b2 + t0)).max(0.0).sqrt();
        let t2 = 2.0 * c * a;
        let rs = (t1 - t2) / (t1 + t2);
        let t3 = cos2 * a2_plus_b2 + sin2 * sin2;
        let t4 = t2 * sin2;
        let rp = rs * (t3 - t4) / (t3 + t4);
        let f = 0.5 * (rs + rp);
        // 0/0 only for eta = k = 0 at normal incidence, which is not a material.
        if f.is_finite() {
            f.clamp(0.0, 1.0) as f32
        } else {
            1.0
        }
    };
    Spectrum::new(
        channel(eta.x, k.x),
        channel(eta.y, k.y),
        channel(eta.z, k.z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_and_tir() {
        let (f, _, _) = dielectric(1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-6);
        let (f_in, _, eta) = dielectric(-1.0, 1.5);
        assert!((f_in - 0.04).abs() < 1e-6 && (eta - 1.0 / 1.5).abs() < 1e-6);
        // Inside glass at 60 degrees: beyond the critical angle (41.8 deg).
        assert_eq!(dielectric(-0.5, 1.5).0, 1.0);
    }

    /// Reference: the Fresnel equations with complex arithmetic, in f64, straight from the
    /// definitions `r_s = (cos_i - n cos_t) / (cos_i + n cos_t)`,
    /// `r_p = (n cos_i - cos_t) / (n cos_i + cos_t)`, `n cos_t = sqrt(n^2 - sin_i^2)`.
    fn conductor_complex(cos_i: f64, eta: f64, k: f64) -> f64 {
        #[derive(Clone, Copy)]
        struct C(f64, f64);
        let mul = |a: C, b: C| C(a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let div = |a: C, b: C| {
            let d = b.0 * b.0 + b.1 * b.1;
            C((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
        };
        let sqrt = |a: C| {
            let r = (a.0 * a.0 + a.1 * a.1).sqrt();
            let re = (0.5 * (r + a.0)).max(0.0).sqrt();
            let im = (0.5 * (r - a.0)).max(0.0).sqrt().copysign(a.1);
            C(re, im)
        };
        let n = C(eta, k);
        let n2 = mul(n, n);
        let sin2 = 1.0 - cos_i * cos_i;
        let n_cos_t = sqrt(C(n2.0 - sin2, n2.1));
        let ci = C(cos_i, 0.0);
        let rs = div(
            C(ci.0 - n_cos_t.0, -n_cos_t.1),
            C(ci.0 + n_cos_t.0, n_cos_t.1),
        );
        // r_p = (n^2 cos_i - n cos_t) / (n^2 cos_i + n cos_t), multiplying through by n.
        let n2c = mul(n2, ci);
        let rp = div(
            C(n2c.0 - n_cos_t.0, n2c.1 - n_cos_t.1),
            C(n2c.0 + n_cos_t.0, n2c.1 + n_cos_t.1),
        );
        let abs2 = |a: C| a.0 * a.0 + a.1 * a.1;
        0.5 * (abs2(rs) + abs2(rp))
    }

    #[test]
    fn conductor_matches_complex_fresnel_and_known_values() {
        // Gold, the RGB constants common in renderers (Mitsuba's / pbrt's Au at the RGB
        // primaries): at normal incidence F = ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2).
        let eta = Spectrum::new(0.143, 0.374, 1.442);
        let k = Spectrum::new(3.983, 2.385, 1.603);
        let f0 = conductor(1.0, eta, k);
        for i in 0..3 {
            let (n, kk) = (eta[i] as f64, k[i] as f64);
            let expected = ((n - 1.0).powi(2) + kk * kk) / ((n + 1.0).powi(2) + kk * kk);
            assert!((f0[i] as f64 - expected).abs() < 1e-6, "{f0} channel {i}");
        }
        // Gold is yellow: F0 = 0.967 / 0.803 / 0.324 (red / green / blue) by the formula.
        assert!(
            f0.x > 0.96 && f0.y > 0.80 && f0.y < 0.81 && f0.z < 0.33,
            "{f0}"
        );
        // Oblique angles: the closed form equals the complex-arithmetic definition, and
        // reaches 1 at grazing incidence; the sign of cos_i does not matter.
        for &(n, kk) in &[
            (0.143, 3.983),
            (1.442, 1.603),
            (2.5, 0.3),
            (0.2, 0.0),
            (1.5, 0.0),
        ] {
            for i in 0..=100 {
                let c = i as f64 / 100.0;
                let got = conductor(
                    c as f32,
                    Spectrum::splat(n as f32),
                    Spectrum::splat(kk as f32),
                );
                let want = conductor_complex(c, n, kk);
                assert!(
                    (got.x as f64 - want).abs() < 1e-5,
                    "n {n} k {kk} cos {c}: {got} vs {want}"
                );
                assert_eq!(
                    got,
                    conductor(
                        -c as f32,
                        Spectrum::splat(n as f32),
                        Spectrum::splat(kk as f32)
                    )
                );
            }
            let g = conductor(0.0, Spectrum::splat(n as f32), Spectrum::splat(kk as f32));
            assert!((g.x - 1.0).abs() < 1e-6);
        }
        // k = 0 reproduces the dielectric formula, from either side.
        for &eta in &[1.5f32, 1.33, 1.0 / 1.5] {
            for i in 0..=50 {
                let c = i as f32 / 50.0;
                let d = dielectric(c, eta).0;
                let f = conductor(c, Spectrum::splat(eta), Spectrum::ZERO).x;
                assert!(
                    (d - f).abs() < 2e-6,
                    "eta {eta} cos {c}: dielectric {d}, conductor {f}"
                );
            }
        }
    }
}

/// The Fresnel reflectance of a (rough) conductor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ConductorFresnel {
    /// A constant RGB reflectance at every angle (no Fresnel falloff), like
    /// [`super::Bsdf::Conductor`].
    Constant(Spectrum),
    /// The exact conductor Fresnel equations per channel, complex index `eta + i k` relative
    /// to the outside medium (see [`conductor`]).
    Complex {
        /// Real part of the relative index of refraction, per channel.
        eta: Spectrum,
        /// Extinction coefficient (imaginary part), per channel.
        k: Spectrum,
        /// Factor on the reflectance per channel (Mitsuba's `specular_reflectance`; 1
        /// physically).
        scale: Spectrum,
    },
}

impl ConductorFresnel {
    /// Reflectance at the cosine `cos` between the incident direction and the microfacet.
    pub fn eval(&self, cos: f32) -> Spectrum {
        match self {
            ConductorFresnel::Constant(r) => *r,
            ConductorFresnel::Complex { eta, k, scale } => conductor(cos, *eta, *k) * *scale,
        }
    }
}
