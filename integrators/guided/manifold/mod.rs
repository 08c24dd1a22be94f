//! The specular-chain step of the guided sampler: a manifold walk seeded by the guide path.
//!
//! Where a guide path has a chain of 1 to [`MAX_CHAIN`] delta vertices (smooth mirrors or
//! dielectrics) after a non-delta vertex `x_a` (a ≥ 1: a rough surface or a medium point) and
//! before its next non-delta vertex or emitter `x_b`, the Gaussian step that draws `x_{a+1}`
//! from `x_a` rarely makes the deterministic chain reach `x_b`'s small target (on `pool`, the
//! refraction at the water's surface misses the sun's cone in most walks). This step instead
//! draws the chain's **far end** first and solves for the chain:
//!
//! - the far end is a direction drawn by the sun's own sampling (uniform in its cone;
//!   `Light::sample_li`), or a point on the plane of
//!   the guide segment's kernel at `g_b` (orthogonal to the segment `g_{b-1} → g_b`, the
//!   kernel's Gaussian conditioned on the guide's own `g_{b-1}`) for an area light or the next
//!   rough surface: the chain's last ray must pass through it;
//! - a Newton walk moves `x_{a+1}` on its surface until the chain traced from `x_a` through it
//!   (reflecting or refracting at each vertex as the guide does, about the shading normal) ends
//!   at the far end. It starts from the guide's own `g_{a+1}` carried along by `x_a − g_a`
//!   (the point the ray from `x_a` towards it hits; [`seed`]), steps in the tangent plane of the current `x_{a+1}` by the inverse of the
//!   chain's 2x2 derivative, re-projects by tracing from `x_a`, and halves a step that does not
//!   lower the residual. The derivative is propagated along the traced chain in f64 (ray
//!   differentials: the transfer to each next tangent plane, the reflection or refraction with
//!   the shading normal's own derivative — constant barycentric interpolation on meshes and
//!   heightfields, `1/r` on spheres, 0 on flat-shaded triangles).
//!
//! **Density.** `x_{a+1}` then has the area density `q_far(T(x_{a+1})) |det ∂T/∂x_{a+1}|`,
//! `T` the map from `x_{a+1}` to the far end (the generalised geometry term of the chain, as in
//! manifold next event estimation), **times the basin indicator**: the Newton walk from the
//! same seed towards `T(x_{a+1})` must return `x_{a+1}` (within [`BASIN`] of the segment's
//! length); where it converges elsewhere the path is not one this step produces and its
//! density here is 0. [`density`] evaluates exactly that from a path's vertices (it runs the
//! walk), for p_g and for the sampler's own density alike, so the estimator stays unbiased.
//! The determinant is taken at the walk's converged point, which lies within the Newton
//! tolerance ([`TOLERANCE`], far below a pixel) of the path's vertex. The vertices of the chain
//! after `x_{a+1}` follow deterministically and keep the delta factors they have in every other
//! technique (DESIGN.md §3).
//!
//! **Mixture.** Where the guide has such a chain at `x_a`, vertex `x_{a+1}` is drawn by this
//! step with probability `share` (option `manifold`, default [`DEFAULT_SHARE`], i.e. off; e.g.
//! `-O manifold=0.5`) and by the vertex's usual mixture (BSDF branch and conditional
//! Gaussian) otherwise; its density is
//! `share q_chain + (1 − share) q_usual`, in the sampler and in p_g. Everywhere else the walk is
//! unchanged. A path the step drew whose own walk does not return it fails (`otherchain`):
//! the step's density there is 0, and the usual branch's alone must not weigh it.
//!
//! **Cost.** A walk takes about ten casts; p_g runs it for the candidate guides of a path
//! whose structure has such a chain, once per seed cell ([`WalkMemo`]), and a guided sample
//! the step drew reads its basin check from that walk. On `pool` the step lowers the guided
//! samples' failures (86 % to 52-73 %) and a pass's error a little, but costs more than it
//! saves at equal time (`docs/results.md`, "The specular-chain step"), so it is off by default.
//!
//! **What it does not cover.** Chains that start at the camera (x_1 delta: the first-vertex
//! kernel decides the pixel and keeps drawing x_1), chains that end in a medium point (the
//! distance along the last ray is free, so the far end is not a 2D target), chains that end on
//! an environment (the usual step reaches a light that fills the sky; the walk would only add
//! its cost to every p_g evaluation of the many paths that see the sky), chains that end on
//! a delta light (a point or directional light cannot be reached through a specular chain by
//! any technique), and chains longer than [`MAX_CHAIN`]. There the usual mixture draws the
//! vertex alone.

pub mod settings;
mod walk;

