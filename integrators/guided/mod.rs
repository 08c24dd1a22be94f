//! `guided-pt`, `guided-bdpt`, `guided-vcm` — selective guided sampling with complete paths
//! (Reibold et al. 2018), mixed with path tracing, bidirectional path tracing, or vertex
//! connection and merging.
//!
//! Every pass runs one sample per pixel of the unguided estimator U (`pt`, `bdpt` with
//! all its (s, t) techniques, or `vcm`: bdpt's techniques on light subpaths shared by the
//! pass plus merging at every non-delta surface vertex, `integrators/vcm/`) and, once the
//! cache holds guide paths, `(1 − α) / α` guided
//! paths per pixel (spec §4). Every complete path X either side forms adds
//! `f(X) / (n_u p_u(X) + n_g p_g(X))` to the pixel of x_1: the balance heuristic over U's
//! techniques and the guided one (DESIGN.md §3), so each of BDPT's technique weights gains
//! `n_g p_g` in its denominator. Guided samples are splatted. Learning (a share of the
//! budget): iteration 0 is pure U and seeds the cache (`seeder.rs`), later iterations mix,
//! seed and rebuild the cache (`cache/`); then the cache is frozen and the render runs
//! (`driver.rs`, which also says how the guided share is chosen).
//!
//! Where to read: `estimator.rs` (the mixture, one pass's densities and a guided sample),
//! `driver.rs` (learning, the share, passes), `seeder.rs` (which paths become guides),
//! `chains.rs` (the Markov-chain seeder), `manifold/` (the specular-chain step: a Newton
//! walk seeded by the guide's chain, its density with the basin indicator), `coverage.rs` (where the variance sits),
//! `stats.rs` (the counters a render reports: failed samples by reason and vertex, p_g's work),
//! `cache/` (storage and weights in `mod.rs`, building in `build.rs`, p_g in `density.rs`;
//! its surface-to-surface Gaussians precomputed in `plane.rs`),
//! `integrators/paths/structure.rs` (a path's nodes and their hash), `kernel.rs` (the per-vertex densities,
//! Gaussians), `sampler/`
//! (building a guided path), `integrators/paths/contribution.rs` (f(X) from vertices), `io.rs`
//! (saved caches);
//! U's side is `integrators/unguided.rs` (the traits) and each estimator's own `unguided.rs`
//! (`pt/`, `bdpt/`, `vcm/`).
//!
//! Options: [`options`] declares them (`lodestar integrators --options`, `docs/integrators.md`).
//!
//! ```text
//! lodestar render scenes/pool.toml --integrator guided-pt --time 60 -O alpha=0.5
//! lodestar render scenes/pool.toml --integrator guided-bdpt --time 60
//! lodestar render scenes/dining.toml --integrator guided-vcm --time 60
//! ```
//!
//! guided-vcm is consistent, not unbiased (merging's radius shrinks with the passes, as in
//! `vcm`). Every pass runs vcm's own tracer: in learning passes it hands every path over
//! (for the seeder), with its densities from its vertices unless the path's p_g is 0 and it is
//! too dim to become an outlier candidate (then at vcm's own weight; before the first cache
//! the camera side keeps such paths without their vertices), in render passes only the paths
//! whose structure the cache holds, weighing every other path itself
//! (`Unguided::renew_render_pass`); with guiding off `vcm` renders the remaining passes.
//! Russian roulette is vcm's, from the first bounce (`rr_depth` 1 only). It takes only the `outliers` seeder: a Markov chain
//! replays one sample alone, and vcm's samples share their pass's light subpaths.
//!
//! A cache saved by guided-pt loads into guided-bdpt and back: guide paths are complete
//! paths, whichever estimator found them.
//!
//! **Where it stops helping (measured on `pool`, 30 s).** The direct caustic (camera, water,
//! floor, water, sun: five vertices) is guided well. About 70 % of the second moment left in
//! the image comes from pt paths of six to nine vertices (the caustic seen after one or more
//! further diffuse bounces) whose p_g is 0. For a third of that second moment, no guide path
//! of the path's structure covers x_1. For half, the candidates that do cover x_1 lose the path
//! at x_3, the vertex after the first diffuse one, where each guide follows its own
//! neighbours' narrow Gaussian. Wider kernels and a wide mixture component left the variance
//! where it was. A BSDF branch at diffuse vertices made most of those paths' p_g non-zero,
//! but not comparable to p_u, and the variance moved within its noise. More guide paths of the
//! full structure (7.7k instead of 2.7k) raised it. Such paths need the specular suffix guided
//! on its own (the specular-chain step, `manifold/`, does so for chains of delta vertices
//! ending on the sun or before a rough vertex). Every render reports this account for its own scene:
//! `unguided_second_moment_by_coverage` (structure not held / p_g = 0 / covered),
//! `pg_zero_second_moment_by_vertex` (where p_g vanished; `estimator.rs`),
//! `failed_walks_by_vertex` (where guided samples fail; with the reason `light` for a step to
//! the emitter that does not reach it) and
//! `variance_by_coverage`: the render passes' image variance split into the same three
//! classes plus the guided samples (`coverage.rs`). The second moment counts each class's
//! mean too; the variance is the error (on dining, direct light holds most of the unguided
//! second moment and under 2 % of the variance).
//! (guided-vcm's render passes hand the paths not held over summed per camera sample and per
//! light-tracing splat, so there the first two count such a sum as one path.)

