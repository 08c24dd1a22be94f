//! The guided estimator of one pass: the unguided technique U and the guided technique G
//! combined by the balance heuristic (DESIGN.md §3, §5).
//!
//! A pass draws `n_u` samples of U (one per pixel) and `n_g = n_u (1 − α) / α` guided paths.
//! Every complete path X that either side forms adds
//!
//! ```text
//!     f(X) / (n_u p_u(X) + n_g p_g(X)) · N_pix  =  f(X) / (p_u(X) + (n_g / n_u) p_g(X))
//! ```
//!
//! to the pixel of x_1, where `p_u` is U's `pdf_unguided` (the sum over its own techniques)
//! and `p_g` the guided density of the frozen cache. With `n_g = 0` (empty cache, or a share
//! that turned guiding off) nothing of G is evaluated and the estimator is U's own.
//!
//! `p_u` has one source wherever it matters: a path U reports carries U's own density sum; when
//! its `p_g` is non-zero (so the guided technique could have made it too), `p_u` is
//! recomputed with `pdf_unguided`, the function guided paths use, so that the weights of all
//! techniques that can form X come from the same numbers and sum to one. The recomputation
//! re-traces every segment, and f32 visibility is not exactly symmetric (a ray grazing an open
//! mesh rim can hit it in one direction and pass in the other), so it can return 0 for a path
//! U has just formed. Where the recomputation is not within a factor 2 of U's own density,
//! the path keeps U's own (counted as `unguided_density_disagreements`), which bounds its
//! value by U's own `f / p_u`. The guided technique cannot know that density for the same
//! path (it has only the recomputation), so on that set the two weights do not sum to one:
//! a bias confined to paths whose visibility f32 rounding decides (on fog-dragon: the bunny's
//! rim). Paths whose `p_u` U computed from their vertices with `pdf_unguided` itself
//! (`PathSink::record_from_vertices`) are not recomputed: vcm's merged paths (in learning
//! passes and render passes alike; a merge's camera vertex stands in for the photon, so the
//! merge's own densities across the photon are not the path's) and every path guided-vcm's
//! render passes hand over.

use super::cache::{GuideCache, Record};
use super::candidates::LearnRow;
use super::kernel::FirstTest;
use super::manifold::WalkMemo;
use super::share;
pub use super::stats::{COVERAGE_CLASSES, FAILURE_REASONS, PG_ZERO_VERTICES, Stats};
use super::stats::{EDGE, NON_FINITE, ZERO};
use super::{contribution, coverage, kernel, sampler};
use crate::integrators::paths::{self, Vertex};
use crate::integrators::unguided::Unguided;
use crate::math::{Sampler, luminance64};
use crate::path::{MAX_VERTICES, Path};
use crate::scene::Scene;
use glam::{DVec3, Vec3};

/// What the cache offers a path U formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coverage {
    /// No guide path has its structure (or the guider does not handle it).
    NotHeld = 0,
    /// Guide paths of its structure exist but none reaches it: p_g = 0.
    Zero = 1,
    /// p_g > 0: the guided technique samples it too.
    Covered = 2,
}

/// What [`Estimator::densities`] finds for a path U formed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Densities {
    /// U's density sum over its own techniques for the path (`Unguided::pdf_unguided`).
    pub p_u: f64,
    /// The guided density of the path under the frozen cache (0 when not held).
    pub p_g: f64,
    /// What the cache offers the path.
    pub coverage: Coverage,
    /// For [`Coverage::Zero`]: the furthest vertex a guide path of the structure follows the
    /// path to before its term vanishes (1: x_1 is outside every first-vertex kernel of the
    /// structure); 0 otherwise.
    pub vanished_at: usize,
}

