//! The Gaussian branch density of a guide segment whose path vertices are both on surfaces
//! (the case p_g meets most: every candidate guide of a path evaluates it once per such
//! segment), with everything that depends on the guide alone folded into f64 constants when
//! the cache is built.
//!
//! [`SegmentTarget::log_gaussian_density`](super::kernel::SegmentTarget::log_gaussian_density)
//! computes, for the path's `x = y[v-1]` and unit direction `w` towards `y[v]`, in the frame
//! `(s, t, n)` of guide segment `g_{v-1} -> g_v`: the conditional mean `m = μ1 + K (z − μ2)`
//! of the conditioning coordinates `z = ((x − g_{v-1})·s, (x − g_{v-1})·t)`, the point where
//! the ray `x + t_P w` crosses the plane through `g_v` orthogonal to `n`, its coordinates
//! `y`, and the truncated Gaussian of `y − m` scaled by `t_P² / |n·w|`. With every point taken
//! relative to `g_v` (`x' = x − g_v`), `a = (x'·s, x'·t)`, `q = (w·s, w·t)` and
//! `t_P = −x'·n / (w·n)`:
//!
//! ```text
//!     y − m = (I − K) a + t_P q + b,    b = −μ1 + K (μ2 + ((g_{v-1} − g_v)·s, (g_{v-1} − g_v)·t))
//!     c_i / σ_i = Σ_j (e_ji / σ_i) (y − m)_j
//! ```
//!
//! The same density to rounding (the tests compare the two), at about a third of the
//! instructions: no f32 to f64 conversions, no mean in a third coordinate, one matrix product.

use super::gaussian::{LogDensity, std_trunc_log_density};
use super::kernel::{Kernel, MIN_PLANE_COS, dvec};
use crate::math::Frame;
use glam::{DVec3, Vec3};

/// One guide segment's Gaussian on its target plane, precomputed (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneKernel {
    /// g_v: every point is taken relative to it.
    g: DVec3,
    s: DVec3,
    t: DVec3,
    n: DVec3,
    /// I − K.
    a: [[f64; 2]; 2],
    b: [f64; 2],
    /// Whitening, `e_ji / σ_i`.
    w: [[f64; 2]; 2],
    /// 1 / (σ_0 σ_1).
    inv_norm: f64,
}

impl PlaneKernel {
    /// The segment `g_prev -> g` with frame `f` and kernel `k`.
    pub fn new(f: &Frame, g_prev: Vec3, g: Vec3, k: &Kernel) -> PlaneKernel {
        let (s, t, n) = (dvec(f.s), dvec(f.t), dvec(f.n));
        let g = dvec(g);
        let prev = dvec(g_prev) - g;
        let prev_st = [prev.dot(s), prev.dot(t)];
        let mut a = [[0.0; 2]; 2];
        let mut b = [0.0; 2];
        let mut w = [[0.0; 2]; 2];
        for i in 0..2 {
            b[i] = -(k.mu1[i] as f64);
            for j in 0..2 {
                let kij = k.k[i][j] as f64;
                b[i] += kij * (k.mu2[j] as f64 + prev_st[j]);
                a[i][j] = if i == j { 1.0 - kij } else { -kij };
                w[i][j] = k.e[j][i] as f64 / k.s[i] as f64;
            }
        }
        PlaneKernel {
            g,
            s,
            t,
            n,
            a,
            b,
            w,
            inv_norm: 1.0 / (k.s[0] as f64 * k.s[1] as f64),
        }
    }

