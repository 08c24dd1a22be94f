//! pt's next-event estimation: one light chosen by power, one point on it, weighted against
//! the continuation (BSDF sampling, or its mixture with a guide) by the power heuristic.

use super::recording::Recording;
use super::{PathTracer, Strategy, guiding};
use crate::bsdf::TransportMode;
use crate::geometry::gamma;
use crate::math::{Sampler, Spectrum, power_heuristic};
use crate::medium::HenyeyGreenstein;
use crate::path::{Vertex as PathVertex, VertexKind};
use crate::scene::{Endpoint, Scene, SurfacePoint, Transmittance};
use glam::Vec3;

impl PathTracer {
    /// Next-event estimation from `from` (in `medium` on the scattering side): one light
    /// chosen by power, one point on it, weighted against the continuation by MIS. Whether
    /// the connection is free comes from `shadow`: traced at once ([`TraceNow`]), or left to a
    /// batch ([`Queue`]), in which case the value returned is the one of a free connection.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn direct(
        &self,
        scene: &Scene,
        from: &Endpoint,
        medium: Option<u32>,
        at: &Scatterer,
        sampler: &mut impl Sampler,
        rec: Option<(&mut Recording, Spectrum, f32)>,
        shadow: &mut impl ShadowTest,
    ) -> Spectrum {
        let u_light = sampler.next_1d();
        let u = sampler.next_2d();
        let Some((light_id, pmf)) = scene.light_sampler.sample(u_light) else {
            return Spectrum::ZERO;
        };
        let Some(ls) = scene.lights[light_id].sample_li(from.p, u) else {
            return Spectrum::ZERO;
        };
        let (f, pdf_scatter) = at.eval(ls.wi);
        if f == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        // The shadow ray starts in the medium on the side it leaves towards.
        let medium = match at {
            Scatterer::Surface { sp, .. } => scene.medium_after(sp, ls.wi, medium),
            Scatterer::Medium { .. } => medium,
        };
        let target = ls.dist.is_finite().then(|| Endpoint {
            p: ls.p,
            n: ls.n,
            err: gamma(8) * ls.p.abs(),
        });
        let Some(t) = shadow.test(scene, from, target.as_ref(), ls.wi, medium) else {
            return Spectrum::ZERO;
        };
        let p_light = pmf * ls.pdf;
        if let Some((r, beta, q_here)) = rec {
            let l = &scene.lights[light_id];
            let infinite = l.is_infinite();
            let (p, n) = if infinite {
                (from.p + ls.wi, ls.wi)
            } else {
                (ls.p, ls.n)
            };
            let v = PathVertex {
                p,
                n,
                ns: Vec3::ZERO,
                uv: glam::Vec2::ZERO,
                tangent: Vec3::ZERO,
                kind: VertexKind::Emitter {
                    light: light_id as u32,
                    delta: l.is_delta(),
                },
            };
            // Next-event density in the light vertex's measure (area; solid angle at infinity).
            let nee = if ls.delta || infinite {
                p_light
            } else {
                p_light * ls.n.dot(ls.wi).abs() / (ls.dist * ls.dist)
            };
            // The continuation's density of reaching the same light vertex (roulette and free
            // flight included); delta lights cannot be hit.
            let by_continuation = if ls.delta {
                0.0
            } else if infinite {
                pdf_scatter * t.pass * q_here
            } else {
                pdf_scatter * t.pass * q_here * ls.n.dot(ls.wi).abs() / (ls.dist * ls.dist)
            };
            r.record_with(
                v,
                nee as f64,
                by_continuation as f64,
                beta * f * t.tr * ls.li / p_light,
                1,
            );
        }
        let w = if ls.delta || self.settings.strategy == Strategy::Nee {
            1.0
        } else {
            power_heuristic(p_light, pdf_scatter * t.pass)
        };
        if crate::check::enabled() {
            use crate::check::{Technique, density, value, weight};
            let nee = Technique::named("pt next-event");
            density(nee, p_light as f64);
            density(nee, pdf_scatter as f64);
            weight(nee, w as f64);
            value(nee, f * t.tr * ls.li * (w / p_light));
        }
        f * t.tr * ls.li * (w / p_light)
    }
}

/// How next-event estimation learns whether its connection is free.
pub(super) trait ShadowTest {
    /// The transmittance from `from` to `to` (or to infinity along `dir`) starting in
    /// `medium`, `None` when blocked.
    fn test(
        &mut self,
        scene: &Scene,
        from: &Endpoint,
        to: Option<&Endpoint>,
        dir: Vec3,
        medium: Option<u32>,
    ) -> Option<Transmittance>;
}

/// Trace the shadow ray at once ([`Scene::transmittance`]).
pub(super) struct TraceNow;

impl ShadowTest for TraceNow {
    #[inline(always)]
    fn test(
        &mut self,
        scene: &Scene,
        from: &Endpoint,
        to: Option<&Endpoint>,
        dir: Vec3,
        medium: Option<u32>,
    ) -> Option<Transmittance> {
        scene.transmittance(from, to, dir, medium)
    }
}

/// Leave the shadow ray to a batch (scenes without media): keep its query (origin,
/// direction, length: [`Scene::shadow_query`]) and answer "free", which is what
/// [`Scene::transmittance`] gives a free connection without media.
#[derive(Default)]
pub(super) struct Queue(pub Option<(Vec3, Vec3, f32)>);

impl ShadowTest for Queue {
    #[inline(always)]
    fn test(
        &mut self,
        scene: &Scene,
        from: &Endpoint,
        to: Option<&Endpoint>,
        dir: Vec3,
        medium: Option<u32>,
    ) -> Option<Transmittance> {
        self.0 = Some(scene.shadow_query(from, to, dir));
        Some(Transmittance::unblocked(medium))
    }
}

/// Where next-event estimation scatters: a surface or a point in a medium.
pub(super) enum Scatterer<'a, 'b> {
    Surface {
        sp: &'b SurfacePoint<'a>,
        wo: Vec3,
        /// The continuation's mixture with a guide, if guided.
        mix: Option<guiding::Mixture<'b>>,
    },
    Medium {
        phase: &'b HenyeyGreenstein,
        wo: Vec3,
    },
}

impl Scatterer<'_, '_> {
    /// (f |cos| or the phase function, solid-angle density of sampling `wi` by continuation).
    pub(super) fn eval(&self, wi: Vec3) -> (Spectrum, f32) {
        match self {
            Scatterer::Surface { sp, wo, mix } => {
                let (f, pdf) = sp
                    .bsdf
                    .eval_pdf(&sp.frame, *wo, wi, TransportMode::Radiance);
                (
                    f * wi.dot(sp.hit.ns).abs(),
                    mix.map_or(pdf, |m| m.pdf(pdf, wi)),
                )
            }
            Scatterer::Medium { phase, wo } => {
                let p = phase.eval(*wo, wi);
                (Spectrum::splat(p), p)
            }
        }
    }
}
