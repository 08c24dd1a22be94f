//! False-colour error images: the per-pixel relative squared error
//! `mean_c (a_c - r_c)^2 / (r_c^2 + 0.01)` mapped through a fixed colour map (viridis, nine
//! stops, linear in between) on a fixed logarithmic range, [`LOG10_MIN`] = -4 (dark purple) to
//! [`LOG10_MAX`] = 1 (yellow), clamped outside; zero error is the bottom colour. The range is
//! the same for every image, so images of different integrators compare directly.

use crate::error::Result;
use crate::film::{Image, write_png_rgb8};
use crate::metrics::relative_error_map;
use std::path::Path;

/// log10 of the relative squared error at the bottom of the colour map.
pub const LOG10_MIN: f64 = -4.0;
/// log10 of the relative squared error at the top of the colour map.
pub const LOG10_MAX: f64 = 1.0;

/// Viridis at u = 0, 1/8, ..., 1 (sRGB bytes).
pub const STOPS: [[u8; 3]; 9] = [
    [0x44, 0x01, 0x54],
    [0x47, 0x2d, 0x7b],
    [0x3b, 0x52, 0x8b],
    [0x2c, 0x72, 0x8e],
    [0x21, 0x91, 0x8c],
    [0x28, 0xae, 0x80],
    [0x5e, 0xc9, 0x62],
    [0xad, 0xdc, 0x30],
    [0xfd, 0xe7, 0x25],
];

/// The colour of `u` in [0, 1] (clamped; NaN maps to the top, so it stands out).
pub fn colour(u: f64) -> [u8; 3] {
    let u = if u.is_nan() { 1.0 } else { u.clamp(0.0, 1.0) };
    let x = u * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let t = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    std::array::from_fn(|c| (a[c] as f64 + t * (b[c] as f64 - a[c] as f64)).round() as u8)
}

/// Position of relative squared error `e` on the colour map.
pub fn position(e: f64) -> f64 {
    if e <= 0.0 {
        return 0.0;
    }
    (e.log10() - LOG10_MIN) / (LOG10_MAX - LOG10_MIN)
}

/// Write the false-colour error PNG of `image` against `reference`.
pub fn write_error_png(path: &Path, image: &Image, reference: &Image) -> Result<()> {
    let map = relative_error_map(image, reference)?;
    let bytes: Vec<u8> = map.iter().flat_map(|&e| colour(position(e))).collect();
    write_png_rgb8(path, image.width, image.height, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_map_and_range() {
        assert_eq!(colour(position(0.0)), STOPS[0]);
        assert_eq!(colour(position(1e-4)), STOPS[0]);
        assert_eq!(colour(position(1e-6)), STOPS[0]);
        assert_eq!(colour(position(10.0)), STOPS[8]);
        assert_eq!(colour(position(1e3)), STOPS[8]);
        assert_eq!(colour(position(f64::NAN)), STOPS[8]);
        // 10^-1.5 is the middle stop.
        assert_eq!(colour(position(10f64.powf(-1.5))), STOPS[4]);
        // Half-way between two stops.
        let c = colour(1.0 / 16.0);
        assert_eq!(c, [0x46, 0x17, 0x68]);
    }
}