pub use settings::{DEFAULT_SHARE, ManifoldSettings};
pub use walk::{ChainMap, From, Goal, Solution, TOLERANCE, chain_map, solve};

use super::cache::GuideCache;
use super::gaussian::sample_std_trunc;
use super::kernel::{Node, Reach, dvec};
use super::stats::Failure;
use crate::integrators::paths::Vertex;
use crate::light::Light;
use crate::math::Sampler;
use crate::scene::Scene;
use glam::{DVec3, IVec3, Vec3};

/// Longest chain of delta vertices the step solves.
pub const MAX_CHAIN: usize = 4;
/// The basin indicator holds when the walk's `x_{a+1}` lies within this times the length of
/// the segment `x_a → x_{a+1}` of the path's own.
pub const BASIN: f64 = 1e-3;
/// The walk's seed offsets are rounded to a grid of this times the scene's radius ([`seed`]).
pub const SEED_GRID: f64 = 0.1;

/// What the chain's far end is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Far {
    /// A direction towards a light at infinity (drawn by the light's own sampling).
    Direction {
        /// Index into `Scene::lights`.
        light: u32,
    },
    /// A point on the plane of the kernel of guide segment `g_{b-1} → g_b`.
    Plane,
}

/// A chain of delta vertices `a+1 .. b-1` of a guide path, between `x_a` and the far end `x_b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chain {
    /// Index of the rough vertex x_a the chain starts after.
    pub a: usize,
    /// Index of the far end x_b (the sun's direction, or a rough vertex).
    pub b: usize,
    /// What the far end is.
    pub far: Far,
    /// Whether the guide transmits at each chain vertex.
    transmit: [bool; MAX_CHAIN],
}

impl Chain {
    /// Whether the guide transmits at the chain's `i`-th vertex.
    pub fn transmits(&self, i: usize) -> bool {
        self.transmit[i]
    }

    /// The chain of delta vertices `a+1 .. b-1` that transmit where `transmit` says (one flag
    /// per vertex), ending at `far`.
    pub fn new(a: usize, b: usize, far: Far, transmit: &[bool]) -> Chain {
        assert!(a >= 1 && b > a + 1 && b - a - 1 <= MAX_CHAIN && transmit.len() == b - a - 1);
        let mut t = [false; MAX_CHAIN];
        t[..transmit.len()].copy_from_slice(transmit);
        Chain {
            a,
            b,
            far,
            transmit: t,
        }
    }

    /// Number of delta vertices.
    pub fn len(&self) -> usize {
        self.b - self.a - 1
    }

    /// Whether the chain has no delta vertex.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The chain of guide `l` after its vertex `a`, if the step solves it (module doc).
pub fn chain_at(scene: &Scene, cache: &GuideCache, l: usize, a: usize) -> Option<Chain> {
    let len = cache.guides[l].len as usize;
    // The Newton walk follows the geometry's normals, not a normal map's.
    if a == 0 || a + 2 >= len || scene.features.normal_maps {
        return None;
    }
    match cache.node(l, a) {
        Node::Surface { delta: false, .. } | Node::Medium { .. } => {}
        _ => return None,
    }
    let mut transmit = [false; MAX_CHAIN];
    let mut b = a + 1;
    while b < len {
        match cache.node(l, b) {
            Node::Surface {
                delta: true,
                transmit: t,
            } => {
                if b - a > MAX_CHAIN {
                    return None;
                }
                transmit[b - a - 1] = t;
                b += 1;
            }
            _ => break,
        }
    }
    if b == a + 1 || b >= len {
        return None;
    }
    let far = match cache.node(l, b) {
        Node::Surface { delta: false, .. } => Far::Plane,
        Node::Emitter {
            reach: Reach::Area, ..
        } => Far::Plane,
        Node::Emitter {
            light,
            reach: Reach::Infinite,
        } if matches!(scene.lights[light as usize], Light::Sun(_)) => Far::Direction { light },
        _ => return None,
    };
    Some(Chain {
        a,
        b,
        far,
        transmit,
    })
}

/// The goal `y` on the plane of guide `l`'s kernel at `g_b`.
fn kernel_plane(scene: &Scene, cache: &GuideCache, l: usize, b: usize, y: [f64; 2]) -> Goal {
    let f = cache.frame(l, b);
    Goal::Plane {
        frame: [dvec(f.s), dvec(f.t), dvec(f.n)],
        g: dvec(cache.vertex(scene, l, b).p),
        y,
    }
}

/// Where the Newton walk for guide `l`'s chain after `x_a` starts: `x_a` plus the guide's own
/// offset `g_{a+1} − g_a` rounded to a grid of [`SEED_GRID`] times the scene's radius (the
/// guide's chain carried along with the path's vertex; the walk casts from `x_a` towards it
/// onto the chain's first surface). Neighbouring guides round to the same seed, so p_g walks
/// once for all of them ([`WalkMemo`]).
pub fn seed(scene: &Scene, cache: &GuideCache, l: usize, a: usize, x_a: Vec3) -> Vec3 {
    let (cell, h) = seed_cell(scene, cache, l, a);
    (dvec(x_a) + cell.as_dvec3() * h).as_vec3()
}

/// The grid cell of guide `l`'s offset `g_{a+1} − g_a`, and the grid's spacing.
fn seed_cell(scene: &Scene, cache: &GuideCache, l: usize, a: usize) -> (IVec3, f64) {
    let h = SEED_GRID * scene.radius as f64;
    let off = dvec(cache.vertex(scene, l, a + 1).p) - dvec(cache.vertex(scene, l, a).p);
    ((off / h).round().as_ivec3(), h)
}

/// A walk of [`WalkMemo`]: the chain's start `a`, the seed's cell, and the walk's `x_{a+1}`
/// and determinant where it converged.
type MemoEntry = (usize, IVec3, Option<(DVec3, f64)>);

/// The outcomes of the walks one path's p_g evaluation ran, by chain start and seed cell
/// (for a chain ending on the sun the goal is the path's own direction whatever the guide, so
/// guides with one seed share the walk).
#[derive(Default)]
pub struct WalkMemo {
    entries: [Option<MemoEntry>; WalkMemo::SIZE],
    len: usize,
}

impl WalkMemo {
    const SIZE: usize = 8;

