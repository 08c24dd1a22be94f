//! Sixteen rays at a time through the flat list: [`Flat::closest_many`] and
//! [`Flat::unoccluded_many`], one AVX-512 register per ray component, each triangle broadcast
//! to all sixteen lanes.
//!
//! A flat scene has no hierarchy to traverse: every ray tests every triangle, so sixteen rays,
//! however incoherent, need no more triangle tests together than one by one, and the test runs
//! once per triangle for all of them instead of once per group of eight for each. Per lane the
//! arithmetic is [`super::avx`]'s (the Möller-Trumbore of [`super::super::bvh`]'s scalar test,
//! operation for operation, no fused multiply-add), and the triangles are taken in the list's
//! order with a strictly closer hit replacing the one before, so each ray's closest triangle,
//! its `t` and its barycentrics are those [`Flat::closest`] reports, bit for bit. The spheres
//! follow, as there, each in all lanes with [`crate::geometry::Sphere::intersect`]'s
//! operations. Where the CPU has AVX but not AVX-512 a packet is tested as two halves of
//! eight in AVX registers ([`super::packet_avx`], the same bits); without AVX
//! ([`Flat::has_packets`]) rays are tested one by one.

use super::lanes::{PACKET, Packet, PacketRay, PacketSphere};
use super::{Flat, Isa};
use crate::geometry::prim::Prim;
use glam::Vec2;

impl Flat {
    /// Whether [`Self::closest_many`] and [`Self::unoccluded_many`] run packets here (the CPU
    /// has AVX: in AVX-512 registers where it has those, else as two halves in AVX ones).
    pub fn has_packets(&self) -> bool {
        self.isa >= Isa::Avx
    }

    /// [`Flat::closest`] for each of `n` rays (`ray(i)` gives the `i`-th), reported as
    /// `hit(i, closest)` in increasing `i`.
    pub fn closest_many(
        &self,
        prims: &[Prim],
        n: usize,
        ray: impl Fn(usize) -> PacketRay,
        mut hit: impl FnMut(usize, Option<(usize, f32, Vec2)>),
    ) {
        if !self.has_packets() {
            for i in 0..n {
                let (o, d, t_max) = ray(i);
                hit(i, self.closest(prims, o, d, t_max));
            }
            return;
        }
        for start in (0..n).step_by(PACKET) {
            let len = PACKET.min(n - start);
            let packet = Packet::new(len, |k| ray(start + k));
            #[cfg(target_arch = "x86_64")]
            let best = match self.isa {
                // SAFETY: `isa` names only features the running CPU reports.
                Isa::Avx512 => unsafe { avx512::closest(self, &packet) },
                _ => {
                    // SAFETY: as above; `has_packets` means AVX at least.
                    let half = |h| unsafe { super::packet_avx::closest(self, &packet, h) };
                    let miss = [(u32::MAX, 0.0, 0.0, 0.0); 8];
                    let (lo, hi) = (half(0), if len > 8 { half(1) } else { miss });
                    std::array::from_fn(|k| if k < 8 { lo[k] } else { hi[k - 8] })
                }
            };
            #[cfg(not(target_arch = "x86_64"))]
            let best: [(u32, f32, f32, f32); PACKET] = unreachable!("{}", packet.t_max.len());
            for (k, &(prim, t, u, v)) in best[..len].iter().enumerate() {
                hit(
                    start + k,
                    (prim != u32::MAX).then(|| (prim as usize, t, Vec2::new(u, v))),
                );
            }
        }
    }

