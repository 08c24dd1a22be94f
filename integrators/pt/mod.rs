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
//! | guiding   | `none` / `sdtree`      | `none`  | `sdtree`: learn a distribution of incident radiance and mix it with BSDF sampling at rough surfaces (`guiding.rs`, which also lists `guide_fraction` and `learn_fraction`) |
//!
//! Roulette continues with the local probability of the vertex (`Bsdf::continuation`: its
//! largest reflectance, 1 for glass; a medium's albedo), so that the density of any path, roulette
//! included, can be computed from the path alone (`pdf_unguided`, shared with BDPT).
//!
//! Media: in a homogeneous medium the path samples a free-flight distance (one RGB channel
//! chosen uniformly, the channel-averaged density); a scattering point is a path vertex that
//! does next-event estimation (transmittance computed analytically, through index-matched
//! boundaries) and samples the phase function. Index-matched boundaries (shapes with media and
//! no material) are crossed without a vertex. MIS compares the light's density with the
//! continuation's density times the probability that free flight passes the connecting
//! segment, which is what the continuation really samples. A scene without media never runs
//! any of this (one branch per segment on the current medium, which is always `None`).
//!
//! ```text
//! lodestar render scenes/cornell-box.toml --integrator pt --spp 64 -O strategy=mis
//! ```

use super::IntegratorParams;
use crate::bsdf::TransportMode;
use crate::error::{Error, Result};
use crate::geometry::Ray;
use crate::math::{IndependentSampler, Sampler, Spectrum, power_heuristic};
use crate::path::{Path, Vertex as PathVertex, VertexKind};
use crate::render::{
    Budget, Integrator, PixelEstimator, RenderContext, RenderResult, render_pixel_estimator,
};
use crate::scene::{Endpoint, Scene};
use direct::Scatterer;
use glam::{Vec2, Vec3};
use guiding::{Guide, Trail};
pub use recording::PathRecorder;
use recording::Recording;

mod direct;
pub mod guiding;
mod recording;
pub mod sdtree;

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
    let pt = PathTracer {
        settings: settings(params)?,
    };
    Ok(match guiding::settings(params)? {
        None => Box::new(pt),
        Some(guiding) => Box::new(guiding::GuidedPathTracer { pt, guiding }),
    })
}

