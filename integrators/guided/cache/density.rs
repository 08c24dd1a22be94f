//! `p_g(X)`, the guided density of a path, from the cache: the candidates of its structure
//! (the structure's BVH over first-vertex kernel boxes, each box tested exactly), and per
//! candidate guide the product of its first-vertex kernel and, per later vertex, the mixture
//! of the BSDF and Gaussian branches. Every guide left out has a term of exactly 0. While it
//! evaluates one candidate, [`GuideCache::terms`] asks the memory system for the guide data of
//! the candidate [`PREFETCH_AHEAD`] further on: on large caches much of a candidate's cost is
//! waiting for its data (`docs/results.md`, "The cost of p_g").

use super::GuideCache;
use crate::integrators::guided::gaussian::LogDensity;
use crate::integrators::guided::manifold::{self, Chain};
use crate::integrators::paths::Vertex;

/// Chains whose step density [`GuideCache::pdf_given`] evaluates last (further ones at once).
const DEFERRED: usize = 4;
use crate::integrators::guided::kernel::{
    FirstTest, FirstVertexQuery, Node, Reach, SegmentTarget, bsdf_branch_density,
    bsdf_branch_probability, dvec, first_vertex_density,
};
use crate::scene::Scene;
use glam::{Vec3, Vec3A};

/// How many candidates ahead [`GuideCache::terms`] prefetches a guide's data.
const PREFETCH_AHEAD: usize = 4;

impl GuideCache {
    /// Density `p(X | l)` of building the path `y` by following guide `l` (structure assumed
    /// equal): the first-vertex kernel times, per later vertex, the mixture of the BSDF and
    /// Gaussian branches (delta lights: the connection, factor 1).
    pub fn pdf_given(&self, scene: &Scene, l: usize, y: &[Vertex]) -> f64 {
        let p1 = LogDensity::plain(self.first_density(scene, l, y));
        self.pdf_given_with(scene, l, y, p1, &mut PathTerms::default())
            .0
    }

    /// Density of `y[1]` under guide `l`'s first-vertex kernel.
    pub fn first_density(&self, scene: &Scene, l: usize, y: &[Vertex]) -> f64 {
        first_vertex_density(scene, y, &self.vertex(scene, l, 1), self.guides[l].sigma1)
    }

    /// [`Self::pdf_given`] from the first-vertex density `p1` ([`Self::first_density`]),
    /// reusing the guide-independent terms of `y` in `terms`, and the vertex at which the term
    /// vanished (1: x_1 outside the first-vertex kernel; the path's vertex count when it did
    /// not).
    fn pdf_given_with(
        &self,
        scene: &Scene,
        l: usize,
        y: &[Vertex],
        p1: LogDensity,
        terms: &mut PathTerms,
    ) -> (f64, usize) {
        let len = self.guides[l].len as usize;
        let share = self.manifold.share;
        let mut p = p1;
        // Vertices that start a specular chain the step solves: the usual mixture's density
        // now, the chain step's (a Newton walk) once every other factor is known non-zero.
        let mut deferred: [Option<(Chain, f64)>; DEFERRED] = [None; DEFERRED];
        let mut n_deferred = 0;
        for v in 2..len {
            if p.is_zero() {
                return (0.0, v - 1);
            }
            let usual = self.vertex_density_with(scene, l, y, v, terms);
            match (share > 0.0)
                .then(|| manifold::chain_at(scene, self, l, v - 1))
                .flatten()
            {
                Some(chain) if n_deferred < DEFERRED => {
                    deferred[n_deferred] = Some((chain, usual.value()));
                    n_deferred += 1;
                }
                Some(chain) => {
                    let q = manifold::density_with(
                        scene,
                        self,
                        l,
                        y,
                        &chain,
                        &self.manifold,
                        &mut terms.walks,
                    );
                    p = p.times(LogDensity::plain(share * q + (1.0 - share) * usual.value()));
                }
                None => p = p.times(usual),
            }
        }
        for (chain, usual) in deferred.iter().take(n_deferred).flatten() {
            if p.is_zero() {
                break;
            }
            let q =
                manifold::density_with(scene, self, l, y, chain, &self.manifold, &mut terms.walks);
            p = p.times(LogDensity::plain(share * q + (1.0 - share) * usual));
        }
        let p = p.value();
        (p, if p == 0.0 { len - 1 } else { len })
    }

