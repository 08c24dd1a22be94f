//! The guide-path cache: compact storage of complete guide paths, their neighbours, the
//! per-segment conditional Gaussians, selection weights (alias table) and one pruning BVH per
//! structure over its guides' first-vertex kernels; and `p_g(X)`, the guided density of any
//! path. Building it (rebuild, install, neighbours, kernels, BVHs) is in `build.rs`, evaluating
//! p_g in `density.rs`.
//!
//! `p_g` of a path sums over the guides of its structure whose first-vertex kernel holds x_1:
//! the structure's BVH yields the guides whose kernel box the camera ray through x_1 crosses,
//! each is tested exactly ([`FirstVertexQuery::inside`](super::kernel::FirstVertexQuery::inside)), and only the survivors' terms are
//! evaluated (every other term is exactly 0 by truncation).
//!
//! Storage is flat: one header per guide path ([`Guide`]), its vertices g_1 .. g_{L-1} in
//! `vertices` (the camera g_0 is the scene's), and one [`Kernel`] per segment g_{v-1} -> g_v
//! for v >= 2 in `kernels`, beside its frame and its [`PlaneKernel`] (the same Gaussian
//! precomputed for p_g's surface-to-surface terms). [`GuideCache::bytes_per_path`] reports the
//! footprint.
//!
//! Rebuild (between learning iterations, spec §2.4, §3): weights `w_j = t C_j / ΣC + (1 − t)
//! w_j_old` with `C = f / (α p_u + (1 − α) p_g)` evaluated under the state that drew the
//! iteration's samples; first-vertex kernels `s = ρ max(1, 90/k + 10) + (1 − ρ) max(1, 90/k +
//! 1)` pixels wide at g_1 (k the learning iteration, ρ the roughness there); neighbours: the
//! k = 10 guide paths of the same structure nearest by summed squared vertex distance, among
//! those whose first-vertex kernel the path's camera ray crosses; per-segment Gaussians from
//! the neighbours (mean, covariance, regression `K = Σ12 Σ22⁻¹`, conditional covariance with
//! eigenvalues clamped to [one pixel footprint², (half the segment)²]); a guide with fewer
//! than 10 neighbours gets isotropic kernels `max(1, 90/(age + 2))` pixels wide.
//!
//! **Widths (a measured deviation from the spec).** The conditional Gaussians' standard
//! deviations are multiplied by [`KernelWidths::regression`] (default 3) before the eigenvalue
//! clamp; the first-vertex width by [`KernelWidths::first_vertex`] (default 2) where g_1 is
//! rough and by [`KernelWidths::first_vertex_specular`] (default 6) where it is specular,
//! interpolated by the roughness at g_1 as the spec interpolates its pixel widths. The spec's
//! kernels (all factors 1) leave most of the caustic paths pt finds outside every guide's
//! support (p_g = 0 on paths of held structures); wider kernels fail more often but cover
//! them. A specular g_1 is followed by its deterministic lobe, so moving x_1 moves the rest of
//! the path smoothly and a wider kernel there covers more of a caustic seen through glass or
//! water; a rough g_1 is followed by its conditional Gaussian, whose regression degrades away
//! from the guide. The equal-time figures at these defaults are in `docs/results.md`.
//!
//! **Weights by second moment (`weights = second_moment`, the default; not the spec's rule,
//! which `weights = c` keeps).** The spec's
//! `C_j` looks at one point, guide path j itself. With this option each learning pass also
//! credits every guide l with its share of the squared values of the samples the pass drew,
//! `V² r w_l p(X | l) / (p_u + r p_g)` per sample X (`Estimator::credit`). Summed, this
//! estimates `w_l ∫ f² p(X | l) / p_mix²`: how much guide l's kernels carry of the
//! estimator's second moment (population Monte Carlo's Rao-Blackwellised weight update with
//! f² for variance). The fresh weights are then half `C_j / ΣC` (new guide paths have only
//! this half) and half each old guide's credit over the total credit. Damping and the final
//! rebuild work as with `C`.
//!
//! **Adaptive first-vertex width (a deviation from the spec, for the cost of p_g).** With the
//! spec's widths, fixed in pixels, the number of guide paths whose first-vertex kernel covers
//! a pixel grows in proportion to the cache, and so does the cost of `p_g`. Here a guide's
//! first-vertex std is also at most the distance from its g_1 to the [`SPACING_RANK`]-th
//! nearest other first vertex of its structure (never below one pixel footprint): a sample-
//! point kernel density estimate. Where guide paths are sparse nothing changes; where they
//! are dense, each kernel still spans its neighbours' first vertices, so the kernels together
//! cover what they covered, while a pixel sees a bounded number of them. Neighbours and
//! conditional kernels are chosen under the spec's widths, as before.

