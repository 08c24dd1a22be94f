//! The scalar helpers pt calls at a vertex, over sixteen lanes: each is its scalar twin's
//! arithmetic operation for operation (named in its doc), with `select` where the twin
//! branches, so a lane's result is the twin's bit for bit (test
//! `wavefront_pt_is_pt_bit_for_bit` in `tests/pt_batch.rs`).

use super::lanes::{F, M, V3};
use crate::geometry::SHADOW_EPS;
use crate::math::warp::sin_cos_quarter;
use crate::math::{INV_PI, PI};

/// [`crate::math::Frame`] per lane: (s, t, n).
#[derive(Clone, Copy)]
pub struct Frame {
    pub s: V3,
    pub t: V3,
    pub n: V3,
}

impl Frame {
    /// `Frame::from_z` (Duff et al. 2017).
    #[inline(always)]
    pub fn from_z(n: V3) -> Frame {
        let sign = F::one().copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = V3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = V3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    #[inline(always)]
    pub fn to_local(self, v: V3) -> V3 {
        V3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline(always)]
    pub fn to_world(self, v: V3) -> V3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// `math::power_heuristic`.
#[inline(always)]
pub fn power_heuristic(a: F, b: F) -> F {
    let (a2, b2) = (a * a, b * b);
    let w = F::select(a2.is_finite(), a2 / (a2 + b2), F::one());
    F::select(a2.eq(F::zero()), F::zero(), w)
}

/// `geometry::offset_origin`: `p` moved off its surface to the side `w` points to.
#[inline(always)]
pub fn offset_origin(p: V3, p_err: V3, n: V3, w: V3) -> V3 {
    let d = n.abs().dot(p_err) * 2.0 + f32::MIN_POSITIVE;
    let offset = V3::select(w.dot(n).lt(F::zero()), n * -d, n * d);
    let q = p + offset;
    V3::new(
        F::next_away(q.x, offset.x),
        F::next_away(q.y, offset.y),
        F::next_away(q.z, offset.z),
    )
}

/// `bvh::shadow_segment` between two surface points: (origin, unit direction, length).
#[inline(always)]
pub fn shadow_segment(p0: V3, err0: V3, n0: V3, p1: V3, err1: V3, n1: V3) -> (V3, V3, F) {
    let o = offset_origin(p0, err0, n0, p1 - p0);
    let target = V3::select(n1.is_zero(), p1, offset_origin(p1, err1, n1, o - p1));
    let v = target - o;
    let len = v.length();
    (o, v / len, len * (1.0 - SHADOW_EPS))
}

/// `bsdf::fresnel::dielectric`: (reflectance, cos of the refracted direction, relative eta).
#[inline(always)]
pub fn fresnel_dielectric(cos_i: F, eta: F) -> (F, F, F) {
    let inside = cos_i.lt(F::zero());
    let (cos_i, eta) = (
        F::select(inside, -cos_i, cos_i),
        F::select(inside, 1.0 / eta, eta),
    );
    let cos_i = cos_i.min(F::one());
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    let total = sin2_t.ge(F::one());
    let cos_t = (1.0 - sin2_t).max(F::zero()).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let f = 0.5 * (rs * rs + rp * rp);
    (
        F::select(total, F::one(), f),
        F::select(total, F::zero(), cos_t),
        eta,
    )
}

/// `warp::square_to_cosine_hemisphere` (through `square_to_disk_concentric`) and its density
/// `warp::cosine_hemisphere_pdf` of the sampled z.
#[inline(always)]
pub fn cosine_hemisphere(ux: F, uy: F) -> (V3, F) {
    let (ox, oy) = (2.0 * ux - 1.0, 2.0 * uy - 1.0);
    let centre = ox.eq(F::zero()) & oy.eq(F::zero());
    let x_major = ox.abs().gt(oy.abs());
    let angle = F::select(x_major, (PI / 4.0) * (oy / ox), (PI / 4.0) * (ox / oy));
    let (sin, cos) = sin_cos_quarter(angle);
    let (r, a, b) = (
        F::select(x_major, ox, oy),
        F::select(x_major, cos, sin),
        F::select(x_major, sin, cos),
    );
    let dx = F::select(centre, F::zero(), r * a);
    let dy = F::select(centre, F::zero(), r * b);
    let one_minus_r = 2.0 * ux.min(1.0 - ux).min(uy).min(1.0 - uy).max(F::zero());
    let z = (one_minus_r * (2.0 - one_minus_r)).max(F::zero()).sqrt();
    let pdf = F::select(z.gt(F::zero()), z * INV_PI, F::zero());
    (V3::new(dx, dy, z), pdf)
}

/// `warp::sin_cos_turn`: `(sin 2 pi u, cos 2 pi u)`, the quadrant `q as i32 & 3` taken as `q`
/// mod 4 in f32 (exact for every integer `q` below 2^31), 3 where the conversion saturates
/// (`q` >= 2^31, infinity) and 0 for NaN as it does.
#[inline(always)]
pub fn sin_cos_turn(u: F) -> (F, F) {
    let q = (4.0 * u + 0.5).floor();
    let (s, c) = sin_cos_quarter((2.0 * PI) * (u - 0.25 * q));
    let r = q - 4.0 * (q * 0.25).floor();
    let saturated = q.ge(F::splat(2_147_483_648.0));
    let (one, two) = (r.eq(F::one()), r.eq(F::splat(2.0)));
    let three = r.eq(F::splat(3.0)) | saturated;
    let sin = F::select(one, c, F::select(two, -s, F::select(three, -c, s)));
    let cos = F::select(one, -s, F::select(two, -c, F::select(three, s, c)));
    (sin, cos)
}

/// `geometry::Sphere::intersect` of the sphere (`center`, `radius`) along `d` from `o`, with
/// no far limit: the nearest positive distance, infinite on a miss.
#[inline(always)]
pub fn sphere_intersect(center: V3, radius: F, o: V3, d: V3) -> F {
    let f = o - center;
    let b = -f.dot(d);
    let r2 = radius * radius;
    let l = f + d * b;
    let disc = r2 - l.length_squared();
    let c = f.length_squared() - r2;
    let q = b + b.signum() * disc.sqrt();
    let q_zero = q.eq(F::zero());
    let (t0, t1) = (
        F::select(q_zero, F::zero(), c / q),
        F::select(q_zero, F::zero(), q),
    );
    let ordered = t0.le(t1);
    let (t0, t1) = (F::select(ordered, t0, t1), F::select(ordered, t1, t0));
    let inf = F::splat(f32::INFINITY);
    let t = F::select(
        t0.gt(F::zero()) & t0.lt(inf),
        t0,
        F::select(t1.gt(F::zero()) & t1.lt(inf), t1, inf),
    );
    F::select(disc.lt(F::zero()), inf, t)
}

/// `light::area::sphere_sample_li` from a point `p` outside the sphere (`center`, `radius`)
/// with the numbers (`ux`, `uy`): a direction uniform in the cone the sphere subtends, the
/// point it sees (the tangent point on a miss), its normal, and the direction's density.
#[inline(always)]
pub fn sphere_sample_li(center: V3, radius: F, p: V3, ux: F, uy: F) -> (V3, V3, F) {
    let dc2 = (center - p).length_squared();
    // `cone_of`: 1 - cos and cos of the cone's half-angle.
    let sin2 = (radius * radius / dc2).min(F::one());
    let cos_max = (1.0 - sin2).max(F::zero()).sqrt();
    let one_minus_cos = sin2 / (1.0 + cos_max);
    let dc = dc2.sqrt();
    let axis = (center - p) / dc;
    // `cone::sample_uniform_cone`.
    let z = ux * one_minus_cos;
    let sin_theta = (z * (2.0 - z)).max(F::zero()).sqrt();
    let (sin, cos) = sin_cos_turn(uy);
    let local = V3::new(sin_theta * cos, sin_theta * sin, 1.0 - z);
    let wi = Frame::from_z(axis).to_world(local);
    let t = sphere_intersect(center, radius, p, wi);
    let t = F::select(t.is_finite(), t, dc * cos_max);
    let v = p + wi * t - center;
    // glam's `normalize`: times the reciprocal of the length.
    let n = v * (1.0 / v.length());
    (center + n * radius, n, 1.0 / ((2.0 * PI) * one_minus_cos))
}

/// `bsdf::geometry_agrees`: `wo` and `wi` on the sides of the geometric normal that the
/// lobe (`transmission` or not) needs.
#[inline(always)]
pub fn geometry_agrees(ng: V3, wo: V3, wi: V3, transmission: M) -> M {
    let (a, b) = (wo.dot(ng), wi.dot(ng));
    let crossed = (a * b).lt(F::zero());
    !(a.eq(F::zero()) | b.eq(F::zero())) & !(crossed ^ transmission)
}
