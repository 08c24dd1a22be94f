//! Error metrics on linear radiance, image `a` against reference `r`, averaged over the pixels
//! of an optional crop window and over the three channels:
//!
//! | metric | per value | |
//! |---|---|---|
//! | MSE | `(a - r)^2` | |
//! | RMSE | `sqrt(MSE)` | |
//! | relMSE | `(a - r)^2 / (r^2 + 0.01)` | [`REL_EPSILON`] = 0.01 keeps dark pixels finite |
//!
//! plus per-channel means (over the crop) and a per-pixel relative squared error map (mean over
//! channels), which `lodestar bench` draws in false colour. A [`Crop`] is the pixel rectangle
//! `[x0, x1) x [y0, y1)` (exclusive upper bounds), written `x0,y0,x1,y1` on the command line.

use crate::error::{Error, Result};
use crate::film::Image;
use glam::DVec3;

/// The constant added to `r^2` in relMSE's denominator.
pub const REL_EPSILON: f64 = 0.01;

/// Image `a` measured against reference `b` over a crop (the whole image without one).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// Per-channel mean of `a` over the crop.
    pub mean_a: DVec3,
    /// Per-channel mean of the reference over the crop.
    pub mean_b: DVec3,
    /// Mean of `(a - r)^2` over pixels and channels.
    pub mse: f64,
    /// `sqrt(mse)`.
    pub rmse: f64,
    /// Mean of `(a - r)^2 / (r^2 + REL_EPSILON)` over pixels and channels.
    pub rel_mse: f64,
}

/// A pixel rectangle `[x0, x1) x [y0, y1)`, non-empty.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crop {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Crop {
    /// Parse `x0,y0,x1,y1` (non-negative integers, x0 < x1, y0 < y1).
    pub fn parse(text: &str) -> Result<Crop> {
        let bad = || {
            Error::new(format!(
                "--crop: expected x0,y0,x1,y1 (pixel integers, x0 < x1, y0 < y1), got '{text}'"
            ))
        };
        let v: Vec<u32> = text
            .split(',')
            .map(|s| s.trim().parse::<u32>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| bad())?;
        let [x0, y0, x1, y1] = v[..] else {
            return Err(bad());
        };
        if x0 >= x1 || y0 >= y1 {
            return Err(bad());
        }
        Ok(Crop { x0, y0, x1, y1 })
    }

    /// The whole `width x height` image.
    pub fn full(width: u32, height: u32) -> Crop {
        Crop {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// An error unless the crop lies inside a `width x height` image.
    pub fn check_inside(&self, width: u32, height: u32) -> Result<()> {
        if self.x1 > width || self.y1 > height {
            return Err(Error::new(format!(
                "--crop {},{},{},{} reaches outside the {width}x{height} image",
                self.x0, self.y0, self.x1, self.y1
            )));
        }
        Ok(())
    }

    fn pixel_count(&self) -> usize {
        ((self.x1 - self.x0) * (self.y1 - self.y0)) as usize
    }

    /// Row-major pixel indices of the crop in an image `width` pixels wide.
    fn indices(&self, width: u32) -> impl Iterator<Item = usize> + '_ {
        (self.y0..self.y1)
            .flat_map(move |y| (self.x0..self.x1).map(move |x| (y * width + x) as usize))
    }
}

/// Compare `a` against reference `r` over the whole image.
pub fn compare(a: &Image, r: &Image) -> Result<Comparison> {
    compare_crop(a, r, None)
}

/// Compare `a` against reference `r` over `crop` (the whole image when `None`).
pub fn compare_crop(a: &Image, r: &Image, crop: Option<Crop>) -> Result<Comparison> {
    check_same_size(a, r)?;
    let crop = crop.unwrap_or(Crop::full(a.width, a.height));
    crop.check_inside(a.width, a.height)?;
    let (mut se, mut rel) = (0.0f64, 0.0f64);
    let (mut sum_a, mut sum_r) = (DVec3::ZERO, DVec3::ZERO);
    for i in crop.indices(a.width) {
        let (x, y) = (a.pixels[i].as_dvec3(), r.pixels[i].as_dvec3());
        sum_a += x;
        sum_r += y;
        let d2 = (x - y) * (x - y);
        se += d2.element_sum();
        rel += (d2 / (y * y + REL_EPSILON)).element_sum();
    }
    let pixels = crop.pixel_count() as f64;
    let n = pixels * 3.0;
    let mse = se / n;
    Ok(Comparison {
        mean_a: sum_a / pixels,
        mean_b: sum_r / pixels,
        mse,
        rmse: mse.sqrt(),
        rel_mse: rel / n,
    })
}