mod build;
mod density;

pub use build::{KERNEL_REFERENCE_HEIGHT, regression_kernel};
pub use density::Terms;

#[cfg(doc)]
use super::kernel::segment_frame;
use super::kernel::{FirstKernel, Kernel, Node};
use super::manifold::settings::ManifoldSettings;
use super::plane::PlaneKernel;
use crate::integrators::paths::structure::{HeldKey, SigMap, SigSet};
use crate::math::AliasTable;
use crate::math::Frame;
use crate::path::{MAX_VERTICES, Vertex as PathVertex, VertexKind};
use crate::scene::Scene;
use glam::Vec3;
use obvhs::cwbvh::CwBvh;

/// Deliberate errors in the guided estimator's weights, for the tests' negative controls
/// ([`GuideCache::weight_faults`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeightFaults {
    /// Factor on p_g in the weights.
    pub p_g: f64,
    /// Factor on n_g / n_u in the weights.
    pub ratio: f64,
}

impl Default for WeightFaults {
    fn default() -> Self {
        WeightFaults {
            p_g: 1.0,
            ratio: 1.0,
        }
    }
}

/// Neighbours per guide path (the path itself included).
pub const NEIGHBOURS: usize = 10;

/// The first-vertex kernel's std is at most the distance to the `SPACING_RANK`-th nearest
/// other first vertex of the same structure (module doc, "Adaptive first-vertex width"); 4
/// rather than 10 gave the same variance on dining and pool with fewer p_g candidates.
pub const SPACING_RANK: usize = 4;

/// A guide path to install: vertices (camera first), luminance of f, p_u, weight, age.
pub type Install = (Vec<PathVertex>, f64, f64, f64, u16);

/// One guide path's header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guide {
    /// Index of g_1 in `vertices` (and `nodes`).
    pub start: u32,
    /// Index of the kernel of segment g_1 -> g_2 in `kernels`.
    pub kernels: u32,
    /// Number of vertices L, camera included.
    pub len: u8,
    /// Number of guide paths of its structure its conditional kernels were fitted to
    /// (itself included; at most [`NEIGHBOURS`]).
    pub neighbours: u8,
    /// Rebuilds survived.
    pub age: u16,
    /// Hash of the nodes (structure).
    pub sig: u64,
    /// Std of the first-vertex kernel.
    pub sigma1: f32,
    /// Luminance of f(X) (f64: in a scene a millimetre across, f of a long path passes
    /// f32's range).
    pub f: f64,
    /// Unguided density of the path.
    pub p_u: f64,
    /// Selection probability.
    pub weight: f64,
}

/// A path offered to the cache by the learning loop: its vertices (camera first), luminance
/// of f, unguided density, and C = f / (α p_u + (1 − α) p_g) under the state that drew it.
#[derive(Debug, Clone)]
pub struct Record {
    /// The path's vertices, camera first.
    pub vertices: Vec<PathVertex>,
    /// Luminance of f(X).
    pub f: f64,
    /// U's density sum for the path.
    pub p_u: f64,
    /// `C = f / (α p_u + (1 − α) p_g)` under the state that drew the path.
    pub c: f64,
}

/// How a rebuild sets the selection weights (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeightRule {
    /// The spec's: `w_j ∝ C_j`, each guide path's own value under the mixture.
    C,
    /// Half `C_j / ΣC`, half each old guide's share of the second moment of the samples the
    /// iteration drew (`RebuildParams::second_moment`).
    SecondMoment,
}

/// Share of the fresh weights that [`WeightRule::SecondMoment`] gives by second moment.
pub const SECOND_MOMENT_SHARE: f64 = 0.5;

