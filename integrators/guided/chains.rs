//! The Markov-chain seeder (`seeder = mcmc`): guide paths from chains that explore around
//! the outliers found so far.
//!
//! After each learning pass (from iteration 1 on), [`CHAINS`] Metropolis chains run in the
//! primary sample space of U's own sample (the first two numbers place it on the image, the
//! rest are what U reads), with the pass's estimator as target: a state's importance is the
//! luminance of everything its sample adds to the image under the current mixture (every
//! path's `f / (n_u p_u + n_g p_g)`), so chains linger where the current cache and U together
//! still leave large contributions. Each chain starts at an outlier of an earlier iteration
//! that U found, drawn in proportion to its C, by replaying that sample's stream (seed, pass,
//! pixel; the raster position up to the rounding of its fraction of the image, the rest
//! exactly); it then takes Kelemen small steps and, with probability `large_step`
//! (0.1), a fresh sample. The paths of every state a chain evaluates are offered like a pass's
//! samples (each chain keeps its brightest) and go through the same outlier test as the pass's
//! own candidates (`Outliers::select`: trust against the iteration's cascade, then per band of
//! rows the `intake` largest C, chain states ranked apart from the passes' candidates so that
//! they add guide paths around the outliers without displacing outliers elsewhere in the
//! image); chain states are not added to the cascade's statistics, since they are not uniform
//! samples. Of the chain states, brightest first, a band keeps only those at least
//! `chain_spread` (7) pixels apart in x or y (`seeder::spread_out`): a chain's states are near
//! copies of each other, and side by side they cost p_g evaluations without covering more of
//! path space (docs/results.md, "The two seeders at 240 s", compares the two seeders).
//!
//! **Steps per learning iteration: `chain_share` x N_pix (default 0.25 N_pix)**, spread over
//! the chains (`CHAINS` = 32, so 512 steps each at 256 x 256). A step costs about one U sample
//! plus the p_g of its paths, so this is a quarter of a learning pass: the passes, which give
//! the cascade its statistics and find new outliers everywhere in the image, stay the larger
//! part of learning, while each chain takes enough steps (hundreds) to move along the
//! caustic it started in and find the neighbouring paths its guide path needs (the kernels
//! are built from 10 neighbours of the same structure).
//!
//! **Target (`chain_target`).** `mixture` (the default) is the importance above. `uncovered`
//! counts only the state's paths that the cache does not cover (structure not held, or
//! p_g = 0), so that chains drift towards what the guided technique cannot yet propose; a
//! chain whose state has no such paths (importance 0) moves to the first proposal that has
//! some (proposals of importance 0 are never accepted). `unguided` is U's own estimate of the
//! state's sample, its paths weighted by the balance heuristic over U's techniques alone
//! (f / p_u: bdpt's own weights; pt's own are the power heuristic's), i.e. pssmlt over pt and
//! PSSMLT over bdpt. A step then costs one U sample and no p_g; only the
//! [`KEPT_STATES`] brightest states a chain visits (accepted states) are evaluated under the
//! mixture afterwards, replayed from their primary samples, and offered like the other
//! targets' states.
//!
//! For guided-bdpt the chains run over BDPT's whole sample (Kelemen's original PSSMLT over
//! BDPT), not over `mmlt`'s single techniques: an outlier found by a BDPT sample is replayed
//! from its stream exactly, which a single-technique state could not be.
//!
//! Guide paths only shape the guided proposal (p_g is evaluated exactly and U stays in the
//! mixture), so the chains need no detailed balance with the image: the render stays unbiased
//! whatever they find.

use super::cache::Record;
use super::collector::Collector;
use super::estimator::RowOutput;
use super::seeder::{Explore, LearnPass, LearnRow, Outliers, Seeder, Source};
use super::share;
use crate::integrators::mcmc::bootstrap::pick_by_importance;
use crate::integrators::mcmc::primary::ReplaySampler;
use crate::integrators::mcmc::{PrimarySampler, SmallStep};
use crate::integrators::paths::Vertex;
use crate::integrators::unguided::{PathSink, Unguided};
use crate::math::{IndependentSampler, Sampler, luminance, luminance64, stream_seed};
use crate::path::Path;
use glam::{DVec3, Vec2};
use rand::RngExt;
use rayon::prelude::*;

