//! The guided share: how many guided paths per unguided sample the render spends, chosen from
//! what the learning passes measured (`share = auto`).
//!
//! A pass with `n_u` unguided samples and `n_g = r n_u` guided ones estimates pixel p by
//! `X_p = U_p(r) + G_p(r)`: U's sample of the pixel (every path it forms weighted by
//! `f / (p_u + r p_g)`) plus the guided samples that land there. The two parts use independent
//! streams, so the image's total variance is
//!
//! ```text
//!     V(r) = Σ_p (E[U_p(r)²] − E[U_p(r)]²)  +  r n_u E[g(r)²]  (− Σ_p E[G_p]² / (r n_u), negligible)
//! ```
//!
//! with `g(r) = f / (p_u + r p_g)` the value of one guided sample. Every quantity can be
//! evaluated for any ratio r from one learning pass at the ratio it ran with: each unguided
//! path and each guided sample carries f, p_u and p_g. `E[U_p²]` comes from the pass itself,
//! `Σ_p E[U_p]²` without bias from the product of two consecutive passes' `U_p`, `E[g²]`
//! from the pass's guided samples. The cost of a pass is counted in rays (deterministic, so an
//! `--spp` render is reproducible, unlike with wall time): U's rays; with r > 0 also
//! `PG_EVALUATION_RAYS` per p_g evaluation and `PG_CANDIDATE_RAYS` per candidate term on U's
//! paths; and per guided sample its rays, `GUIDED_SAMPLE_RAYS` for the work around them (path
//! building, f(X), p_u), and its own p_g evaluation. The render uses the ratio of [`RATIOS`]
//! with the least `V(r) · cost(r)`, estimated from the later half of the measured learning
//! passes (the caches closest to the final one), if that is below [`MARGIN`] times U's own,
//! both from all of those passes and from each half of them. Where the
//! whole and a half disagree the share is undecided, and the driver learns on (up to
//! [`EXTENSION`] times the learning budget) before it decides. r = 0 turns guiding off: the estimator is U's own and nothing of the guider
//! is evaluated. The choice is global, not per image region. [`EarlyStop`] says when
//! learning may end before its budget because no ratio pays.

use super::stats::Stats;

/// Ratios n_g / n_u the render may use (unguided share α = 1 / (1 + r): 1, 0.9, 0.8, 2/3,
/// 0.5, 1/3, 0.25).
pub const RATIOS: [f64; 7] = [0.0, 1.0 / 9.0, 0.25, 0.5, 1.0, 2.0, 3.0];
/// Number of ratios in [`RATIOS`].
pub const N: usize = RATIOS.len();

/// Costs in units of one of U's rays (with its shading): one p_g evaluation (structure, path
/// conversion, BVH query), one candidate term of it, one guided sample beyond its rays.
/// Calibrated from single-thread renders at α = 1 and α = 0.5 of cornell-box, dining and pool
/// with guided-pt and guided-bdpt (12 spp, `-O share=fixed`): with these values the model
/// gives the measured extra time of the guided passes to within 30 % in all six (the largest
/// miss: dining with bdpt, 3.5M rays predicted against 2.7M measured).
pub const PG_EVALUATION_RAYS: f64 = 2.0;
/// Cost of one candidate term of a p_g evaluation, in U's rays (see above).
pub const PG_CANDIDATE_RAYS: f64 = 0.05;
/// Cost of one guided sample beyond its rays, in U's rays (see above).
pub const GUIDED_SAMPLE_RAYS: f64 = 3.5;

/// Guiding is turned on only for a predicted `V · cost` below this share of U's alone: the
/// prediction is optimistic where guiding gains little (by about 20 % on dining). The margin
/// was chosen with the learning passes left out of the image (`keep_learning = false`); by
/// default they are kept, as U's estimate with guiding off and the mixture's with it on.
/// Measured on ajar, 60 s, one thread: guided-pt with a predicted 0.81 rendered at 0.89x
/// pt's efficiency (so 0.85 let it on); with the spec's weight rule (`weights = c`), a
/// predicted gain of a few per cent became a 0.83x loss. Where guiding pays the prediction
/// sits far lower (30 s: dining 0.25 for guided-pt, 0.49 for guided-bdpt, pool lower still;
/// cornell-box guided-bdpt 0.59, which renders at 1.0x bdpt).
pub const MARGIN: f64 = 0.75;

