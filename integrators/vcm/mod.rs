//! `vcm` — vertex connection and merging (Georgiev, Křivánek, Davidovič, Slusallek 2012; the
//! same estimator as Hachisuka et al.'s unified path sampling); `bpm` — its merging half
//! alone (bidirectional photon mapping).
//!
//! Consistent: the merging radius shrinks over the passes, r_i = r_0 (i + 1)^((radius_alpha - 1) / 2)
//! (i = 0, 1, ... the pass), so the bias of merging vanishes and the image converges to the
//! unbiased one (DESIGN.md §4). Per pass, with N = the number of pixels:
//!
//! 1. N light subpaths (`light.rs`), one light chosen by power each, random walks with media
//!    and Russian roulette from the first bounce; their connectible vertices are stored, and
//!    each is connected to the pinhole (light tracing, splatted);
//! 2. a hash grid (`geometry/hash_grid.rs`) over the stored surface vertices, cells of 4 r_i, each
//!    vertex stored in every cell its r_i-ball reaches, so a query reads one bucket;
//! 3. one camera subpath per pixel (`camera.rs`): at every vertex, emitter hits (s = 0),
//!    next-event estimation (s = 1), connections to every vertex of the light subpath with
//!    the pixel's index (every other BDPT technique), and merging with all stored light
//!    vertices within r_i at non-delta surface vertices, normalised by 1 / (pi r_i^2 N).
//!
//! MIS is the balance heuristic over all these techniques, with merging counted as
//! `eta = pi r_i^2 N` connections, computed from the recursive quantities `d_vcm`, `d_vc`,
//! `d_vm` stored at every vertex (SmallVCM; `vertex.rs` defines them, `walk.rs` updates them).
//! Every density includes Russian roulette (a local continuation probability, from the first
//! bounce) and free flight, so with merging off the weights are exactly those of `bdpt -O
//! rr_depth=1` (tested path by path in `tests/vcm.rs`).
//!
//! Media: medium vertices take part in every connection technique (next-event estimation,
//! connections, light tracing, emitter hits) but are not merged at; `bpm` therefore only sees
//! paths with at least one non-delta surface vertex inside, or none that merging could
//! take: an emitter hit counts in `bpm` when no vertex before it is a merging vertex.
//!
//! Options: [`OPTIONS`], bpm's [`BPM_OPTIONS`] (`lodestar integrators --options`,
//! `docs/integrators.md`).
//!
//! Light subpaths start in the medium around the light, as in `bdpt`. Limits: no merging in
//! media.
//!
//! ```text
//! lodestar render scenes/cornell-box.toml --integrator vcm --spp 64 -O radius=0.01
//! ```

mod camera;
pub mod densities;
mod light;
mod light_paths;
mod unguided;
mod vertex;
mod walk;

pub use camera::CameraTracer;
pub use densities::{densities_from_vertices, mergeable};
pub use light_paths::{LightPaths, Photon};
pub use unguided::{VcmPass, VcmTracer, VcmUnguided};

use super::IntegratorParams;
use super::options::{Declared, DefaultValue, Kind, SAMPLER, Spec};
use crate::error::{Error, Result};
use crate::film::Film;
use crate::geometry::HashGrid;
use crate::math::{
    IndependentSampler, PI, PixelSampler, SamplerKind, SobolSampler, Spectrum, is_finite3,
};
use crate::path::Path;
use crate::render::{Budget, Integrator, RenderContext, RenderResult, run_passes_with_snapshots};
use crate::scene::Scene;
use glam::{UVec2, Vec2, Vec3};
use light::LightTracer;
use rayon::prelude::*;
use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};
use walk::MisFactors;

/// Settings of `vcm` and `bpm`.
#[derive(Debug, Clone, PartialEq)]
pub struct VcmSettings {
    /// Maximum number of path segments.
    pub max_depth: u32,
    /// Initial merging radius r_0; `None`: 0.003 x the scene's bounding-sphere radius.
    pub radius: Option<f32>,
    /// Radius schedule exponent (default 0.75).
    pub alpha: f32,
    /// Vertex connection: BDPT's techniques (default true; false for `bpm`).
    pub connect: bool,
    /// Vertex merging (default true).
    pub merge: bool,
    /// Directly seen emitters also by the light origin's splat, weighed by MIS (option
    /// `direct_splats`, default false: left to the camera ray through vacuum in the pixels
    /// they fill).
    pub direct_splats: bool,
}

