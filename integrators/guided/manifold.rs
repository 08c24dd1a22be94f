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

use super::gaussian::sample_std_trunc;
use super::kernel::{MIN_PLANE_COS, Node, Reach, dvec};
use super::sampler::{Failure, trace};
use crate::geometry::bvh::ShapeGeometry;
use crate::geometry::{Hit, Ray, gamma, offset_origin};
use crate::integrators::bdpt::Vertex;
use crate::light::Light;
use crate::math::Sampler;
use crate::scene::{Scene, SurfacePoint};
use glam::{DVec3, IVec3, Vec3};

use super::cache::GuideCache;

/// Longest chain of delta vertices the step solves.
pub const MAX_CHAIN: usize = 4;
/// Default probability of the step where a guide's chain allows it (option `manifold`): off,
/// since it does not yet pay at equal time (`docs/results.md`, "The specular-chain step").
pub const DEFAULT_SHARE: f64 = 0.0;
/// The Newton walk has converged when the far end lies within this of the target: radians for
/// a direction, the distance to the kernel plane times this for a point.
pub const TOLERANCE: f64 = 1e-5;
/// The basin indicator holds when the walk's `x_{a+1}` lies within this times the length of
/// the segment `x_a → x_{a+1}` of the path's own.
pub const BASIN: f64 = 1e-3;
/// The walk's seed offsets are rounded to a grid of this times the scene's radius ([`seed`]).
pub const SEED_GRID: f64 = 0.1;
const MAX_ITERATIONS: usize = 12;
const MAX_HALVINGS: usize = 4;
/// Full Newton steps tried after convergence, kept while they lower the residual.
const POLISH: usize = 1;

/// The step's settings (on the cache: p_g and the sampler read them alike).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManifoldSettings {
    /// Probability of the step where the guide's chain allows it; 0 turns it off.
    pub share: f64,
    /// Testing hooks (negative controls), never changed by the renderer: a factor on the
    /// Jacobian determinant (1; 0 leaves it out of the density), and whether the basin
    /// indicator applies.
    pub jacobian: f64,
    pub basin: bool,
}

impl Default for ManifoldSettings {
    fn default() -> Self {
        ManifoldSettings {
            share: DEFAULT_SHARE,
            jacobian: 1.0,
            basin: true,
        }
    }
}

/// What the chain's far end is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Far {
    /// A direction towards a light at infinity (drawn by the light's own sampling).
    Direction { light: u32 },
    /// A point on the plane of the kernel of guide segment `g_{b-1} → g_b`.
    Plane,
}

/// A chain of delta vertices `a+1 .. b-1` of a guide path, between `x_a` and the far end `x_b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chain {
    pub a: usize,
    pub b: usize,
    pub far: Far,
    /// Whether the guide transmits at each chain vertex.
    transmit: [bool; MAX_CHAIN],
}

