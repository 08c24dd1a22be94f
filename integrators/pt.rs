//! `pt` — unidirectional path tracing.
//!
//! Estimates each pixel's measurement (unbiased) from camera paths. At every non-delta vertex
//! it combines next-event estimation (one light chosen by power, one point on it) with BSDF
//! sampling that hits emitters, weighting the two by the power heuristic; paths continue by
//! BSDF sampling with Russian roulette.
//!
//! | option    | type                   | default | meaning |
//! |-----------|------------------------|---------|---------|
//! | max_depth | integer >= 1           | 8       | maximum number of path segments; 1 shows only emitters seen directly, 2 is direct lighting (`--max-depth`) |
//! | rr_depth  | integer >= 1           | 5       | Russian roulette starts on paths of this many segments (Mitsuba's default) |
//! | strategy  | `mis` / `bsdf` / `nee` | `mis`   | `bsdf`: emitters only found by BSDF sampling; `nee`: only by next-event estimation (except after delta bounces and for the camera ray) |
//!
//! Roulette continues with probability `min(1, max(beta * eta_scale))`, where `eta_scale`
//! undoes the radiance scaling of refraction (pbrt-v4's rule).
//! Limits: no participating media yet (they arrive with the media issue).
//!
//! ```text
//! lodestar render scenes/cornell-box.toml --integrator pt --spp 64 -O strategy=mis
//! ```

use super::IntegratorParams;
use crate::bsdf::TransportMode;
use crate::error::{Error, Result};
use crate::geometry::gamma;
use crate::math::{IndependentSampler, Sampler, Spectrum, power_heuristic};
use crate::render::{
    Budget, Integrator, PixelEstimator, RenderContext, RenderResult, render_pixel_estimator,
};
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// How emitters are reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// Next-event estimation and BSDF sampling, power heuristic.
    Mis,
    /// BSDF sampling only.
    Bsdf,
    /// Next-event estimation only.
    Nee,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PtSettings {
    /// Maximum number of path segments (default 8).
    pub max_depth: u32,
    /// Path length (segments) from which Russian roulette applies (default 5).
    pub rr_depth: u32,
    /// Default `Mis`.
    pub strategy: Strategy,
}

impl Default for PtSettings {
    fn default() -> Self {
        PtSettings {
            max_depth: 8,
            rr_depth: 5,
            strategy: Strategy::Mis,
        }
    }
}

pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let o = &params.options;
    let strategy = match o.choice("strategy", "mis", &["mis", "bsdf", "nee"])? {
        "bsdf" => Strategy::Bsdf,
        "nee" => Strategy::Nee,
        _ => Strategy::Mis,
    };
    let rr_depth = o.get("rr_depth", 5u32, "an integer >= 1")?;
    if rr_depth == 0 {
        return Err(Error::new(
            "option 'rr_depth': expected an integer >= 1, got 0",
        ));
    }
    Ok(Box::new(PathTracer {
        settings: PtSettings {
            max_depth: params.max_depth,
            rr_depth,
            strategy,
        },
    }))
}

pub struct PathTracer {
    pub settings: PtSettings,
}

impl Integrator for PathTracer {
    fn name(&self) -> &'static str {
        "pt"
    }

    fn settings(&self) -> String {
        format!("{:?}", self.settings)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        render_pixel_estimator(ctx, budget, self)
    }
}

impl PixelEstimator for PathTracer {
    fn estimate(&self, scene: &Scene, raster: Vec2, sampler: &mut IndependentSampler) -> Spectrum {
        self.li(scene, raster, sampler)
    }
}