    /// [`Flat::unoccluded`] for each of `n` segments (`segment(i)` gives the `i`-th), reported
    /// as `free(i, unoccluded)` in increasing `i`.
    pub fn unoccluded_many(
        &self,
        prims: &[Prim],
        n: usize,
        segment: impl Fn(usize) -> PacketRay,
        mut free: impl FnMut(usize, bool),
    ) {
        if !self.has_packets() {
            for i in 0..n {
                let (o, d, t_max) = segment(i);
                free(i, self.unoccluded(prims, o, d, t_max));
            }
            return;
        }
        for start in (0..n).step_by(PACKET) {
            let len = PACKET.min(n - start);
            let packet = Packet::new(len, |k| segment(start + k));
            let all = (u32::MAX >> (32 - len)) as u16;
            #[cfg(target_arch = "x86_64")]
            let blocked = match self.isa {
                // SAFETY: as in `closest_many`.
                Isa::Avx512 => unsafe { avx512::blocked(self, &packet, all) },
                _ => {
                    let all = all as u32;
                    // SAFETY: as in `closest_many`.
                    let half = |h| unsafe {
                        super::packet_avx::blocked(self, &packet, h, (all >> (8 * h)) & 0xff)
                    };
                    let hi = if len > 8 { half(1) } else { 0 };
                    (half(0) | hi << 8) as u16
                }
            };
            #[cfg(not(target_arch = "x86_64"))]
            let blocked: u16 = unreachable!("{all}");
            for k in 0..len {
                free(start + k, blocked & (1 << k) == 0);
            }
        }
    }
}