// `!(x > 0.0)` deliberately rejects NaN with the invalid values; the small dense linear
// algebra reads best with explicit indices.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod cache;
pub mod candidates;
pub mod chains;
pub mod collector;
pub mod coverage;
pub mod driver;
pub mod estimator;
pub mod gaussian;
pub mod io;
pub mod kernel;
pub mod learn;
pub mod manifold;
pub mod options;
pub mod plane;
pub mod report;
pub mod sampler;
pub mod seeder;
pub mod share;
pub mod stats;

pub use crate::integrators::paths::contribution;

pub use chains::{ChainSettings, ChainTarget, Mcmc};
pub use driver::Guided;
pub use estimator::{Estimator, Stats};
pub use options::check_parts;
pub use seeder::{Outliers, Seeder};

use super::IntegratorParams;
use super::bdpt::{BdptSettings, BdptUnguided, RR_DEPTH};
use super::paths::Heuristic;
use super::pt::{PathTracer, PtSettings};
use super::vcm::VcmUnguided;
use crate::error::Result;
use crate::math::SamplerKind;
use crate::render::Integrator;
use cache::{GuideCache, KernelWidths, WeightRule};
use std::path::PathBuf;

/// guided-pt: the guider over pt, fed by outliers.
pub type GuidedPt = Guided<PathTracer, Outliers>;
/// guided-bdpt: the guider over bdpt, fed by outliers.
pub type GuidedBdpt = Guided<BdptUnguided, Outliers>;

/// How the guided share is set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Share {
    /// α where learning measured that guiding pays, else 1 (`driver.rs`).
    Auto,
    /// Always α.
    Fixed,
}

/// The guider's own settings (U's are in U).
#[derive(Debug, Clone, PartialEq)]
pub struct GuidedSettings {
    /// Unguided share α of the samples once the cache holds guide paths: a pass draws
    /// `(1 − α) / α` guided paths per pixel (option `alpha`).
    pub alpha: f64,
    /// Whether α is kept only where learning measured that guiding pays (option `share`).
    pub share: Share,
    /// Share of the budget spent learning (option `learn_fraction`).
    pub learn_fraction: f64,
    /// Cache capacity; the lightest guide paths are dropped first (option `max_guides`).
    pub max_guides: usize,
    /// Outliers a seeder keeps per band of rows and iteration (option `intake`).
    pub intake: usize,
    /// Damping t of the selection-weight update: `t w_fresh + (1 − t) w_old`.
    pub damping: f64,
    /// The selection weights' update rule (`cache/build.rs`).
    pub weights: WeightRule,
    /// Factors on the kernels' widths (options `kernel_width`, `first_width`,
    /// `first_width_specular`).
    pub widths: KernelWidths,
    /// Where to write the learned cache (option `save_guides`).
    pub save_guides: Option<PathBuf>,
    /// A saved cache to start from, skipping learning (option `load_guides`).
    pub load_guides: Option<PathBuf>,
    /// Where guide paths come from: `None` the outliers of the passes, else also the
    /// Markov chains of `chains.rs` with these settings.
    pub chains: Option<ChainSettings>,
    /// Keep the learning passes in the image, each with the estimate the passes before it
    /// chose (`driver.rs`).
    pub keep_learning: bool,
    /// U's sampler in the render passes (option `sampler`).
    pub sampler: SamplerKind,
    /// Probability of the specular-chain step where a guide's chain allows it (option
    /// `manifold`, `manifold/`).
    pub manifold: f64,
}

impl Default for GuidedSettings {
    fn default() -> Self {
        GuidedSettings {
            alpha: options::ALPHA,
            share: Share::Auto,
            learn_fraction: options::LEARN_FRACTION,
            max_guides: options::MAX_GUIDES as usize,
            intake: options::INTAKE as usize,
            damping: 0.5,
            weights: WeightRule::SecondMoment,
            widths: KernelWidths::default(),
            save_guides: None,
            load_guides: None,
            chains: None,
            keep_learning: true,
            sampler: SamplerKind::Independent,
            manifold: manifold::DEFAULT_SHARE,
        }
    }
}

impl<S: Seeder> Guided<PathTracer, S> {
    /// guided-pt with pt settings `pt`, guider settings `settings`, seeder `seeder` and,
    /// optionally, a cache to render with instead of learning one.
    pub fn over_pt(
        pt: PtSettings,
        settings: GuidedSettings,
        seeder: S,
        cache: Option<GuideCache>,
    ) -> Self {
        Guided {
            name: "guided-pt",
            seeder,
            unguided: PathTracer { settings: pt },
            settings,
            cache,
        }
    }
}

