//! Emitters that pt's continuation (or the camera ray) finds: their MIS weight against
//! next-event estimation (power heuristic, or 1 / 0 under `strategy = bsdf` / `nee`) and their
//! hand-over to a path recorder.

use super::{Extras, PathState, PathTracer, Scattered, Strategy};
use crate::math::{Spectrum, power_heuristic};
use crate::path::{Vertex as PathVertex, VertexKind};
use crate::scene::Scene;
use glam::Vec3;

/// Where the continuation found an emitter.
#[derive(Clone, Copy)]
pub(super) enum EmitterAt {
    /// A light at infinity, in the direction of the segment.
    Infinity,
    /// A point of an area light and its geometric normal.
    Surface { p: Vec3, n: Vec3 },
}

impl PathTracer {
    /// Emission `le` of light `li` that `path.ray` found `at`: added to `path.l` under its MIS
    /// weight against next-event estimation, and handed to the recorder as an emitter vertex
    /// with next-event estimation's density for it (solid angle for a light at infinity, area
    /// on a surface).
    #[inline(always)]
    pub(super) fn emission(
        &self,
        scene: &Scene,
        path: &mut PathState,
        extras: &mut Extras,
        li: usize,
        le: Spectrum,
        at: EmitterAt,
    ) {
        let (light, prev, d) = (&scene.lights[li], &path.prev, path.ray.d);
        let pdf_li = || match at {
            EmitterAt::Infinity => light.pdf_li(prev.p, Vec3::ZERO, Vec3::ZERO, d),
            EmitterAt::Surface { p, n } => light.pdf_li(prev.p, p, n, d),
        };
        if let Some(r) = &mut extras.rec {
            let (p, n, to_vertex_measure) = match at {
                EmitterAt::Infinity => {
                    let last = r.path.vertices().last().map_or(path.ray.o, |v| v.p);
                    (last + d, d, 1.0)
                }
                EmitterAt::Surface { p, n } => {
                    let d2 = (p - prev.p).length_squared() as f64;
                    (p, n, n.dot(d).abs() as f64 / d2)
                }
            };
            let v = PathVertex {
                p,
                n,
                ns: Vec3::ZERO,
                uv: glam::Vec2::ZERO,
                tangent: Vec3::ZERO,
                kind: VertexKind::Emitter {
                    light: li as u32,
                    delta: false,
                },
            };
            let nee = if prev.delta {
                0.0
            } else {
                scene.light_sampler.pmf(li) as f64 * pdf_li() as f64 * to_vertex_measure
            };
            r.emitter(scene, v, path.pass, nee, path.beta * le);
        }
        let w = self.emission_weight(scene, li, prev, path.pass, pdf_li);
        path.l += path.beta * le * w;
        if prev.delta
            && let Some(d) = &mut extras.direct
        {
            *d += path.beta * le * w;
        }
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