impl PathTracer {
    /// Radiance arriving at the pinhole through raster position `raster`.
    pub fn li(&self, scene: &Scene, raster: Vec2, sampler: &mut impl Sampler) -> Spectrum {
        let s = &self.settings;
        let use_nee = s.strategy != Strategy::Bsdf;
        let mut ray = scene.camera.generate_ray(raster);
        let mut l = Spectrum::ZERO;
        let mut beta = Spectrum::ONE;
        let mut eta_scale = 1.0f32;
        // State of the previous vertex, for MIS on emitter hits.
        let mut prev_delta = true; // the pinhole is a delta vertex
        let mut prev_pdf = 0.0f32; // solid-angle density of the last BSDF sample
        let mut prev_p = ray.o;

        // `depth` = number of segments of the path once `ray` is traced.
        for depth in 1..=s.max_depth {
            let Some(sp) = scene.intersect(&ray) else {
                // ---- Escaped: environment emission ----
                if let Some(env) = scene.environment {
                    let le = scene.lights[env].le(Vec3::ZERO, ray.d);
                    let w = self.emission_weight(scene, env, prev_delta, prev_pdf, || {
                        scene.lights[env].pdf_li(prev_p, Vec3::ZERO, Vec3::ZERO, ray.d)
                    });
                    l += beta * le * w;
                }
                break;
            };
            let hit = sp.hit;
            let wo = -ray.d;

            // ---- Emission of a hit emitter ----
            if let Some(li) = sp.light {
                let le = scene.lights[li].le(hit.ng, wo);
                if le != Spectrum::ZERO {
                    let w = self.emission_weight(scene, li, prev_delta, prev_pdf, || {
                        scene.lights[li].pdf_li(prev_p, hit.p, hit.ng, ray.d)
                    });
                    l += beta * le * w;
                }
            }
            if sp.bsdf.is_black() || depth == s.max_depth {
                break;
            }

            // ---- Next-event estimation (adds a path of depth + 1 segments) ----
            if use_nee && !sp.bsdf.is_delta() {
                let u_light = sampler.next_1d();
                let u = sampler.next_2d();
                if let Some((light_id, pmf)) = scene.light_sampler.sample(u_light) {
                    let light = &scene.lights[light_id];
                    if let Some(ls) = light.sample_li(hit.p, u) {
                        let f = sp.bsdf.eval(&sp.frame, wo, ls.wi, TransportMode::Radiance)
                            * ls.wi.dot(hit.ns).abs();
                        if f != Spectrum::ZERO {
                            let visible = if ls.dist.is_infinite() {
                                scene.escapes(&hit, ls.wi)
                            } else {
                                scene.visible(&hit, ls.p, ls.n, gamma(8) * ls.p.abs())
                            };
                            if visible {
                                let p_light = pmf * ls.pdf;
                                let w = if ls.delta || s.strategy == Strategy::Nee {
                                    1.0
                                } else {
                                    power_heuristic(
                                        p_light,
                                        sp.bsdf.pdf(&sp.frame, wo, ls.wi, TransportMode::Radiance),
                                    )
                                };
                                l += beta * f * ls.li * (w / p_light);
                            }
                        }
                    }
                }
            }

            // ---- BSDF sampling: extend the path ----
            let u_lobe = sampler.next_1d();
            let u = sampler.next_2d();
            let Some(bs) = sp
                .bsdf
                .sample(&sp.frame, wo, u_lobe, u, TransportMode::Radiance)
            else {
                break;
            };
            beta *= bs.weight;
            if bs.transmission {
                eta_scale *= bs.eta * bs.eta;
            }
            prev_delta = bs.delta;
            prev_pdf = bs.pdf;
            prev_p = hit.p;

            // ---- Russian roulette ----
            if depth >= s.rr_depth {
                let q = (beta * eta_scale).max_element().min(1.0);
                if sampler.next_1d() >= q {
                    break;
                }
                beta /= q;
            }
            ray = hit.spawn(bs.wi);
        }
        l
    }

    /// MIS weight of emission found by BSDF sampling (or by the camera ray).
    fn emission_weight(
        &self,
        scene: &Scene,
        light: usize,
        prev_delta: bool,
        prev_pdf: f32,
        pdf_li: impl FnOnce() -> f32,
    ) -> f32 {
        if prev_delta {
            return 1.0; // no other strategy can produce this path
        }
        match self.settings.strategy {
            Strategy::Bsdf => 1.0,
            Strategy::Nee => 0.0,
            Strategy::Mis => power_heuristic(prev_pdf, scene.light_sampler.pmf(light) * pdf_li()),
        }
    }
}
