//! Markov-chain Monte Carlo integrators: `pssmlt` and `mmlt`.
//!
//! - `pssmlt` — primary-sample-space Metropolis light transport (Kelemen et al. 2002) over
//!   `pt`: a chain's state is every uniform number one pt sample reads (the first two place
//!   the sample on the image), its importance the luminance of that sample's estimate.
//! - `mmlt` — multiplexed Metropolis light transport (Hachisuka et al. 2014) over `bdpt`: one
//!   group of chains per path length k; a state's first number picks one of the k + 1
//!   techniques (s, t), and its contribution is that technique's MIS-weighted estimate times
//!   k + 1. Each length gets mutations in proportion to its bootstrap estimate b_k.
//!
//! Both are unbiased up to the bootstrap's estimate of the normalisation b (consistent), and
//! both render under `--spp` (mutations per pixel) or `--time` like every integrator; the
//! driver (`driver.rs`) explains the bootstrap, the chain schedule and the splatting, and
//! `primary.rs` the lazily mutated primary samples.
//!
//! | option     | type                    | default  | meaning |
//! |------------|-------------------------|----------|---------|
//! | bootstrap  | integer >= 1            | 100000   | bootstrap samples (per path length for `mmlt`) |
//! | chains     | integer >= 1            | 1024     | Markov chains over all groups |
//! | large_step | number in [0, 1]        | 0.3      | probability of a large step (a fresh sample) |
//! | small_step | `kelemen` / `gaussian`  | `kelemen`| small-step kernel |
//! | s1, s2     | 0 < s1 <= s2 < 1        | 1/1024, 1/64 | Kelemen's smallest and largest step |
//! | sigma      | number in (0, 1)        | 0.01     | deviation of the Gaussian step |
//! | rr_depth, strategy | as in `pt`      | as in `pt` | `pssmlt`: pt's own settings (`mmlt` walks fixed lengths and never plays roulette) |
//! | mis        | `balance` / `power`     | `balance`| `mmlt`: MIS heuristic among the techniques of a length |
//! | separate_specular | `true` / `false` | `false`  | `mmlt`: the s = 0 technique on paths E S* L (lights seen directly or through mirrors and glass) estimated per pixel, not by the chains (`mmlt.rs`) |
//! | specular_every | integer >= 1        | 4        | `mmlt`: a pixel's sample of those paths every this many passes (every pixel in the first) |
//!
//! ```text
//! lodestar render scenes/ajar.toml --integrator mmlt --time 60
//! lodestar render scenes/cornell-glossy.toml --integrator pssmlt --spp 64 -O small_step=gaussian
//! ```

pub mod bootstrap;
pub mod chains;
pub mod driver;
pub mod faults;
pub mod mmlt;
pub mod primary;
pub mod pssmlt;
pub mod target;

pub use mmlt::{Mmlt, MmltTarget};
pub use primary::{PrimarySampler, ReplaySampler, SmallStep};
pub use pssmlt::{PssTarget, Pssmlt};
pub use target::{Contribution, McmcSettings, Split, Target};

use super::{IntegratorParams, Options};
use crate::error::{Error, Result};

/// The chain settings common to both integrators.
pub fn settings(o: &Options) -> Result<McmcSettings> {
    let d = McmcSettings::default();
    let bootstrap = o.get("bootstrap", d.bootstrap, "an integer >= 1")?;
    let chains = o.get("chains", d.chains, "an integer >= 1")?;
    for (key, v) in [("bootstrap", bootstrap), ("chains", chains)] {
        if v == 0 {
            return Err(Error::new(format!(
                "option '{key}': expected an integer >= 1, got 0"
            )));
        }
    }
    let large_step = o.get("large_step", d.large_step, "a number in [0, 1]")?;
    if !(0.0..=1.0).contains(&large_step) {
        return Err(Error::new(format!(
            "option 'large_step': expected a number in [0, 1], got {large_step}"
        )));
    }
    let kind = o.choice("small_step", "kelemen", &["kelemen", "gaussian"])?;
    let small_step = if kind == "gaussian" {
        let sigma = o.get("sigma", 0.01f64, "a number in (0, 1)")?;
        if !(sigma > 0.0 && sigma < 1.0) {
            return Err(Error::new(format!(
                "option 'sigma': expected a number in (0, 1), got {sigma}"
            )));
        }
        SmallStep::Gaussian { sigma }
    } else {
        let s1 = o.get("s1", 1.0f64 / 1024.0, "a number in (0, 1)")?;
        let s2 = o.get("s2", 1.0f64 / 64.0, "a number in (0, 1)")?;
        if !(s1 > 0.0 && s1 <= s2 && s2 < 1.0) {
            return Err(Error::new(format!(
                "options 's1', 's2': expected 0 < s1 <= s2 < 1, got s1 = {s1}, s2 = {s2}"
            )));
        }
        SmallStep::Kelemen { s1, s2 }
    };
    if kind == "kelemen" && o.has("sigma") || kind == "gaussian" && (o.has("s1") || o.has("s2")) {
        return Err(Error::new(format!(
            "options: 'sigma' belongs to small_step=gaussian, 's1'/'s2' to small_step=kelemen (small_step is {kind})"
        )));
    }
    Ok(McmcSettings {
        bootstrap,
        chains,
        large_step,
        small_step,
        split: d.split,
        direct_every: d.direct_every,
        faults: d.faults,
    })
}

/// `--part` (`Entry::parts`): the Markov-chain integrators cannot be split.
pub fn check_parts(name: &str, _: &Options) -> Result<()> {
    Err(Error::new(format!(
        "--part: {name} cannot be split; its chains depend on all their earlier mutations \
         and each render normalises by its own bootstrap, so render independent seeds instead"
    )))
}

/// Build pssmlt (Metropolis over pt's primary samples) from its parameters.
pub fn build_pssmlt(params: &IntegratorParams) -> Result<Box<dyn crate::render::Integrator>> {
    pssmlt::build(params)
}

/// Build mmlt (multiplexed Metropolis over bdpt's techniques) from its parameters.
pub fn build_mmlt(params: &IntegratorParams) -> Result<Box<dyn crate::render::Integrator>> {
    mmlt::build(params)
}