/// Chains per learning iteration.
pub const CHAINS: usize = 32;
/// Numbers of an outlier's stream replayed into a chain's initial state (more than any U
/// sample of `MAX_VERTICES` vertices reads); later dimensions are fresh.
const PREFIX: usize = 1024;
/// Unguided outliers kept as chain starts (the most recent).
const POOL: usize = 8192;
/// Stream keys of the seeder's chains (`math::streams`).
const CHAIN_KEY: u64 = crate::math::streams::SEEDER_CHAINS;

/// What a chain state's importance counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChainTarget {
    /// Everything its sample adds to the image under the current mixture.
    Mixture,
    /// Only what its paths that the cache does not cover (structure not held, or p_g = 0) add.
    Uncovered,
    /// U's own estimate of the sample (no p_g); the brightest states visited are evaluated
    /// under the mixture afterwards.
    Unguided,
}

/// States of a chain with `ChainTarget::Unguided` evaluated under the mixture after it ran.
pub const KEPT_STATES: usize = 48;

/// U's own estimate of one sample (its paths weighted by U's techniques alone), as
/// luminance: the importance of [`ChainTarget::Unguided`]. Declines every path's densities.
#[derive(Default)]
struct OwnEstimate {
    sum: f64,
}

impl OwnEstimate {
    fn add(&mut self, v: DVec3) {
        if v.is_finite() && v.min_element() >= 0.0 {
            self.sum += luminance64(v);
        }
    }
}

impl PathSink for OwnEstimate {
    fn record(&mut self, _: &Path, _: Option<&[Vertex]>, f: DVec3, p_u: f64, _: bool) {
        if p_u > 0.0 {
            self.add(f / p_u);
        }
    }

    fn needs_densities(&mut self, _: &[Vertex], _: &[Vertex]) -> bool {
        false
    }

    fn record_weighted(&mut self, _: u32, value: DVec3, _: bool) {
        self.add(value);
    }
}

/// U's own estimate of the sample `sampler` holds, read from its first dimension on (the
/// importance of [`ChainTarget::Unguided`]).
pub fn own_estimate<U: Unguided>(
    unguided: &U,
    tracer: &mut U::Tracer<'_>,
    scene: &crate::scene::Scene,
    sampler: &mut impl Sampler,
) -> f64 {
    let raster = sampler.next_2d() * scene.camera.resolution.as_vec2();
    let mut sink = OwnEstimate::default();
    unguided.trace(tracer, scene, raster, sampler, &mut sink);
    if sink.sum.is_finite() { sink.sum } else { 0.0 }
}

/// Settings of the chain seeder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainSettings {
    /// Chain steps per learning iteration, per pixel (default 0.25).
    pub share: f64,
    /// Large-step probability (default 0.1).
    pub large_step: f64,
    /// The chains' target (default `Mixture`).
    pub target: ChainTarget,
    /// Chain states kept as guide paths lie at least this many pixels apart (default 7;
    /// 0: any distance; [`super::seeder::spread_out`]).
    pub spread: u32,
}

impl ChainSettings {
    /// The default settings (the `chain_*` options' defaults).
    pub const DEFAULT: ChainSettings = ChainSettings {
        share: 0.25,
        large_step: 0.1,
        target: ChainTarget::Mixture,
        spread: 7,
    };
}

impl Default for ChainSettings {
    fn default() -> Self {
        ChainSettings::DEFAULT
    }
}

/// Outlier selection fed by the learning passes and by Markov chains started at outliers.
pub struct Mcmc {
    outliers: Outliers,
    settings: ChainSettings,
    /// Outliers U found in earlier iterations: (pass, pixel index, C).
    pool: Vec<(u64, u64, f64)>,
    steps: u64,
    accepted: u64,
    offered: u64,
    kept: u64,
}

