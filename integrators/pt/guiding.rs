//! `pt -O guiding=sdtree`: path tracing whose continuation at rough surfaces is a mixture of
//! BSDF sampling and a learned distribution of incident radiance (Müller, Gross and Novák
//! 2017, "Practical Path Guiding"; the tree is `sdtree.rs`).
//!
//! At a surface vertex that is not a delta and whose region of the tree has learned something,
//! the continuation draws its direction from the tree with probability `guide_fraction` and
//! from the BSDF otherwise; its density is the mixture's, `(1 − a) p_bsdf + a p_tree`, in the
//! path's weight and in the MIS weights against next-event estimation alike, so the estimator
//! stays unbiased whatever the tree holds.
//!
//! Learning: iterations of 1, 2, 4, ... passes, each path tracing with the tree of the
//! iterations before and recording, at every rough surface vertex, the luminance of the
//! radiance its continuation brought back divided by the density of its direction; after each
//! iteration the tree is refined (`SdTree::refine`). Learning stops before an iteration would
//! take the learning budget past `learn_fraction` of the render's (of its passes under
//! `--spp`, of its seconds under `--time`); its images are not kept. Then the tree is frozen
//! and the render's passes run with it: the image does not depend on the number of threads
//! (fixed-point sums), and under `--spp` not on the machine either.
//!
//! Options `guiding`, `guide_fraction`, `learn_fraction`: in pt's table (`super::OPTIONS`).
//!
//! Only pt's own continuation is guided: guided-pt, pssmlt and the recorders use pt without
//! the tree, and media scatter by their phase function. With `--part`, each part learns its
//! own tree from its own budget (the parts stay unbiased, their sum is not the single render's
//! image bit for bit).

use super::PathTracer;
use super::sdtree::{DTree, INV_FOUR_PI, SdTree, from_square, to_square};
use crate::bsdf::{BsdfSample, TransportMode};
use crate::error::{Error, Result};
use crate::integrators::IntegratorParams;
use crate::integrators::options::{DefaultValue, Kind, Spec};
use crate::math::{IndependentSampler, Sampler, SamplerKind, Spectrum, luminance};
use crate::render::{
    Budget, Integrator, PixelEstimator, RenderContext, RenderResult, render_pixel_estimator,
};
use crate::scene::{Scene, SurfacePoint};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Stream key of the learning passes (apart from the render's passes; `math::streams`).
const LEARN_KEY: u64 = crate::math::streams::SDTREE_LEARNING;

/// Options of pt's SD-tree guiding (`guiding=sdtree`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidingSettings {
    /// Probability of drawing the continuation from the tree where it has learned something.
    pub guide_fraction: f32,
    /// Share of the budget spent learning.
    pub learn_fraction: f64,
}

/// Option `guiding` of pt.
pub const GUIDING_OPTION: Spec = Spec {
    name: "guiding",
    kind: Kind::Choice(&["none", "sdtree"]),
    default: DefaultValue::Word("none"),
    doc: "`sdtree`: learn a distribution of incident radiance and mix it with BSDF sampling at \
          rough surfaces (`pt/guiding.rs`)",
};

/// Option `guide_fraction` of pt.
pub const GUIDE_FRACTION_OPTION: Spec = Spec {
    name: "guide_fraction",
    kind: Kind::open(0.0, 1.0),
    default: DefaultValue::Number(0.7),
    doc: "`guiding=sdtree`: probability of drawing the continuation from the tree where it has \
          learned something (Müller et al. use 0.5; 0.7 measured the lower error on dining and \
          pool)",
};

/// Option `learn_fraction` of pt.
pub const LEARN_FRACTION_OPTION: Spec = Spec {
    name: "learn_fraction",
    kind: Kind::open(0.0, 1.0),
    default: DefaultValue::Number(0.25),
    doc: "`guiding=sdtree`: share of the budget spent learning",
};

/// The guiding options of pt; `None` without `guiding=sdtree`.
pub fn settings(params: &IntegratorParams) -> Result<Option<GuidingSettings>> {
    let o = params.options.declared(&[super::OPTIONS]);
    if o.word("guiding")? == "none" {
        for key in ["guide_fraction", "learn_fraction"] {
            if o.has(key) {
                return Err(Error::new(format!(
                    "option '{key}': only a setting of pt with guiding=sdtree"
                )));
            }
        }
        return Ok(None);
    }
    let guide_fraction = o.number("guide_fraction")? as f32;
    let learn_fraction = o.number("learn_fraction")?;
    Ok(Some(GuidingSettings {
        guide_fraction,
        learn_fraction,
    }))
}

