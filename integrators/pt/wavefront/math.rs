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

/// `bsdf::geometry_agrees`: `wo` and `wi` on the sides of the geometric normal that the
/// lobe (`transmission` or not) needs.
#[inline(always)]
pub fn geometry_agrees(ng: V3, wo: V3, wi: V3, transmission: M) -> M {
    let (a, b) = (wo.dot(ng), wi.dot(ng));
    let crossed = (a * b).lt(F::zero());
    !(a.eq(F::zero()) | b.eq(F::zero())) & !(crossed ^ transmission)
}
