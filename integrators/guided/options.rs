//! The guided integrators' options: declared ([`PT_OPTIONS`], [`BDPT_OPTIONS`],
//! [`VCM_OPTIONS`], and [`COMMON`] with [`SEEDERS`] for an integrator guided through
//! `build_over`), parsed into [`GuidedSettings`] and U's settings, and checked.

use super::cache::{KernelWidths, WeightRule};
use super::chains::{ChainSettings, ChainTarget};
use super::{GuidedSettings, Share, manifold};
use crate::error::{Error, Result};
use crate::integrators::bdpt::{BdptSettings, DIRECT_SPLATS_OPTION};
use crate::integrators::options::{Declared, DefaultValue, Kind, Options, SAMPLER, Spec};
use crate::integrators::paths::Heuristic;
use crate::integrators::vcm::{RADIUS_ALPHA_OPTION, RADIUS_OPTION};
use crate::integrators::{IntegratorParams, options};
use std::path::PathBuf;

/// Default unguided share α.
pub const ALPHA: f64 = 0.5;
/// Default share of the budget spent learning.
pub const LEARN_FRACTION: f64 = 0.1;
/// Default cache capacity.
pub const MAX_GUIDES: i64 = 100_000;
/// Default outliers kept per band of rows and iteration.
pub const INTAKE: i64 = 100;

/// Options every guided integrator reads.
pub const COMMON: &[Spec] = &[
    Spec {
        name: "rr_depth",
        kind: Kind::Int { min: 1 },
        default: DefaultValue::Computed(
            "U's: 5 for guided-pt (pt's), 1 for guided-bdpt (bdpt's); guided-vcm: 1 only \
             (vcm's roulette)",
        ),
        doc: "U's Russian roulette start",
    },
    Spec {
        name: "alpha",
        kind: Kind::open_closed(0.0, 1.0),
        default: DefaultValue::Number(ALPHA),
        doc: "unguided share α once the cache holds guide paths: a pass draws (1 − α) / α \
              guided paths per pixel (`--alpha`)",
    },
    Spec {
        name: "share",
        kind: Kind::Choice(&["auto", "fixed"]),
        default: DefaultValue::Word("auto"),
        doc: "`auto`: keep α only where learning measured that guiding pays (`driver.rs`), \
              else α = 1; `fixed`: always α",
    },
    Spec {
        name: "learn_fraction",
        kind: Kind::closed_open(0.0, 1.0),
        default: DefaultValue::Number(LEARN_FRACTION),
        doc: "share of the budget spent learning (`--learn-fraction`)",
    },
    Spec {
        name: "max_guides",
        kind: Kind::Int { min: 1 },
        default: DefaultValue::Int(MAX_GUIDES),
        doc: "cache capacity; the lightest guide paths go first (`--max-guides`)",
    },
    Spec {
        name: "intake",
        kind: Kind::Int { min: 1 },
        default: DefaultValue::Int(INTAKE),
        doc: "outliers kept per worker (band of rows) and iteration",
    },
    Spec {
        name: "weights",
        kind: Kind::Choice(&["second_moment", "c"]),
        default: DefaultValue::Word("second_moment"),
        doc: "selection weights: half the spec's `C` of each guide path and half each guide's \
              share of the learning samples' second moment, or the spec's `C` alone \
              (`cache/mod.rs`)",
    },
    Spec {
        name: "kernel_width",
        kind: Kind::above(0.0),
        default: DefaultValue::Number(KernelWidths::DEFAULT.regression),
        doc: "factor on the conditional Gaussians' standard deviations (1: the spec's; \
              `cache/build.rs`)",
    },
    Spec {
        name: "first_width",
        kind: Kind::above(0.0),
        default: DefaultValue::Number(KernelWidths::DEFAULT.first_vertex),
        doc: "factor on the first-vertex kernel's width (1: the spec's)",
    },
    Spec {
        name: "first_width_specular",
        kind: Kind::above(0.0),
        default: DefaultValue::Number(KernelWidths::DEFAULT.first_vertex_specular),
        doc: "the same where g_1 is specular (roughness 0); interpolated by roughness in between",
    },
    Spec {
        name: "keep_learning",
        kind: Kind::Bool,
        default: DefaultValue::Bool(true),
        doc: "keep the learning passes in the image: each its mixed estimate where the passes \
              before it chose guiding, else U's own (chosen before the pass, so unbiased; \
              `driver.rs`)",
    },
    Spec {
        name: "manifold",
        kind: Kind::closed(0.0, 1.0),
        default: DefaultValue::Number(manifold::DEFAULT_SHARE),
        doc: "probability of the specular-chain step where the guide has a chain of 1-4 delta \
              vertices after a non-delta vertex (`manifold/`; 0: off)",
    },
    Spec {
        name: "save_guides",
        kind: Kind::Text("a file path"),
        default: DefaultValue::Absent,
        doc: "write the learned cache (`--save-guides`)",
    },
    Spec {
        name: "load_guides",
        kind: Kind::Text("a file path"),
        default: DefaultValue::Absent,
        doc: "start from a saved cache and skip learning (`--load-guides`)",
    },
    SAMPLER,
];