/// The tree as pt's continuation sees it.
pub struct Guide<'t> {
    /// The learned spatio-directional tree.
    pub tree: &'t SdTree,
    /// Probability of drawing from the tree where it has learned something.
    pub fraction: f32,
}

impl Guide<'_> {
    /// The mixture at a surface point: the tree's directions there and the tree's share, or
    /// `None` (BSDF sampling alone) at delta surfaces and where the tree has learned nothing.
    pub fn at<'t>(&'t self, sp: &SurfacePoint) -> Option<Mixture<'t>> {
        if sp.bsdf.is_delta() {
            return None;
        }
        self.tree.directions_at(sp.hit.p).map(|d| Mixture {
            directions: d,
            a: self.fraction,
        })
    }
}

/// BSDF sampling mixed with the tree's directions.
#[derive(Clone, Copy)]
pub struct Mixture<'t> {
    /// The tree's directional distribution at the point.
    pub directions: &'t DTree,
    /// Probability of drawing from the tree.
    pub a: f32,
}

impl Mixture<'_> {
    /// The mixture's solid-angle density of `wi`, given the BSDF's.
    pub fn pdf(&self, pdf_bsdf: f32, wi: Vec3) -> f32 {
        let p_tree = self.directions.pdf(to_square(wi)) * INV_FOUR_PI;
        ((1.0 - self.a as f64) * pdf_bsdf as f64 + self.a as f64 * p_tree) as f32
    }

    /// A continuation direction from the mixture, as a BSDF sample whose `pdf` is the
    /// mixture's and `weight` is `f |cos| / pdf`.
    pub fn sample(
        &self,
        sp: &SurfacePoint,
        wo: Vec3,
        sampler: &mut (impl Sampler + ?Sized),
    ) -> Option<BsdfSample> {
        let mode = TransportMode::Radiance;
        if sampler.next_1d() >= self.a {
            let u_lobe = sampler.next_1d();
            let u = sampler.next_2d();
            let bs = sp.bsdf.sample(&sp.frame, wo, u_lobe, u, mode)?;
            if bs.delta {
                // A delta lobe beside non-delta ones (smooth plastic's coating): a discrete
                // choice the tree never makes, of probability (1 - a) times the lobe's.
                let keep = 1.0 - self.a;
                return Some(BsdfSample {
                    pdf: bs.pdf * keep,
                    weight: bs.weight / keep,
                    ..bs
                });
            }
            let pdf = self.pdf(bs.pdf, bs.wi);
            let weight = bs.weight * (bs.pdf / pdf);
            return weight
                .is_finite()
                .then_some(BsdfSample { pdf, weight, ..bs });
        }
        let (p, _) = self.directions.sample(|| sampler.next_1d());
        let wi = from_square(p);
        let (f, pdf_bsdf) = sp.bsdf.eval_pdf(&sp.frame, wo, wi, mode);
        if f == Spectrum::ZERO {
            return None;
        }
        let pdf = self.pdf(pdf_bsdf, wi);
        let weight = f * wi.dot(sp.hit.ns).abs() / pdf;
        if !(pdf > 0.0 && weight.is_finite()) || weight == Spectrum::ZERO {
            return None;
        }
        let ng = sp.hit.ng;
        let transmission = wi.dot(ng) * wo.dot(ng) < 0.0;
        Some(BsdfSample {
            wi,
            f,
            pdf,
            weight,
            delta: false,
            transmission,
            eta: 1.0,
        })
    }
}

/// The vertices of one path whose continuation the tree learns from (scratch kept per row of
/// a learning pass, so no path allocates).
#[derive(Default)]
pub struct Trail {
    at: Vec<(Vec3, Vec3, f32, Spectrum, Spectrum)>,
}

impl Trail {
    /// The continuation left `p` along `wi` with density `pdf`; `beta` is the throughput after
    /// it (roulette included), `l` the radiance gathered so far.
    pub fn push(&mut self, p: Vec3, wi: Vec3, pdf: f32, beta: Spectrum, l: Spectrum) {
        self.at.push((p, wi, pdf, beta, l));
    }

