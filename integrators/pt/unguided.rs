//! pt as an [`Unguided`] estimator: its continuation hitting an emitter (s = 0) and
//! next-event estimation (s = 1) are the techniques summed in `p_u`; its own estimate of a row
//! is pt's, traced as a wavefront, batched or one path after the other (`batch.rs`).

use super::batch::{BatchMode, Batched, Tracing};
use super::{PathRecorder, PathTracer, PtSettings};
use crate::integrators::paths::{Vertex, technique_densities_of_vertices};
use crate::integrators::unguided::{PathSink, Unguided, finite};
use crate::math::{Sampler, Spectrum};
use crate::path::Path;
use crate::render::PixelEstimator;
use crate::scene::Scene;
use glam::{DVec3, Vec2};

impl Unguided for PathTracer {
    type Tracer<'s> = ();
    type Pass<'s> = ();

    fn name(&self) -> &'static str {
        "pt"
    }

    fn max_depth(&self) -> u32 {
        self.settings.max_depth
    }

    fn begin_pass<'s>(&'s self, _: &'s Scene, _: u64, _: u64, _: u64) {}

    fn tracer<'s, 'p: 's>(&'s self, _: &'s Scene, _: &'s ()) {}

    fn trace(
        &self,
        _: &mut (),
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn PathSink,
    ) {
        /// pt's recorder hands over each path with `density + other` = its `pdf_unguided`.
        struct Forward<'k>(&'k mut dyn PathSink);
        impl PathRecorder for Forward<'_> {
            fn record(&mut self, path: &Path, f: DVec3, _: usize, density: f64, other: f64) {
                self.0.record(path, None, f, density + other, false);
            }
        }
        self.li_recorded(scene, raster, sampler, Some(&mut Forward(sink)));
    }

    fn estimate(
        &self,
        _: &mut (),
        scene: &Scene,
        raster: Vec2,
        sampler: &mut impl Sampler,
        _: &mut Vec<(u32, DVec3)>,
    ) -> DVec3 {
        finite(self.li(scene, raster, sampler).as_dvec3())
    }

    /// A row as pt renders it at `batch = auto`: as a wavefront, batched or one path after
    /// the other (`pt::batch`), each value `estimate`'s bit for bit.
    fn estimate_row<S: Sampler>(
        &self,
        _: &mut (),
        scene: &Scene,
        rasters: &[Vec2],
        samplers: &mut [S],
        _: &mut Vec<(u32, DVec3)>,
        out: &mut [DVec3],
    ) {
        let mut values = vec![Spectrum::ZERO; rasters.len()];
        // The row tracers of pt's own driver (`pt::batch`).
        match BatchMode::Auto.tracing(self, scene) {
            Tracing::Wavefront(isa) => {
                Batched(self, Some(isa)).estimate_row(scene, rasters, samplers, &mut values)
            }
            Tracing::Batched => {
                Batched(self, None).estimate_row(scene, rasters, samplers, &mut values)
            }
            Tracing::Single => {
                PixelEstimator::estimate_row(self, scene, rasters, samplers, &mut values)
            }
        }
        for (o, v) in out.iter_mut().zip(values) {
            *o = finite(v.as_dvec3());
        }
    }

    /// pt's techniques are BDPT's s = 0 and (two or more segments) s = 1.
    fn pdf_unguided(&self, scene: &Scene, _: &(), y: &[Vertex]) -> f64 {
        let s: &PtSettings = &self.settings;
        technique_densities_of_vertices(y, scene, s.max_depth, s.rr_depth, false)
            .map_or(0.0, |p| p[0] + if y.len() >= 3 { p[1] } else { 0.0 })
    }
}