impl Chain {
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

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The chain of guide `l` after its vertex `a`, if the step solves it (module doc).
pub fn chain_at(scene: &Scene, cache: &GuideCache, l: usize, a: usize) -> Option<Chain> {
    let len = cache.guides[l].len as usize;
    if a == 0 || a + 2 >= len {
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

/// An orthonormal basis (s, t, n) around unit `n` (Duff et al. 2017), in f64.
fn basis(n: DVec3) -> [DVec3; 3] {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    [
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
        n,
    ]
}

/// What the chain's last direction is aimed at: a direction (its basis, `n` the target), or a
/// point `y` on the plane through `g` with basis (s, t, n).
#[derive(Debug, Clone, Copy)]
pub enum Goal {
    Direction {
        frame: [DVec3; 3],
    },
    Plane {
        frame: [DVec3; 3],
        g: DVec3,
        y: [f64; 2],
    },
}

impl Goal {
    /// The direction `w` (towards a light at infinity).
    pub fn direction(w: DVec3) -> Goal {
        Goal::Direction {
            frame: basis(w.normalize()),
        }
    }

    /// The point `y` on the plane through `g` with unit normal `n`.
    pub fn point_on_plane(g: DVec3, n: DVec3, y: [f64; 2]) -> Goal {
        Goal::Plane {
            frame: basis(n.normalize()),
            g,
            y,
        }
    }

    /// The plane of guide `l`'s kernel at `g_b`.
    fn plane(scene: &Scene, cache: &GuideCache, l: usize, b: usize, y: [f64; 2]) -> Goal {
        let f = cache.frame(l, b);
        Goal::Plane {
            frame: [dvec(f.s), dvec(f.t), dvec(f.n)],
            g: dvec(cache.vertex(scene, l, b).p),
            y,
        }
    }

    /// Where the last ray of a chain (leaving `x` along `w`, with derivatives `dx`, `dw` with
    /// respect to the tangent coordinates of `x_{a+1}`) meets the goal.
    fn measure(&self, x: DVec3, dx: [DVec3; 2], w: DVec3, dw: [DVec3; 2]) -> Option<Measured> {
        match *self {
            Goal::Direction { frame: [s, t, n] } => {
                let wn = w.dot(n);
                if !(wn > 0.1) {
                    return None;
                }
                let c = [w.dot(s) / wn, w.dot(t) / wn];
                let dc = |d: DVec3| {
                    let dn = d.dot(n);
                    [
                        (d.dot(s) * wn - w.dot(s) * dn) / (wn * wn),
                        (d.dot(t) * wn - w.dot(t) * dn) / (wn * wn),
                    ]
                };
                let (c0, c1) = (dc(dw[0]), dc(dw[1]));
                // Solid angle per area: dw projected on a basis orthogonal to w.
                let [b1, b2, _] = basis(w);
                let det = (b1.dot(dw[0]) * b2.dot(dw[1]) - b1.dot(dw[1]) * b2.dot(dw[0])).abs();
                Some(Measured {
                    r: c,
                    j: [[c0[0], c1[0]], [c0[1], c1[1]]],
                    det,
                    scale: 1.0,
                })
            }
            Goal::Plane {
                frame: [s, t, n],
                g,
                y,
            } => {
                let nw = n.dot(w);
                if nw.abs() < MIN_PLANE_COS {
                    return None;
                }
                let tp = n.dot(g - x) / nw;
                if !(tp > 0.0) {
                    return None;
                }
                let p = x + w * tp - g;
                let dp = |k: usize| {
                    let m = dx[k] + dw[k] * tp;
                    m - w * (n.dot(m) / nw)
                };
                let (p0, p1) = (dp(0), dp(1));
                let j = [[p0.dot(s), p1.dot(s)], [p0.dot(t), p1.dot(t)]];
                Some(Measured {
                    r: [p.dot(s) - y[0], p.dot(t) - y[1]],
                    j,
                    det: (j[0][0] * j[1][1] - j[0][1] * j[1][0]).abs(),
                    scale: tp,
                })
            }
        }
    }
}

/// A chain traced to its goal: the residual, its 2x2 derivative with respect to `x_{a+1}`'s
/// tangent coordinates, `|det|` of the far end's measure per area at `x_{a+1}` (solid angle or
/// plane area), and the length that scales the convergence test.
#[derive(Debug, Clone, Copy)]
struct Measured {
    r: [f64; 2],
    j: [[f64; 2]; 2],
    det: f64,
    scale: f64,
}

impl Measured {
    fn error(&self) -> f64 {
        (self.r[0] * self.r[0] + self.r[1] * self.r[1]).sqrt() / self.scale
    }
}

/// The derivative of the shading normal at `hit` along the tangent displacements `dx`.
fn normal_derivative(scene: &Scene, hit: &Hit, dx: [DVec3; 2]) -> [DVec3; 2] {
    let ns = dvec(hit.ns);
    match &scene.shapes[hit.shape as usize] {
        ShapeGeometry::Sphere(s) => {
            let sign = if ns.dot(dvec(hit.p - s.center)) < 0.0 {
                -1.0
            } else {
                1.0
            };
            let r = s.radius as f64;
            dx.map(|d| (d - ns * ns.dot(d)) * (sign / r))
        }
        ShapeGeometry::Mesh(m) => {
            let Some(normals) = &m.normals else {
                return [DVec3::ZERO; 2];
            };
            let [ia, ib, ic] = m.indices[hit.prim as usize].map(|i| i as usize);
            let [pa, pb, pc] = [ia, ib, ic].map(|i| dvec(m.positions[i]));
            let [na, nb, nc] = [ia, ib, ic].map(|i| dvec(normals[i]));
            let (b1, b2) = (hit.uv.x as f64, hit.uv.y as f64);
            let big_n = na * (1.0 - b1 - b2) + nb * b1 + nc * b2;
            let len = big_n.length();
            if !(len > 0.0) {
                return [DVec3::ZERO; 2];
            }
            let n = big_n / len;
            let sign = if n.dot(ns) < 0.0 { -1.0 } else { 1.0 };
            let (e1, e2) = (pb - pa, pc - pa);
            let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let det = g11 * g22 - g12 * g12;
            if !(det > 0.0) {
                return [DVec3::ZERO; 2];
            }
            dx.map(|d| {
                let (r1, r2) = (e1.dot(d), e2.dot(d));
                let db1 = (g22 * r1 - g12 * r2) / det;
                let db2 = (g11 * r2 - g12 * r1) / det;
                let dn = (nb - na) * db1 + (nc - na) * db2;
                (dn - n * n.dot(dn)) * (sign / len)
            })
        }
    }
}

/// Reflection of the travelling direction `d` about unit `n`, with derivatives.
fn reflect(d: DVec3, dd: [DVec3; 2], n: DVec3, dn: [DVec3; 2]) -> (DVec3, [DVec3; 2]) {
    let dn_ = d.dot(n);
    let w = d - n * (2.0 * dn_);
    let dw = [0, 1].map(|k| {
        let ddn = dd[k].dot(n) + d.dot(dn[k]);
        dd[k] - (n * ddn + dn[k] * dn_) * 2.0
    });
    (w, dw)
}

/// Refraction of the travelling direction `d` through the interface with unit shading normal
/// `n` (front side) and `eta` = index inside / outside, with derivatives; `None` at total
/// internal reflection. The formula of `bsdf/dielectric.rs`, in f64.
fn refract(
    d: DVec3,
    dd: [DVec3; 2],
    n: DVec3,
    dn: [DVec3; 2],
    eta: f64,
) -> Option<(DVec3, [DVec3; 2])> {
    // The normal on the side d comes from, and the relative index of the side entered.
    let (n, dn, eta) = if -d.dot(n) >= 0.0 {
        (n, dn, eta)
    } else {
        (-n, dn.map(|v| -v), 1.0 / eta)
    };
    let cos_o = (-d.dot(n)).min(1.0);
    let sin2_t = (1.0 - cos_o * cos_o) / (eta * eta);
    if !(sin2_t < 1.0) {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let w = d / eta + n * (cos_o / eta - cos_t);
    let dw = [0, 1].map(|k| {
        let dcos_o = -(dd[k].dot(n) + d.dot(dn[k]));
        let dcos_t = cos_o * dcos_o / (eta * eta * cos_t);
        dd[k] / eta + n * (dcos_o / eta - dcos_t) + dn[k] * (cos_o / eta - cos_t)
    });
    Some((w, dw))
}

/// The vertex the chain starts from: its position and geometric normal (zero in a medium).
#[derive(Debug, Clone, Copy)]
pub struct From {
    pub p: Vec3,
    pub n: Vec3,
    /// The medium a ray from it towards the chain starts in (the sampler's; p_g passes None:
    /// only the geometry matters there).
    pub medium: Option<u32>,
}

impl From {
    /// The ray from this vertex towards `d`, offset from its surface by a bound computed from
    /// the position alone (the same for the sampler's vertex and the path's).
    fn ray(&self, d: Vec3) -> Ray {
        if self.n == Vec3::ZERO {
            Ray::new(self.p, d)
        } else {
            Ray::new(offset_origin(self.p, gamma(8) * self.p.abs(), self.n, d), d)
        }
    }
}

/// The walk's current `x_{a+1}`: the surface point, the medium the ray reached it through,
/// and the direction of that ray.
struct Cast<'s> {
    sp: SurfacePoint<'s>,
    medium: Option<u32>,
    dir: Vec3,
}

/// Trace from `from` towards `p`: the first surface must be a delta one on `shape` (the
/// guide's chain starts on it).
fn cast<'s>(scene: &'s Scene, from: &From, p: DVec3, shape: Option<u32>) -> Option<Cast<'s>> {
    let dir = (p - dvec(from.p)).normalize().as_vec3();
    if !dir.is_finite() || dir == Vec3::ZERO {
        return None;
    }
    let (sp, medium) = trace(scene, from.ray(dir), from.medium);
    let sp = sp?;
    if !sp.bsdf.is_delta() || shape.is_some_and(|s| s != sp.hit.shape) {
        return None;
    }
    Some(Cast { sp, medium, dir })
}

/// Trace the chain from `from` through `first` (the guide's modes at each vertex) and measure
/// its last ray against `goal`; `None` where it leaves the guide's structure.
fn trace_chain(
    scene: &Scene,
    from: &From,
    first: &SurfacePoint,
    chain: &Chain,
    goal: &Goal,
) -> Option<Measured> {
    let o = dvec(from.p);
    let mut x = dvec(first.hit.p);
    let ng = dvec(first.hit.ng);
    let [e1, e2, _] = basis(ng);
    let mut dx = [e1, e2];
    let dist = (x - o).length();
    let mut d = (x - o) / dist;
    let mut dd = dx.map(|e| (e - d * d.dot(e)) / dist);
    let mut hit = first.hit;
    let mut bsdf = first.bsdf;
    for i in 0..chain.len() {
        if !bsdf.is_delta() {
            return None;
        }
        let n = dvec(hit.ns);
        let dn = normal_derivative(scene, &hit, dx);
        let (w, dw) = match (bsdf, chain.transmit[i]) {
            (crate::bsdf::Bsdf::Dielectric { eta }, true) => refract(d, dd, n, dn, *eta as f64)?,
            (_, false) => reflect(d, dd, n, dn),
            _ => return None,
        };
        // The guide's mode also on the geometric side (as the walk's own check).
        let g = dvec(hit.ng);
        let crossed = (d.dot(g) < 0.0) == (w.dot(g) < 0.0);
        if crossed != chain.transmit[i] || !w.is_finite() {
            return None;
        }
        if i + 1 == chain.len() {
            return goal.measure(x, dx, w, dw);
        }
        let (next, _) = trace(scene, hit.spawn_along(w.as_vec3()), None);
        let next = next?;
        let ng2 = dvec(next.hit.ng);
        let x2 = dvec(next.hit.p);
        let wn = w.dot(ng2);
        if wn.abs() < 1e-9 {
            return None;
        }
        let t = (x2 - x).dot(w);
        dx = [0, 1].map(|k| {
            let m = dx[k] + dw[k] * t;
            m - w * (ng2.dot(m) / wn)
        });
        x = x2;
        d = w;
        dd = dw;
        hit = next.hit;
        bsdf = next.bsdf;
    }
    None
}

/// The chain map at the point `x_{a+1}` that the ray from `from` towards `p` hits (for
/// tests): `x_{a+1}`, the tangent basis of its coordinates, the far end's residual against
/// `goal` and its derivative in those coordinates, and `|det ∂T/∂x_{a+1}|`.
pub struct ChainMap {
    pub x1: DVec3,
    pub tangent: [DVec3; 2],
    pub residual: [f64; 2],
    pub jacobian: [[f64; 2]; 2],
    pub det: f64,
}

/// [`ChainMap`] of the chain through the point the ray from `from` towards `p` hits.
pub fn chain_map(
    scene: &Scene,
    from: &From,
    p: DVec3,
    chain: &Chain,
    goal: &Goal,
) -> Option<ChainMap> {
    let c = cast(scene, from, p, None)?;
    let m = trace_chain(scene, from, &c.sp, chain, goal)?;
    let [e1, e2, _] = basis(dvec(c.sp.hit.ng));
    Some(ChainMap {
        x1: dvec(c.sp.hit.p),
        tangent: [e1, e2],
        residual: m.r,
        jacobian: m.j,
        det: m.det,
    })
}

/// The solved `x_{a+1}`: its surface point, the medium the ray reached it through, the
/// direction from `x_a`, and `|det ∂T/∂x_{a+1}|`.
pub struct Solution<'s> {
    pub sp: SurfacePoint<'s>,
    pub medium: Option<u32>,
    pub dir: Vec3,
    pub det: f64,
}