impl Mcmc {
    /// The chain seeder: outliers (`intake` per band of rows and iteration) plus chains with
    /// `settings`.
    pub fn new(intake: usize, settings: ChainSettings) -> Mcmc {
        let mut outliers = Outliers::new(intake);
        outliers.chain_spread = settings.spread;
        Mcmc {
            outliers,
            settings,
            pool: Vec::new(),
            steps: 0,
            accepted: 0,
            offered: 0,
            kept: 0,
        }
    }
}

/// Importance of a chain state under `target`: the luminance of all its sample adds to the
/// image, or of what its uncovered paths add.
fn evaluate<U: Unguided>(
    explore: &Explore<'_, '_, U>,
    target: ChainTarget,
    tracer: &mut U::Tracer<'_>,
    out: &mut RowOutput,
    sampler: &mut impl Sampler,
) -> f64 {
    let est = explore.est;
    let scene = est.scene;
    out.uncovered = 0.0;
    let raster = sampler.next_2d() * scene.camera.resolution.as_vec2();
    let mut col = Collector {
        est,
        sum: DVec3::ZERO,
        grid: [0.0; share::N],
        u_sum: DVec3::ZERO,
        class_sum: Default::default(),
        classes: false,
        own_image: false,
        learning: true,
        measuring: false,
        source: Source::Chain,
        out: &mut *out,
    };
    est.unguided.trace(tracer, scene, raster, sampler, &mut col);
    let mut value = luminance(col.sum.as_vec3()) as f64;
    for (_, v) in out.splats.drain(..) {
        value += luminance(v.as_vec3()) as f64;
    }
    // Chain states are not uniform samples: they stay out of the cascade's statistics.
    out.learn.samples.clear();
    let importance = match target {
        ChainTarget::Mixture | ChainTarget::Unguided => value,
        ChainTarget::Uncovered => out.uncovered,
    };
    // A non-finite importance would freeze the chain (every ratio against it is 0 or NaN).
    if importance.is_finite() {
        importance
    } else {
        0.0
    }
}

/// Keep the state `sampler` holds among the [`KEPT_STATES`] of largest importance (copied
/// only when it makes the list, into the buffer of the state it replaces).
fn keep_state(kept: &mut Vec<(f64, Vec<f32>)>, importance: f64, sampler: &PrimarySampler) {
    if !(importance > 0.0) {
        return;
    }
    if kept.len() < KEPT_STATES {
        let mut values = Vec::new();
        sampler.values_into(&mut values);
        kept.push((importance, values));
        return;
    }
    let smallest = (0..kept.len())
        .min_by(|&a, &b| kept[a].0.total_cmp(&kept[b].0))
        .expect("the list is full");
    if importance > kept[smallest].0 {
        kept[smallest].0 = importance;
        sampler.values_into(&mut kept[smallest].1);
    }
}

/// The initial state of a chain at U's sample (seed, pass, index): the raster position it
/// traced, as a fraction of the image, then the numbers U read from the stream.
pub fn replayed_state(seed: u64, pass: u64, index: u64, res: glam::UVec2) -> Vec<f64> {
    let mut s = IndependentSampler::new(seed, pass, index);
    let (x, y) = ((index % res.x as u64) as f32, (index / res.x as u64) as f32);
    let raster = Vec2::new(x, y) + s.next_2d();
    let mut v = Vec::with_capacity(PREFIX);
    v.push((raster.x / res.x as f32) as f64);
    v.push((raster.y / res.y as f32) as f64);
    v.extend((2..PREFIX).map(|_| s.next_1d() as f64));
    v
}