/// The candidates of the last x_1 and structure queried (guides of that structure whose
/// first-vertex kernel holds x_1, with what that kernel's density needs). All paths of one
/// unguided sample whose first vertex is the camera ray's hit share x_1 (pt: every path;
/// bdpt: every technique with t >= 2), so paths of one structure among them share one query.
///
/// With `collect_terms` (learning under `weights = second_moment`), each p_g evaluation also
/// leaves its non-zero terms `(l, w_l p(X | l))` in `terms`.
#[derive(Default)]
pub struct X1Candidates {
    /// Position, normal and medium flag of the last x_1 (the density depends on all three)
    /// and the structure queried.
    x1: Option<(Vec3, Vec3, bool, u64)>,
    list: Vec<FirstTest>,
    /// Query the BVH for every path instead (for measuring what the reuse saves).
    pub no_reuse: bool,
    /// Leave each p_g evaluation's non-zero terms in `terms`.
    pub collect_terms: bool,
    /// `(l, w_l p(X | l))` of the last p_g evaluation, when `collect_terms` is set.
    pub terms: Vec<(u32, f64)>,
}

impl X1Candidates {
    /// The candidates of `x1`, queried only when it differs from the last one.
    pub fn of(
        &mut self,
        cache: &GuideCache,
        scene: &Scene,
        sig: u64,
        x1: &Vertex,
        stats: &mut Stats,
    ) -> &[FirstTest] {
        self.at(cache, scene, sig, (x1.p, x1.n, x1.is_medium()), stats)
    }

    /// [`Self::of`] a first vertex given by position, normal and medium flag.
    pub fn at(
        &mut self,
        cache: &GuideCache,
        scene: &Scene,
        sig: u64,
        (p, n, medium): (Vec3, Vec3, bool),
        stats: &mut Stats,
    ) -> &[FirstTest] {
        let key = (p, n, medium, sig);
        if self.no_reuse || self.x1 != Some(key) {
            cache.candidates_at(scene, sig, p, n, medium, &mut self.list);
            self.x1 = Some(key);
            stats.bvh_queries += 1;
        }
        &self.list
    }
}

/// A successful guided sample.
pub struct GuidedValue {
    /// Row-major index of the pixel x_1 projects to.
    pub pixel: u32,
    /// The weighted contribution `f(X) / (n_u p_u + n_g p_g) · N_pix` to splat.
    pub value: DVec3,
    /// Guide path followed.
    pub guide: usize,
    /// The path offered to the cache, when the caller asked for one (learning).
    pub record: Option<Record>,
    /// Luminance of f(X) and the densities (for the share's measurements).
    pub f_lum: f64,
    /// U's density sum for the path.
    pub p_u: f64,
    /// The guided density of the path.
    pub p_g: f64,
}

/// The estimator of one pass: cache, split and densities.
pub struct Estimator<'a, U: Unguided> {
    /// The scene rendered.
    pub scene: &'a Scene,
    /// The unguided estimator U.
    pub unguided: &'a U,
    /// U's shared state of this pass (`Unguided::begin_pass`).
    pub pass: U::Pass<'a>,
    /// The frozen guide cache of this pass.
    pub cache: &'a GuideCache,
    /// Unguided share α of this pass (1: no guided samples).
    pub alpha: f64,
    /// Unguided samples per pass (one per pixel) and guided paths per pass.
    pub n_u: f64,
    /// Guided paths per pass, `n_u (1 − α) / α` (0 with guiding off).
    pub n_g: f64,
}

impl<'a, U: Unguided> Estimator<'a, U> {
    /// The estimator with unguided share `alpha` (taken as 1 with an empty cache).
    pub fn new(
        scene: &'a Scene,
        unguided: &'a U,
        pass: U::Pass<'a>,
        cache: &'a GuideCache,
        alpha: f64,
    ) -> Self {
        let (alpha, n_u, n_g) = Self::split(scene, unguided, cache, alpha);
        Estimator {
            scene,
            unguided,
            pass,
            cache,
            alpha,
            n_u,
            n_g,
        }
    }

    /// The share α (1 with an empty cache), n_u and n_g of an estimator with share `alpha`.
    pub fn split(scene: &Scene, unguided: &U, cache: &GuideCache, alpha: f64) -> (f64, f64, f64) {
        let alpha = if cache.is_empty() { 1.0 } else { alpha };
        let n_u = unguided.samples_per_pass(scene);
        (alpha, n_u, (n_u * (1.0 - alpha) / alpha).round())
    }