/// The Newton walk from `seed` (the guide's `g_{a+1}`) for the chain from `from` to `goal`
/// (module doc). Fails with [`Failure::NoConvergence`].
pub fn solve<'s>(
    scene: &'s Scene,
    from: &From,
    seed: Vec3,
    chain: &Chain,
    goal: &Goal,
) -> Result<Solution<'s>, Failure> {
    let fail = Err(Failure::NoConvergence);
    let Some(mut cur) = cast(scene, from, dvec(seed), None) else {
        return fail;
    };
    let shape = Some(cur.sp.hit.shape);
    let Some(mut m) = trace_chain(scene, from, &cur.sp, chain, goal) else {
        return fail;
    };
    // Newton steps, halved until the residual falls, up to the tolerance; then up to
    // POLISH full steps more while they still lower it (down to the f32 hit points' noise).
    let mut polish = 0;
    for _ in 0..MAX_ITERATIONS + POLISH {
        let converged = m.error() <= TOLERANCE;
        if converged && polish == POLISH {
            break;
        }
        let Some(step) = newton_step(&m) else {
            break;
        };
        let [e1, e2, _] = basis(dvec(cur.sp.hit.ng));
        let x = dvec(cur.sp.hit.p);
        let mut lambda = 1.0;
        let mut accepted = false;
        for _ in 0..if converged { 1 } else { MAX_HALVINGS } {
            let p = x + (e1 * step[0] + e2 * step[1]) * lambda;
            if let Some(next) = cast(scene, from, p, shape)
                && let Some(mm) = trace_chain(scene, from, &next.sp, chain, goal)
                && mm.error() < m.error()
            {
                cur = next;
                m = mm;
                accepted = true;
                break;
            }
            lambda *= 0.5;
        }
        if converged {
            polish += 1;
            if !accepted {
                break;
            }
        } else if !accepted {
            return fail;
        }
    }
    if m.error() <= TOLERANCE {
        return Ok(Solution {
            sp: cur.sp,
            medium: cur.medium,
            dir: cur.dir,
            det: m.det,
        });
    }
    fail
}