/// The luminance an unguided path or guided sample adds to its pixel under each ratio.
pub fn values(f_lum: f64, p_u: f64, p_g: f64) -> [f64; N] {
    RATIOS.map(|r| {
        let v = f_lum / (p_u + r * p_g);
        if v.is_finite() { v } else { 0.0 }
    })
}

/// A measured learning pass, reduced.
struct Measured {
    /// Σ_p U_p(r)² per ratio.
    m2: [f64; N],
    /// Σ_p U_p(r) U'_p(r) with the previous measured pass (None for the first).
    cross: Option<[f64; N]>,
    /// E[g(r)²] over the pass's guided samples.
    g2: [f64; N],
    n_u: f64,
    rays_u: f64,
    /// p_g evaluations and candidates for U's paths.
    eval_u: f64,
    cand_u: f64,
    /// Per guided sample: rays, p_g evaluations and candidates.
    rays_g: f64,
    eval_g: f64,
    cand_g: f64,
}

/// The share decision's evidence.
#[derive(Default)]
pub struct ShareMeter {
    passes: Vec<Measured>,
    previous: Vec<[f64; N]>,
}

/// The ratio chosen and the relative inefficiency `V · cost` of every ratio (1 for r = 0).
#[derive(Debug, Clone)]
pub struct Decision {
    /// The ratio n_g / n_u chosen (0: guiding off).
    pub ratio: f64,
    /// Predicted `V · cost` of each ratio of [`RATIOS`] relative to U's alone.
    pub relative: [f64; N],
    /// The passes as a whole put a ratio with guided samples below [`MARGIN`], but one of
    /// their halves did not: guiding stays off on this evidence, and more learning passes
    /// may settle it (the driver learns on, up to [`EXTENSION`] times its budget).
    pub undecided: bool,
}

/// While the share is undecided at the end of the learning budget, learning goes on up to
/// this multiple of it. Measured on dining (guided-vcm, 60 s, one thread, seeds 0 and 2):
/// after 7 and 9 learning passes the whole predicted 0.52 and 0.71 but a half of each
/// predicted more than [`MARGIN`], so guiding stayed off, where with guiding on those seeds
/// rendered at 0.64x and 0.72x vcm's MSE. The learning passes are not lost when guiding
/// stays off (U's own image keeps them).
pub const EXTENSION: f64 = 2.0;

impl ShareMeter {
    /// Add one learning pass: per-pixel `U_p(r)` (`image`), the guided samples' Σ g(r)²,
    /// and the pass's counters.
    pub fn add(&mut self, image: Vec<[f64; N]>, guided_m2: [f64; N], n_u: f64, stats: &Stats) {
        let mut m2 = [0.0; N];
        for v in &image {
            for i in 0..N {
                m2[i] += v[i] * v[i];
            }
        }
        let cross = (self.previous.len() == image.len()).then(|| {
            let mut c = [0.0; N];
            for (a, b) in image.iter().zip(&self.previous) {
                for i in 0..N {
                    c[i] += a[i] * b[i];
                }
            }
            c
        });
        let n_g = stats.guided.max(1) as f64;
        self.passes.push(Measured {
            m2,
            cross,
            g2: guided_m2.map(|x| x / n_g),
            n_u,
            rays_u: stats.rays_u as f64,
            eval_u: (stats.pg_evaluations - stats.pg_evaluations_guided) as f64,
            cand_u: (stats.pg_candidates - stats.pg_candidates_guided) as f64,
            rays_g: stats.rays_g as f64 / n_g,
            eval_g: stats.pg_evaluations_guided as f64 / n_g,
            cand_g: stats.pg_candidates_guided as f64 / n_g,
        });
        self.previous = image;
    }

