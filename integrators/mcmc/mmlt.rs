//! `mmlt`: multiplexed Metropolis over `bdpt`'s techniques (Hachisuka et al. 2014). Group g
//! holds the paths of k = g + 1 segments. A state's first number picks the technique s of
//! the k + 1 (t = k + 1 − s camera vertices), the next two place the sample on the image
//! (unused for t = 1, where the connection to the pinhole decides), and the rest drive the
//! camera walk (stream 0), the light walk (stream 1) and the connection (stream 2). The
//! contribution is the technique's estimate times its MIS weight among the k + 1 techniques,
//! times k + 1. Subpaths have fixed lengths, so no roulette is played.
//!
//! **Paths no connection makes** (`-O separate_specular`, default `auto`). On a path where
//! no two consecutive vertices are off delta surfaces (the pinhole and the light counting as
//! off), every technique but s = 0 has density zero: a light seen through mirrors and glass
//! (E S* L), a caustic seen through them (E S+ D S+ L, the floor under the glass bunny of
//! `fog-dragon`, the pool's bottom under its water), the light seen directly (E L). Their
//! s = 0 technique can leave the chains and be estimated per pixel instead
//! ([`Tracer::unconnectible_emission`]: one camera walk that stops where two consecutive
//! vertices are off delta surfaces, every length at once), as Veach's MLT renders what the
//! camera sees of the lights on its own. Every pixel gets a sample in the first pass and
//! then one every `specular_every` passes (default 4; interleaved over the image, in columns
//! when the width is a multiple of it).
//!
//! When it pays: these paths can make small, very bright regions of the image. Chains start
//! at bootstrap samples drawn by importance, so a region that a handful of the bootstrap's
//! samples stand for starts far too few or far too many chains, and one that none stands
//! for starts none; large steps reach it too rarely to correct that within a render. On
//! `fog-dragon` neither the bootstrap (100 000 samples per length) nor a sample per pixel
//! finds one of these paths, yet they are about 5 % of the image, and with them in the
//! chains 60 s renders are 4-5 % dark. Where the regions are many sub-pixel glints
//! (`pool`'s light in the rippled water and its caustics), the chains, which find a glint and
//! stay on it, beat one sample per pixel every few passes by far, and there the bootstrap
//! holds them on about 20 samples' worth, in the share the first pass estimates. `auto`
//! keeps them in the chains only then (see the driver's `Split::Auto`); `true` and `false`
//! force either way. The statistic `mcmc_direct_split` reports the decision and both
//! estimates. Caveat (as for every length): a length whose remaining techniques the
//! bootstrap never lights gets no chains.

use super::driver;
use super::pssmlt::raster_of;
use super::target::{Contribution, McmcSettings, Target};
use crate::error::Result;
use crate::integrators::IntegratorParams;
use crate::integrators::bdpt::{BdptSettings, TECHNIQUE_STREAMS, Tracer};
use crate::integrators::paths::Heuristic;
use crate::math::Sampler;
use crate::render::{Budget, Integrator, RenderContext, RenderResult};
use crate::scene::Scene;
use glam::{DVec3, Vec2};

/// Build mmlt from its parameters (`max_depth` must fit a stored path).
pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    let o = params.options.declared(super::MMLT_OPTIONS);
    let heuristic = crate::integrators::bdpt::heuristic(&o)?;
    let settings = super::settings(&params.options)?;
    Ok(Box::new(Mmlt {
        bdpt: mmlt_bdpt_settings(params.max_depth, heuristic),
        settings,
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
        direct_splats: true,
    }
}

/// Multiplexed Metropolis light transport (Hachisuka et al. 2014) as an integrator.
pub struct Mmlt {
    /// BDPT's settings for the techniques the chains pick among.
    pub bdpt: BdptSettings,
    /// Bootstrap, chains and mutation settings (`split`: whether s = 0 on paths E S* L is
    /// estimated per pixel, not with the chains).
    pub settings: McmcSettings,
}

/// One BDPT technique per state, grouped by path length.
pub struct MmltTarget<'a> {
    /// BDPT's settings.
    pub bdpt: &'a BdptSettings,
    /// The scene rendered.
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
        let u = sampler.next_2d();
        let raster = raster_of(self.scene, u);
        let camera = &self.scene.camera;
        match tracer.sample_technique(raster, s, t, sampler) {
            // t = 1 lands where the connection to the pinhole decides, and the pixel filter
            // picks its pixel with the raster's first number, which t = 1 leaves unused.
            Some((r, c)) if t == 1 => match camera.splat_pixel(r, u.x) {
                Some((pixel, w)) => Contribution {
                    pixel: pixel as u32,
                    value: c.as_dvec3() * (n as f64 * w as f64),
                    direct: DVec3::ZERO,
                },
                None => Contribution::ZERO,
            },
            // s = 0 on a path no connection makes: what `direct` estimates when the driver
            // splits it off.
            Some((r, c)) => {
                let value = c.as_dvec3() * n as f64;
                let flagged = s == 0 && tracer.camera_unconnectible();
                Contribution {
                    pixel: camera.pixel_index(r) as u32,
                    value,
                    direct: if flagged { value } else { DVec3::ZERO },
                }
            }
            None => Contribution::ZERO,
        }
    }

    fn has_direct(&self) -> bool {
        true
    }

    fn direct<S: Sampler>(&self, tracer: &mut Tracer<'_>, raster: Vec2, sampler: &mut S) -> DVec3 {
        tracer.unconnectible_emission(raster, sampler).as_dvec3()
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
