//! Vertex merging inside bdpt's tracer: the unguided estimator of `guided-vcm`
//! (`integrators::vcm::VcmUnguided`).
//!
//! A pass first traces N light subpaths (one per pixel, N = the pixel count) into
//! [`SharedLights`], with a hash grid over their non-delta surface vertices. The tracer of
//! pixel k then uses light subpath k for every BDPT technique (instead of tracing its own),
//! and at each non-delta surface vertex y_m of its camera subpath it also merges with every
//! stored light vertex within radius r of it (VCM, Georgiev et al. 2012): the merged path is
//! the camera prefix y_0 .. y_m followed by the light prefix before the photon, and its value
//! is `beta_cam f(y_m) beta_light / (pi r^2 N)`.
//!
//! Each path's densities can be assembled explicitly (`PathTerms`): the density of each
//! connection technique of the path plus, for each non-delta surface vertex y_j, the merging
//! density `eta prod_{l <= j} pc[l] prod_{l >= j} pl[l]` with `eta = pi r^2 N`
//! (`PathTerms::merge_densities`). So the sum of all densities is a `p_u` that a further
//! technique (the guider) can join by adding its own density. Where the sink does not need
//! them (`PathSink::needs_densities`: the guider, for a path whose structure its cache does
//! not hold), the same weights come from VCM's recursive form instead, O(1) per path: each
//! subpath vertex's running sum holds the merges beside the connections (`cache::mis_sums`). At a merge the two vertices
//! the kernel pairs stand for one: the camera side keeps its densities up to y_m, the light
//! side its own from the photon on, and the densities across y_m are evaluated from the
//! camera vertex's BSDF with the photon's incoming direction (as VCM's weights are). Those
//! weigh the merge in U's own estimate; in recording mode a merged path goes to the sink with
//! the densities of its vertices instead ([`densities_from_vertices`], `recording.rs`), the
//! numbers `pdf_unguided` gives any other technique that forms the same vertices.
//! Merging is consistent, not unbiased: the radius shrinks with the pass,
//! r_i = r_0 (i + 1)^((alpha - 1) / 2), as in `vcm`.

use super::cache::{Cached, cache_subpath, mis_sums};
use super::walk::{light_subpath, roulette};
use super::{BdptSettings, Tracer, light_nee};
use crate::bsdf::TransportMode;
use crate::geometry::HashGrid;
use crate::geometry::bvh::{count_ray_equivalents, rays_traced};
use crate::integrators::paths::{Kind, PathTerms, Vertex, hittable, path_terms_into};
use crate::integrators::unguided::PathSink;
use crate::math::{IndependentSampler, PI, Spectrum};
use crate::path::MAX_VERTICES;
use crate::scene::Scene;
use rayon::prelude::*;

/// The cost of evaluating one photon of a merge (its cache misses, BSDF, explicit weight), in
/// rays: the guided share compares techniques by rays traced (`integrators/guided/share.rs`),
/// and a pass's merges would otherwise cost nothing there. Measured on dining (one thread,
/// 12 passes with guiding off, merging radius 1e-7 against the default, two paired runs):
/// 0.55 M photons cost 0.3 to 0.7 s where 4.9 M rays took 3.9 to 5.1 s, so 0.6 to 1.3 rays.
const MERGE_RAYS_PER_PHOTON: f64 = 1.0;

/// Stream index offset of the shared light subpaths (pixels use 0 .. N, guided samples
/// N ..; the offset keeps the light subpaths apart from both).
pub const LIGHT_STREAMS: u64 = crate::math::streams::LIGHT_STREAMS;

/// What a merge needs of a stored light vertex before touching its subpath, kept in the grid
/// beside its position (one run of memory per query).
#[derive(Clone, Copy, Default)]
pub struct Photon {
    /// Unit direction towards the light walk's previous vertex.
    wo: glam::Vec3,
    /// Its light subpath, and its depth there (segments from the light).
    path: u32,
    depth: u32,
}

/// The light subpaths of one pass, shared by every pixel's tracer, and the merging grid
/// over their vertices. Stored by image row, as traced (no copy into one array), and
/// refilled in place pass after pass ([`SharedLights::retrace`]): fresh allocations of this
/// size would cost page faults every pass.
#[derive(Default)]
pub struct SharedLights<'a> {
    rows: Vec<LightRow<'a>>,
    /// Light subpaths per row (subpath k is number k % per_row of row k / per_row).
    per_row: usize,
    /// The grid's input (kept for its memory).
    points: Vec<(glam::Vec3, Photon)>,
    pub(super) grid: HashGrid<Photon>,
    /// eta = pi r^2 N, and 1 / eta (the merge's normalisation).
    pub eta: f64,
    /// Merging radius r of the pass.
    pub radius: f32,
    /// Rays the light subpaths took (the guider counts them as the pass's cost).
    pub rays: u64,
}

