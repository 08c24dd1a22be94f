//! The error function and its inverse, in `f64`, for the Beckmann microfacet distribution
//! (`bsdf::microfacet`): its Smith masking term and its visible-slope sampler.
//!
//! * [`erfc`]: Chebyshev-fitted `exp(-x^2 + P(t))`, `t = 1 / (1 + x / 2)` (Press et al.,
//!   "Numerical Recipes", §6.2), relative error below 1.2e-7 for every `x >= 0`; `erfc(-x) =
//!   2 - erfc(x)`.
//! * [`erf`]: `1 - erfc(x)`, absolute error below 2.4e-7.
//! * [`erf_inv`]: Giles' single-precision polynomial ("Approximating the erfinv function",
//!   GPU Computing Gems, 2011) as the first guess, refined by Newton steps on [`erf`] (two
//!   where the first moves it by more than 1e-6, else one), so that `erf(erf_inv(y)) = y` to
//!   the accuracy of [`erf`].

/// 2 / sqrt(pi).
const TWO_OVER_SQRT_PI: f64 = std::f64::consts::FRAC_2_SQRT_PI;

/// The complementary error function `1 - erf(x)`.
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// The error function.
pub fn erf(x: f64) -> f64 {
    1.0 - erfc(x)
}

/// The inverse error function on (-1, 1); +-infinity at +-1, NaN outside.
pub fn erf_inv(y: f64) -> f64 {
    if !(-1.0..=1.0).contains(&y) {
        return f64::NAN;
    }
    if y.abs() == 1.0 {
        return y * f64::INFINITY;
    }
    // Odd: solve for |y|, where erfc(x) = 1 - |y| keeps its relative accuracy in the tail.
    let a = y.abs();
    let w = -((1.0 - a) * (1.0 + a)).ln();
    let mut x = if w < 5.0 {
        let w = w - 2.5;
        let mut p = 2.810_226_36e-08;
        p = 3.432_739_39e-07 + p * w;
        p = -3.523_387_7e-06 + p * w;
        p = -4.391_506_54e-06 + p * w;
        p = 0.000_218_580_87 + p * w;
        p = -0.001_253_725_03 + p * w;
        p = -0.004_177_681_64 + p * w;
        p = 0.246_640_727 + p * w;
        p = 1.501_409_41 + p * w;
        p * a
    } else {
        let w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_257;
        p = 0.000_100_950_558 + p * w;
        p = 0.001_349_343_22 + p * w;
        p = -0.003_673_428_44 + p * w;
        p = 0.005_739_507_73 + p * w;
        p = -0.007_622_461_3 + p * w;
        p = 0.009_438_870_47 + p * w;
        p = 1.001_674_06 + p * w;
        p = 2.832_976_82 + p * w;
        p * a
    };
    // Newton on erfc(x) - (1 - |y|); the derivative is -2/sqrt(pi) exp(-x^2). A step of dx
    // leaves an error of about x dx^2 (erfc''/2erfc' = -x), so after a first step below 1e-6
    // (the guess is good to about 4e-7 relative below |y| = 1 - 1e-5) a second one would move
    // x by about 1e-12 relative, far below erfc's accuracy and an f32 ulp: it is taken only
    // in the tails, where the guess is rougher.
    for _ in 0..2 {
        let d = TWO_OVER_SQRT_PI * (-x * x).exp();
        if !(d.is_finite() && d > 0.0) {
            break;
        }
        let dx = (erfc(x) - (1.0 - a)) / d;
        x += dx;
        if dx.abs() <= 1e-6 {
            break;
        }
    }
    x.copysign(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agree_with_statrs() {
        for i in -600..=600 {
            let x = i as f64 / 100.0;
            let (e, c) = (
                statrs::function::erf::erf(x),
                statrs::function::erf::erfc(x),
            );
            assert!((erf(x) - e).abs() < 2.5e-7, "erf({x}) = {} vs {e}", erf(x));
            assert!(
                (erfc(x) - c).abs() <= 1.3e-7 * c.max(1e-300),
                "erfc({x}) = {} vs {c}",
                erfc(x)
            );
        }
        for i in -999..=999 {
            let y = i as f64 / 1000.0;
            let x = erf_inv(y);
            let want = statrs::function::erf::erf_inv(y);
            assert!(
                (x - want).abs() < 1e-5 * (1.0 + want.abs()),
                "erf_inv({y}) = {x} vs {want}"
            );
        }
        // erf_inv inverts this module's erfc (what the Beckmann sampler's search relies on),
        // in the tails too: the residual is far below erfc's own accuracy.
        let tails = (1..=9).map(|k| 1.0 - 10f64.powi(-k));
        for y in (-999..=999).map(|i| i as f64 / 1000.0).chain(tails) {
            let (x, a) = (erf_inv(y), y.abs());
            let residual = (erfc(x.abs()) - (1.0 - a)).abs() / (1.0 - a);
            assert!(
                residual < 1e-9,
                "erf_inv({y}) = {x}: erfc residual {residual:e}"
            );
        }
        assert!(erf_inv(0.0).abs() < 1e-7);
        assert!(erf_inv(1.0).is_infinite() && erf_inv(1.5).is_nan());
    }
}