impl VcmSettings {
    /// The initial radius for `scene`.
    pub fn initial_radius(&self, scene: &Scene) -> f32 {
        self.radius.unwrap_or(0.003 * scene.radius)
    }

    /// The merging radius of pass `pass` (0-based).
    pub fn radius_at(&self, scene: &Scene, pass: u64) -> f32 {
        self.initial_radius(scene) * ((pass + 1) as f32).powf(0.5 * (self.alpha - 1.0))
    }
}

/// Option `radius` of vcm, bpm and guided-vcm.
pub const RADIUS_OPTION: Spec = Spec {
    name: "radius",
    kind: Kind::above(0.0),
    default: DefaultValue::Computed("0.003 x the scene's bounding-sphere radius"),
    doc: "initial merging radius r_0 (scene units)",
};

/// Option `radius_alpha` of vcm, bpm and guided-vcm.
pub const RADIUS_ALPHA_OPTION: Spec = Spec {
    name: "radius_alpha",
    kind: Kind::open_closed(0.0, 1.0),
    default: DefaultValue::Number(0.75),
    doc: "radius schedule exponent: r_i = r_0 (i + 1)^((radius_alpha - 1) / 2) in pass i \
          (1: a fixed radius)",
};

/// The options of vcm.
pub const OPTIONS: &[Spec] = &[
    RADIUS_OPTION,
    RADIUS_ALPHA_OPTION,
    Spec {
        name: "merge",
        kind: Kind::Bool,
        default: DefaultValue::Bool(true),
        doc: "merging on (`false` gives BDPT's techniques)",
    },
    Spec {
        name: "direct_splats",
        kind: Kind::Bool,
        default: DefaultValue::Bool(false),
        doc: "directly seen emitters also by the light origin's splat, MIS-weighted (otherwise \
              left to the camera ray through vacuum in the pixels they fill, as bdpt)",
    },
    SAMPLER,
];

/// The options of bpm.
pub const BPM_OPTIONS: &[Spec] = &[RADIUS_OPTION, RADIUS_ALPHA_OPTION, SAMPLER];

/// The merging radius (`None`: the scene's default) and its schedule exponent, options
/// `radius` and `radius_alpha` read through `o`.
pub fn radius_options(o: &Declared) -> Result<(Option<f32>, f32)> {
    let radius = o.number_given(RADIUS_OPTION.name)?.map(|r| r as f32);
    let alpha = o.number(RADIUS_ALPHA_OPTION.name)? as f32;
    Ok((radius, alpha))
}

fn settings(params: &IntegratorParams, connect: bool) -> Result<VcmSettings> {
    let o = params.options.declared(&[OPTIONS]);
    // `alpha` names one thing across integrators: the guided integrators' unguided share.
    if o.has("alpha") {
        return Err(Error::new(
            "option 'alpha': vcm's and bpm's radius schedule exponent is 'radius_alpha' \
             ('alpha' is the guided integrators' unguided share)",
        ));
    }
    let (radius, alpha) = radius_options(&o)?;
    let merge = if connect { o.flag("merge")? } else { true };
    let direct_splats = connect && o.flag("direct_splats")?;
    Ok(VcmSettings {
        max_depth: params.max_depth,
        radius,
        alpha,
        connect,
        merge,
        direct_splats,
    })
}

/// Build vcm (connections and merging) from its parameters.
pub fn build(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Vcm {
        settings: settings(params, true)?,
        sampler: params.sampler()?,
    }))
}

/// Build bpm (merging alone) from its parameters.
pub fn build_bpm(params: &IntegratorParams) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Vcm {
        settings: settings(params, false)?,
        sampler: params.sampler()?,
    }))
}

/// Vertex connection and merging (and bpm, its merging alone) as an integrator.
pub struct Vcm {
    /// Radius schedule, depth limit and which of connecting and merging are on.
    pub settings: VcmSettings,
    /// Whose numbers each pixel's camera subpath draws (option `sampler`).
    pub sampler: SamplerKind,
}

