//! Batched pt: the samples of a whole row of pixels traced together, segment by segment.
//!
//! In each round every path of the row still running takes one segment: the row's rays go
//! through the BVH together ([`Scene::intersect_many`]), each path then does its vertex
//! (`PathTracer::advance`: emission, next-event sample, continuation) with its shadow ray
//! queued, and the queued shadow rays go through the BVH together
//! ([`Scene::unoccluded_many`]). On a BVH larger than the caches a single ray waits on one
//! memory miss after another; a batch keeps 16 rays in flight so their misses overlap
//! ([`crate::geometry::interleaved`]). In a scene small enough to be tested without a BVH
//! (the Cornell boxes) every ray tests every primitive anyway, and a batch tests sixteen rays
//! against each triangle at once (one AVX-512 register, or two AVX ones;
//! `geometry/flat/packet.rs`). Each path draws from its own sample stream in the
//! order [`PathTracer::li`] does and adds to its radiance in the same order, so the image is
//! pt's bit for bit (test `batched_pt_is_pt_bit_for_bit` in `tests/pt_batch.rs`).
//!
//! | option | values               | default | meaning |
//! |--------|----------------------|---------|---------|
//! | batch  | `auto` / `wavefront` / `wavefront-avx2` / `on` / `off` | `auto`  | `auto`: the wavefront (`wavefront/`: vertices shaded sixteen at a time, in AVX-512 or AVX2 registers) where it applies, else batched where the accelerator says batches pay (`Accel::batches_pay`: a BVH of at least 16 MB, `BATCH_MIN_BYTES`, or a flat list of primitives on a CPU with AVX); `wavefront`: the wavefront where it applies, else as `on`; `wavefront-avx2`: the same on AVX2 instructions even where the CPU has AVX-512; `on`: batched wherever it applies; `off`: one path at a time |
//!
//! It applies to plain pt in scenes without media (a shadow ray through media crosses its
//! boundaries one segment at a time) and not under `--check` (which inspects each
//! next-event value once its visibility is known); elsewhere pt traces one path at a time
//! whatever the option says.

use super::round::{ROUND, Round};
use super::wavefront::{self, Isa};
use super::{Deferred, Extras, PathState, PathTracer};
use crate::error::Result;
use crate::integrators::IntegratorParams;
use crate::integrators::options::{DefaultValue, Kind, Spec};
use crate::math::{Sampler, SamplerKind, Spectrum};
use crate::render::{
    Budget, Integrator, PixelEstimator, RenderContext, RenderResult, render_pixel_estimator,
};
use crate::scene::Scene;
use glam::Vec2;

/// When pt traces a row's paths together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BatchMode {
    /// The wavefront where it applies, else batches where they pay (default).
    Auto,
    /// The wavefront where it applies, else batches: on the given instructions where the CPU
    /// has them (`None`: the widest it has, [`Isa::detect`]).
    Wavefront(Option<Isa>),
    /// Batches wherever they apply.
    On,
    /// One path at a time.
    Off,
}

/// How pt traces a scene's rows under a [`BatchMode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tracing {
    /// Shaded sixteen paths at a time (`wavefront/`).
    Wavefront(Isa),
    /// Rays traced a row at a time, paths shaded one by one.
    Batched,
    /// One path at a time.
    Single,
}

/// Option `batch` of pt.
pub const BATCH_OPTION: Spec = Spec {
    name: "batch",
    kind: Kind::Choice(&["auto", "wavefront", "wavefront-avx2", "on", "off"]),
    default: DefaultValue::Word("auto"),
    doc: "trace a row's paths together, segment by segment: `wavefront` shades them sixteen at \
          a time in vector registers, AVX-512 or else AVX2 (scenes without media; vertices of \
          rough, plastic, masked or normal-mapped materials by the scalar code, \
          `pt/wavefront/`), `wavefront-avx2` the same in AVX2 registers on any CPU that has \
          them, `on` traces their rays together so that misses in a large BVH overlap \
          (`pt/batch.rs`), `auto` takes the wavefront where it applies and batches where that \
          pays; the same image bit for bit in every mode",
};

impl BatchMode {
    /// The mode of option `batch` (`auto`, `wavefront`, `on`, `off`).
    pub fn parse(params: &IntegratorParams) -> Result<BatchMode> {
        Ok(
            match params.options.declared(&[&[BATCH_OPTION]]).word("batch")? {
                "wavefront" => BatchMode::Wavefront(None),
                "wavefront-avx2" => BatchMode::Wavefront(Some(Isa::Avx2)),
                "on" => BatchMode::On,
                "off" => BatchMode::Off,
                _ => BatchMode::Auto,
            },
        )
    }

    /// Whether pt traces `scene`'s rows batched under this mode (wavefront or not).
    pub fn applies(self, scene: &Scene) -> bool {
        let possible = !scene.features.media && !crate::check::enabled();
        possible
            && match self {
                BatchMode::Auto => scene.accel.batches_pay(),
                BatchMode::Wavefront(_) | BatchMode::On => true,
                BatchMode::Off => false,
            }
    }

