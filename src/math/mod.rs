//! Maths shared by every integrator: spectra (RGB), orthonormal frames, sampling warps with
//! their densities, discrete distributions and the counter-based random streams.

pub mod alias;
pub mod any_sampler;
pub mod cie;
pub mod distribution;
pub mod frame;
pub mod rng;
pub mod sobol;
pub mod special;
pub mod streams;
pub mod warp;

pub use alias::AliasTable;
pub use any_sampler::{AnySampler, SamplerKind};
pub use distribution::Distribution1D;
pub use frame::Frame;
pub use rng::{IndependentSampler, PixelSampler, Sampler, stream_seed};
pub use sobol::SobolSampler;

use glam::Vec3;

/// Linear RGB radiance / reflectance. Components are independent; no spectral upsampling.
pub type Spectrum = Vec3;

/// π in f32.
pub const PI: f32 = std::f32::consts::PI;
/// 1 / π in f32.
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
/// 1 / (4π) in f32: the uniform sphere density.
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Rec. 709 luminance of a linear RGB value.
#[inline]
pub fn luminance(c: Spectrum) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// [`luminance`] of an f64 colour (whole-path contributions, which may pass f32's range).
pub fn luminance64(c: glam::DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Power heuristic (beta = 2) weight of strategy `a` against `b`, with densities in the same
/// measure (and already multiplied by their sample counts).
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 == 0.0 {
        return 0.0;
    }
    if !a2.is_finite() {
        return 1.0;
    }
    a2 / (a2 + b2)
}

/// Convert a solid-angle density at a point to an area density at a point a distance
/// `sqrt(dist2)` away whose surface has `|cos|` to the connecting direction.
#[inline]
pub fn solid_angle_to_area(pdf_w: f32, abs_cos: f32, dist2: f32) -> f32 {
    pdf_w * abs_cos / dist2
}

/// Inverse of [`solid_angle_to_area`]. Returns 0 for grazing configurations.
#[inline]
pub fn area_to_solid_angle(pdf_a: f32, abs_cos: f32, dist2: f32) -> f32 {
    if abs_cos <= 0.0 {
        0.0
    } else {
        pdf_a * dist2 / abs_cos
    }
}

/// True when every component is finite.
#[inline]
pub fn is_finite3(v: Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}