    /// Density of vertex `v` of `y` given `y[..v]` when following guide `l`.
    pub fn vertex_density(&self, scene: &Scene, l: usize, y: &[Vertex], v: usize) -> f64 {
        self.vertex_density_with(scene, l, y, v, &mut PathTerms::default())
            .value()
    }

    fn vertex_density_with(
        &self,
        scene: &Scene,
        l: usize,
        y: &[Vertex],
        v: usize,
        terms: &mut PathTerms,
    ) -> LogDensity {
        let node = self.node(l, v);
        if let Node::Emitter {
            reach: Reach::Delta,
            ..
        } = node
        {
            return LogDensity::ONE;
        }
        // v >= 2: both vertices are stored (by reference: p_g visits them per candidate).
        let (g_prev, g) = (self.stored_vertex(l, v - 1), self.stored_vertex(l, v));
        let k = self.kernel(l, v);
        let mut spill = None;
        let t = terms.get(v, &mut spill, || {
            let p_b = bsdf_branch_probability(scene, &y[v - 1]);
            let fb = if p_b > 0.0 && !y[v].is_medium() {
                bsdf_branch_density(scene, y, v, None)
            } else {
                0.0
            };
            VertexTerms {
                p_b,
                fb_surface: fb,
                target: (p_b < 1.0).then(|| SegmentTarget::new(scene, y, v)),
            }
        });
        let p_b = t.p_b;
        let gaussian = |target: &SegmentTarget| match target.surface_to_surface() {
            Some((x, w, area)) => self.plane(l, v).log_density(x, w).scaled(area),
            None => target.log_gaussian_density(self.frame(l, v), g_prev, g, k),
        };
        if p_b == 0.0 {
            // The Gaussian branch alone: its exponent joins the product's.
            return t.target.as_ref().map_or(LogDensity::ZERO, gaussian);
        }
        let fb = if matches!(node, Node::Medium { .. }) {
            let ell = (dvec(g.p) - dvec(g_prev.p)).length();
            bsdf_branch_density(scene, y, v, Some((ell, k.sigma_dist as f64)))
        } else {
            t.fb_surface
        };
        let fg = t
            .target
            .as_ref()
            .map_or(0.0, |target| gaussian(target).value());
        LogDensity::plain(p_b * fb + (1.0 - p_b) * fg)
    }

    /// Ask the memory system for what [`Self::terms`] reads of guide `l` (its header, first
    /// vertices and nodes, first plane kernel) a few candidates before it is evaluated.
    #[inline]
    fn prefetch_guide(&self, l: usize) {
        let Some(g) = self.guides.get(l) else {
            return;
        };
        crate::prefetch::line(g);
        let (start, k) = (g.start as usize, g.kernels as usize);
        if let Some(v) = self
            .vertices
            .get(start..(start + 2).min(self.vertices.len()))
        {
            crate::prefetch::slice(v, 2);
        }
        if let Some(n) = self.nodes.get(start) {
            crate::prefetch::line(n);
        }
        if let Some(planes) = self.planes.get(k..(k + 1).min(self.planes.len())) {
            crate::prefetch::slice(planes, 3);
        }
    }

    /// Guide paths of structure `sig` whose first-vertex kernel holds `x1` (a path's first
    /// vertex), with what their kernel's density there needs: the structure's BVH candidates
    /// ([`Self::candidates`]) tested exactly. A guide left out has `p(X | l) = 0` for every
    /// path of this structure through `x1`.
    pub fn candidates_of(&self, scene: &Scene, sig: u64, x1: &Vertex, out: &mut Vec<FirstTest>) {
        self.candidates_at(scene, sig, x1.p, x1.n, x1.is_medium(), out);
    }

    /// [`Self::candidates_of`] a first vertex at `p` with normal `n` (zero in a medium).
    pub fn candidates_at(
        &self,
        scene: &Scene,
        sig: u64,
        p: Vec3,
        n: Vec3,
        medium: bool,
        out: &mut Vec<FirstTest>,
    ) {
        out.clear();
        let Some(index) = self.index.get(&sig) else {
            return;
        };
        let q = FirstVertexQuery::at(scene, p, n, medium);
        index
            .bvh
            .ray_traverse_anyhit(self.camera_ray(scene, p), |_, i| {
                if let Some(t) = q.inside(&index.kernels[i]) {
                    out.push(t);
                }
            });
    }