/// The seeders of guided-pt and guided-bdpt and the chain seeder's options.
pub const SEEDERS: &[Spec] = &[
    Spec {
        name: "seeder",
        kind: Kind::Choice(&["outliers", "mcmc"]),
        default: DefaultValue::Word("outliers"),
        doc: "where guide paths come from: the passes' outliers, or also Markov chains started \
              at them (`chains.rs`, `--seeder`)",
    },
    Spec {
        name: "chain_share",
        kind: Kind::above(0.0),
        default: DefaultValue::Number(ChainSettings::DEFAULT.share),
        doc: "`mcmc`: chain steps per learning iteration, per pixel",
    },
    Spec {
        name: "chain_large_step",
        kind: Kind::closed(0.0, 1.0),
        default: DefaultValue::Number(ChainSettings::DEFAULT.large_step),
        doc: "`mcmc`: large-step probability of the chains",
    },
    Spec {
        name: "chain_target",
        kind: Kind::Choice(&["mixture", "uncovered", "unguided"]),
        default: DefaultValue::Word("mixture"),
        doc: "`mcmc`: a chain state's importance: all its sample adds under the current \
              mixture, only its paths with p_g = 0, or U's own estimate with the brightest \
              states evaluated under the mixture afterwards (`chains.rs`)",
    },
    Spec {
        name: "chain_spread",
        kind: Kind::Int { min: 0 },
        default: DefaultValue::Int(ChainSettings::DEFAULT.spread as i64),
        doc: "`mcmc`: chain states kept as guide paths lie at least this many pixels apart in \
              x or y, per band of rows and iteration (0: any distance; `seeder.rs`)",
    },
];

/// guided-vcm's seeder: the outliers only (a Markov chain replays one sample alone, and
/// vcm's samples share their pass's light subpaths).
const VCM_SEEDER: &[Spec] = &[Spec {
    name: "seeder",
    kind: Kind::Choice(&["outliers"]),
    default: DefaultValue::Word("outliers"),
    doc: "`outliers` only: a Markov chain replays one sample alone, and vcm's samples share \
          their pass's light subpaths",
}];

/// U's options in guided-bdpt and guided-vcm.
const BDPT_U: &[Spec] = &[
    Spec {
        name: "mis",
        kind: Kind::Choice(&["balance"]),
        default: DefaultValue::Word("balance"),
        doc: "the balance heuristic only: the guided technique joins U's techniques by adding \
              n_g p_g to its denominator",
    },
    DIRECT_SPLATS_OPTION,
];

/// The options of guided-pt.
pub const PT_OPTIONS: &[&[Spec]] = &[COMMON, SEEDERS];
/// The options of guided-bdpt.
pub const BDPT_OPTIONS: &[&[Spec]] = &[COMMON, SEEDERS, BDPT_U];
/// The options of guided-vcm.
pub const VCM_OPTIONS: &[&[Spec]] = &[
    COMMON,
    VCM_SEEDER,
    BDPT_U,
    &[RADIUS_OPTION, RADIUS_ALPHA_OPTION],
];