impl Seeder for Mcmc {
    fn name(&self) -> &'static str {
        "mcmc"
    }

    fn explore<U: Unguided>(&mut self, explore: Explore<'_, '_, U>, rows: &mut [LearnRow]) {
        if self.pool.is_empty() {
            return;
        }
        let scene = explore.est.scene;
        let res = scene.camera.resolution;
        let weights: Vec<f64> = self.pool.iter().map(|p| p.2).collect();
        let total_c: f64 = weights.iter().sum();
        let steps_total = (self.settings.share * scene.camera.pixel_count() as f64).ceil() as u64;
        let steps = steps_total.div_ceil(CHAINS as u64);
        let (pool, st, it) = (&self.pool, self.settings, explore.iteration as u64);
        let seed = explore.seed;
        let results: Vec<(Vec<super::seeder::Candidate>, u64)> = (0..CHAINS as u64)
            .into_par_iter()
            .map(|j| {
                let key = stream_seed(seed, CHAIN_KEY + it, j);
                let mut pick = crate::integrators::mcmc::primary::rng(key);
                let start = &pool[pick_by_importance(&weights, total_c, pick.random::<f64>())];
                let prefix = replayed_state(seed, start.0, start.1, res);
                let mut sampler = PrimarySampler::with_prefix(
                    &prefix,
                    key ^ 1,
                    SmallStep::default(),
                    st.large_step,
                );
                let unguided = explore.est.unguided;
                let mut tracer = unguided.tracer(scene, &explore.est.pass);
                let mut out = RowOutput::default();
                let own = st.target == ChainTarget::Unguided;
                // ChainTarget::Unguided: the brightest states visited, (importance, values).
                let mut kept: Vec<(f64, Vec<f32>)> = Vec::new();
                let importance = |sampler: &mut PrimarySampler,
                                  tracer: &mut U::Tracer<'_>,
                                  out: &mut RowOutput| {
                    sampler.restart();
                    if own {
                        own_estimate(unguided, tracer, scene, sampler)
                    } else {
                        evaluate(&explore, st.target, tracer, out, sampler)
                    }
                };
                let mut current = importance(&mut sampler, &mut tracer, &mut out);
                sampler.accept();
                if own {
                    keep_state(&mut kept, current, &sampler);
                }
                let mut accepted = 0;
                for _ in 0..steps {
                    sampler.start_iteration();
                    let proposal = importance(&mut sampler, &mut tracer, &mut out);
                    if sampler.metropolis(current, proposal).1 {
                        current = proposal;
                        accepted += 1;
                        if own {
                            keep_state(&mut kept, current, &sampler);
                        }
                    }
                }
                for (_, values) in &kept {
                    let mut replay = ReplaySampler::new(values, sampler.streams());
                    evaluate(&explore, st.target, &mut tracer, &mut out, &mut replay);
                }
                out.learn.cut();
                // A chain's states sample one neighbourhood: together they weigh what one
                // outlier would (their C shared among them), so the guided samples they draw
                // stay spread like the outliers'.
                let mut candidates = out.learn.candidates;
                let share = 1.0 / candidates.len().max(1) as f64;
                for c in &mut candidates {
                    c.record.c *= share;
                }
                (candidates, accepted)
            })
            .collect();
        self.steps += steps * CHAINS as u64;
        for (candidates, accepted) in results {
            self.accepted += accepted;
            self.offered += candidates.len() as u64;
            for c in candidates {
                let row = (c.pixel / res.x) as usize;
                if let Some(r) = rows.get_mut(row) {
                    r.candidates.push(c);
                }
            }
        }
    }

    fn harvest(&mut self, pass: LearnPass) -> Vec<Record> {
        let selected = self.outliers.select(pass);
        for c in &selected {
            match c.source {
                Source::Unguided { pass, index } => self.pool.push((pass, index, c.record.c)),
                Source::Chain => self.kept += 1,
                Source::Guided => {}
            }
        }
        if self.pool.len() > POOL {
            self.pool.drain(..self.pool.len() - POOL);
        }
        self.pool.retain(|p| p.2 > 0.0 && p.2.is_finite());
        selected.into_iter().map(|c| c.record).collect()
    }

    fn stats(&self) -> Vec<(String, String)> {
        let s = |k: &str, v: u64| (k.to_string(), v.to_string());
        vec![
            s("seeder_chain_steps", self.steps),
            s("seeder_chain_accepted", self.accepted),
            s("seeder_chain_candidates", self.offered),
            s("seeder_chain_guides", self.kept),
        ]
    }
}