    /// The ray from the camera towards `x1` in the BVHs' coordinates.
    fn camera_ray(&self, scene: &Scene, x1: Vec3) -> obvhs::ray::Ray {
        let o = scene.camera.position;
        // +0.0 canonicalises -0.0 components (obvhs misclassifies their octant).
        let d = Vec3A::from((x1 - o).normalize()) + Vec3A::ZERO;
        obvhs::ray::Ray::new_inf(Vec3A::from(o) * self.bvh_scale, d)
    }

    /// Guide paths of structure `sig` whose first-vertex kernel box the camera ray towards
    /// `x1` crosses (what learning picks neighbours among).
    pub fn candidates(&self, scene: &Scene, sig: u64, x1: Vec3, out: &mut Vec<u32>) {
        out.clear();
        let Some(index) = self.index.get(&sig) else {
            return;
        };
        let ray = self.camera_ray(scene, x1);
        index.bvh.ray_traverse_anyhit(ray, |_, i| {
            // The BVH's compressed nodes are conservative, so a leaf also yields boxes the
            // ray misses: each box is tested, so the set does not depend on the tree.
            let l = index.kernels[i].guide;
            if self
                .scaled_kernel_box(scene, l as usize)
                .intersect_ray(&ray)
                < f32::INFINITY
            {
                out.push(l);
            }
        });
    }

    /// `p_g(X) = Σ_l w_l p(X | l)` over all guide paths of the path's structure (`sig`,
    /// `nodes`); returns the density and the number of candidates examined. Exact: every guide
    /// whose first-vertex kernel contains x_1 is a candidate, and truncation makes the others'
    /// terms exactly zero.
    pub fn pdf(
        &self,
        scene: &Scene,
        y: &[Vertex],
        sig: u64,
        nodes: &[Node],
        scratch: &mut Vec<FirstTest>,
    ) -> (f64, usize) {
        if self.is_empty() || !self.holds(sig) {
            return (0.0, 0);
        }
        self.candidates_of(scene, sig, &y[1], scratch);
        let sum = self.terms(scene, y, sig, nodes, scratch, None, None).sum;
        (sum, scratch.len())
    }

    /// [`Self::pdf`] over `candidates`, which must be [`Self::candidates_of`] `sig` and
    /// `y[1]` (paths of one structure through one x_1 share them), with what the sum saw on
    /// the way: the own guide's term `p(X | own)` (a guided sample's own guide, whose term the
    /// sum computes anyway; 0 without `own` or when `own` is not among the candidates) and the
    /// furthest vertex a term reached. With `each`, every non-zero term `w_l p(X | l)` of the
    /// sum is pushed as `(l, term)`.
    #[allow(clippy::too_many_arguments)]
    pub fn terms(
        &self,
        scene: &Scene,
        y: &[Vertex],
        sig: u64,
        nodes: &[Node],
        candidates: &[FirstTest],
        own: Option<usize>,
        each: Option<&mut Vec<(u32, f64)>>,
    ) -> Terms {
        let mut walks = manifold::WalkMemo::default();
        self.terms_with(scene, y, sig, nodes, candidates, own, each, &mut walks)
    }

    /// [`Self::terms`], leaving in `walks` the specular-chain step's walks it ran for `y`
    /// (which a guided sample's basin check then reads instead of walking again).
    #[allow(clippy::too_many_arguments)]
    pub fn terms_with(
        &self,
        scene: &Scene,
        y: &[Vertex],
        sig: u64,
        nodes: &[Node],
        candidates: &[FirstTest],
        own: Option<usize>,
        mut each: Option<&mut Vec<(u32, f64)>>,
        walks: &mut manifold::WalkMemo,
    ) -> Terms {
        let mut terms = PathTerms {
            walks: std::mem::take(walks),
            ..PathTerms::default()
        };
        let mut own_term = None;
        let (mut sum, mut reach) = (0.0, 1);
        if takes_mixed_delta_lobe(y) {
            return Terms {
                sum: 0.0,
                own: 0.0,
                reach: 1,
            };
        }
        if let Some(index) = self.index.get(&sig).filter(|_| !self.is_empty()) {
            // Where every guide path of the structure has the same nodes, the path's are
            // compared with them once (a path with other nodes gets no term at all).
            let same = self.nodes_of(index.first as usize) == nodes;
            if index.uniform && !same {
                return Terms {
                    sum: 0.0,
                    own: 0.0,
                    reach: 1,
                };
            }
            let check_nodes = !index.uniform;
            let first = FirstVertexQuery::new(scene, &y[1]);
            for (i, c) in candidates.iter().enumerate() {
                if let Some(ahead) = candidates.get(i + PREFETCH_AHEAD) {
                    self.prefetch_guide(ahead.guide as usize);
                }
                let l = c.guide as usize;
                let g = &self.guides[l];
                if g.sig != sig || g.weight == 0.0 || (check_nodes && self.nodes_of(l) != nodes) {
                    continue;
                }
                let p1 = first.log_density_of(c);
                let (term, vanished) = self.pdf_given_with(scene, l, y, p1, &mut terms);
                reach = reach.max(vanished);
                if own == Some(l) {
                    own_term = Some(term);
                }
                if self.skip_in_pdf != Some(l) {
                    sum += g.weight * term;
                    if let Some(e) = each.as_deref_mut()
                        && term > 0.0
                    {
                        e.push((l as u32, g.weight * term));
                    }
                }
            }
        }
        // The own guide's term counts only where the sum has it: if rounding put x_1 just
        // outside the own guide's box (so the sum left it out), the sample gets 0 and is a
        // failure, and the guided samples kept are exactly those whose term p_g holds.
        let own = own_term.unwrap_or(0.0);
        *walks = terms.walks;
        Terms { sum, own, reach }
    }