/// The Newton step `-J⁻¹ r` in the tangent coordinates, `None` where J is singular.
fn newton_step(m: &Measured) -> Option<[f64; 2]> {
    let [[a, b], [c, d]] = m.j;
    let det = a * d - b * c;
    if !(det.abs() > 0.0) || !det.is_finite() {
        return None;
    }
    Some([
        -(d * m.r[0] - b * m.r[1]) / det,
        -(a * m.r[1] - c * m.r[0]) / det,
    ])
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

/// The outcomes of the walks one path's p_g evaluation ran, by chain start and seed cell
/// (for a chain ending on the sun the goal is the path's own direction whatever the guide, so
/// guides with one seed share the walk).
/// A walk of [`WalkMemo`]: the chain's start `a`, the seed's cell, and the walk's `x_{a+1}`
/// and determinant where it converged.
type MemoEntry = (usize, IVec3, Option<(DVec3, f64)>);

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
            Some(Goal::plane(scene, cache, l, chain.b, [y[0], y[1]]))
        }
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
            let f = cache.frame(l, b);
            let (s, t, n) = (dvec(f.s), dvec(f.t), dvec(f.n));
            let g = dvec(cache.vertex(scene, l, b).p);
            let x = dvec(y[b - 1].p);
            let w = (dvec(y[b].p) - x).normalize();
            let nw = n.dot(w);
            if nw.abs() < MIN_PLANE_COS {
                return 0.0;
            }
            let tp = n.dot(g - x) / nw;
            if !(tp > 0.0) {
                return 0.0;
            }
            let p = x + w * tp - g;
            let yc = [p.dot(s), p.dot(t)];
            let k = cache.kernel(l, b);
            let q = k.density([yc[0], yc[1], 0.0], k.mean([0.0; 3], 2), 2);
            (Goal::plane(scene, cache, l, b, yc), q)
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