    fn get(&self, a: usize, cell: IVec3) -> Option<Option<(DVec3, f64)>> {
        self.entries[..self.len]
            .iter()
            .flatten()
            .find(|e| e.0 == a && e.1 == cell)
            .map(|e| e.2)
    }

    fn put(&mut self, a: usize, cell: IVec3, walk: Option<(DVec3, f64)>) {
        if self.len < Self::SIZE {
            self.entries[self.len] = Some((a, cell, walk));
            self.len += 1;
        }
    }
}

/// Draw the chain's far end for guide `l` from `x_a` at `from`: the goal and its density
/// (solid angle or plane area); `None` where the light draws nothing.
pub fn draw_goal(
    scene: &Scene,
    cache: &GuideCache,
    l: usize,
    chain: &Chain,
    from: Vec3,
    sampler: &mut impl Sampler,
) -> Option<Goal> {
    match chain.far {
        Far::Direction { light } => {
            let ls = scene.lights[light as usize].sample_li(from, sampler.next_2d())?;
            (ls.pdf > 0.0).then(|| Goal::direction(dvec(ls.wi)))
        }
        Far::Plane => {
            let k = cache.kernel(l, chain.b);
            let m = k.mean([0.0; 3], 2);
            let z = sample_std_trunc(2, sampler);
            let y = k.warp(z, m, 2);
            Some(kernel_plane(scene, cache, l, chain.b, [y[0], y[1]]))
        }
    }
}

/// The chains of its guide that a guided walk met and the step could solve: per chain, the
/// density of its `x_{a+1}` under the vertex's usual mixture, and whether the step drew it.
/// The chain step's factors are completed from the finished path.
#[derive(Debug, Clone, Default)]
pub struct DrawnChains(Vec<(Chain, f64, bool)>);

impl DrawnChains {
    /// Note a chain met, with the density `usual` of its `x_{a+1}` under the usual mixture and
    /// whether the step drew it.
    pub fn push(&mut self, chain: Chain, usual: f64, drawn: bool) {
        self.0.push((chain, usual, drawn));
    }

    /// Whether no chain was met.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Whether the step drew some vertex.
    pub fn used_step(&self) -> bool {
        self.0.iter().any(|d| d.2)
    }

    /// A path the step drew is one it produces only where the walk from the path's own far
    /// end returns it (the basin indicator): elsewhere its density is 0 and the sample must fail
    /// ([`Failure::OtherChain`]), or the usual branch's density alone would weigh it. `y` is the
    /// path's vertices, `memo` the walks p_g's evaluation of it ran (or empty).
    pub fn check(
        &self,
        scene: &Scene,
        cache: &GuideCache,
        l: usize,
        y: &[Vertex],
        memo: &WalkMemo,
    ) -> Result<(), Failure> {
        for (chain, _, drawn) in &self.0 {
            if *drawn && !returns_own_chain(scene, cache, l, y, chain, memo) {
                return Err(Failure::OtherChain);
            }
        }
        Ok(())
    }