/// The light subpaths of one image row.
#[derive(Default)]
struct LightRow<'a> {
    vertices: Vec<Vertex<'a>>,
    caches: Vec<Cached>,
    /// Subpath j of the row has vertices `starts[j] .. starts[j + 1]`.
    starts: Vec<u32>,
    /// Next-event density of each subpath's origin from its second vertex.
    nee: Vec<f64>,
    rays: u64,
    /// The subpath being traced and its caches (scratch, kept for its memory).
    path: Vec<Vertex<'a>>,
    cache: Vec<Cached>,
}

/// Whether a vertex can be merged at: a non-delta, non-black surface (not in media).
pub fn mergeable(scene: &Scene, v: &Vertex) -> bool {
    matches!(v.kind, Kind::Surface { .. }) && v.connectible(scene)
}

/// Every technique's density for the path `y` (camera first, an emitter last) from its
/// vertices alone, as `pdf_unguided` of vcm evaluates it for any path: bdpt's techniques by
/// s in `vc[..=k]` and, with `eta = pi r^2 N > 0`, merging at each mergeable y_j in `vm[j]`;
/// returns their sum, or `None` for a path of no segment or of more than `max_depth`.
/// `terms` is scratch (no allocation once grown).
pub fn densities_from_vertices(
    scene: &Scene,
    y: &[Vertex],
    settings: &BdptSettings,
    eta: f64,
    terms: &mut PathTerms,
    vc: &mut [f64; MAX_VERTICES],
    vm: &mut [f64; MAX_VERTICES],
) -> Option<f64> {
    let k = y.len().saturating_sub(1);
    if k == 0 || k > settings.max_depth as usize {
        return None;
    }
    path_terms_into(scene, y, settings.rr_depth, terms);
    terms.direct_by_camera &= !settings.direct_splats;
    terms.eta = eta;
    vc.fill(0.0);
    vm.fill(0.0);
    terms.technique_densities(vc);
    let merge = terms.merge_densities(|j| mergeable(scene, &y[j]), vm);
    Some(vc[..=k].iter().sum::<f64>() + merge)
}

impl<'a> SharedLights<'a> {
    /// Trace the N light subpaths of pass `stream` (light subpath k from stream
    /// (seed, stream, LIGHT_STREAMS + k)) and grid their mergeable vertices at `radius`.
    pub fn trace(
        scene: &'a Scene,
        settings: &BdptSettings,
        seed: u64,
        stream: u64,
        radius: f32,
    ) -> SharedLights<'a> {
        let mut s = SharedLights::default();
        s.retrace(scene, settings, seed, stream, radius);
        s
    }

    /// [`SharedLights::trace`] in this pass's memory: the same subpaths and grid as a fresh
    /// trace.
    pub fn retrace(
        &mut self,
        scene: &'a Scene,
        settings: &BdptSettings,
        seed: u64,
        stream: u64,
        radius: f32,
    ) {
        let n = scene.camera.pixel_count();
        let rows = scene.camera.resolution.y.max(1) as usize;
        let per_row = n.div_ceil(rows);
        let max_vertices = settings.max_depth as usize + 1;
        let eta = PI as f64 * radius as f64 * radius as f64 * n as f64;
        self.rows.resize_with(rows, LightRow::default);
        self.rows.par_iter_mut().enumerate().for_each(|(r, row)| {
            row.vertices.clear();
            row.caches.clear();
            row.nee.clear();
            row.starts.clear();
            row.starts.push(0);
            let (mut path, mut cache) = (
                std::mem::take(&mut row.path),
                std::mem::take(&mut row.cache),
            );
            let rays = rays_traced();
            for k in (r * per_row)..((r + 1) * per_row).min(n) {
                let mut sampler = IndependentSampler::new(seed, stream, LIGHT_STREAMS + k as u64);
                light_subpath(
                    scene,
                    max_vertices,
                    settings.rr_depth,
                    &mut sampler,
                    &mut path,
                );
                cache_subpath(scene, &path, settings.rr_depth, &mut cache);
                let nee_k = light_nee(scene, &path);
                // The sums of the recursive weights (used where they apply).
                mis_sums(
                    scene,
                    &path,
                    &mut cache,
                    Some(nee_k),
                    settings.heuristic,
                    eta,
                );
                row.nee.push(nee_k);
                row.vertices.extend_from_slice(&path);
                row.caches.extend_from_slice(&cache);
                row.starts.push(row.vertices.len() as u32);
            }
            row.rays = rays_traced() - rays;
            (row.path, row.cache) = (path, cache);
        });
        self.per_row = per_row;
        self.radius = radius;
        self.eta = eta;
        self.rays = self.rows.iter().map(|r| r.rays).sum();
        let mut points = std::mem::take(&mut self.points);
        points.clear();
        for (r, row) in self.rows.iter().enumerate() {
            for (j, w) in row.starts.windows(2).enumerate() {
                let path = (r * per_row + j) as u32;
                for g in w[0] as usize + 1..w[1] as usize {
                    let v = &row.vertices[g];
                    if mergeable(scene, v) {
                        let depth = (g - w[0] as usize) as u32;
                        let wo = row.caches[g].wo;
                        points.push((v.p, Photon { wo, path, depth }));
                    }
                }
            }
        }
        self.grid.rebuild(&points, radius);
        self.points = points;
    }

    /// Light subpath `k`: its vertices, their caches and its origin's next-event density.
    pub fn path(&self, k: usize) -> (&[Vertex<'a>], &[Cached], f64) {
        let (row, j) = (&self.rows[k / self.per_row], k % self.per_row);
        let (a, b) = (row.starts[j] as usize, row.starts[j + 1] as usize);
        (&row.vertices[a..b], &row.caches[a..b], row.nee[j])
    }
}

