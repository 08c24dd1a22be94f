//! Sampled spectra to linear sRGB, as Mitsuba 3's RGB variants read a `<spectrum>` given by
//! wavelengths (`400:0.5, 500:0.6, ...`): the piecewise-linear spectrum is integrated against
//! the CIE 1931 2° colour-matching functions (1000 evenly spaced samples over 360-830 nm, the
//! spectrum zero outside its first and last wavelength), reflectances weighted by the D65
//! illuminant, then XYZ goes to Rec. 709 / sRGB primaries and out-of-gamut values are
//! clamped: to [0, 1] for a reflectance, to >= 0 for an emitter's radiance or intensity.
//!
//! Tables: CIE 1931 2° standard observer and CIE standard illuminant D65 at 5 nm (CIE 15,
//! public data), the same samples Mitsuba 3 interpolates linearly.

use glam::DVec3;

/// First and last tabulated wavelength (nm).
const LAMBDA_MIN: f64 = 360.0;
const LAMBDA_MAX: f64 = 830.0;
const STEP: f64 = 5.0;

/// 1 / ∫ ȳ(λ) dλ over the table (1 / 106.7502): a spectrum of 1 (unweighted) has luminance
/// Y = 1.
const Y_NORMALIZATION: f64 = 0.009367658735689113;
/// Scales the D65 table (100 at 560 nm) so that ∫ ȳ D65 dλ = ∫ ȳ dλ: a reflectance of 1
/// under it keeps Y = 1.
const D65_NORMALIZATION: f64 = 0.010101273599490354;