/// Learning parameters of a rebuild.
#[derive(Debug, Clone, Copy)]
pub struct RebuildParams {
    /// Learning iteration k >= 1 (sets the first-vertex kernel width).
    pub iteration: u32,
    /// Unguided share of the iteration that drew the samples.
    pub alpha: f64,
    /// Damping t of the weight update.
    pub damping: f64,
    /// Final rebuild: weights from this iteration alone (no damping).
    pub render_mode: bool,
    /// Cache capacity: beyond it the guide paths of lowest weight are dropped.
    pub max_guides: usize,
}

/// Kernel widths relative to the spec's (module doc): factors on the standard deviations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelWidths {
    /// Factor on the conditional (regression) Gaussians, before the eigenvalue clamp.
    pub regression: f64,
    /// Factor on the first-vertex kernel (after the spec's one-pixel floor) where g_1 is
    /// rough (roughness 1).
    pub first_vertex: f64,
    /// The same where g_1 is specular (roughness 0); in between the two factors are
    /// interpolated by the roughness, as the spec interpolates its pixel widths.
    pub first_vertex_specular: f64,
}

impl KernelWidths {
    /// Every factor finite and positive (what options and saved caches must give).
    pub fn is_valid(&self) -> bool {
        [
            self.regression,
            self.first_vertex,
            self.first_vertex_specular,
        ]
        .iter()
        .all(|&x| x > 0.0 && x.is_finite())
    }
}

impl KernelWidths {
    /// The default factors (options `kernel_width`, `first_width`, `first_width_specular`).
    pub const DEFAULT: KernelWidths = KernelWidths {
        regression: 3.0,
        first_vertex: 2.0,
        first_vertex_specular: 6.0,
    };
}

impl Default for KernelWidths {
    fn default() -> Self {
        KernelWidths::DEFAULT
    }
}

/// The pruning BVH over the first-vertex kernel boxes of one structure's guide paths.
struct StructureIndex {
    bvh: CwBvh,
    /// The first-vertex kernel of each BVH primitive, in BVH order (with its guide's index),
    /// so a query reads its candidates from one compact array.
    kernels: Vec<FirstKernel>,
    /// A guide path of the structure, and whether every one of them has its nodes (equal
    /// hashes with other nodes would differ): `terms` then compares a path's nodes once.
    first: u32,
    uniform: bool,
}

/// The guide-path cache: guide paths, their kernels and selection weights, and the
/// per-structure BVHs that p_g is evaluated with (module doc).
#[derive(Default)]
pub struct GuideCache {
    /// Kernel widths used by [`GuideCache::install`] (saved with the cache).
    pub widths: KernelWidths,
    /// One header per guide path.
    pub guides: Vec<Guide>,
    /// Vertices g_1 .. g_{L-1} of every guide path, one after the other ([`Guide::start`]).
    pub vertices: Vec<PathVertex>,
    /// The structure node of each vertex, beside `vertices`.
    pub nodes: Vec<Node>,
    /// One conditional kernel per segment g_{v-1} -> g_v, v >= 2 ([`Guide::kernels`]).
    pub kernels: Vec<Kernel>,
    /// The frame of each segment's kernel ([`segment_frame`]), beside `kernels`.
    frames: Vec<Frame>,
    /// Each segment's kernel precomputed for surface-to-surface paths (`plane.rs`), beside
    /// `kernels`.
    planes: Vec<PlaneKernel>,
    /// Every (vertex count, emitter) that a held structure has, sorted: what
    /// [`GuideCache::may_hold`] tests before a structure is hashed.
    ends: Vec<(usize, u32)>,
    alias: AliasTable,
    /// One pruning BVH per structure held, by signature (a path is only ever evaluated
    /// against guides of its own structure; a structure not held is rejected by the lookup).
    index: SigMap<StructureIndex>,
    /// The BVHs' coordinates are world coordinates times this power of two.
    bvh_scale: f32,
    /// Learning iterations the cache has seen.
    pub iteration: u32,
    /// Testing hook: leave this guide path out of `pdf` (a deliberately wrong p_g, which the
    /// unbiasedness test must detect). Never set by the renderer.
    pub skip_in_pdf: Option<usize>,
    /// Testing hooks: factors on p_g and on the ratio n_g / n_u where the estimator weighs a
    /// path (`Estimator::mix`), not where it samples one: deliberately wrong weights that the
    /// tests' controls must detect. 1 (no effect) unless a test sets them.
    pub weight_faults: WeightFaults,
    /// The specular-chain step's settings (`manifold/`), which sampling and p_g share; set
    /// from the render's options, not saved with the cache.
    pub manifold: ManifoldSettings,
    /// The ratio n_g / n_u the learning run chose for rendering (`share.rs`); a loaded cache
    /// renders with it, so it repeats the render phase of the run that saved it.
    pub learned_ratio: Option<f64>,
}