/// Which technique produced a path (for inspection).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Technique {
    /// A BDPT technique with `s` light vertices (s = 0: emitter hit, 1: next-event estimation
    /// or the light's origin seen by the pinhole, t = 1: light tracing).
    Connect {
        /// Number of light vertices of the technique.
        s: usize,
    },
    /// Merging at path vertex x_t (camera index): the path's x_t is the camera vertex, the
    /// light subpath's vertex within the radius is not part of it.
    Merge {
        /// Camera-side index of the merging vertex.
        t: usize,
    },
}

/// A weighted contribution handed to an inspector: the path (camera first, ending on the
/// emitter), its technique, and its MIS weight.
pub struct Record {
    /// The technique that formed the path.
    pub technique: Technique,
    /// The path, camera first, ending on the emitter (its `f` is left at zero).
    pub path: Path,
    /// vcm's MIS weight of the technique for the path.
    pub weight: f64,
}

/// Receives every weighted contribution of [`inspect_pass`].
pub type Inspector<'p> = RefCell<dyn FnMut(&Record) + 'p>;

/// A contribution whose path a pass's [`HeldPaths`](crate::integrators::unguided::HeldPaths)
/// holds (guided-vcm's passes, `unguided.rs`): kept out of vcm's own sum, unweighted, for the
/// caller to weigh. Borrowed from where it is kept ([`Claims`], or a light-tracing path's
/// recorded light subpath).
#[derive(Clone, Copy)]
pub struct Claimed<'c> {
    /// The technique that formed the path.
    pub technique: Technique,
    /// The path is `head` followed by `tail` reversed: camera first, ending on the emitter.
    pub head: &'c [crate::path::Vertex],
    /// See `head`.
    pub tail: &'c [crate::path::Vertex],
    /// The pixel (row-major index) the path lands in.
    pub pixel: u32,
    /// The technique's unweighted estimate f(X) / p_technique(X).
    pub value: Spectrum,
    /// vcm's own MIS weight of the path.
    pub weight: f32,
    /// A light-tracing path (splatted to `pixel`).
    pub splat: bool,
}

impl Claimed<'_> {
    /// The path as a [`Path`] in `path` (its previous contents replaced).
    pub fn path_into(&self, path: &mut Path) {
        join_into(path, self.head, self.tail);
        if self.splat
            && let Some(x1) = path.vertices_mut().get_mut(1)
        {
            // A light-tracing path's x_1 is the light vertex joined to the pinhole, read
            // from the recorded light subpath: its mark of a delta lobe left (set when the
            // walk went on through one, after the claim) is not this path's.
            x1.set_delta(false);
        }
        path.pixel = self.pixel;
    }
}

/// What a claim keeps beside its vertices, which are `start..end` of a buffer its keeper
/// knows ([`Claims`]' own, or a light row's recorded subpaths).
#[derive(Clone, Copy)]
struct ClaimHead {
    technique: Technique,
    start: u32,
    end: u32,
    pixel: u32,
    value: Spectrum,
    weight: f32,
}

impl ClaimHead {
    /// Where the claim's vertices are in its keeper's buffer.
    fn span(&self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }

    /// The claim, its path `head` followed by `tail` reversed.
    fn claimed<'c>(
        &self,
        head: &'c [crate::path::Vertex],
        tail: &'c [crate::path::Vertex],
        splat: bool,
    ) -> Claimed<'c> {
        Claimed {
            technique: self.technique,
            head,
            tail,
            pixel: self.pixel,
            value: self.value,
            weight: self.weight,
            splat,
        }
    }
}

/// The camera tracer's claimed paths, their vertices in one buffer: a claim costs its own
/// few vertices, not a [`Path`]'s inline room for `MAX_VERTICES`. Claims the caller takes
/// without their vertices (below its `PathSink::own_weight_floor`) keep only their pixel and
/// weighted value ([`Claims::dim`]). [`Claims::clear`] keeps the buffers for reuse.
#[derive(Default)]
pub struct Claims {
    heads: Vec<ClaimHead>,
    vertices: Vec<crate::path::Vertex>,
    dim: Vec<(u32, Spectrum)>,
}

impl Claims {
    /// Drop every claim, keeping the buffers.
    pub fn clear(&mut self) {
        self.heads.clear();
        self.vertices.clear();
        self.dim.clear();
    }

    /// The claims kept without their vertices: (pixel, value under vcm's weight).
    pub fn dim(&self) -> &[(u32, Spectrum)] {
        &self.dim
    }