/// x̄, ȳ, z̄ and D65 from 360 nm in steps of 5 nm.
#[rustfmt::skip]
const TABLE: [[f64; 4]; 95] = [
    [0.0001299, 3.917e-06, 0.0006061, 46.6383], // 360 nm
    [0.0002321, 6.965e-06, 0.001086, 49.3637], // 365 nm
    [0.0004149, 1.239e-05, 0.001946, 52.0891], // 370 nm
    [0.0007416, 2.202e-05, 0.003486, 51.0323], // 375 nm
    [0.001368, 3.9e-05, 0.00645, 49.9755], // 380 nm
    [0.002236, 6.4e-05, 0.01055, 52.3118], // 385 nm
    [0.004243, 0.00012, 0.02005, 54.6482], // 390 nm
    [0.00765, 0.000217, 0.03621, 68.7015], // 395 nm
    [0.01431, 0.000396, 0.06785, 82.7549], // 400 nm
    [0.02319, 0.00064, 0.1102, 87.1204], // 405 nm
    [0.04351, 0.00121, 0.2074, 91.486], // 410 nm
    [0.07763, 0.00218, 0.3713, 92.4589], // 415 nm
    [0.13438, 0.004, 0.6456, 93.4318], // 420 nm
    [0.21477, 0.0073, 1.03905, 90.057], // 425 nm
    [0.2839, 0.0116, 1.3856, 86.6823], // 430 nm
    [0.3285, 0.01684, 1.62296, 95.7736], // 435 nm
    [0.34828, 0.023, 1.74706, 104.865], // 440 nm
    [0.34806, 0.0298, 1.7826, 110.936], // 445 nm
    [0.3362, 0.038, 1.77211, 117.008], // 450 nm
    [0.3187, 0.048, 1.7441, 117.41], // 455 nm
    [0.2908, 0.06, 1.6692, 117.812], // 460 nm
    [0.2511, 0.0739, 1.5281, 116.336], // 465 nm
    [0.19536, 0.09098, 1.28764, 114.861], // 470 nm
    [0.1421, 0.1126, 1.0419, 115.392], // 475 nm
    [0.09564, 0.13902, 0.81295, 115.923], // 480 nm
    [0.05795, 0.1693, 0.6162, 112.367], // 485 nm
    [0.03201, 0.20802, 0.46518, 108.811], // 490 nm
    [0.0147, 0.2586, 0.3533, 109.082], // 495 nm
    [0.0049, 0.323, 0.272, 109.354], // 500 nm
    [0.0024, 0.4073, 0.2123, 108.578], // 505 nm
    [0.0093, 0.503, 0.1582, 107.802], // 510 nm
    [0.0291, 0.6082, 0.1117, 106.296], // 515 nm
    [0.06327, 0.71, 0.07825, 104.79], // 520 nm
    [0.1096, 0.7932, 0.05725, 106.239], // 525 nm
    [0.1655, 0.862, 0.04216, 107.689], // 530 nm
    [0.22575, 0.91485, 0.02984, 106.047], // 535 nm
    [0.2904, 0.954, 0.0203, 104.405], // 540 nm
    [0.3597, 0.9803, 0.0134, 104.225], // 545 nm
    [0.43345, 0.99495, 0.00875, 104.046], // 550 nm
    [0.51205, 1.0, 0.00575, 102.023], // 555 nm
    [0.5945, 0.995, 0.0039, 100.0], // 560 nm
    [0.6784, 0.9786, 0.00275, 98.1671], // 565 nm
    [0.7621, 0.952, 0.0021, 96.3342], // 570 nm
    [0.8425, 0.9154, 0.0018, 96.0611], // 575 nm
    [0.9163, 0.87, 0.00165, 95.788], // 580 nm
    [0.9786, 0.8163, 0.0014, 92.2368], // 585 nm
    [1.0263, 0.757, 0.0011, 88.6856], // 590 nm
    [1.0567, 0.6949, 0.001, 89.3459], // 595 nm
    [1.0622, 0.631, 0.0008, 90.0062], // 600 nm
    [1.0456, 0.5668, 0.0006, 89.8026], // 605 nm
    [1.0026, 0.503, 0.00034, 89.5991], // 610 nm
    [0.9384, 0.4412, 0.00024, 88.6489], // 615 nm
    [0.85445, 0.381, 0.00019, 87.6987], // 620 nm
    [0.7514, 0.321, 0.0001, 85.4936], // 625 nm
    [0.6424, 0.265, 5e-05, 83.2886], // 630 nm
    [0.5419, 0.217, 3e-05, 83.4939], // 635 nm
    [0.4479, 0.175, 2e-05, 83.6992], // 640 nm
    [0.3608, 0.1382, 1e-05, 81.863], // 645 nm
    [0.2835, 0.107, 0.0, 80.0268], // 650 nm
    [0.2187, 0.0816, 0.0, 80.1207], // 655 nm
    [0.1649, 0.061, 0.0, 80.2146], // 660 nm
    [0.1212, 0.04458, 0.0, 81.2462], // 665 nm
    [0.0874, 0.032, 0.0, 82.2778], // 670 nm
    [0.0636, 0.0232, 0.0, 80.281], // 675 nm
    [0.04677, 0.017, 0.0, 78.2842], // 680 nm
    [0.0329, 0.01192, 0.0, 74.0027], // 685 nm
    [0.0227, 0.00821, 0.0, 69.7213], // 690 nm
    [0.01584, 0.005723, 0.0, 70.6652], // 695 nm
    [0.0113592, 0.004102, 0.0, 71.6091], // 700 nm
    [0.00811092, 0.002929, 0.0, 72.979], // 705 nm
    [0.00579035, 0.002091, 0.0, 74.349], // 710 nm
    [0.00410946, 0.001484, 0.0, 67.9765], // 715 nm
    [0.00289933, 0.001047, 0.0, 61.604], // 720 nm
    [0.00204919, 0.00074, 0.0, 65.7448], // 725 nm
    [0.00143997, 0.00052, 0.0, 69.8856], // 730 nm
    [0.000999949, 0.0003611, 0.0, 72.4863], // 735 nm
    [0.000690079, 0.0002492, 0.0, 75.087], // 740 nm
    [0.000476021, 0.0001719, 0.0, 69.3398], // 745 nm
    [0.000332301, 0.00012, 0.0, 63.5927], // 750 nm
    [0.000234826, 8.48e-05, 0.0, 55.0054], // 755 nm
    [0.00016615, 6e-05, 0.0, 46.4182], // 760 nm
    [0.000117413, 4.24e-05, 0.0, 56.6118], // 765 nm
    [8.30753e-05, 3e-05, 0.0, 66.8054], // 770 nm
    [5.87065e-05, 2.12e-05, 0.0, 65.0941], // 775 nm
    [4.15099e-05, 1.499e-05, 0.0, 63.3828], // 780 nm
    [2.93533e-05, 1.06e-05, 0.0, 63.8434], // 785 nm
    [2.06738e-05, 7.4657e-06, 0.0, 64.304], // 790 nm
    [1.45598e-05, 5.2578e-06, 0.0, 61.8779], // 795 nm
    [1.0254e-05, 3.7029e-06, 0.0, 59.4519], // 800 nm
    [7.22146e-06, 2.6078e-06, 0.0, 55.7054], // 805 nm
    [5.08587e-06, 1.8366e-06, 0.0, 51.959], // 810 nm
    [3.58165e-06, 1.2934e-06, 0.0, 54.6998], // 815 nm
    [2.52252e-06, 9.1093e-07, 0.0, 57.4406], // 820 nm
    [1.77651e-06, 6.4153e-07, 0.0, 58.8765], // 825 nm
    [1.25114e-06, 4.5181e-07, 0.0, 60.3125], // 830 nm
];

/// The table's row at `lambda` (nm, inside [360, 830]), linearly interpolated.
fn lookup(lambda: f64) -> [f64; 4] {
    let t = (lambda - LAMBDA_MIN) / STEP;
    let i = (t as usize).min(TABLE.len() - 2);
    let f = t - i as f64;
    let (a, b) = (TABLE[i], TABLE[i + 1]);
    std::array::from_fn(|c| a[c] * (1.0 - f) + b[c] * f)
}

