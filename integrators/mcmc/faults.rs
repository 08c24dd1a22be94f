//! Deliberate errors of the Markov chains (`McmcSettings::faults`): the negative controls the
//! tests run (`tests/mcmc_tiles.rs`, `tests/mcmc.rs`) to show they can fail. No option sets
//! them; a render has none.

/// Deliberate errors of the chains, each of which a correct test must catch
/// (`tests/mcmc_tiles.rs` runs them). All off by default.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Faults {
    /// Accept every large step (a wrong acceptance: the chain no longer has the target's
    /// distribution).
    pub accept_large: bool,
    /// Double the normalisation b of this group (for mmlt, one path length).
    pub double_b: Option<usize>,
    /// Splat every sample one pixel further along its row (wrapping into the next row).
    pub shift_splats: bool,
}

impl Faults {
    /// Where a splat to `pixel` of an image of `n` pixels lands.
    pub(super) fn pixel(&self, pixel: u32, n: usize) -> usize {
        (pixel as usize + usize::from(self.shift_splats)) % n
    }

    /// The factor on group `g`'s normalisation.
    pub(super) fn b_factor(&self, g: usize) -> f64 {
        if self.double_b == Some(g) { 2.0 } else { 1.0 }
    }
}