    /// How `pt` traces `scene` under this mode: `auto` and `wavefront` take the wavefront
    /// where it applies (`wavefront::supports`, a CPU with the instructions), then fall back
    /// as `auto` and `on` do.
    pub fn tracing(self, pt: &PathTracer, scene: &Scene) -> Tracing {
        let isa = match self {
            BatchMode::Auto | BatchMode::Wavefront(None) => Isa::detect(),
            BatchMode::Wavefront(Some(isa)) => Some(isa).filter(|isa| isa.on_this_cpu()),
            BatchMode::On | BatchMode::Off => None,
        };
        if let Some(isa) = isa
            && wavefront::supports(pt, scene)
        {
            return Tracing::Wavefront(isa);
        }
        let fallback = match self {
            BatchMode::Wavefront(_) => BatchMode::On,
            m => m,
        };
        if fallback.applies(scene) {
            Tracing::Batched
        } else {
            Tracing::Single
        }
    }
}

/// `pt` as registered: the path tracer and its batch mode.
pub struct Pt {
    /// The path tracer.
    pub pt: PathTracer,
    /// When rows are traced together (option `batch`).
    pub batch: BatchMode,
    /// Whose numbers each pixel's path draws (option `sampler`).
    pub sampler: SamplerKind,
}

impl Integrator for Pt {
    fn name(&self) -> &'static str {
        "pt"
    }

    fn settings(&self) -> String {
        format!(
            "{:?}, batch: {:?}, sampler: {:?}",
            self.pt.settings, self.batch, self.sampler
        )
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        match self.batch.tracing(&self.pt, ctx.scene) {
            Tracing::Wavefront(isa) => {
                render_pixel_estimator(ctx, budget, self.sampler, &Batched(&self.pt, Some(isa)))
            }
            Tracing::Batched => {
                render_pixel_estimator(ctx, budget, self.sampler, &Batched(&self.pt, None))
            }
            Tracing::Single => render_pixel_estimator(ctx, budget, self.sampler, &self.pt),
        }
    }
}

/// pt estimating a row at a time: batched (`None`) or with the wavefront on the given
/// instructions.
pub struct Batched<'a>(pub &'a PathTracer, pub Option<Isa>);

impl PixelEstimator for Batched<'_> {
    fn estimate<S: Sampler>(&self, scene: &Scene, raster: Vec2, sampler: &mut S) -> Spectrum {
        self.0.li(scene, raster, sampler)
    }

    fn estimate_row<S: Sampler>(
        &self,
        scene: &Scene,
        rasters: &[Vec2],
        samplers: &mut [S],
        out: &mut [Spectrum],
    ) {
        match self.1 {
            Some(isa) => self.0.li_row_wavefront(scene, rasters, samplers, out, isa),
            None => self.0.li_row(scene, rasters, samplers, out),
        }
    }
}

impl PathTracer {
    /// [`Self::li`] for the rasters of a row, each with its own sampler, into `out`: the same
    /// values bit for bit, traced in rounds of one segment per path (module doc). The scene
    /// must have no media.
    pub fn li_row<S: Sampler>(
        &self,
        scene: &Scene,
        rasters: &[Vec2],
        samplers: &mut [S],
        out: &mut [Spectrum],
    ) {
        assert!(
            !scene.features.media,
            "batched pt traces scenes without media"
        );
        let lanes = PathState::row(scene, rasters);
        ROUND.with_borrow_mut(|b| self.rounds(scene, lanes, samplers, out, b));
    }

    /// The rounds of [`Self::li_row`] until every path of `lanes` has ended.
    fn rounds<S: Sampler>(
        &self,
        scene: &Scene,
        mut lanes: Vec<(usize, PathState)>,
        samplers: &mut [S],
        out: &mut [Spectrum],
        b: &mut Round,
    ) {
        while !lanes.is_empty() {
            b.trace(scene, &lanes);
            for (k, (i, path)) in lanes.iter_mut().enumerate() {
                let hit = b.hits[k].take();
                let (deferred, owner) = (&mut b.deferred, &mut b.owner);
                let alive =
                    self.advance_in_round(scene, path, hit, &mut samplers[*i], deferred, owner, k);
                b.alive.push(alive);
            }
            b.settle(scene, &mut lanes, out);
        }
    }
}

impl PathTracer {
    /// pt's own step at `hit` for a path of a round: its next-event sample, if any, pushed to
    /// `deferred` with `k` (its index in the round) in `owner`; returns whether it goes on.
    /// The batched rounds take every vertex this way, the wavefront's those its lanes do
    /// not shade.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn advance_in_round<S: Sampler>(
        &self,
        scene: &Scene,
        path: &mut PathState,
        hit: Option<crate::geometry::Hit>,
        sampler: &mut S,
        deferred: &mut Vec<Deferred>,
        owner: &mut Vec<usize>,
        k: usize,
    ) -> bool {
        let sp = hit.map(|h| scene.surface_point(h, &path.ray));
        let before = deferred.len();
        let mut extras = Extras {
            rec: None,
            guide: None,
            trail: None,
            deferred: Some(deferred),
            direct: None,
        };
        let alive = self.advance(scene, path, sp.as_ref(), sampler, &mut extras);
        owner.resize(deferred.len().max(before), k);
        alive
    }
}