impl<S: Seeder> Guided<BdptUnguided, S> {
    /// guided-bdpt with bdpt settings `bdpt` (balance heuristic), guider settings
    /// `settings`, seeder `seeder` and, optionally, a cache to render with.
    pub fn over_bdpt(
        bdpt: BdptSettings,
        settings: GuidedSettings,
        seeder: S,
        cache: Option<GuideCache>,
    ) -> Self {
        Guided {
            name: "guided-bdpt",
            seeder,
            unguided: BdptUnguided {
                settings: BdptSettings {
                    heuristic: Heuristic::Balance,
                    light_tracing: false,
                    techniques: Default::default(),
                    ..bdpt
                },
            },
            settings,
            cache,
        }
    }
}

impl GuidedPt {
    /// guided-pt fed by outliers (see [`Guided::over_pt`]).
    pub fn new(pt: PtSettings, settings: GuidedSettings, cache: Option<GuideCache>) -> Self {
        let seeder = Outliers::new(settings.intake);
        Guided::over_pt(pt, settings, seeder, cache)
    }
}

impl GuidedBdpt {
    /// guided-bdpt fed by outliers (see [`Guided::over_bdpt`]).
    pub fn new(bdpt: BdptSettings, settings: GuidedSettings, cache: Option<GuideCache>) -> Self {
        let seeder = Outliers::new(settings.intake);
        Guided::over_bdpt(bdpt, settings, seeder, cache)
    }
}

/// The guider over an estimator of the caller's: what an integrator outside the crate calls
/// to be guided (`examples/bsdf_pt/`). Reads every option of the table above from `params`
/// (`rr_depth`, default `default_rr`, is handed to `make`, which builds U) and feeds the cache
/// from the seeder they name.
pub fn build_over<U: crate::integrators::unguided::Unguided + 'static>(
    name: &'static str,
    params: &IntegratorParams,
    default_rr: u32,
    make: impl FnOnce(u32) -> Result<U>,
) -> Result<Box<dyn Integrator>> {
    let (settings, rr_depth) =
        options::read(params, &[options::COMMON, options::SEEDERS], default_rr)?;
    let unguided = make(rr_depth)?;
    Ok(match settings.chains {
        Some(chains) => Box::new(Guided {
            name,
            seeder: Mcmc::new(settings.intake, chains),
            unguided,
            settings,
            cache: None,
        }),
        None => Box::new(Guided {
            name,
            seeder: Outliers::new(settings.intake),
            unguided,
            settings,
            cache: None,
        }),
    })
}

/// Build guided-pt (with the chain seeder under `-O seeder=mcmc`) from its parameters.
pub fn build_pt(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let (settings, rr_depth) =
        options::read(params, options::PT_OPTIONS, PtSettings::default().rr_depth)?;
    let pt = PtSettings {
        max_depth: params.max_depth,
        rr_depth,
        ..PtSettings::default()
    };
    Ok(match settings.chains {
        Some(chains) => {
            let seeder = Mcmc::new(settings.intake, chains);
            Box::new(Guided::over_pt(pt, settings, seeder, None))
        }
        None => Box::new(GuidedPt::new(pt, settings, None)),
    })
}

/// Build guided-bdpt (with the chain seeder under `-O seeder=mcmc`) from its parameters.
pub fn build_bdpt(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let (settings, rr_depth) = options::read(params, options::BDPT_OPTIONS, RR_DEPTH)?;
    let bdpt = options::bdpt_settings(params, "guided-bdpt", rr_depth)?;
    Ok(match settings.chains {
        Some(chains) => {
            let seeder = Mcmc::new(settings.intake, chains);
            Box::new(Guided::over_bdpt(bdpt, settings, seeder, None))
        }
        None => Box::new(GuidedBdpt::new(bdpt, settings, None)),
    })
}

/// Build guided-vcm (outlier seeder only) from its parameters.
pub fn build_vcm(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let (settings, rr_depth) = options::read(params, options::VCM_OPTIONS, RR_DEPTH)?;
    if rr_depth != 1 {
        return Err(crate::error::Error::new(format!(
            "option 'rr_depth': guided-vcm plays Russian roulette as vcm does, from the first \
             bounce (its recursive weights need every vertex's local continuation \
             probability); expected 1, got {rr_depth}"
        )));
    }
    let bdpt = options::bdpt_settings(params, "guided-vcm", rr_depth)?;
    let (radius, radius_alpha) =
        crate::integrators::vcm::radius_options(&params.options.declared(options::VCM_OPTIONS))?;
    let seeder = Outliers::new(settings.intake);
    Ok(Box::new(Guided {
        name: "guided-vcm",
        seeder,
        unguided: VcmUnguided {
            settings: bdpt,
            radius,
            alpha: radius_alpha,
        },
        settings,
        cache: None,
    }))
}