impl GuideCache {
    /// An empty cache whose kernels will have these widths.
    pub fn with_widths(widths: KernelWidths) -> GuideCache {
        GuideCache {
            widths,
            ..GuideCache::default()
        }
    }

    /// Whether no guide path can be selected (no guides, or no positive weight).
    pub fn is_empty(&self) -> bool {
        self.guides.is_empty() || self.alias.is_empty()
    }

    /// Number of guide paths.
    pub fn len(&self) -> usize {
        self.guides.len()
    }

    /// Whether some guide path has this structure (else p_g is 0 without any work).
    pub fn holds(&self, sig: u64) -> bool {
        self.index.contains_key(&sig)
    }

    /// Whether some guide path has `len` vertices (camera included) and ends on emitter
    /// `light`: false rules out every structure of such paths without hashing one.
    pub fn may_hold(&self, len: usize, light: u32) -> bool {
        self.ends.contains(&(len, light))
    }

    /// The structures held, as a test of paths for U's render passes (`HeldPaths`).
    pub fn held(&self) -> HeldStructures {
        let mut low = vec![0u64; 1 << (HeldKey::BITS - 6)];
        for &sig in self.index.keys() {
            let b = (sig & ((1 << HeldKey::BITS) - 1)) as usize;
            low[b / 64] |= 1 << (b % 64);
        }
        HeldStructures {
            ends: self.ends.clone(),
            sigs: self.index.keys().copied().collect(),
            low,
            filter: true,
        }
    }

    /// Number of distinct structures among the guide paths.
    pub fn structures(&self) -> usize {
        self.index.len()
    }

    /// Vertex v (1 .. L-1) of guide `l`; v = 0 is the camera.
    pub fn vertex(&self, scene: &Scene, l: usize, v: usize) -> PathVertex {
        if v == 0 {
            return PathVertex {
                p: scene.camera.position,
                n: Vec3::ZERO,
                ns: Vec3::ZERO,
                uv: glam::Vec2::ZERO,
                tangent: Vec3::ZERO,
                kind: VertexKind::Camera,
            };
        }
        *self.stored_vertex(l, v)
    }

    /// Vertex `v >= 1` of guide `l` as stored (the camera, v = 0, is the scene's).
    #[inline]
    pub fn stored_vertex(&self, l: usize, v: usize) -> &PathVertex {
        &self.vertices[self.guides[l].start as usize + v - 1]
    }

    /// Node of vertex `v >= 1` of guide `l`.
    pub fn node(&self, l: usize, v: usize) -> Node {
        self.nodes[self.guides[l].start as usize + v - 1]
    }

    /// Nodes of vertices 1 .. L-1 of guide `l`: its structure.
    pub fn nodes_of(&self, l: usize) -> &[Node] {
        let g = &self.guides[l];
        &self.nodes[g.start as usize..g.start as usize + g.len as usize - 1]
    }

    /// The conditional kernel of guide `l`'s segment g_{v-1} -> g_v (v >= 2).
    pub fn kernel(&self, l: usize, v: usize) -> &Kernel {
        &self.kernels[self.guides[l].kernels as usize + v - 2]
    }

    /// The frame of the kernel of segment g_{v-1} -> g_v of guide `l` (v >= 2), which
    /// [`segment_frame`] gives from the two vertices.
    pub fn frame(&self, l: usize, v: usize) -> &Frame {
        &self.frames[self.guides[l].kernels as usize + v - 2]
    }