/// The guider's settings and U's roulette depth (`default_rr`: U's own), read through the
/// tables `tables` (the integrator's: [`COMMON`] and a seeder table at least).
pub fn read(
    params: &IntegratorParams,
    tables: &[&[Spec]],
    default_rr: u32,
) -> Result<(GuidedSettings, u32)> {
    let o = params.options.declared(tables);
    let rr_depth = o.int_or("rr_depth", default_rr as i64)?;
    let share = match o.word("share")? {
        "fixed" => Share::Fixed,
        _ => Share::Auto,
    };
    let weights = match o.word("weights")? {
        "c" => WeightRule::C,
        _ => WeightRule::SecondMoment,
    };
    let load = o.text("load_guides")?;
    let widths = KernelWidths {
        regression: o.number("kernel_width")?,
        first_vertex: o.number("first_width")?,
        first_vertex_specular: o.number("first_width_specular")?,
    };
    for key in ["kernel_width", "first_width", "first_width_specular"] {
        if load.is_some() && o.has(key) {
            return Err(Error::new(format!(
                "option '{key}' has no effect with load_guides: a loaded cache keeps the \
                 kernel widths it was learned with"
            )));
        }
    }
    let settings = GuidedSettings {
        alpha: o.number("alpha")?,
        share,
        learn_fraction: o.number("learn_fraction")?,
        max_guides: o.int("max_guides")?,
        intake: o.int("intake")?,
        weights,
        widths,
        save_guides: o.text("save_guides")?.map(PathBuf::from),
        load_guides: load.map(PathBuf::from),
        chains: chain_settings(&o)?,
        keep_learning: o.flag("keep_learning")?,
        sampler: options::sampler(&o)?,
        manifold: o.number("manifold")?,
        ..GuidedSettings::default()
    };
    Ok((settings, rr_depth))
}

/// The chain seeder's settings under `seeder=mcmc`, else `None` (and its options an error).
fn chain_settings(o: &Declared) -> Result<Option<ChainSettings>> {
    let seeder = o.word("seeder")?;
    const CHAIN_KEYS: [&str; 4] = [
        "chain_share",
        "chain_large_step",
        "chain_target",
        "chain_spread",
    ];
    if seeder != "mcmc" {
        if let Some(key) = CHAIN_KEYS.iter().find(|k| o.has(k)) {
            return Err(Error::new(format!(
                "option '{key}' belongs to seeder=mcmc (the seeder is '{seeder}')"
            )));
        }
        return Ok(None);
    }
    Ok(Some(ChainSettings {
        share: o.number("chain_share")?,
        large_step: o.number("chain_large_step")?,
        target: match o.word("chain_target")? {
            "uncovered" => ChainTarget::Uncovered,
            "unguided" => ChainTarget::Unguided,
            _ => ChainTarget::Mixture,
        },
        spread: o.int("chain_spread")?,
    }))
}

/// U's settings for guided-bdpt and guided-vcm (`name`): bdpt's with the balance heuristic.
pub fn bdpt_settings(params: &IntegratorParams, name: &str, rr_depth: u32) -> Result<BdptSettings> {
    let o = params.options.declared(&[BDPT_U]);
    if o.word("mis").is_err() {
        return Err(Error::new(format!(
            "option 'mis': {name} needs 'balance': the guided technique joins BDPT's \
             techniques by adding n_g p_g to the balance heuristic's denominator, which the \
             power heuristic has no place for"
        )));
    }
    Ok(BdptSettings {
        max_depth: params.max_depth,
        rr_depth,
        heuristic: Heuristic::Balance,
        light_tracing: false,
        techniques: Default::default(),
        direct_splats: o.flag("direct_splats")?,
    })
}

/// `--part` (`Entry::parts`) of guided-pt and guided-bdpt: only with a saved guide cache,
/// so that every part renders the same estimator.
pub fn check_parts(name: &str, o: &Options) -> Result<()> {
    if o.has("load_guides") {
        return Ok(());
    }
    Err(Error::new(format!(
        "--part with {name}: every part must render with the same saved guide cache \
         (learn it once with --save-guides, then give each part --load-guides)"
    )))
}