/// Per-pixel relative squared error `mean_c (a_c - r_c)^2 / (r_c^2 + 0.01)`, row-major over
/// the whole image (the crop only restricts the averages).
pub fn relative_error_map(a: &Image, r: &Image) -> Result<Vec<f64>> {
    check_same_size(a, r)?;
    Ok(a.pixels
        .iter()
        .zip(&r.pixels)
        .map(|(x, y)| {
            let (x, y) = (x.as_dvec3(), y.as_dvec3());
            ((x - y) * (x - y) / (y * y + REL_EPSILON)).element_sum() / 3.0
        })
        .collect())
}

fn check_same_size(a: &Image, r: &Image) -> Result<()> {
    if (a.width, a.height) != (r.width, r.height) {
        return Err(Error::new(format!(
            "images differ in size: {}x{} against {}x{}",
            a.width, a.height, r.width, r.height
        )));
    }
    Ok(())
}

/// Median of `values` (the mean of the two middle ones for an even count); NaN when empty.
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
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
        // Per pixel: (1 / 0.01) / 3 and (4 / 4.01) / 3.
        let map = relative_error_map(&a, &r).unwrap();
        assert!((map[0] - 100.0 / 3.0).abs() < 1e-9 && (map[1] - 4.0 / 4.01 / 3.0).abs() < 1e-9);
    }

    /// A 3x2 image where only the crop [1, 3) x [1, 2) (pixels (1,1) and (2,1)) counts.
    #[test]
    fn crop_restricts_every_metric() {
        let mut a = Image::new(3, 2);
        let r = Image {
            width: 3,
            height: 2,
            pixels: vec![Vec3::ONE; 6],
        };
        a.pixels = vec![Vec3::splat(9.0); 6];
        a.pixels[4] = Vec3::new(2.0, 1.0, 1.0); // error 1 in one channel
        a.pixels[5] = Vec3::new(1.0, 1.0, 4.0); // error 3 in one channel
        let crop = Crop::parse("1,1,3,2").unwrap();
        let c = compare_crop(&a, &r, Some(crop)).unwrap();
        // Squared errors 1 and 9 over 2 pixels x 3 channels.
        assert!((c.mse - 10.0 / 6.0).abs() < 1e-12);
        assert!((c.rel_mse - 10.0 / 1.01 / 6.0).abs() < 1e-12);
        assert!((c.mean_a - DVec3::new(1.5, 1.0, 2.5)).length() < 1e-12);
        assert_eq!(c.mean_b, DVec3::ONE);
        // The whole image sees the 9s.
        assert!(compare(&a, &r).unwrap().mse > 10.0);
        // Outside the image.
        let outside = Crop::parse("1,1,4,2").unwrap();
        let e = compare_crop(&a, &r, Some(outside)).unwrap_err();
        assert!(e.message().contains("outside the 3x2 image"), "{e}");
    }

    #[test]
    fn crop_parse_errors() {
        for bad in [
            "",
            "1,2,3",
            "1,2,3,4,5",
            "0,0,0,4",
            "3,0,2,4",
            "a,0,1,1",
            "-1,0,2,2",
        ] {
            let e = Crop::parse(bad).unwrap_err();
            assert!(e.message().starts_with("--crop: expected"), "{bad}: {e}");
        }
        assert_eq!(
            Crop::parse(" 0, 1,2 ,3").unwrap(),
            Crop {
                x0: 0,
                y0: 1,
                x1: 2,
                y1: 3
            }
        );
    }

    #[test]
    fn medians() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&[5.0]), 5.0);
        assert!(median(&[]).is_nan());
    }
}
