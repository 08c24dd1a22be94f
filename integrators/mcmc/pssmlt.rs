//! `pssmlt`: primary-sample-space Metropolis over `pt` (Kelemen et al. 2002). The target of
//! a state is one pt sample: its first two numbers place the sample on the image, the rest
//! drive `PathTracer::li`. Options: the chain options of the module above and pt's own
//! (`rr_depth`, `strategy`).
//!
//! **Emission only a continued walk finds** (`-O separate_specular`, default `auto`): the
//! part of a sample that is emission reached from a delta vertex or by the camera ray (no
//! next-event estimate makes it: caustics, lights seen through glass, the light seen
//! directly; `PathTracer::li_split`) can leave the chains and be estimated per pixel by pt
//! itself, every `specular_every` passes, as mmlt's split (`mmlt.rs`). On `fog-dragon` the
//! bootstrap holds those paths on one sample's worth (one sample carries 5 % of its
//! importance, and draws that share of the chains to a few caustic paths), so `auto` splits
//! them; on `pool` it holds them on about 190 samples' worth and keeps them in the chains,
//! whose exploration of the caustics is pssmlt's strength there.

use super::driver;
use super::target::{Contribution, McmcSettings, Target};
use crate::error::Result;
use crate::integrators::IntegratorParams;
use crate::integrators::pt::PathTracer;
use crate::math::Sampler;
use crate::render::{Budget, Integrator, RenderContext, RenderResult};
use crate::scene::Scene;
use glam::{DVec3, Vec2};

/// Build pssmlt from its parameters (pt's options plus the Metropolis ones).
pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Pssmlt {
        pt: PathTracer {
            settings: crate::integrators::pt::settings(params)?,
        },
        settings: super::settings(&params.options)?,
    }))
}

/// Primary-sample-space Metropolis light transport (Kelemen et al. 2002) over pt.
pub struct Pssmlt {
    /// The path tracer whose samples the chains explore.
    pub pt: PathTracer,
    /// Bootstrap, chains and mutation settings.
    pub settings: McmcSettings,
}

/// One pt sample as a function of primary samples.
pub struct PssTarget<'a> {
    /// The path tracer.
    pub pt: &'a PathTracer,
    /// The scene rendered.
    pub scene: &'a Scene,
}

/// The raster position of two primary samples, anywhere on the image.
pub fn raster_of(scene: &Scene, u: Vec2) -> Vec2 {
    u * scene.camera.resolution.as_vec2()
}

impl Target for PssTarget<'_> {
    type Scratch<'s>
        = ()
    where
        Self: 's;

    fn scratch(&self) {}

    fn streams(&self) -> u32 {
        1
    }

    fn groups(&self) -> usize {
        1
    }

    fn eval<S: Sampler>(&self, _: &mut (), _: usize, sampler: &mut S) -> Contribution {
        let raster = raster_of(self.scene, sampler.next_2d());
        let (l, direct) = self.pt.li_split(self.scene, raster, sampler);
        Contribution {
            pixel: self.scene.camera.pixel_index(raster) as u32,
            value: l.as_dvec3(),
            direct: direct.as_dvec3(),
        }
    }

    fn has_direct(&self) -> bool {
        true
    }

    fn direct<S: Sampler>(&self, _: &mut (), raster: Vec2, sampler: &mut S) -> DVec3 {
        self.pt.li_split(self.scene, raster, sampler).1.as_dvec3()
    }
}

impl Integrator for Pssmlt {
    fn name(&self) -> &'static str {
        "pssmlt"
    }

    fn settings(&self) -> String {
        format!("{:?} {:?}", self.pt.settings, self.settings)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        let target = PssTarget {
            pt: &self.pt,
            scene: ctx.scene,
        };
        driver::render(&target, &self.settings, ctx, budget)
    }
}