    /// The ratio of least `V · cost`; `None` without measured passes. A ratio with guided
    /// samples is chosen only if it stays below [`MARGIN`] in each half of the passes it is
    /// estimated from as well as in all of them: on a scene where guiding gains little the
    /// estimate from a handful of passes scatters around the margin (ajar, guided-pt, 60 s:
    /// predictions 0.78-0.83 in three seeds), and a heavy-tailed pass or two must not turn
    /// guiding on by luck.
    pub fn decide(&self) -> Option<Decision> {
        let n = self.passes.len();
        if n == 0 {
            return None;
        }
        let late = &self.passes[n / 2..];
        let relative = relative_scores(late);
        let halves = late.split_at(late.len() / 2);
        let agree = |i: usize| {
            late.len() < 2
                || [halves.0, halves.1]
                    .iter()
                    .all(|h| relative_scores(h)[i] < MARGIN)
        };
        let best = (0..N)
            .filter(|&i| relative[i].is_finite())
            .min_by(|&a, &b| relative[a].total_cmp(&relative[b]).then(a.cmp(&b)))
            .filter(|&i| relative[i] < MARGIN);
        let chosen = best.filter(|&i| agree(i));
        Some(Decision {
            ratio: RATIOS[chosen.unwrap_or(0)],
            relative,
            undecided: best.is_some() && chosen.is_none(),
        })
    }
}

/// `V(r) · cost(r)` of every ratio relative to U's alone (1 for r = 0), estimated from
/// `passes` (module doc).
fn relative_scores(passes: &[Measured]) -> [f64; N] {
    let k = passes.len() as f64;
    let with_cross: Vec<&Measured> = passes.iter().filter(|m| m.cross.is_some()).collect();
    let mut score = [0.0; N];
    for i in 0..N {
        let r = RATIOS[i];
        let avg = |f: &dyn Fn(&Measured) -> f64| passes.iter().map(f).sum::<f64>() / k;
        // Σ μ² from the cross products (0 with a single measured pass: then second
        // moments are compared, which favours no ratio in particular).
        let mean2 = if with_cross.is_empty() {
            0.0
        } else {
            with_cross
                .iter()
                .map(|m| m.cross.expect("filtered")[i])
                .sum::<f64>()
                / with_cross.len() as f64
        };
        let v = (avg(&|m| m.m2[i]) - mean2).max(0.0) + r * avg(&|m| m.n_u * m.g2[i]);
        let guided = avg(&|m| {
            m.n_u
                * (m.rays_g
                    + GUIDED_SAMPLE_RAYS
                    + PG_EVALUATION_RAYS * m.eval_g
                    + PG_CANDIDATE_RAYS * m.cand_g)
        });
        let on_u = avg(&|m| PG_EVALUATION_RAYS * m.eval_u + PG_CANDIDATE_RAYS * m.cand_u);
        let cost = avg(&|m| m.rays_u) + if r > 0.0 { on_u + r * guided } else { 0.0 };
        score[i] = v * cost;
    }
    let base = score[0];
    score.map(|s| if base > 0.0 { s / base } else { 1.0 })
}

/// Every ratio with guided samples must lose to U alone by this factor, ...
pub const EARLY_STOP_MARGIN: f64 = 1.25;
/// ... in this many consecutive learning iterations, ...
pub const EARLY_STOP_RUN: usize = 3;
/// ... each with a cache at most this much larger than the iteration before's, for learning
/// to stop early ([`EarlyStop`]).
pub const EARLY_STOP_GROWTH: f64 = 0.1;

/// When learning may stop before its budget because nothing is worth guiding: the share's
/// decision has put every ratio with guided samples above [`EARLY_STOP_MARGIN`] times U's
/// own `V · cost` in each of the last [`EARLY_STOP_RUN`] iterations, and over them the cache
/// has settled (grown by at most [`EARLY_STOP_GROWTH`] per iteration). The verdict is about
/// the cache that was measured; while the cache still grows, the next one may differ (on
/// dining the first small caches can measure above the margin and a later one far below
/// it). Stopping saves little: the learning passes are kept when guiding
/// stays off, so only their extra cost is lost.
#[derive(Debug, Default)]
pub struct EarlyStop {
    /// Per measured iteration: the cache's size, and whether every guided ratio lost by
    /// the margin.
    history: Vec<(usize, bool)>,
}

