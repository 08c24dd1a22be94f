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
//! Options: [`PSSMLT_OPTIONS`], [`MMLT_OPTIONS`] (`lodestar integrators --options`,
//! `docs/integrators.md`).
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

use super::options::{DefaultValue, Kind, Spec};
use super::{IntegratorParams, Options};
use crate::error::{Error, Result};

/// The chain options common to pssmlt and mmlt.
const CHAIN_OPTIONS: &[Spec] = &[
    Spec {
        name: "bootstrap",
        kind: Kind::Int { min: 1 },
        default: DefaultValue::Int(target::BOOTSTRAP),
        doc: "bootstrap samples (per path length for `mmlt`); under `--time` it stops after the sixteenth of them that reaches 10 % of the budget",
    },
    Spec {
        name: "chains",
        kind: Kind::Int { min: 1 },
        default: DefaultValue::Int(target::CHAINS),
        doc: "Markov chains over all groups",
    },
    Spec {
        name: "large_step",
        kind: Kind::closed(0.0, 1.0),
        default: DefaultValue::Number(target::LARGE_STEP),
        doc: "probability of a large step (a fresh sample)",
    },
    Spec {
        name: "small_step",
        kind: Kind::Choice(&["kelemen", "gaussian"]),
        default: DefaultValue::Word("kelemen"),
        doc: "small-step kernel",
    },
    Spec {
        name: "s1",
        kind: Kind::open(0.0, 1.0),
        default: DefaultValue::Number(primary::S1),
        doc: "`kelemen`: the smallest step (s1 <= s2)",
    },
    Spec {
        name: "s2",
        kind: Kind::open(0.0, 1.0),
        default: DefaultValue::Number(primary::S2),
        doc: "`kelemen`: the largest step",
    },
    Spec {
        name: "sigma",
        kind: Kind::open(0.0, 1.0),
        default: DefaultValue::Number(primary::SIGMA),
        doc: "`gaussian`: deviation of the Gaussian step",
    },
];

/// The per-pixel split of the paths a chain start cannot represent (`driver.rs`, step 4).
const SPLIT_OPTIONS: &[Spec] = &[
    Spec {
        name: "separate_specular",
        kind: Kind::Choice(&["auto", "true", "false"]),
        default: DefaultValue::Word("auto"),
        doc: "estimate per pixel, not by the chains, the paths only a camera walk continuing \
              through mirrors and glass finds (mmlt: s = 0 where no connection makes the path, \
              `mmlt.rs`; pssmlt: emission reached from a delta vertex or by the camera ray); \
              `auto`: unless the bootstrap holds them on 16 samples' worth and agrees with the \
              first pass's per-pixel estimate of them",
    },
    Spec {
        name: "specular_every",
        kind: Kind::Int { min: 1 },
        default: DefaultValue::Int(target::DIRECT_EVERY),
        doc: "with `separate_specular`: a pixel's sample of those paths every this many \
              passes (every pixel in the first)",
    },
];

/// The options of pssmlt: the chains', the split's, and pt's `rr_depth` and `strategy`.
pub const PSSMLT_OPTIONS: &[&[Spec]] = &[
    CHAIN_OPTIONS,
    SPLIT_OPTIONS,
    &[super::pt::RR_DEPTH_OPTION, super::pt::STRATEGY_OPTION],
];

/// The options of mmlt (which walks fixed lengths and never plays roulette).
pub const MMLT_OPTIONS: &[&[Spec]] = &[CHAIN_OPTIONS, SPLIT_OPTIONS, &[super::bdpt::MIS_OPTION]];

/// The chain settings common to both integrators, the split's included.
pub fn settings(o: &Options) -> Result<McmcSettings> {
    let o = o.declared(&[CHAIN_OPTIONS, SPLIT_OPTIONS]);
    let d = McmcSettings::default();
    let bootstrap = o.int("bootstrap")?;
    let chains = o.int("chains")?;
    let large_step = o.number("large_step")?;
    let kind = o.word("small_step")?;
    let small_step = if kind == "gaussian" {
        SmallStep::Gaussian {
            sigma: o.number("sigma")?,
        }
    } else {
        let s1 = o.number("s1")?;
        let s2 = o.number("s2")?;
        if s1 > s2 {
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
        split: match o.word("separate_specular")? {
            "true" => Split::Always,
            "false" => Split::Never,
            _ => Split::Auto,
        },
        direct_every: o.int("specular_every")?,
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