    /// The product over the chains of `share q_chain + (1 − share) q_usual`, q_chain from the
    /// path's vertices `y` ([`density`]).
    pub fn density(&self, scene: &Scene, cache: &GuideCache, l: usize, y: &[Vertex]) -> f64 {
        let share = cache.manifold.share;
        self.0
            .iter()
            .map(|(chain, usual, _)| {
                share * density(scene, cache, l, y, chain, &cache.manifold) + (1.0 - share) * usual
            })
            .product()
    }
}

/// Whether the walk for guide `l`'s chain towards the path `y`'s own far end returns `y`'s
/// `x_{a+1}` (the basin indicator of a path the step drew): read from `memo` where p_g's
/// evaluation already walked from the same seed, else walked here.
pub fn returns_own_chain(
    scene: &Scene,
    cache: &GuideCache,
    l: usize,
    y: &[Vertex],
    chain: &Chain,
    memo: &WalkMemo,
) -> bool {
    let shared = matches!(chain.far, Far::Direction { .. });
    let (cell, _) = seed_cell(scene, cache, l, chain.a);
    match shared.then(|| memo.get(chain.a, cell)).flatten() {
        Some(walk) => walk.is_some_and(|(x, _)| in_basin(y, chain.a, x)),
        None => density(scene, cache, l, y, chain, &cache.manifold) > 0.0,
    }
}

/// Whether the walk's `x` is the path `y`'s `x_{a+1}` (within [`BASIN`] of its segment).
fn in_basin(y: &[Vertex], a: usize, x: DVec3) -> bool {
    let own = dvec(y[a + 1].p);
    let reach = (own - dvec(y[a].p)).length();
    (x - own).length() <= BASIN * reach
}

/// The step's density of the path `y`'s vertex `x_{a+1}` given `x_a` along guide `l` (area
/// measure; module doc): the far end's density times the chain's `|det ∂T/∂x_{a+1}|`, where
/// the Newton walk towards `y`'s far end returns `y`'s `x_{a+1}`, else 0.
pub fn density(
    scene: &Scene,
    cache: &GuideCache,
    l: usize,
    y: &[Vertex],
    chain: &Chain,
    settings: &ManifoldSettings,
) -> f64 {
    density_with(
        scene,
        cache,
        l,
        y,
        chain,
        settings,
        &mut WalkMemo::default(),
    )
}

/// [`density`], reusing the walks of `memo` (which must hold only walks of the path `y`).
pub fn density_with(
    scene: &Scene,
    cache: &GuideCache,
    l: usize,
    y: &[Vertex],
    chain: &Chain,
    settings: &ManifoldSettings,
    memo: &mut WalkMemo,
) -> f64 {
    let (a, b) = (chain.a, chain.b);
    let (goal, q_far) = match chain.far {
        Far::Direction { light } => {
            let w = y[b].n;
            let lt = &scene.lights[light as usize];
            let q = lt.pdf_li(y[a].p, y[b].p, y[b].n, w) as f64;
            (Goal::direction(dvec(w)), q)
        }
        Far::Plane => {
            // Where the path's last segment meets the kernel's plane, in its coordinates.
            let x = dvec(y[b - 1].p);
            let w = (dvec(y[b].p) - x).normalize();
            let plane = kernel_plane(scene, cache, l, b, [0.0; 2]);
            let Some(m) = plane.measure(x, [DVec3::ZERO; 2], w, [DVec3::ZERO; 2]) else {
                return 0.0;
            };
            let k = cache.kernel(l, b);
            let q = k.density([m.r[0], m.r[1], 0.0], k.mean([0.0; 3], 2), 2);
            (kernel_plane(scene, cache, l, b, m.r), q)
        }
    };
    if !(q_far > 0.0) {
        return 0.0;
    }
    let (cell, h) = seed_cell(scene, cache, l, a);
    // Walks towards the sun share the path's goal; a plane goal is the guide's own.
    let shared = matches!(chain.far, Far::Direction { .. });
    let walk = match shared.then(|| memo.get(a, cell)).flatten() {
        Some(walk) => walk,
        None => {
            let from = From {
                p: y[a].p,
                n: y[a].n,
                medium: None,
            };
            let seed = (dvec(y[a].p) + cell.as_dvec3() * h).as_vec3();
            let walk = solve(scene, &from, seed, chain, &goal)
                .ok()
                .map(|sol| (dvec(sol.sp.hit.p), sol.det));
            if shared {
                memo.put(a, cell, walk);
            }
            walk
        }
    };
    let Some((x, det)) = walk else {
        return 0.0;
    };
    if settings.basin && !in_basin(y, a, x) {
        return 0.0;
    }
    if settings.jacobian == 0.0 {
        q_far
    } else {
        q_far * det * settings.jacobian
    }
}
