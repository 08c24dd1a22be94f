//! `mmlt`: multiplexed Metropolis over `bdpt`'s techniques (Hachisuka et al. 2014). Group g
//! holds the paths of k = g + 1 segments. A state's first number picks the technique s of
//! the k + 1 (t = k + 1 − s camera vertices), the next two place the sample on the image
//! (unused for t = 1, where the connection to the pinhole decides), and the rest drive the
//! camera walk (stream 0), the light walk (stream 1) and the connection (stream 2). The
//! contribution is the technique's estimate times its MIS weight among the k + 1 techniques,
//! times k + 1. Subpaths have fixed lengths, so no roulette is played.

use super::driver::{self, Contribution, McmcSettings, Target};
use super::pssmlt::raster_of;
use crate::error::{Error, Result};
use crate::integrators::IntegratorParams;
use crate::integrators::bdpt::{BdptSettings, Heuristic, TECHNIQUE_STREAMS, Tracer};
use crate::math::Sampler;
use crate::render::{Budget, Integrator, RenderContext, RenderResult};
use crate::scene::Scene;

pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    // One chain group per path length, each with its own bootstrap: lengths must be few.
    crate::path::check_stored_depth("mmlt", params.max_depth).map_err(Error::new)?;
    let o = &params.options;
    let heuristic = match o.choice("mis", "balance", &["balance", "power"])? {
        "power" => Heuristic::Power,
        _ => Heuristic::Balance,
    };
    Ok(Box::new(Mmlt {
        bdpt: mmlt_bdpt_settings(params.max_depth, heuristic),
        settings: super::settings(o)?,
    }))
}

/// BDPT's settings for fixed-length subpaths: roulette starts past the longest subpath.
pub fn mmlt_bdpt_settings(max_depth: u32, heuristic: Heuristic) -> BdptSettings {
    BdptSettings {
        max_depth,
        rr_depth: max_depth + 1,
        heuristic,
        light_tracing: false,
        techniques: Default::default(),
    }
}

pub struct Mmlt {
    pub bdpt: BdptSettings,
    pub settings: McmcSettings,
}

/// One BDPT technique per state, grouped by path length.
pub struct MmltTarget<'a> {
    pub bdpt: &'a BdptSettings,
    pub scene: &'a Scene,
}

impl Target for MmltTarget<'_> {
    type Scratch<'s>
        = Tracer<'s>
    where
        Self: 's;

    fn scratch(&self) -> Tracer<'_> {
        Tracer::new(self.scene, self.bdpt)
    }

    fn streams(&self) -> u32 {
        TECHNIQUE_STREAMS
    }

    fn groups(&self) -> usize {
        self.bdpt.max_depth as usize
    }

    fn eval<S: Sampler>(
        &self,
        tracer: &mut Tracer<'_>,
        group: usize,
        sampler: &mut S,
    ) -> Contribution {
        let k = group + 1;
        let n = k + 1;
        sampler.start_stream(0);
        let s = ((sampler.next_1d() * n as f32) as usize).min(n - 1);
        let t = k + 1 - s;
        let raster = raster_of(self.scene, sampler.next_2d());
        match tracer.sample_technique(raster, s, t, sampler) {
            Some((r, c)) => Contribution {
                pixel: self.scene.camera.pixel_index(r) as u32,
                value: c.as_dvec3() * n as f64,
            },
            None => Contribution::ZERO,
        }
    }
}

impl Integrator for Mmlt {
    fn name(&self) -> &'static str {
        "mmlt"
    }

    fn settings(&self) -> String {
        format!("{:?} {:?}", self.bdpt, self.settings)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        let target = MmltTarget {
            bdpt: &self.bdpt,
            scene: ctx.scene,
        };
        driver::render(&target, &self.settings, ctx, budget)
    }
}