    /// Keep a claim without its vertices.
    pub fn push_dim(&mut self, pixel: u32, weighted: Spectrum) {
        self.dim.push((pixel, weighted));
    }

    /// The claims with their vertices, in the order they were made.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = Claimed<'_>> + '_ {
        (self.heads.iter()).map(|h| h.claimed(&self.vertices[h.span()], &[], false))
    }

    /// Keep the path `head` followed by `tail` reversed, landing in `pixel` (its unweighted
    /// value `value`, vcm's weight `weight` beside it).
    pub fn push(
        &mut self,
        technique: Technique,
        (head, tail): (&[crate::path::Vertex], &[crate::path::Vertex]),
        (pixel, value, weight): (u32, Spectrum, f32),
    ) {
        let start = self.vertices.len() as u32;
        self.vertices.extend_from_slice(head);
        self.vertices.extend(tail.iter().rev());
        self.heads.push(ClaimHead {
            technique,
            start,
            end: self.vertices.len() as u32,
            pixel,
            value,
            weight,
        });
    }
}

/// The path `head` followed by `tail` reversed.
pub(crate) fn joined(head: &[crate::path::Vertex], tail: &[crate::path::Vertex]) -> Path {
    let mut path = Path::default();
    join_into(&mut path, head, tail);
    path
}

/// Make `path` (its vertices and f) `head` followed by `tail` reversed.
fn join_into(path: &mut Path, head: &[crate::path::Vertex], tail: &[crate::path::Vertex]) {
    path.clear();
    for v in head.iter().chain(tail.iter().rev()) {
        path.push(*v);
    }
}

/// Constants of one pass.
pub struct PassConstants {
    /// Merging radius r of the pass.
    pub radius: f32,
    /// Light subpaths per pass (N).
    pub light_paths: usize,
    /// How merging and connecting enter the MIS quantities this pass.
    pub factors: MisFactors,
    /// 1 / (pi r^2 N).
    pub vm_normalization: f32,
}

impl PassConstants {
    /// The constants of pass `pass` (0-based): its radius, N = one light subpath per pixel.
    pub fn new(settings: &VcmSettings, scene: &Scene, pass: u64) -> PassConstants {
        let n = scene.camera.pixel_count();
        let radius = settings.radius_at(scene, pass);
        let eta = PI * radius * radius * n as f32;
        PassConstants {
            radius,
            light_paths: n,
            factors: MisFactors {
                vm: if settings.merge { eta } else { 0.0 },
                vc: if settings.connect { 1.0 / eta } else { 0.0 },
            },
            vm_normalization: 1.0 / eta,
        }
    }

    /// eta = pi r^2 N.
    pub fn eta(&self) -> f32 {
        1.0 / self.vm_normalization
    }
}