    /// `p_u` and `p_g` of a path U reported with density sum `p_u` (see the module doc for
    /// when `p_u` is recomputed), and what the cache offers the path. `y` is the path as BDPT
    /// vertices if the caller has them; `candidates` holds the BVH candidates of the last x_1
    /// (no allocation per path).
    pub fn densities(
        &self,
        path: &Path,
        y: Option<&[Vertex]>,
        p_u: f64,
        stats: &mut Stats,
        candidates: &mut X1Candidates,
    ) -> Densities {
        self.densities_with(path, y, p_u, true, stats, candidates)
    }

    /// [`Self::densities`]; `recompute = false` when `p_u` is already `pdf_unguided` of `y`
    /// (a path U weighed from its vertices, `PathSink::record_from_vertices`).
    pub fn densities_with(
        &self,
        path: &Path,
        y: Option<&[Vertex]>,
        p_u: f64,
        recompute: bool,
        stats: &mut Stats,
        candidates: &mut X1Candidates,
    ) -> Densities {
        let not_held = Densities {
            p_u,
            p_g: 0.0,
            coverage: Coverage::NotHeld,
            vanished_at: 0,
        };
        if self.n_g == 0.0 {
            return not_held;
        }
        // The hash alone (cheaper than the nodes) rejects every path whose structure the cache
        // lacks.
        match kernel::signature(self.scene, path, MAX_VERTICES) {
            Some(sig) if self.cache.holds(sig) => {}
            _ => return not_held,
        }
        let Some((sig, nodes)) = kernel::structure(self.scene, path, MAX_VERTICES) else {
            return not_held;
        };
        let owned;
        let y = match y {
            Some(y) => y,
            None => match paths::from_path(self.scene, path) {
                Some(v) => {
                    owned = v;
                    &owned
                }
                None => return not_held,
            },
        };
        let mut each = std::mem::take(&mut candidates.terms);
        each.clear();
        let collect = candidates.collect_terms;
        let list = candidates.of(self.cache, self.scene, sig, &y[1], stats);
        let terms = self.cache.terms(
            self.scene,
            y,
            sig,
            &nodes,
            list,
            None,
            collect.then_some(&mut each),
        );
        stats.pg_evaluations += 1;
        stats.pg_candidates += list.len() as u64;
        candidates.terms = each;
        let (p_g, vanished_at) = (terms.sum, terms.reach);
        if p_g > 0.0 && !recompute {
            Densities {
                p_u,
                p_g,
                coverage: Coverage::Covered,
                vanished_at: 0,
            }
        } else if p_g > 0.0 {
            // One source for p_u: the same function guided samples use. It re-traces every
            // segment, and visibility is not exactly symmetric in f32 (a ray grazing a mesh's
            // open rim hits it one way and passes the other: fog-dragon's bunny), so it can
            // call a path U has just formed impossible. U's own density then stands in, which
            // bounds the value by U's own f / p_u; with 0 the value would be f / (r p_g),
            // unbounded (fireflies of 1e5 on fog-dragon before).
            let recomputed = self.unguided.pdf_unguided(self.scene, &self.pass, y);
            let p_u = if recomputed > 0.5 * p_u && recomputed < 2.0 * p_u {
                recomputed
            } else {
                stats.pu_disagreements += 1;
                p_u
            };
            Densities {
                p_u,
                p_g,
                coverage: Coverage::Covered,
                vanished_at: 0,
            }
        } else {
            Densities {
                p_u,
                p_g: 0.0,
                coverage: Coverage::Zero,
                vanished_at,
            }
        }
    }

