//! What the Markov-chain integrators explore and how: a [`Target`] maps primary samples to a
//! [`Contribution`] on the image, in one or more chain groups; [`McmcSettings`] are the
//! chains' options, shared by `pssmlt` and `mmlt` (`driver.rs` runs them).

pub use super::faults::Faults;
use super::primary::SmallStep;
use crate::math::{Sampler, luminance};
use glam::{DVec3, Vec2};

/// A contribution to the image: the pixel it lands in and its RGB value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contribution {
    /// Row-major index of the pixel.
    pub pixel: u32,
    /// The path's contribution f / p to that pixel, in pixel units.
    pub value: DVec3,
    /// The part of `value` that [`Target::direct`] estimates per pixel, which the chains
    /// leave out when the driver splits those paths off ([`Split`]); zero for most samples.
    pub direct: DVec3,
}

impl Contribution {
    /// Nothing: zero value (importance 0) in pixel 0.
    pub const ZERO: Contribution = Contribution {
        pixel: 0,
        value: DVec3::ZERO,
        direct: DVec3::ZERO,
    };

    /// The chain's target density (up to b): luminance, 0 for invalid values.
    pub fn importance(&self) -> f64 {
        importance_of(self.value)
    }

    /// The same contribution without its [`Contribution::direct`] part.
    pub fn without_direct(&self) -> Contribution {
        Contribution {
            value: self.value - self.direct,
            direct: DVec3::ZERO,
            ..*self
        }
    }
}

/// Luminance of `v`, 0 for invalid (non-finite or negative) values.
pub fn importance_of(v: DVec3) -> f64 {
    if v.is_finite() && v.min_element() >= 0.0 {
        luminance(v.as_vec3()) as f64
    } else {
        0.0
    }
}

/// What a chain explores: a deterministic function of the primary samples.
pub trait Target: Sync {
    /// Per-thread scratch (subpath buffers).
    type Scratch<'s>
    where
        Self: 's;
    /// Fresh scratch for one thread.
    fn scratch(&self) -> Self::Scratch<'_>;
    /// Sampler streams the target reads (`Sampler::start_stream`).
    fn streams(&self) -> u32;
    /// Number of chain groups, each with its own normalisation.
    fn groups(&self) -> usize;
    /// Group `group`'s contribution for the sampler's numbers (read from the start).
    fn eval<S: Sampler>(
        &self,
        scratch: &mut Self::Scratch<'_>,
        group: usize,
        sampler: &mut S,
    ) -> Contribution;
    /// Whether [`Target::direct`] can estimate the paths flagged
    /// [`Contribution::direct`] per pixel, so the driver may leave them out of the chains.
    fn has_direct(&self) -> bool {
        false
    }
    /// One sample at `raster` of the paths flagged [`Contribution::direct`] (pixel units).
    fn direct<S: Sampler>(
        &self,
        _scratch: &mut Self::Scratch<'_>,
        _raster: Vec2,
        _sampler: &mut S,
    ) -> DVec3 {
        DVec3::ZERO
    }
}

/// Options of the Metropolis integrators.
#[derive(Debug, Clone, PartialEq)]
pub struct McmcSettings {
    /// Bootstrap samples per group (default 100 000).
    pub bootstrap: u64,
    /// Number of chains over all groups (default 1024).
    pub chains: u64,
    /// Probability of a large step (default 0.3).
    pub large_step: f64,
    /// The kernel of small steps (default Kelemen's, sizes 1/1024 to 1/64).
    pub small_step: SmallStep,
    /// Whether the paths a target flags [`Contribution::direct`] leave the chains for a
    /// per-pixel estimate (default [`Split::Auto`]; only for targets with
    /// [`Target::has_direct`]).
    pub split: Split,
    /// A pixel's samples of [`Target::direct`] come every this many passes, after pass 0
    /// which samples every pixel (default 4).
    pub direct_every: u64,
    /// Deliberate errors for the tests' negative controls (none by default; no option sets
    /// them).
    pub faults: Faults,
}

/// Default bootstrap samples (per path length for mmlt).
pub const BOOTSTRAP: i64 = 100_000;
/// Default number of chains.
pub const CHAINS: i64 = 1024;
/// Default large-step probability.
pub const LARGE_STEP: f64 = 0.3;
/// Default passes between a pixel's samples of the separated paths (mmlt).
pub const DIRECT_EVERY: i64 = 4;

impl Default for McmcSettings {
    fn default() -> Self {
        McmcSettings {
            bootstrap: BOOTSTRAP as u64,
            chains: CHAINS as u64,
            large_step: LARGE_STEP,
            small_step: SmallStep::default(),
            split: Split::Auto,
            direct_every: DIRECT_EVERY as u64,
            faults: Faults::default(),
        }
    }
}

/// Whether the paths a target flags [`Contribution::direct`] are estimated per pixel
/// ([`Target::direct`]) instead of by the chains.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Split {
    /// Never: the chains explore every path.
    Never,
    /// Always (for targets with [`Target::has_direct`]).
    Always,
    /// Unless the bootstrap holds the flagged paths on at least [`SPLIT_SAMPLES`] samples'
    /// worth and its estimate of their part of `b` agrees with the first pass's per-pixel
    /// estimate within [`SPLIT_Z`] standard errors. Otherwise the chains would start with a
    /// wrong share of their time on those paths (none at all when the bootstrap missed them),
    /// which large steps, reaching them too rarely, would not correct within a render.
    Auto,
}

/// The effective number of bootstrap samples (`(Σ I)² / Σ I²`) the flagged paths must rest
/// on for [`Split::Auto`] to leave them in the chains: their share among the chains' starts
/// then has a relative standard error of at most a quarter.
pub const SPLIT_SAMPLES: f64 = 16.0;

/// Standard errors by which the bootstrap's and the first pass's estimates of the flagged
/// paths' part of `b` may differ for [`Split::Auto`] to leave them in the chains (a false
/// split, for a normal z, about 6e-5).
pub const SPLIT_Z: f64 = 4.0;