    /// Solid-angle density (as a [`LogDensity`]) of leaving surface point `x` along unit
    /// direction `w` through this segment's Gaussian: 0 where the plane is behind `x` or
    /// `|n·w| <` [`MIN_PLANE_COS`], or the crossing lies beyond the truncation.
    #[inline]
    pub fn log_density(&self, x: DVec3, w: DVec3) -> LogDensity {
        let cos = self.n.dot(w);
        if cos.abs() < MIN_PLANE_COS {
            return LogDensity::ZERO;
        }
        let x = x - self.g;
        let t_p = -x.dot(self.n) / cos;
        if !(t_p > 0.0) {
            return LogDensity::ZERO;
        }
        let (xs, xt) = (x.dot(self.s), x.dot(self.t));
        let d0 = self.a[0][0] * xs + self.a[0][1] * xt + t_p * w.dot(self.s) + self.b[0];
        let d1 = self.a[1][0] * xs + self.a[1][1] * xt + t_p * w.dot(self.t) + self.b[1];
        let c0 = self.w[0][0] * d0 + self.w[0][1] * d1;
        let c1 = self.w[1][0] * d0 + self.w[1][1] * d1;
        std_trunc_log_density(2, c0 * c0 + c1 * c1).scaled(self.inv_norm * t_p * t_p / cos.abs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::guided::kernel::{SegmentTarget, segment_frame};
    use crate::math::{IndependentSampler, Sampler};
    use crate::path::{Vertex as PathVertex, VertexKind};

    fn point(p: Vec3) -> PathVertex {
        PathVertex {
            p,
            n: Vec3::Y,
            ns: Vec3::Y,
            uv: glam::Vec2::ZERO,
            tangent: Vec3::ZERO,
            kind: VertexKind::Surface {
                material: 0,
                shape: 0,
                delta: false,
            },
        }
    }

    fn uniform(rng: &mut IndependentSampler, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * rng.next_1d()
    }

    fn v3(rng: &mut IndependentSampler, r: f32) -> Vec3 {
        Vec3::new(
            uniform(rng, -r, r),
            uniform(rng, -r, r),
            uniform(rng, -r, r),
        )
    }

    /// The precomputed form gives the generic evaluation's density (relative 1e-9) on random
    /// kernels, frames and paths, and is zero exactly where that is (truncation, plane behind,
    /// grazing directions).
    #[test]
    fn plane_kernel_matches_the_generic_gaussian() {
        let rng = &mut IndependentSampler::from_u64(7);
        let (mut nonzero, mut zero) = (0, 0);
        for _ in 0..20000 {
            let offset = v3(rng, 50.0);
            let g_prev = offset + v3(rng, 1.0);
            let g = offset + v3(rng, 2.0);
            let frame = segment_frame(&point(g_prev), &point(g), false);
            let (sin, cos) = uniform(rng, 0.0, std::f32::consts::TAU).sin_cos();
            let sigma = uniform(rng, 0.01, 0.3);
            let mut u = |r: f32| uniform(rng, -r, r);
            let k = Kernel {
                mu1: [u(0.05), u(0.05), 0.0],
                mu2: [u(0.05), u(0.05), 0.0],
                k: [
                    [u(1.0), u(1.0), 0.3],
                    [u(1.0), u(1.0), -0.2],
                    [0.5, 0.5, 0.5],
                ],
                e: [[cos, -sin, 0.0], [sin, cos, 0.0], [0.0, 0.0, 1.0]],
                s: [sigma, sigma * (0.6 + u(0.4)), 1.0],
                sigma_dist: 0.1,
            };
            let plane = PlaneKernel::new(&frame, g_prev, g, &k);
            let x = g_prev + v3(rng, 0.2);
            let next = g + v3(rng, 0.5);
            let target = SegmentTarget::surface_pair(x, next, v3(rng, 1.0).normalize());
            let generic = target
                .log_gaussian_density(&frame, &point(g_prev), &point(g), &k)
                .value();
            let (x64, w, area) = target.surface_to_surface().unwrap();
            let fast = plane.log_density(x64, w).scaled(area).value();
            if generic == 0.0 {
                zero += 1;
                assert_eq!(fast, 0.0, "generic 0, plane {fast}");
            } else {
                nonzero += 1;
                let rel = (fast - generic).abs() / generic;
                assert!(rel < 1e-9, "generic {generic}, plane {fast}, rel {rel:e}");
            }
        }
        assert!(
            nonzero > 2000 && zero > 2000,
            "{nonzero} non-zero, {zero} zero"
        );
    }
}
