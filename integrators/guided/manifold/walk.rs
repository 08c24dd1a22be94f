//! The Newton walk of the specular-chain step: a chain of delta vertices traced from `x_a`
//! through a point `x_{a+1}`, its far end measured against a goal (a direction, or a point on a
//! plane) with the derivative with respect to `x_{a+1}`'s tangent coordinates propagated in f64
//! (ray differentials; the shading normal's own derivative), and the walk that moves `x_{a+1}`
//! until the far end meets the goal (`super` says how the step uses it).

use super::Chain;
use crate::geometry::bvh::ShapeGeometry;
use crate::geometry::{Hit, Ray, gamma, offset_origin};
use crate::integrators::guided::kernel::{MIN_PLANE_COS, dvec};
use crate::integrators::guided::sampler::{Failure, trace};
use crate::scene::{Scene, SurfacePoint};
use glam::{DVec3, Vec3};

/// The Newton walk has converged when the far end lies within this of the target: radians for
/// a direction, the distance to the kernel plane times this for a point.
pub const TOLERANCE: f64 = 1e-5;
const MAX_ITERATIONS: usize = 12;
const MAX_HALVINGS: usize = 4;
/// Full Newton steps tried after convergence, kept while they lower the residual.
const POLISH: usize = 1;

/// An orthonormal basis (s, t, n) around unit `n` (Duff et al. 2017), in f64.
pub(super) fn basis(n: DVec3) -> [DVec3; 3] {
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
    /// The chain must leave along a direction.
    Direction {
        /// Orthonormal basis (s, t, n), `n` the target direction.
        frame: [DVec3; 3],
    },
    /// The chain must reach a point on a plane.
    Plane {
        /// Orthonormal basis (s, t, n), `n` the plane's normal.
        frame: [DVec3; 3],
        /// A point of the plane, the origin of `y`.
        g: DVec3,
        /// The target point's coordinates along (s, t), relative to `g`.
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

    /// Where the last ray of a chain (leaving `x` along `w`, with derivatives `dx`, `dw` with
    /// respect to the tangent coordinates of `x_{a+1}`) meets the goal.
    pub(super) fn measure(
        &self,
        x: DVec3,
        dx: [DVec3; 2],
        w: DVec3,
        dw: [DVec3; 2],
    ) -> Option<Measured> {
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
pub(super) struct Measured {
    pub(super) r: [f64; 2],
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
    /// Position of x_a.
    pub p: Vec3,
    /// Geometric normal at x_a (zero in a medium).
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
        let (w, dw) = match (bsdf, chain.transmits(i)) {
            (crate::bsdf::Bsdf::Dielectric { eta }, true) => refract(d, dd, n, dn, *eta as f64)?,
            (_, false) => reflect(d, dd, n, dn),
            _ => return None,
        };
        // The guide's mode also on the geometric side (as the walk's own check).
        let g = dvec(hit.ng);
        let crossed = (d.dot(g) < 0.0) == (w.dot(g) < 0.0);
        if crossed != chain.transmits(i) || !w.is_finite() {
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
    /// The chain's first vertex `x_{a+1}`.
    pub x1: DVec3,
    /// Tangent basis of the coordinates of `x_{a+1}`.
    pub tangent: [DVec3; 2],
    /// The far end's offset from the goal, in the goal's coordinates.
    pub residual: [f64; 2],
    /// Derivative of `residual` in the tangent coordinates of `x_{a+1}`.
    pub jacobian: [[f64; 2]; 2],
    /// `|det ∂T/∂x_{a+1}|`.
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
    /// The surface point `x_{a+1}`.
    pub sp: SurfacePoint<'s>,
    /// The medium the ray from `x_a` reached it through.
    pub medium: Option<u32>,
    /// Unit direction from `x_a` to `x_{a+1}`.
    pub dir: Vec3,
    /// `|det ∂T/∂x_{a+1}|`, the chain's Jacobian determinant.
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