impl EarlyStop {
    /// Record an iteration's verdict on a cache of `guides` guide paths; true when learning
    /// should stop.
    pub fn observe(&mut self, guides: usize, decision: Option<&Decision>) -> bool {
        let hopeless = decision.is_some_and(|d| {
            d.ratio == 0.0 && d.relative[1..].iter().all(|&c| c > EARLY_STOP_MARGIN)
        });
        self.history.push((guides, hopeless));
        let n = self.history.len();
        if n < EARLY_STOP_RUN + 1 {
            return false;
        }
        let recent = &self.history[n - EARLY_STOP_RUN - 1..];
        recent[1..].iter().all(|&(_, h)| h)
            && recent.windows(2).all(|w| {
                let (before, now) = (w[0].0 as f64, w[1].0 as f64);
                now <= before * (1.0 + EARLY_STOP_GROWTH)
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pass of one unguided sample whose second moment under each ratio is `m2` (no
    /// cross products, no guided samples' variance, one ray, no p_g work).
    fn pass(m2_guided: f64) -> Measured {
        let mut m2 = [10.0; N];
        m2[0] = 1.0;
        m2[1] = m2_guided;
        Measured {
            m2,
            cross: None,
            g2: [0.0; N],
            n_u: 1.0,
            rays_u: 1.0,
            eval_u: 0.0,
            cand_u: 0.0,
            rays_g: 0.0,
            eval_g: 0.0,
            cand_g: 0.0,
        }
    }

    fn decide(late: [f64; 2]) -> Decision {
        let meter = ShareMeter {
            passes: vec![pass(1.0), pass(1.0), pass(late[0]), pass(late[1])],
            previous: Vec::new(),
        };
        meter.decide().expect("measured passes")
    }

    #[test]
    fn guiding_turns_on_only_where_both_halves_agree() {
        // r = 1/9 costs 1 + 3.5 / 9 rays: relative = m2 * 1.389.
        let both = decide([0.46, 0.46]);
        assert!((both.relative[1] - 0.46 * (1.0 + GUIDED_SAMPLE_RAYS / 9.0)).abs() < 1e-12);
        assert_eq!(both.ratio, RATIOS[1]);
        // The same mean (relative 0.64 < MARGIN), but the second half alone predicts 0.86.
        let split = decide([0.30, 0.62]);
        assert!(split.relative[1] < MARGIN);
        assert_eq!(split.ratio, 0.0);
        // ... which leaves the share undecided (learning goes on), unlike a clear "no" or
        // a clear "yes".
        assert!(split.undecided);
        assert!(!both.undecided);
        assert!(!decide([0.9, 0.9]).undecided);
    }
}

#[cfg(test)]
mod early_stop_tests {
    use super::*;

    fn decision(best: f64) -> Decision {
        let mut relative = [best; N];
        relative[0] = 1.0;
        let ratio = if best < MARGIN { 1.0 } else { 0.0 };
        Decision {
            ratio,
            relative,
            undecided: false,
        }
    }

    fn stops_at(trajectory: &[(usize, f64)]) -> Option<usize> {
        let mut e = EarlyStop::default();
        trajectory
            .iter()
            .position(|&(g, best)| e.observe(g, Some(&decision(best))))
    }

    /// Dining, guided-vcm, seed 3, 30 s with learn_fraction 0.8 (iterations 2 to 8: cache
    /// size, best relative cost): the growing cache's early verdicts must not stop learning.
    #[test]
    fn a_growing_cache_does_not_stop_learning() {
        let dining = [
            (8, 1.174),
            (137, 1.337),
            (162, 1.393),
            (234, 1.384),
            (296, 0.611),
            (314, 0.582),
            (349, 0.646),
        ];
        assert_eq!(stops_at(&dining), None);
    }

    /// A settled cache that loses by the margin three times running stops learning, and not
    /// before; one verdict within the margin resets the run.
    #[test]
    fn a_settled_hopeless_cache_stops_learning() {
        let settled = [(400, 1.4), (410, 1.5), (420, 1.45), (430, 1.6), (440, 1.6)];
        assert_eq!(stops_at(&settled), Some(3));
        let reset = [
            (400, 1.4),
            (410, 1.5),
            (420, 1.2),
            (430, 1.6),
            (440, 1.6),
            (450, 1.6),
        ];
        assert_eq!(stops_at(&reset), Some(5));
        let none = [(0, 1.0); 8];
        let mut e = EarlyStop::default();
        assert!(none.iter().all(|&(g, _)| !e.observe(g, None)));
    }
}