/// The packet tests in AVX-512 registers.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::{Flat, PACKET, Packet, PacketSphere};
    use std::arch::x86_64::*;

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn load(x: &[f32; PACKET]) -> __m512 {
        // SAFETY: `x` is sixteen readable f32s; the unaligned load has no other requirement.
        unsafe { _mm512_loadu_ps(x.as_ptr()) }
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn store(x: __m512) -> [f32; PACKET] {
        let mut out = [0.0; PACKET];
        // SAFETY: `out` is sixteen writable f32s; the unaligned store has no other requirement.
        unsafe { _mm512_storeu_ps(out.as_mut_ptr(), x) };
        out
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn cross(p: [__m512; 3], q: [__m512; 3]) -> [__m512; 3] {
        let m = _mm512_mul_ps;
        [
            _mm512_sub_ps(m(p[1], q[2]), m(p[2], q[1])),
            _mm512_sub_ps(m(p[2], q[0]), m(p[0], q[2])),
            _mm512_sub_ps(m(p[0], q[1]), m(p[1], q[0])),
        ]
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn dot(p: [__m512; 3], q: [__m512; 3]) -> __m512 {
        let m = _mm512_mul_ps;
        _mm512_add_ps(_mm512_add_ps(m(p[0], q[0]), m(p[1], q[1])), m(p[2], q[2]))
    }

    /// One triangle (`a`, `b`, `c` broadcast) against the packet's rays: the lanes whose ray
    /// hits it with `0 < t < t_max` (lane by lane), and their `t_det` and `det` (`t` is
    /// `t_det / det` as [`super::super::avx`] computes it).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn test(
        abc: &[[f32; 3]; 3],
        o: &[__m512; 3],
        d: &[__m512; 3],
        t_max: __m512,
    ) -> (__mmask16, __m512, __m512, __m512, __m512) {
        let splat = |v: [f32; 3]| {
            [
                _mm512_set1_ps(v[0]),
                _mm512_set1_ps(v[1]),
                _mm512_set1_ps(v[2]),
            ]
        };
        let (a, b, c) = (splat(abc[0]), splat(abc[1]), splat(abc[2]));
        let pvec = cross(*d, c);
        let det = dot(b, pvec);
        let tvec = [
            _mm512_sub_ps(o[0], a[0]),
            _mm512_sub_ps(o[1], a[1]),
            _mm512_sub_ps(o[2], a[2]),
        ];
        let u_det = dot(tvec, pvec);
        let qvec = cross(tvec, b);
        let v_det = dot(*d, qvec);
        let t_det = dot(c, qvec);
        // signum (±1 with det's sign; NaN lanes are dropped by the mask) and |det|, by bits
        // (AVX-512 F has the bitwise operations on integers only).
        let (bits, sign_bit) = (_mm512_castps_si512(det), _mm512_set1_epi32(i32::MIN));
        let one = _mm512_castps_si512(_mm512_set1_ps(1.0));
        let sign = _mm512_castsi512_ps(_mm512_or_si512(_mm512_and_si512(bits, sign_bit), one));
        let abs_det = _mm512_castsi512_ps(_mm512_andnot_si512(sign_bit, bits));
        let (u_s, v_s, t_s) = (
            _mm512_mul_ps(u_det, sign),
            _mm512_mul_ps(v_det, sign),
            _mm512_mul_ps(t_det, sign),
        );
        let zero = _mm512_setzero_ps();
        let mut m = _mm512_cmp_ps_mask::<_CMP_NEQ_OQ>(det, zero);
        m = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(m, abs_det, _mm512_set1_ps(f32::INFINITY));
        m = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(m, u_s, zero);
        m = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(m, v_s, zero);
        m = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(m, _mm512_add_ps(u_s, v_s), abs_det);
        m = _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(m, t_s, zero);
        if m == 0 {
            return (0, zero, zero, zero, zero);
        }
        let inv_det = _mm512_div_ps(_mm512_set1_ps(1.0), det);
        let t = _mm512_mul_ps(t_det, inv_det);
        m = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(m, t, t_max);
        (m, t, u_det, v_det, inv_det)
    }

    /// The packet's rays as registers: origins, directions, `t_max`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn rays(p: &Packet) -> ([__m512; 3], [__m512; 3], __m512) {
        let o = [load(&p.o[0]), load(&p.o[1]), load(&p.o[2])];
        let d = [load(&p.d[0]), load(&p.d[1]), load(&p.d[2])];
        (o, d, load(&p.t_max))
    }

    /// Each lane's closest triangle: (primitive index or `u32::MAX`, t, u, v).
    #[target_feature(enable = "avx512f")]
    pub(super) fn closest(flat: &Flat, p: &Packet) -> [(u32, f32, f32, f32); PACKET] {
        let (o, d, mut t_best) = rays(p);
        let mut prim = _mm512_set1_epi32(-1);
        let (mut u_best, mut v_best) = (_mm512_setzero_ps(), _mm512_setzero_ps());
        for tri in &flat.packet_tris {
            let (m, t, u_det, v_det, inv_det) = test(&tri.abc, &o, &d, t_best);
            if m == 0 {
                continue;
            }
            t_best = _mm512_mask_mov_ps(t_best, m, t);
            u_best = _mm512_mask_mov_ps(u_best, m, _mm512_mul_ps(u_det, inv_det));
            v_best = _mm512_mask_mov_ps(v_best, m, _mm512_mul_ps(v_det, inv_det));
            prim = _mm512_mask_mov_epi32(prim, m, _mm512_set1_epi32(tri.prim as i32));
        }
        for sphere in &flat.packet_spheres {
            let t = sphere_test(sphere, &o, &d, t_best);
            let m = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(t, t_best);
            if m == 0 {
                continue;
            }
            t_best = _mm512_mask_mov_ps(t_best, m, t);
            u_best = _mm512_mask_mov_ps(u_best, m, _mm512_setzero_ps());
            v_best = _mm512_mask_mov_ps(v_best, m, _mm512_setzero_ps());
            prim = _mm512_mask_mov_epi32(prim, m, _mm512_set1_epi32(sphere.prim as i32));
        }
        let mut prims = [0u32; PACKET];
        // SAFETY: `prims` is sixteen writable u32s; the unaligned store has no other
        // requirement.
        unsafe { _mm512_storeu_si512(prims.as_mut_ptr().cast(), prim) };
        let (t, u, v) = (store(t_best), store(u_best), store(v_best));
        std::array::from_fn(|k| (prims[k], t[k], u[k], v[k]))
    }

    /// The lanes (of `all`) whose segment some triangle blocks.
    #[target_feature(enable = "avx512f")]
    pub(super) fn blocked(flat: &Flat, p: &Packet, all: __mmask16) -> __mmask16 {
        let (o, d, t_max) = rays(p);
        let mut blocked: __mmask16 = 0;
        for tri in &flat.packet_tris {
            blocked |= test(&tri.abc, &o, &d, t_max).0;
            if blocked & all == all {
                break;
            }
        }
        for sphere in &flat.packet_spheres {
            if blocked & all == all {
                break;
            }
            let t = sphere_test(sphere, &o, &d, t_max);
            blocked |= _mm512_cmp_ps_mask::<_CMP_LT_OQ>(t, t_max);
        }
        blocked & all
    }

    /// `a . b` of one component set per lane, in glam's `Vec3::dot` order.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn dot_lanes(a: &[__m512; 3], b: &[__m512; 3]) -> __m512 {
        dot(*a, *b)
    }

    /// [`crate::geometry::Sphere::intersect`] on every lane, operation for operation: the
    /// nearest `t` in `(0, t_max)` or infinity.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn sphere_test(s: &PacketSphere, o: &[__m512; 3], d: &[__m512; 3], t_max: __m512) -> __m512 {
        let f = [
            _mm512_sub_ps(o[0], _mm512_set1_ps(s.center[0])),
            _mm512_sub_ps(o[1], _mm512_set1_ps(s.center[1])),
            _mm512_sub_ps(o[2], _mm512_set1_ps(s.center[2])),
        ];
        let sign_bit = _mm512_set1_epi32(i32::MIN);
        let neg =
            |x: __m512| _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(x), sign_bit));
        let b = neg(dot_lanes(&f, d));
        let r2 = _mm512_set1_ps(s.radius * s.radius);
        let l = [
            _mm512_add_ps(f[0], _mm512_mul_ps(b, d[0])),
            _mm512_add_ps(f[1], _mm512_mul_ps(b, d[1])),
            _mm512_add_ps(f[2], _mm512_mul_ps(b, d[2])),
        ];
        let disc = _mm512_sub_ps(r2, dot_lanes(&l, &l));
        let zero = _mm512_setzero_ps();
        let inf = _mm512_set1_ps(f32::INFINITY);
        let missed = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(disc, zero);
        let c = _mm512_sub_ps(dot_lanes(&f, &f), r2);
        // signum(b) for every b but NaN (whose q is NaN either way).
        let one = _mm512_castps_si512(_mm512_set1_ps(1.0));
        let sign = _mm512_and_si512(_mm512_castps_si512(b), sign_bit);
        let signum = _mm512_castsi512_ps(_mm512_or_si512(sign, one));
        let q = _mm512_add_ps(b, _mm512_mul_ps(signum, _mm512_sqrt_ps(disc)));
        let q_zero = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(q, zero);
        let t0 = _mm512_mask_mov_ps(_mm512_div_ps(c, q), q_zero, zero);
        let t1 = _mm512_mask_mov_ps(q, q_zero, zero);
        let ordered = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(t0, t1);
        let (near, far) = (
            _mm512_mask_mov_ps(t1, ordered, t0),
            _mm512_mask_mov_ps(t0, ordered, t1),
        );
        let within = |t: __m512| {
            _mm512_cmp_ps_mask::<_CMP_GT_OQ>(t, zero) & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(t, t_max)
        };
        let t = _mm512_mask_mov_ps(
            _mm512_mask_mov_ps(inf, within(far), far),
            within(near),
            near,
        );
        _mm512_mask_mov_ps(t, missed, inf)
    }
}