impl<'a> Tracer<'a> {
    /// Merge the last camera vertex of `c` with every photon within the radius (paths of at
    /// most `max_depth` segments). With `sink` (recording mode) each merged path goes there
    /// and the return is zero.
    pub(super) fn merge_at<'k>(
        &mut self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        mut sink: Option<&mut (dyn PathSink + 'k)>,
    ) -> Spectrum {
        let Some(shared) = self.shared else {
            return Spectrum::ZERO;
        };
        let m = c.len() - 1;
        let a = &c[m];
        let Kind::Surface { bsdf, frame, .. } = a.kind else {
            return Spectrum::ZERO;
        };
        if m == 0 || !cc[m].connectible {
            return Spectrum::ZERO;
        }
        let max = self.settings.max_depth as usize;
        let mut found = std::mem::take(&mut self.photons);
        found.clear();
        shared.grid.query(a.p, |ph| {
            if m + ph.depth as usize <= max {
                found.push(*ph);
            }
        });
        let norm = (1.0 / shared.eta) as f32;
        let mut sum = Spectrum::ZERO;
        for ph in &found {
            let e = bsdf.eval_pdfs(&frame, cc[m].wo, ph.wo, TransportMode::Radiance);
            if e.f == Spectrum::ZERO {
                continue;
            }
            let (lv, lc, nee) = shared.path(ph.path as usize);
            let i = ph.depth as usize;
            let raw = a.beta * e.f * lv[i].beta * norm;
            let w = self.weight_merge(c, cc, &lv[..=i], &lc[..=i], e.pdf_fwd, e.pdf_rev, nee);
            let value = raw * w as f32;
            match sink.as_deref_mut() {
                Some(sink) => self.deliver(value, None, sink, c, &lv[..i]),
                None => sum += value,
            }
        }
        // Whole rays' worth, by a deterministic rounding of this query's total.
        count_ray_equivalents((found.len() as f64 * MERGE_RAYS_PER_PHOTON).round() as u64);
        self.photons = found;
        sum
    }