/// CIE XYZ to linear sRGB (Rec. 709 primaries, D65 white).
fn xyz_to_srgb(xyz: DVec3) -> DVec3 {
    DVec3::new(
        3.240479 * xyz.x - 1.537150 * xyz.y - 0.498535 * xyz.z,
        -0.969256 * xyz.x + 1.875991 * xyz.y + 0.041556 * xyz.z,
        0.055648 * xyz.x - 0.204043 * xyz.y + 1.057311 * xyz.z,
    )
}

/// What a sampled spectrum describes: a reflectance (D65-weighted, clamped to [0, 1]) or an
/// emission (unweighted, clamped to >= 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumUse {
    /// A reflectance or other albedo: weighted by D65, clamped to [0, 1].
    Reflectance,
    /// An emitter's radiance or intensity: unweighted, clamped below at 0.
    Emission,
}

/// The linear sRGB colour of a uniform spectrum of value `v`: `v` for a reflectance (D65-
/// weighted, a flat spectrum is white), and for an emission the colour of the equal-energy
/// illuminant, `v` times XYZ (1, 1, 1) in sRGB (about 1.205, 0.948, 0.909), as Mitsuba 3
/// converts `<spectrum value="v"/>` on an emitter.
pub fn uniform_spectrum_to_srgb(v: f64, usage: SpectrumUse) -> DVec3 {
    match usage {
        SpectrumUse::Reflectance => DVec3::splat(v),
        SpectrumUse::Emission => xyz_to_srgb(DVec3::ONE) * v,
    }
}

/// The linear sRGB colour of the piecewise-linear spectrum through (`wavelengths[i]`,
/// `values[i]`) (nm, increasing, at least two), as Mitsuba 3 converts it.
pub fn spectrum_to_srgb(wavelengths: &[f64], values: &[f64], usage: SpectrumUse) -> DVec3 {
    debug_assert!(wavelengths.len() >= 2 && wavelengths.len() == values.len());
    const STEPS: usize = 1000;
    let mut xyz = DVec3::ZERO;
    let mut j = 0;
    for i in 0..STEPS {
        let x = LAMBDA_MIN + i as f64 / (STEPS - 1) as f64 * (LAMBDA_MAX - LAMBDA_MIN);
        if x < wavelengths[0] || x > wavelengths[wavelengths.len() - 1] {
            continue;
        }
        while j + 2 < wavelengths.len() && wavelengths[j + 1] <= x {
            j += 1;
        }
        let (x0, x1, y0, y1) = (wavelengths[j], wavelengths[j + 1], values[j], values[j + 1]);
        let mut y = y0 + (y1 - y0) * (x - x0) / (x1 - x0);
        let [cx, cy, cz, d65] = lookup(x);
        if usage == SpectrumUse::Reflectance {
            y *= d65 * D65_NORMALIZATION;
        }
        xyz += DVec3::new(cx, cy, cz) * y;
    }
    let rgb = xyz_to_srgb(xyz * ((LAMBDA_MAX - LAMBDA_MIN) / STEPS as f64) * Y_NORMALIZATION);
    match usage {
        SpectrumUse::Reflectance => rgb.clamp(DVec3::ZERO, DVec3::ONE),
        SpectrumUse::Emission => rgb.max(DVec3::ZERO),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values from Mitsuba 3.9.1 (`mi.spectrum_list_to_srgb`, scalar_rgb) for the spectrum
    /// 400:0.5, 500:0.6, 600:0.7, 700:0.8. Mitsuba sums in single precision and prints six
    /// digits: agreement to 1e-5 (a wrong normalisation or weighting is off by 1e-3 or more).
    #[test]
    fn matches_mitsubas_conversion() {
        let (w, v) = ([400.0, 500.0, 600.0, 700.0], [0.5, 0.6, 0.7, 0.8]);
        let e = spectrum_to_srgb(&w, &v, SpectrumUse::Emission);
        let r = spectrum_to_srgb(&w, &v, SpectrumUse::Reflectance);
        for (got, want) in [
            (e, [0.881938, 0.611177, 0.48583]),
            (r, [0.738914, 0.642815, 0.538268]),
        ] {
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 1e-5, "{got} against {want:?}");
            }
        }
    }

    /// Mitsuba 3.9.1's values for a flat reflectance and a saturated blue (clamped to
    /// [0, 1] as a reflectance, only below 0 as an emission).
    #[test]
    fn white_and_the_gamut_clamp_match_mitsuba() {
        let flat = spectrum_to_srgb(&[360.0, 830.0], &[1.0, 1.0], SpectrumUse::Reflectance);
        let (w, v) = ([400.0, 500.0, 700.0], [2.0, 0.1, 0.1]);
        let r = spectrum_to_srgb(&w, &v, SpectrumUse::Reflectance);
        let e = spectrum_to_srgb(&w, &v, SpectrumUse::Emission);
        let want = [
            (flat, [0.998983, 0.998872, 0.998802]),
            (r, [0.153559, 0.0267476, 1.0]),
            (e, [0.178581, 0.0208576, 1.01798]),
        ];
        for (got, want) in want {
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 1e-5, "{got} against {want:?}");
            }
        }
    }
}