/// pt's settings from `max_depth` and the options of the table above (also `pssmlt`'s).
pub fn settings(params: &IntegratorParams) -> Result<PtSettings> {
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
    Ok(PtSettings {
        max_depth: params.max_depth,
        rr_depth,
        strategy,
    })
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
    /// `pdf_unguided` (DESIGN.md §3): the density with which pt produces `path` by either of
    /// its techniques (the continuation hits the emitter; next-event estimation), summed. The
    /// techniques are BDPT's s = 0 and (for paths of two or more segments) s = 1, so the
    /// densities come from the same code; a one-segment path is only found by the camera ray.
    pub fn pdf_unguided(&self, scene: &Scene, path: &Path) -> f64 {
        let s = &self.settings;
        super::bdpt::technique_densities_of(scene, path, s.max_depth, s.rr_depth)
            .map_or(0.0, |(p, k)| p[0] + if k >= 2 { p[1] } else { 0.0 })
    }

    /// Radiance arriving at the pinhole through raster position `raster`.
    pub fn li(&self, scene: &Scene, raster: Vec2, sampler: &mut impl Sampler) -> Spectrum {
        self.li_recorded(scene, raster, sampler, None)
    }

    /// As [`Self::li`], handing every complete path it forms to `recorder`.
    pub fn li_recorded(
        &self,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        recorder: Option<&mut dyn PathRecorder>,
    ) -> Spectrum {
        self.li_with(scene, raster, sampler, recorder, None, None)
    }

    /// As [`Self::li`], the continuation guided by `guide` (`guiding.rs`); with `trail`
    /// (learning), what each continuation brings back is recorded into the guide's tree.
    pub fn li_guided(
        &self,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        guide: &Guide,
        trail: Option<&mut Trail>,
    ) -> Spectrum {
        self.li_with(scene, raster, sampler, None, Some(guide), trail)
    }

    fn li_with(
        &self,
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        recorder: Option<&mut dyn PathRecorder>,
        guide: Option<&Guide>,
        mut trail: Option<&mut Trail>,
    ) -> Spectrum {
        let s = &self.settings;
        let use_nee = s.strategy != Strategy::Bsdf;
        let mut ray = scene.camera.generate_ray(raster);
        let mut rec = recorder.map(|sink| {
            Recording::new(scene, sink, ray.d, scene.camera.pixel_index(raster) as u32)
        });
        let mut medium = scene.camera_medium;
        let mut l = Spectrum::ZERO;
        let mut beta = Spectrum::ONE;
        // The last scattering vertex (the pinhole is a delta vertex), for MIS on emitters that
        // the continuation finds, and the free-flight pass probability since then.
        let mut prev = Scattered {
            delta: true,
            pdf: 0.0,
            p: ray.o,
        };
        let mut pass = 1.0f32;
        // Number of segments of the path once `ray` reaches its next vertex.
        let mut depth = 1u32;
        let mut null_crossings = 0u32;

        loop {
            let sp = scene.intersect(&ray);

            // ---- Medium: scatter before the surface, or pass it ----
            if let Some(m) = medium {
                let m = &scene.media[m as usize];
                let t_hit = sp.as_ref().map_or(f32::INFINITY, |sp| sp.hit.t);
                let flight = m.sample_distance(t_hit, sampler.next_1d(), sampler.next_1d());
                beta *= flight.weight;
                if flight.scattered {
                    if depth == s.max_depth {
                        break;
                    }
                    let p = ray.at(flight.t);
                    let wo = -ray.d;
                    let here = Endpoint::point(p);
                    if let Some(r) = &mut rec {
                        let v = PathVertex {
                            p,
                            n: Vec3::ZERO,
                            ns: Vec3::ZERO,
                            kind: VertexKind::Medium {
                                medium: medium.unwrap_or(0),
                            },
                        };
                        r.arrive(scene, v, pass * flight.pdf);
                    }
                    if use_nee {
                        let q_here = self.roulette_probability(depth, m.continuation());
                        let phase = Scatterer::Medium {
                            phase: &m.phase,
                            wo,
                        };
                        l += beta
                            * self.direct(
                                scene,
                                &here,
                                medium,
                                &phase,
                                sampler,
                                rec.as_mut().map(|r| (r, beta, q_here)),
                            );
                    }
                    let (wi, pdf) = m.phase.sample(wo, sampler.next_2d());
                    if let Some(r) = &mut rec {
                        r.scatter(pdf, self.roulette_probability(depth, m.continuation()));
                    }
                    prev = Scattered {
                        delta: false,
                        pdf,
                        p,
                    };
                    pass = 1.0;
                    if !self.roulette(depth, m.continuation(), &mut beta, sampler) {
                        break;
                    }
                    ray = Ray::new(p, wi);
                    depth += 1;
                    continue;
                }
                pass *= flight.pdf;
                if beta == Spectrum::ZERO {
                    break;
                }
            }

            let Some(sp) = &sp else {
                // ---- Escaped: lights at infinity ----
                for &li in &scene.infinite_lights {
                    let light = &scene.lights[li];
                    let le = light.le(Vec3::ZERO, ray.d);
                    if le != Spectrum::ZERO {
                        if let Some(r) = &mut rec {
                            let at = r.path.vertices().last().map_or(ray.o, |v| v.p) + ray.d;
                            let v = PathVertex {
                                p: at,
                                n: ray.d,
                                ns: Vec3::ZERO,
                                kind: VertexKind::Emitter {
                                    light: li as u32,
                                    delta: false,
                                },
                            };
                            let nee = if prev.delta {
                                0.0
                            } else {
                                scene.light_sampler.pmf(li) as f64
                                    * light.pdf_li(prev.p, Vec3::ZERO, Vec3::ZERO, ray.d) as f64
                            };
                            r.emitter(scene, v, pass, nee, beta * le);
                        }
                        let pdf_li = || light.pdf_li(prev.p, Vec3::ZERO, Vec3::ZERO, ray.d);
                        l += beta * le * self.emission_weight(scene, li, &prev, pass, pdf_li);
                    }
                }
                break;
            };
            let hit = &sp.hit;

            // ---- Index-matched boundary: straight through, still the same segment ----
            if sp.is_null() {
                null_crossings += 1;
                if null_crossings > 256 {
                    break;
                }
                medium = scene.medium_after(sp, ray.d, medium);
                ray = hit.spawn(ray.d);
                continue;
            }
            let wo = -ray.d;

            // ---- Emission of a hit emitter ----
            if let Some(li) = sp.light() {
                let light = &scene.lights[li];
                let le = light.le(hit.ng, wo);
                if le != Spectrum::ZERO {
                    if let Some(r) = &mut rec {
                        let v = PathVertex {
                            p: hit.p,
                            n: hit.ng,
                            ns: Vec3::ZERO,
                            kind: VertexKind::Emitter {
                                light: li as u32,
                                delta: false,
                            },
                        };
                        let nee = if prev.delta {
                            0.0
                        } else {
                            let d2 = (hit.p - prev.p).length_squared() as f64;
                            scene.light_sampler.pmf(li) as f64
                                * light.pdf_li(prev.p, hit.p, hit.ng, ray.d) as f64
                                * hit.ng.dot(ray.d).abs() as f64
                                / d2
                        };
                        r.emitter(scene, v, pass, nee, beta * le);
                    }
                    let pdf_li = || light.pdf_li(prev.p, hit.p, hit.ng, ray.d);
                    l += beta * le * self.emission_weight(scene, li, &prev, pass, pdf_li);
                }
            }
            if sp.bsdf.is_black() || depth == s.max_depth {
                break;
            }
            if let Some(r) = &mut rec {
                let kind = VertexKind::Surface {
                    material: sp.material,
                    shape: sp.info.index,
                    delta: sp.bsdf.is_delta(),
                };
                r.arrive(
                    scene,
                    PathVertex {
                        p: hit.p,
                        n: hit.ng,
                        ns: hit.ns,
                        kind,
                    },
                    pass,
                );
            }

            // ---- Next-event estimation (adds a path of depth + 1 segments) ----
            let mix = guide.and_then(|g| g.at(sp));
            if use_nee && !sp.bsdf.is_delta() {
                let q_here = self.roulette_probability(depth, sp.bsdf.continuation());
                let surface = Scatterer::Surface { sp, wo, mix };
                l += beta
                    * self.direct(
                        scene,
                        &Endpoint::surface(hit),
                        medium,
                        &surface,
                        sampler,
                        rec.as_mut().map(|r| (r, beta, q_here)),
                    );
            }

            // ---- BSDF sampling (mixed with the guide's directions): extend the path ----
            let bs = match &mix {
                Some(m) => m.sample(sp, wo, sampler),
                None => {
                    let u_lobe = sampler.next_1d();
                    let u = sampler.next_2d();
                    sp.bsdf
                        .sample(&sp.frame, wo, u_lobe, u, TransportMode::Radiance)
                }
            };
            let Some(bs) = bs else {
                break;
            };
            beta *= bs.weight;
            if let Some(r) = &mut rec {
                r.scatter(
                    bs.pdf,
                    self.roulette_probability(depth, sp.bsdf.continuation()),
                );
            }
            if bs.transmission {
                medium = scene.medium_after(sp, bs.wi, medium);
            }
            prev = Scattered {
                delta: bs.delta,
                pdf: bs.pdf,
                p: hit.p,
            };
            pass = 1.0;
            if !self.roulette(depth, sp.bsdf.continuation(), &mut beta, sampler) {
                break;
            }
            if let Some(t) = &mut trail
                && !bs.delta
            {
                t.push(hit.p, bs.wi, bs.pdf, beta, l);
            }
            ray = hit.spawn(bs.wi);
            depth += 1;
        }
        if let (Some(t), Some(g)) = (trail, guide) {
            t.record(g.tree, l);
        }
        l
    }

    /// Russian roulette on paths of `rr_depth` segments or more, continuing with the local
    /// probability `q` of the vertex (`Bsdf::continuation`, the medium's albedo); false
    /// terminates the path. A local rule keeps the path's density computable from the path
    /// alone (`pdf_unguided`), in both directions, like BDPT's.
    fn roulette_probability(&self, depth: u32, q: f32) -> f32 {
        super::paths::roulette(q.min(1.0), depth as usize, self.settings.rr_depth)
    }

    fn roulette(
        &self,
        depth: u32,
        q: f32,
        beta: &mut Spectrum,
        sampler: &mut impl Sampler,
    ) -> bool {
        let q = self.roulette_probability(depth, q);
        if q >= 1.0 {
            return true;
        }
        if sampler.next_1d() >= q {
            return false;
        }
        *beta /= q;
        true
    }

    /// MIS weight of emission found by continuing the path (or by the camera ray).
    fn emission_weight(
        &self,
        scene: &Scene,
        light: usize,
        prev: &Scattered,
        pass: f32,
        pdf_li: impl FnOnce() -> f32,
    ) -> f32 {
        if prev.delta {
            return 1.0; // no other strategy can produce this path
        }
        let w = match self.settings.strategy {
            Strategy::Bsdf => 1.0,
            Strategy::Nee => 0.0,
            Strategy::Mis => {
                power_heuristic(prev.pdf * pass, scene.light_sampler.pmf(light) * pdf_li())
            }
        };
        crate::check::weight(crate::check::Technique::named("pt emitter hit"), w as f64);
        w
    }
}

/// The last scattering vertex of the path.
struct Scattered {
    /// Delta BSDF (or the pinhole): no other strategy shares the next vertex.
    delta: bool,
    /// Solid-angle density (or lobe probability) of the sampled direction.
    pdf: f32,
    p: Vec3,
}