    /// Weight of merging camera prefix `c` (its last vertex y_m) with the last vertex of
    /// light prefix `lp` (the photon, at depth i): the path y_0 .. y_m, then `lp` before the
    /// photon, reversed (k = m + i segments). `pdf_fwd` / `pdf_rev`: the camera vertex's BSDF
    /// densities from its `wo` to the photon's incoming direction and back.
    #[allow(clippy::too_many_arguments)]
    fn weight_merge(
        &mut self,
        c: &[Vertex<'a>],
        cc: &[Cached],
        lp: &[Vertex<'a>],
        lc: &[Cached],
        pdf_fwd: f32,
        pdf_rev: f32,
        nee_k: f64,
    ) -> f64 {
        let scene = self.scene;
        let rr_depth = self.settings.rr_depth;
        let rr = |q: f32, segments: usize| roulette(q, segments, rr_depth) as f64;
        let (m, i) = (c.len() - 1, lp.len() - 1);
        let k = m + i;
        let Kind::Light { light } = lp[0].kind else {
            return 0.0;
        };
        let (a, b) = (&c[m], &lp[i]);
        // The two densities across the merged vertex: y_{m+1} generated from y_m having come
        // from y_{m-1}, and y_{m-1} from y_m having come from y_{m+1}.
        let pc_next = (pdf_fwd * lc[i].to_prev * b.edge.factor(scene, lp[i - 1].is_medium(), false))
            as f64
            * rr(cc[m].q, m);
        let pl_prev = if m >= 2 {
            (pdf_rev * cc[m].to_prev * a.edge.factor(scene, c[m - 1].is_medium(), false)) as f64
                * rr(cc[m].q, i)
        } else {
            0.0
        };
        let recursive = self.recursive_mis().then(|| {
            let h = self.settings.heuristic;
            weight_merge_recursive(cc, lc, pc_next, pl_prev, self.terms.eta, h)
        });
        if let Some(w) = recursive
            && !self.recording
        {
            return w;
        }
        let terms = &mut self.terms;
        terms.reset(k);
        terms.hittable = hittable(scene, light);
        terms.nee_k = nee_k;
        // y_j is c[j] for j <= m and lp[k - j] after; y_m is both.
        for (j, v) in cc.iter().enumerate() {
            terms.connectible[j] = v.connectible;
        }
        for (ii, v) in lc[..i].iter().enumerate() {
            terms.connectible[k - ii] = v.connectible;
        }
        // Camera side: its own walk up to y_m, then from y_m towards the photon's previous
        // vertex along the photon's direction, then the light walk's reverse densities.
        terms.pc[1..=m]
            .iter_mut()
            .zip(&cc[1..=m])
            .for_each(|(p, v)| *p = v.fwd);
        terms.pc[m + 1] = pc_next;
        for j in m + 2..=k {
            let ii = k - j;
            terms.pc[j] = rr(lc[ii + 1].q, j - 1) * lp[ii].pdf_rev as f64;
        }
        // Light side: its own walk up to the photon, then from y_m back to y_{m-1} having
        // come along the photon's direction, then the camera walk's reverse densities.
        for j in m..=k {
            terms.pl[j] = lc[k - j].fwd;
        }
        if m >= 2 {
            terms.pl[m - 1] = pl_prev;
        }
        for j in 1..m.saturating_sub(1) {
            terms.pl[j] = rr(cc[j + 1].q, k - j - 1) * c[j].pdf_rev as f64;
        }
        if let Some(w) = recursive {
            return self.hold_recursive(w, k + 1 + m);
        }
        self.hold(c, &lp[..i], k + 1 + m)
    }
}

/// Recursive MIS weight of merging the last vertex y_m of a camera subpath (cache `cc`) with
/// the photon, the last vertex of a light subpath (cache `lc`, depth i): the number
/// `weight_merge` assembles explicitly, from the subpaths' sums (`cache::mis_sums` with
/// eta). Relative to the merge's density `eta pc[m] g(m)` (g(t): the generic density of
/// connecting y_{t-1} with y_t), the techniques with fewer camera vertices sum to
/// `(mis_valid_m + h(pl[m-1] / pc[m-1]) (mis_valid_{m-1} + mis_merge_{m-1} + S_{m-2})) /
/// h(eta pc[m])`, those with more likewise from the light side; `pc_next` = pc[m+1] and
/// `pl_prev` = pl[m-1] are the densities across the merged vertex.
fn weight_merge_recursive(
    cc: &[Cached],
    lc: &[Cached],
    pc_next: f64,
    pl_prev: f64,
    eta: f64,
    h: crate::integrators::paths::Heuristic,
) -> f64 {
    use super::cache::heuristic;
    let (m, i) = (cc.len() - 1, lc.len() - 1);
    let r = |num: f64, den: f64| heuristic(h, num / den);
    let camera = {
        let before = if m >= 2 {
            r(pl_prev, cc[m - 1].fwd)
                * (cc[m - 1].mis_valid + cc[m - 1].mis_merge + cc[m - 2].mis_sum)
        } else {
            0.0
        };
        (cc[m].mis_valid + before) / heuristic(h, eta * cc[m].fwd)
    };
    let light = {
        let sum = if i >= 2 { lc[i - 2].mis_sum } else { 0.0 };
        let before = r(pc_next, lc[i - 1].fwd) * (lc[i - 1].mis_valid + lc[i - 1].mis_merge + sum);
        (lc[i].mis_valid + before) / heuristic(h, eta * lc[i].fwd)
    };
    super::weights::inverse_or_zero(1.0 + camera + light)
}