impl Integrator for Vcm {
    fn name(&self) -> &'static str {
        if self.settings.connect { "vcm" } else { "bpm" }
    }

    fn settings(&self) -> String {
        format!("{:?}, sampler: {:?}", self.settings, self.sampler)
    }

    fn render(&mut self, ctx: &RenderContext, budget: Budget) -> RenderResult {
        let scene = ctx.scene;
        let st = &self.settings;
        let sampler = self.sampler;
        let UVec2 { x: w, y: h } = scene.camera.resolution;
        let mut film = Film::new(w, h);
        let invalid = AtomicU64::new(0);
        let merges = AtomicU64::new(0);
        // Reused from pass to pass (see `LightPaths`).
        let mut lights = LightPaths::default();
        let (mut points, mut grid) = (Vec::new(), HashGrid::default());
        let pass = |film: &mut Film, pass: u64| {
            let pc = PassConstants::new(st, scene, pass);
            // 1. Light subpaths, a row of path indices per task.
            let streams = (ctx.seed, pass, pc.light_paths as u64);
            lights.trace(scene, st, &pc, streams, h as usize, w as usize, None);
            let lights = &lights;
            // 2. The hash grid over the merging vertices.
            let grid = st.merge.then(|| {
                mergeable_points(lights, &mut points);
                grid.rebuild(&points, pc.radius);
                &grid
            });
            merges.fetch_add(grid.map_or(0, |g| g.len() as u64), Ordering::Relaxed);
            // 3. Camera subpaths, one per pixel, a row per task.
            film.par_rows_mut().enumerate().for_each(|(y, row)| {
                let mut ct = CameraTracer::new(scene, st, &pc, lights, grid, None, None);
                for (x, acc) in row.iter_mut().enumerate() {
                    let k = y * w as usize + x;
                    let l = match sampler {
                        SamplerKind::Independent => {
                            camera_sample::<IndependentSampler>(&mut ct, ctx.seed, pass, k, x, y)
                        }
                        SamplerKind::Sobol => {
                            camera_sample::<SobolSampler>(&mut ct, ctx.seed, pass, k, x, y)
                        }
                    };
                    crate::check::value(crate::check::Technique::named("pixel sample"), l);
                    if is_finite3(l) && l.min_element() >= 0.0 {
                        *acc += l.as_dvec3();
                    } else {
                        invalid.fetch_add(1, Ordering::Relaxed);
                    }
                }
            });
            let splats: Vec<_> = lights.splats().collect();
            invalid.fetch_add(film.add_splat_lists(&splats), Ordering::Relaxed);
        };
        let image = |film: &Film, passes: u64| film.to_image(passes as f64, 1.0 / passes as f64);
        let (passes, seconds) = run_passes_with_snapshots(ctx, budget, &mut film, pass, image);
        let splat_scale = if passes > 0 { 1.0 / passes as f64 } else { 0.0 };
        RenderResult {
            // No firefly cascade: `--dbor` reports that vcm does not support it.
            dbor: None,
            image: film.to_image(passes as f64, splat_scale),
            spp: passes,
            passes,
            seconds,
            stats: vec![
                (
                    "invalid_samples".to_string(),
                    invalid.load(Ordering::Relaxed).to_string(),
                ),
                (
                    "initial_radius".to_string(),
                    st.initial_radius(scene).to_string(),
                ),
                (
                    "stored_merge_vertices".to_string(),
                    merges.load(Ordering::Relaxed).to_string(),
                ),
            ],
        }
    }
}

/// One camera sample of pixel `k` = (x, y): its stream (sample `pass` of the pixel, from `S`),
/// the jittered raster position, the path.
pub fn camera_sample<S: PixelSampler>(
    ct: &mut CameraTracer,
    seed: u64,
    pass: u64,
    k: usize,
    x: usize,
    y: usize,
) -> Spectrum {
    let mut sampler = S::for_pixel(seed, pass, k as u64);
    let jitter = sampler.next_2d();
    ct.sample(k, Vec2::new(x as f32, y as f32) + jitter, &mut sampler)
}

fn build_grid(lights: &LightPaths, radius: f32) -> HashGrid<Photon> {
    let mut points = Vec::new();
    mergeable_points(lights, &mut points);
    HashGrid::new(&points, radius)
}

/// The light vertices merging can use (position, index), into `points`.
pub fn mergeable_points(lights: &LightPaths, points: &mut Vec<(Vec3, Photon)>) {
    points.clear();
    points.extend(
        (lights.vertices_with_keys())
            .filter(|(_, v, _)| v.mergeable())
            .map(|(i, v, key)| (v.p, Photon::of(v, i, key))),
    );
}

/// Run pass `pass` of `settings` on one thread, handing every weighted contribution to
/// `inspector` instead of accumulating an image (for tests of the MIS weights).
pub fn inspect_pass(
    scene: &Scene,
    settings: &VcmSettings,
    seed: u64,
    pass: u64,
    inspector: &mut dyn FnMut(&Record),
) {
    let cell = RefCell::new(|r: &Record| inspector(r));
    let cell: &Inspector = &cell;
    let pc = PassConstants::new(settings, scene, pass);
    let UVec2 { x: w, y: h } = scene.camera.resolution;
    let lt = LightTracer {
        scene,
        settings,
        pc: &pc,
        inspector: Some(cell),
        claims: None,
    };
    let mut lights = LightPaths::default();
    lights.trace_one_row(&lt, (seed, pass), (w * h) as usize);
    let grid = settings.merge.then(|| build_grid(&lights, pc.radius));
    let mut ct = CameraTracer::new(
        scene,
        settings,
        &pc,
        &lights,
        grid.as_ref(),
        Some(cell),
        None,
    );
    for y in 0..h as usize {
        for x in 0..w as usize {
            camera_sample::<IndependentSampler>(&mut ct, seed, pass, y * w as usize + x, x, y);
        }
    }
}