    /// [`Self::terms`] over every guide path of the structure, no pruning and no own guide:
    /// the reference for tests.
    pub fn terms_brute_force(
        &self,
        scene: &Scene,
        y: &[Vertex],
        sig: u64,
        nodes: &[Node],
    ) -> Terms {
        let (mut sum, mut reach) = (0.0, 1);
        for (l, g) in self.guides.iter().enumerate() {
            if g.sig != sig || self.nodes_of(l) != nodes || takes_mixed_delta_lobe(y) {
                continue;
            }
            let p1 = LogDensity::plain(self.first_density(scene, l, y));
            let (term, vanished) = self.pdf_given_with(scene, l, y, p1, &mut PathTerms::default());
            sum += g.weight * term;
            if g.weight != 0.0 {
                reach = reach.max(vanished);
            }
        }
        Terms {
            sum,
            own: 0.0,
            reach,
        }
    }
}

/// Terms of a path's guided density that do not depend on the guide path (the BSDF-branch
/// probability, for surface targets the BSDF-branch density, and what the Gaussian branch
/// needs of the path), computed once per path for its first [`PathTerms::CACHED`] vertices
/// (on the stack; longer paths recompute the rest).
#[derive(Default)]
struct PathTerms {
    values: [Option<VertexTerms>; PathTerms::CACHED],
    /// The specular-chain step's walks from the path's vertices (`manifold/`).
    walks: manifold::WalkMemo,
}

#[derive(Clone, Copy)]
struct VertexTerms {
    p_b: f64,
    fb_surface: f64,
    /// None where the BSDF branch is taken always (p_b = 1).
    target: Option<SegmentTarget>,
}

impl PathTerms {
    const CACHED: usize = 16;

    /// Vertex `v`'s terms, computed on first use (past [`Self::CACHED`] vertices every time,
    /// into `spill`).
    fn get<'t>(
        &'t mut self,
        v: usize,
        spill: &'t mut Option<VertexTerms>,
        compute: impl FnOnce() -> VertexTerms,
    ) -> &'t VertexTerms {
        match self.values.get_mut(v) {
            Some(slot) => slot.get_or_insert_with(compute),
            None => spill.insert(compute()),
        }
    }
}

/// What [`GuideCache::terms`] finds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Terms {
    /// p_g(X) = sum of w_l p(X | l) over the candidates of the path's structure.
    pub sum: f64,
    /// p(X | own) of the guide asked for (0 without one).
    pub own: f64,
    /// The furthest vertex any candidate's term reached before vanishing (1: x_1 is outside
    /// every first-vertex kernel of the structure; the path's vertex count when a term is
    /// non-zero).
    pub reach: usize,
}

/// Whether path `y` takes the delta lobe of a surface that also has a non-delta one (smooth
/// plastic's coating): the guided sampler never does (at such a surface it follows the
/// guide's direction or the BSDF's non-delta lobe; a BSDF sample of the delta lobe fails), so
/// the guided density of such a path is 0.
pub(crate) fn takes_mixed_delta_lobe(y: &[Vertex]) -> bool {
    y.iter().any(|v| {
        v.is_specular_surface()
            && matches!(v.kind, crate::integrators::paths::Kind::Surface { bsdf, .. } if !bsdf.is_delta())
    })
}
