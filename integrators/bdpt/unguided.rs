//! bdpt as an [`Unguided`] estimator ([`BdptUnguided`]): every (s, t) technique, weighed by the
//! balance heuristic; its tracer reports each path with the sum of their densities
//! (`recording.rs`). [`bdpt_estimate`] is the tracer's own estimate of a sample.

use super::{BdptSettings, Tracer};
use crate::integrators::paths::{Vertex, technique_densities_of_vertices};
use crate::integrators::unguided::{PathSink, Unguided, finite};
use crate::math::Sampler;
use crate::scene::Scene;
use glam::{DVec3, Vec2};

/// BDPT as an unguided estimator: balance heuristic over all its techniques (the power
/// heuristic does not mix with a further technique by adding its density).
pub struct BdptUnguided {
    /// BDPT's depth limit and Russian roulette; the heuristic must be the balance one, with
    /// all techniques and no light tracing alone.
    pub settings: BdptSettings,
}

impl Unguided for BdptUnguided {
    type Tracer<'s> = Tracer<'s>;
    type Pass<'s> = ();

    fn name(&self) -> &'static str {
        "bdpt"
    }

    fn max_depth(&self) -> u32 {
        self.settings.max_depth
    }

    fn begin_pass<'s>(&'s self, _: &'s Scene, _: u64, _: u64, _: u64) {}

    fn tracer<'s, 'p: 's>(&'s self, scene: &'s Scene, _: &'s ()) -> Tracer<'s> {
        Tracer::new(scene, &self.settings)
    }

    fn trace(
        &self,
        tracer: &mut Tracer<'_>,
        _: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn PathSink,
    ) {
        tracer.sample_recorded(raster, sampler, sink);
    }

    fn estimate(
        &self,
        tracer: &mut Tracer<'_>,
        _: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        splats: &mut Vec<(u32, DVec3)>,
    ) -> DVec3 {
        bdpt_estimate(tracer, raster, sampler, splats)
    }

    fn pdf_unguided(&self, scene: &Scene, _: &(), y: &[Vertex]) -> f64 {
        let s = &self.settings;
        technique_densities_of_vertices(y, scene, s.max_depth, s.rr_depth, s.direct_splats)
            .map_or(0.0, |p| p[..y.len()].iter().sum())
    }
}

/// bdpt's tracer's own estimate of one sample (its weights), its splats moved to `splats`
/// (BDPT's and vcm's `Unguided::estimate`).
pub(crate) fn bdpt_estimate(
    tracer: &mut Tracer<'_>,
    raster: Vec2,
    sampler: &mut impl Sampler,
    splats: &mut Vec<(u32, DVec3)>,
) -> DVec3 {
    let v = tracer.sample(raster, sampler);
    for (p, c) in tracer.splats.drain(..) {
        let c = finite(c.as_dvec3());
        if c != DVec3::ZERO {
            splats.push((p, c));
        }
    }
    finite(v.as_dvec3())
}