#[cfg(test)]
mod tests {
    use crate::geometry::bvh::tests::closed_box_with_spheres;
    use crate::geometry::bvh::{Accel, Index, ShapeGeometry};
    use crate::geometry::{Hit, Ray, TriangleMesh};
    use crate::math::{IndependentSampler, Sampler, warp::square_to_uniform_sphere};
    use glam::Vec3;

    fn key(h: &Option<Hit>) -> Option<[u32; 8]> {
        h.map(|h| {
            [
                h.shape,
                h.prim,
                h.t.to_bits(),
                h.uv.x.to_bits(),
                h.uv.y.to_bits(),
                h.p.x.to_bits(),
                h.ng.y.to_bits(),
                h.ns.z.to_bits(),
            ]
        })
    }

    /// Packets of rays ([`Accel::intersect_many`], [`Accel::unoccluded_many`] on a flat
    /// list) report for every ray what the ray alone reports, bit for bit: in a closed box
    /// with two spheres and a few loose triangles (so the last group of eight is partial),
    /// from random points inside and from points on the surfaces (rays spawned off their
    /// hits), with finite and infinite `t_max`, axis-parallel directions with -0.0 among
    /// them, in batches of random length (partial packets); with AVX-512 where the CPU has
    /// it and with AVX alone. Where the CPU has no AVX the batches are traced ray by ray and
    /// the test says so.
    #[test]
    fn packets_agree_with_single_rays_bit_for_bit() {
        let mut shapes = closed_box_with_spheres();
        shapes.push(ShapeGeometry::Mesh(TriangleMesh::quad(
            Vec3::new(-0.3, 0.2, -0.5),
            Vec3::new(0.6, 0.1, 0.0),
            Vec3::new(0.0, 0.3, 0.5),
        )));
        shapes.push(ShapeGeometry::Mesh(TriangleMesh::quad(
            Vec3::new(0.2, -0.6, 0.4),
            Vec3::new(0.0, 0.5, 0.2),
            Vec3::new(-0.4, 0.0, 0.3),
        )));
        let accel = Accel::build(&shapes);
        let Index::Flat(flat) = &accel.index else {
            panic!("a scene of 18 primitives is tested flat");
        };
        if !flat.has_packets() {
            eprintln!("this CPU has no AVX: batches are traced ray by ray");
        }
        // The same list with packets in AVX registers (two halves of eight) where the CPU
        // has AVX-512 too.
        let mut avx = Accel::build(&shapes);
        if let Index::Flat(f) = &mut avx.index {
            *f = f.clone().without_avx512();
        }
        let mut rng = IndependentSampler::new(7, 0, 0);
        let axes = [Vec3::X, Vec3::Y, Vec3::Z];
        let mut rays = Vec::new();
        for i in 0..6000 {
            let o = (Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) - 0.5) * 1.9;
            let d = match i % 10 {
                // Axis-parallel, some with -0.0 components.
                0 => axes[i % 3] * if i % 20 == 0 { -1.0 } else { 1.0 } - Vec3::splat(0.0),
                _ => square_to_uniform_sphere(rng.next_2d()),
            };
            let mut ray = Ray::new(o, d);
            if i % 3 == 0 {
                ray.t_max = 0.2 + 2.0 * rng.next_1d();
            }
            // Every other ray leaves a surface.
            if i % 2 == 1
                && let Some(h) = accel.intersect(&ray, &shapes)
            {
                ray = h.spawn(square_to_uniform_sphere(rng.next_2d()));
            }
            rays.push(ray);
        }
        let (mut hits, mut free, mut n_hit, mut n_free) = (Vec::new(), Vec::new(), 0, 0);
        let mut start = 0;
        while start < rays.len() {
            let len = (1 + (rng.next_1d() * 40.0) as usize).min(rays.len() - start);
            let batch = &rays[start..start + len];
            let segments: Vec<_> = batch.iter().map(|r| (r.o, r.d, r.t_max)).collect();
            for (variant, packets) in [("default", &accel), ("avx", &avx)] {
                packets.intersect_many(batch, &shapes, &mut hits);
                packets.unoccluded_many(&segments, &mut free);
                assert_eq!((hits.len(), free.len()), (len, len));
                for (k, ray) in batch.iter().enumerate() {
                    let alone = accel.intersect(ray, &shapes);
                    assert_eq!(key(&hits[k]), key(&alone), "{variant}: ray {ray:?}");
                    let clear = accel.unoccluded(ray.o, ray.d, ray.t_max);
                    assert_eq!(free[k], clear, "{variant}: segment {ray:?}");
                    n_hit += alone.is_some() as usize;
                    n_free += clear as usize;
                }
            }
            start += len;
        }
        // Both outcomes of both queries occur often.
        assert!((2000..11800).contains(&n_hit), "{n_hit} hits");
        assert!((1000..11000).contains(&n_free), "{n_free} free");
    }
}