    /// [`Self::kernel`] of guide `l`'s segment g_{v-1} -> g_v precomputed for paths whose
    /// vertices there are both on surfaces.
    pub fn plane(&self, l: usize, v: usize) -> &PlaneKernel {
        &self.planes[self.guides[l].kernels as usize + v - 2]
    }

    /// Bytes a guide path of `len` vertices (camera included) occupies: header, vertices and
    /// nodes of g_1 .. g_{L-1}, kernels of the L - 2 later segments, its first-vertex kernel
    /// in the BVH and its alias entry (the BVH nodes not counted).
    pub fn bytes_for_length(len: usize) -> usize {
        std::mem::size_of::<Guide>()
            + (len - 1) * (std::mem::size_of::<PathVertex>() + std::mem::size_of::<Node>())
            + (len - 2)
                * (std::mem::size_of::<Kernel>()
                    + std::mem::size_of::<Frame>()
                    + std::mem::size_of::<PlaneKernel>())
            + std::mem::size_of::<FirstKernel>()
            + 20
    }

    /// Pick a guide path by weight (alias table); returns it and its probability.
    pub fn select(&self, u1: f64, u2: f64) -> (usize, f64) {
        let l = self.alias.sample(u1, u2);
        (l, self.alias.pmf(l))
    }

    /// Probability that [`Self::select`] picks guide `l`: the one selection pmf, which p_g
    /// uses too (`Guide::weight` is set to it by `install`).
    pub fn selection_pmf(&self, l: usize) -> f64 {
        if self.alias.is_empty() {
            0.0
        } else {
            self.alias.pmf(l)
        }
    }

    /// Bytes held by the cache, per guide path (headers, vertices, nodes, kernels, the BVHs'
    /// first-vertex kernels).
    pub fn bytes_per_path(&self) -> f64 {
        if self.guides.is_empty() {
            return 0.0;
        }
        let bytes = self.guides.len() * std::mem::size_of::<Guide>()
            + self.vertices.len() * std::mem::size_of::<PathVertex>()
            + self.nodes.len() * std::mem::size_of::<Node>()
            + self.kernels.len()
                * (std::mem::size_of::<Kernel>()
                    + std::mem::size_of::<Frame>()
                    + std::mem::size_of::<PlaneKernel>())
            + self.guides.len() * std::mem::size_of::<FirstKernel>()
            + self.alias.len() * 20;
        bytes as f64 / self.guides.len() as f64
    }

    /// The stored vertices of guide `l` as a complete path (camera first).
    pub fn path_vertices(&self, scene: &Scene, l: usize) -> Vec<PathVertex> {
        (0..self.guides[l].len as usize)
            .map(|v| self.vertex(scene, l, v))
            .collect()
    }
}

/// The structures a cache holds (a copy, for U's tracers): a path is held when some guide
/// path has its vertex count and emitter (`GuideCache::may_hold`) and its structure hash is
/// among the cache's (`GuideCache::holds`), the test the collector makes of bdpt's paths.
pub struct HeldStructures {
    ends: Vec<(usize, u32)>,
    sigs: SigSet,
    /// One bit per value of a hash's low `HeldKey::BITS` bits: set where a held structure's
    /// hash has them (`may_hold_hash`).
    low: Vec<u64>,
    /// Whether `may_hold_hash` tests `low` (else it passes every path; tests compare both).
    pub filter: bool,
}

impl crate::integrators::unguided::HeldPaths for HeldStructures {
    fn holds(&self, scene: &Scene, head: &[PathVertex], tail: &[PathVertex]) -> bool {
        let Some(PathVertex {
            kind: VertexKind::Emitter { light, .. },
            ..
        }) = tail.first().or(head.last())
        else {
            return false;
        };
        if !self.ends.contains(&(head.len() + tail.len(), *light)) {
            return false;
        }
        super::kernel::signature_of_split(scene, head, tail, MAX_VERTICES, |v| *v)
            .is_some_and(|sig| self.sigs.contains(&sig))
    }

    #[inline]
    fn may_hold_hash(&self, h: u64) -> bool {
        let b = (h & ((1 << HeldKey::BITS) - 1)) as usize;
        !self.filter || self.low[b / 64] & (1 << (b % 64)) != 0
    }
}
