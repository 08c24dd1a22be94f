//! Error metrics on linear radiance: MSE, RMSE, relMSE (mean of (x - r)^2 / (r^2 + 0.01)),
//! averaged over pixels and channels, plus per-channel means.

use crate::error::{Error, Result};
use crate::film::Image;
use glam::DVec3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    pub mean_a: DVec3,
    pub mean_b: DVec3,
    pub mse: f64,
    pub rmse: f64,
    pub rel_mse: f64,
}

/// Compare `a` against reference `r`.
pub fn compare(a: &Image, r: &Image) -> Result<Comparison> {
    if (a.width, a.height) != (r.width, r.height) {
        return Err(Error::new(format!(
            "images differ in size: {}x{} against {}x{}",
            a.width, a.height, r.width, r.height
        )));
    }
    let (mut se, mut rel) = (0.0f64, 0.0f64);
    for (x, y) in a.pixels.iter().zip(&r.pixels) {
        for c in 0..3 {
            let (xv, yv) = (x[c] as f64, y[c] as f64);
            let d2 = (xv - yv) * (xv - yv);
            se += d2;
            rel += d2 / (yv * yv + 0.01);
        }
    }
    let n = (a.pixels.len() * 3).max(1) as f64;
    let mse = se / n;
    Ok(Comparison {
        mean_a: a.mean(),
        mean_b: r.mean(),
        mse,
        rmse: mse.sqrt(),
        rel_mse: rel / n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn hand_computed_metrics() {
        let mut a = Image::new(2, 1);
        let mut r = Image::new(2, 1);
        a.pixels = vec![Vec3::new(1.0, 0.0, 0.0), Vec3::ZERO];
        r.pixels = vec![Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0)];
        let c = compare(&a, &r).unwrap();
        // Squared errors: 1 and 4 over 6 values.
        assert!((c.mse - 5.0 / 6.0).abs() < 1e-12);
        assert!((c.rmse - (5.0f64 / 6.0).sqrt()).abs() < 1e-12);
        // relMSE: 1 / 0.01 + 4 / 4.01 over 6 values.
        assert!((c.rel_mse - (100.0 + 4.0 / 4.01) / 6.0).abs() < 1e-9);
        assert!(compare(&a, &Image::new(1, 1)).is_err());
    }
}