    /// Record into `tree` what each continuation brought back, given the path's final `l`.
    pub fn record(&mut self, tree: &SdTree, l: Spectrum) {
        for &(p, wi, pdf, beta, l_then) in &self.at {
            let gained = l - l_then;
            let li = Spectrum::new(
                if beta.x > 0.0 { gained.x / beta.x } else { 0.0 },
                if beta.y > 0.0 { gained.y / beta.y } else { 0.0 },
                if beta.z > 0.0 { gained.z / beta.z } else { 0.0 },
            );
            tree.record(p, wi, luminance(li).max(0.0) as f64 / pdf as f64);
        }
        self.at.clear();
    }
}

/// `pt` with `guiding=sdtree`.
pub struct GuidedPathTracer {
    /// The path tracer whose continuations are guided.
    pub pt: PathTracer,
    /// Guiding's options.
    pub guiding: GuidingSettings,
    /// The sampler of the render after learning (learning draws independent numbers).
    pub sampler: SamplerKind,
}

impl Integrator for GuidedPathTracer {
    fn name(&self) -> &'static str {
        "pt"
    }

    fn settings(&self) -> String {
        format!("{:?} {:?}", self.pt.settings, self.guiding)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        render(&self.pt, &self.guiding, self.sampler, ctx, budget)
    }
}

/// pt with a frozen tree, as a per-pixel estimator.
struct Frozen<'a> {
    pt: &'a PathTracer,
    guide: Guide<'a>,
}

impl PixelEstimator for Frozen<'_> {
    fn estimate<S: Sampler>(&self, scene: &Scene, raster: Vec2, sampler: &mut S) -> Spectrum {
        self.pt.li_guided(scene, raster, sampler, &self.guide, None)
    }
}

/// Learn the tree, then render with it (module doc).
pub fn render(
    pt: &PathTracer,
    g: &GuidingSettings,
    sampler: SamplerKind,
    ctx: &RenderContext,
    budget: Budget,
) -> RenderResult {
    let scene = ctx.scene;
    let clock = ctx.clock;
    let start = clock.now();
    let mut tree = SdTree::new(scene.center, scene.radius);
    let (w, h) = (scene.camera.resolution.x, scene.camera.resolution.y);
    let mut learned = 0u64;
    let mut last = 0.0f64;
    for iteration in 0..=20u32 {
        let n = 1u64 << iteration;
        let go = match budget {
            // At least one pass is left for the render.
            Budget::Spp(total) => {
                learned + n
                    <= ((total as f64 * g.learn_fraction) as u64).min(total.saturating_sub(1))
            }
            Budget::Seconds(s) => {
                let t = (clock.now() - start).as_secs_f64();
                iteration == 0 || t + 2.0 * last <= s * g.learn_fraction
            }
        };
        if !go || ctx.stopped() {
            break;
        }
        let t0 = clock.now();
        let guide = Guide {
            tree: &tree,
            fraction: g.guide_fraction,
        };
        for pass in learned..learned + n {
            (0..h).into_par_iter().for_each(|y| {
                let mut trail = Trail::default();
                for x in 0..w {
                    let index = y as u64 * w as u64 + x as u64;
                    let mut sampler = IndependentSampler::new(ctx.seed ^ LEARN_KEY, pass, index);
                    let jitter = sampler.next_2d();
                    let raster = Vec2::new(x as f32, y as f32) + jitter;
                    pt.li_guided(scene, raster, &mut sampler, &guide, Some(&mut trail));
                }
            });
        }
        tree.refine(n);
        learned += n;
        last = (clock.now() - t0).as_secs_f64();
    }
    let learning_seconds = (clock.now() - start).as_secs_f64();
    let rest = match budget {
        Budget::Spp(total) => Budget::Spp(total.saturating_sub(learned)),
        Budget::Seconds(s) => Budget::Seconds((s - learning_seconds).max(0.0)),
    };
    let frozen = Frozen {
        pt,
        guide: Guide {
            tree: &tree,
            fraction: g.guide_fraction,
        },
    };
    let mut result = render_pixel_estimator(ctx, rest, sampler, &frozen);
    result.seconds += learning_seconds;
    let (leaves, nodes) = tree.size();
    result.stats.extend([
        ("learning_passes".to_string(), learned.to_string()),
        (
            "learning_seconds".to_string(),
            format!("{learning_seconds:.3}"),
        ),
        ("sdtree_spatial_leaves".to_string(), leaves.to_string()),
        (
            "sdtree_mean_quadtree_nodes".to_string(),
            format!("{nodes:.1}"),
        ),
    ]);
    result
}