    /// The denominator of a contribution, `(n_u p_u + n_g p_g) / N_pix`: densities are
    /// image-wide and a pixel's measurement carries the factor N_pix (one unguided sample per
    /// pixel and pass gives the usual `f / p_u`).
    pub fn mix(&self, p_u: f64, p_g: f64) -> f64 {
        let faults = self.cache.weight_faults;
        let (p_g, r) = (p_g * faults.p_g, self.n_g / self.n_u * faults.ratio);
        if crate::check::enabled() {
            use crate::check::{Technique, density, weight};
            let (u, g) = (Technique::named("unguided"), Technique::named("guided"));
            density(u, p_u);
            density(g, p_g);
            let m = p_u + r * p_g;
            if m > 0.0 {
                weight(u, p_u / m);
                weight(g, r * p_g / m);
            }
        }
        p_u + r * p_g
    }

    /// Credit each guide path with its share of a sample's squared value (`weights =
    /// second_moment`): the sample X, of value V = f / (p_u + r p_g) with r = n_g / n_u,
    /// adds `V² r w_l p(X | l) / (p_u + r p_g)` to guide l for each term of p_g. Summed over
    /// a pass's samples (all drawn from the mixture) this estimates `w_l ∫ f² p(X | l) /
    /// p_mix² dX`, the part of the estimator's second moment that guide l's weight can
    /// reduce: raising w_l lowers the second moment where this is large (the
    /// Rao-Blackwellised mixture update of population Monte Carlo, with f² for variance).
    pub fn credit(
        &self,
        value: DVec3,
        p_u: f64,
        p_g: f64,
        terms: &[(u32, f64)],
        out: &mut Vec<(u32, f64)>,
    ) {
        let v = luminance64(value);
        let r = self.n_g / self.n_u;
        let mix = p_u + r * p_g;
        if !(v > 0.0 && mix > 0.0) {
            return;
        }
        for &(l, term) in terms {
            out.push((l, v * v * r * term / mix));
        }
    }

    /// The selection value `C = f / (α p_u + (1 − α) p_g)` of a path (luminance of f).
    pub fn c(&self, f_lum: f64, p_u: f64, p_g: f64) -> f64 {
        f_lum / (self.alpha * p_u + (1.0 - self.alpha) * p_g)
    }

    /// One guided sample from stream `sampler`: its pixel and value when it succeeds.
    pub fn guided(
        &self,
        sampler: &mut impl Sampler,
        want_record: bool,
        stats: &mut Stats,
        candidates: &mut X1Candidates,
        path: &mut Path,
    ) -> Option<GuidedValue> {
        stats.guided += 1;
        let g = match sampler::sample_path_into(self.scene, self.cache, sampler, path) {
            Ok(g) => g,
            Err(e) => {
                // The walk leaves the vertices drawn so far in `path`: it failed at the next.
                stats.fail_at(e, path.vertices().len());
                return None;
            }
        };
        if g.used_chain_step() {
            stats.chain_steps += 1;
        }
        // x_1 decides where the sample lands; the pixel filter picks the pixel it counts for
        // (`Camera::splat_pixel`: the pixel of x_1 with weight 1 for the box).
        let u = self.scene.camera.splat_number(sampler);
        let Some((pixel, filter)) = self.scene.camera.splat_pixel(g.raster, u) else {
            stats.fail(sampler::Failure::OffImage as usize);
            return None;
        };
        let path = &*path;
        let Some(y) = paths::from_path(self.scene, path) else {
            stats.fail(sampler::Failure::Structure as usize);
            return None;
        };
        let k = y.len() - 1;
        let last_delta = matches!(
            y[k].kind,
            paths::Kind::Light { light } if self.scene.lights[light].is_delta()
        );
        let visible = if last_delta {
            (1u64 << (k - 1)) - 1
        } else {
            u64::MAX
        };
        let f = contribution::contribution(self.scene, &y, visible);
        if f == DVec3::ZERO {
            stats.fail(ZERO);
            return None;
        }
        // Sampling drew the path from the guide's Gaussians with f64 points; evaluation sees
        // the f32 hit points. Where the two fall on different sides of a truncation edge the
        // path's own term is 0 (likewise when x_1 rounds out of its guide's candidate box):
        // such a sample is a failure (value 0), so that what is kept is exactly where the
        // evaluated density holds the own guide's term.
        let Some((sig, nodes)) = kernel::structure(self.scene, path, MAX_VERTICES) else {
            stats.fail(sampler::Failure::Structure as usize);
            return None;
        };
        let mut each = std::mem::take(&mut candidates.terms);
        each.clear();
        let collect = candidates.collect_terms;
        let list = candidates.of(self.cache, self.scene, sig, &y[1], stats);
        let n = list.len();
        let mut walks = WalkMemo::default();
        let terms = self.cache.terms_with(
            self.scene,
            &y,
            sig,
            &nodes,
            list,
            Some(g.guide),
            collect.then_some(&mut each),
            &mut walks,
        );
        candidates.terms = each;
        let (p_g, own) = (terms.sum, terms.own);
        if let Err(e) = g.check_chains(self.scene, self.cache, &y, &walks) {
            stats.fail(e as usize);
            return None;
        }
        if own == 0.0 {
            stats.fail(EDGE);
            return None;
        }
        let p_u = self.unguided.pdf_unguided(self.scene, &self.pass, &y);
        stats.pg_evaluations += 1;
        stats.pg_candidates += n as u64;
        stats.pg_candidates_guided += n as u64;
        stats.pg_evaluations_guided += 1;
        let value = f / self.mix(p_u, p_g) * filter as f64;
        if !(value.is_finite() && value.min_element() >= 0.0) {
            stats.fail(NON_FINITE);
            return None;
        }
        let f_lum = luminance64(f);
        let record = want_record.then(|| Record {
            vertices: path.vertices().to_vec(),
            f: f_lum,
            p_u,
            c: self.c(f_lum, p_u, p_g),
        });
        Some(GuidedValue {
            pixel: pixel as u32,
            value,
            guide: g.guide,
            record,
            f_lum,
            p_u,
            p_g,
        })
    }
}

/// What one row of a pass produces besides its pixels' unguided sums.
#[derive(Default)]
pub struct RowOutput {
    /// (pixel, value) splats of the row: guided samples and U's splatted paths, added to the
    /// film after the pass in row order.
    pub splats: Vec<(u32, DVec3)>,
    /// While learning: the row's sample luminances and brightest candidates, for the seeder.
    pub learn: LearnRow,
    /// The row's counters.
    pub stats: Stats,
    /// BVH candidates of the last x_1 (reused).
    pub candidates: X1Candidates,
    /// The guided samples' path buffer (reused).
    pub path: Path,
    /// While measuring the share (`share.rs`): per pixel of the row what U's sample adds to
    /// it under each ratio, U's splats likewise, and Σ g(r)² of the row's guided samples.
    pub grid: Vec<[f64; share::N]>,
    /// U's splats under each ratio, as `grid` (pixel, values).
    pub grid_splats: Vec<(u32, [f64; share::N])>,
    /// Σ g(r)² of the row's guided samples under each ratio, as `grid`.
    pub guided_m2: [f64; share::N],
    /// While learning: per pixel of the row U's own estimate from its sample (every path
    /// weighted `f / p_u`, the guided technique left out), and U's splats likewise; the image
    /// the learning passes leave when the share turns guiding off.
    pub u_pixels: Vec<DVec3>,
    /// Per pixel of the row, the luminance its own sample's paths add by coverage class, and
    /// (pixel, class, luminance) of splatted paths and guided samples (`coverage.rs`).
    pub class_pixels: Vec<[f64; coverage::CLASSES]>,
    /// (pixel, class, luminance) of splatted paths and guided samples, as `class_pixels`.
    pub class_splats: Vec<(u32, u8, f64)>,
    /// While learning under `weights = second_moment`: (guide, credit) of the row's samples
    /// ([`Estimator::credit`]).
    pub responsibility: Vec<(u32, f64)>,
    /// While learning: U's own splats, as `u_pixels`.
    pub u_splats: Vec<(u32, DVec3)>,
    /// Luminance of the contributions of U's paths that the cache does not cover (structure
    /// not held, or p_g = 0), summed (the chain seeder's `uncovered` target).
    pub uncovered: f64,
}
