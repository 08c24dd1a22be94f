//! [`super::packet`]'s tests on CPUs with AVX but not AVX-512: a packet of sixteen rays as two
//! halves of eight, each in AVX registers, with the same operations in the same order per
//! lane (so the same hits, bit for bit), lane masks kept as vectors and blended in.

use super::Flat;
use super::avx::{cross, dot, inside_mask, store};
use super::lanes::{PACKET, Packet, PacketSphere};
use std::arch::x86_64::*;

/// Rays per half packet: one per lane of an AVX register.
const HALF: usize = 8;

#[inline]
#[target_feature(enable = "avx")]
fn load(x: &[f32; PACKET], half: usize) -> __m256 {
    // SAFETY: `x[HALF * half ..]` holds eight readable f32s (`half` is 0 or 1); the unaligned
    // load has no other requirement.
    unsafe { _mm256_loadu_ps(x[HALF * half..HALF * half + HALF].as_ptr()) }
}

#[inline]
#[target_feature(enable = "avx")]
fn splat3(v: [f32; 3]) -> [__m256; 3] {
    [
        _mm256_set1_ps(v[0]),
        _mm256_set1_ps(v[1]),
        _mm256_set1_ps(v[2]),
    ]
}

/// `signum(x)` on every lane (±1; NaN lanes give ±1 too).
#[inline]
#[target_feature(enable = "avx")]
fn signum(x: __m256) -> __m256 {
    _mm256_or_ps(_mm256_and_ps(x, _mm256_set1_ps(-0.0)), _mm256_set1_ps(1.0))
}

/// One triangle against half a packet, as `packet::avx512::test`: the lanes that hit it with
/// `0 < t < t_max` (all bits set), `t`, `u_det`, `v_det` and `1 / det`.
#[inline]
#[target_feature(enable = "avx")]
fn test(
    abc: &[[f32; 3]; 3],
    o: &[__m256; 3],
    d: &[__m256; 3],
    t_max: __m256,
) -> Option<(__m256, __m256, __m256, __m256, __m256)> {
    let (a, b, c) = (splat3(abc[0]), splat3(abc[1]), splat3(abc[2]));
    let pvec = cross(*d, c);
    let det = dot(b, pvec);
    let tvec = [
        _mm256_sub_ps(o[0], a[0]),
        _mm256_sub_ps(o[1], a[1]),
        _mm256_sub_ps(o[2], a[2]),
    ];
    let u_det = dot(tvec, pvec);
    let qvec = cross(tvec, b);
    let v_det = dot(*d, qvec);
    let t_det = dot(c, qvec);
    let m = inside_mask(det, u_det, v_det, t_det);
    if _mm256_movemask_ps(m) == 0 {
        return None;
    }
    let inv_det = _mm256_div_ps(_mm256_set1_ps(1.0), det);
    let t = _mm256_mul_ps(t_det, inv_det);
    let m = _mm256_and_ps(m, _mm256_cmp_ps::<_CMP_LT_OQ>(t, t_max));
    Some((m, t, u_det, v_det, inv_det))
}

/// [`crate::geometry::Sphere::intersect`] on every lane, operation for operation.
#[inline]
#[target_feature(enable = "avx")]
fn sphere_test(s: &PacketSphere, o: &[__m256; 3], d: &[__m256; 3], t_max: __m256) -> __m256 {
    let center = splat3(s.center);
    let f = [
        _mm256_sub_ps(o[0], center[0]),
        _mm256_sub_ps(o[1], center[1]),
        _mm256_sub_ps(o[2], center[2]),
    ];
    let b = _mm256_xor_ps(dot(f, *d), _mm256_set1_ps(-0.0));
    let r2 = _mm256_set1_ps(s.radius * s.radius);
    let l = [
        _mm256_add_ps(f[0], _mm256_mul_ps(b, d[0])),
        _mm256_add_ps(f[1], _mm256_mul_ps(b, d[1])),
        _mm256_add_ps(f[2], _mm256_mul_ps(b, d[2])),
    ];
    let disc = _mm256_sub_ps(r2, dot(l, l));
    let (zero, inf) = (_mm256_setzero_ps(), _mm256_set1_ps(f32::INFINITY));
    let missed = _mm256_cmp_ps::<_CMP_LT_OQ>(disc, zero);
    let c = _mm256_sub_ps(dot(f, f), r2);
    let q = _mm256_add_ps(b, _mm256_mul_ps(signum(b), _mm256_sqrt_ps(disc)));
    let q_zero = _mm256_cmp_ps::<_CMP_EQ_OQ>(q, zero);
    let t0 = _mm256_blendv_ps(_mm256_div_ps(c, q), zero, q_zero);
    let t1 = _mm256_blendv_ps(q, zero, q_zero);
    let ordered = _mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1);
    let (near, far) = (
        _mm256_blendv_ps(t1, t0, ordered),
        _mm256_blendv_ps(t0, t1, ordered),
    );
    let within = |t: __m256| {
        _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(t, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(t, t_max),
        )
    };
    let t = _mm256_blendv_ps(_mm256_blendv_ps(inf, far, within(far)), near, within(near));
    _mm256_blendv_ps(t, inf, missed)
}

/// Half `half` (0 or 1) of the packet's rays as registers: origins, directions, `t_max`.
#[inline]
#[target_feature(enable = "avx")]
fn rays(p: &Packet, half: usize) -> ([__m256; 3], [__m256; 3], __m256) {
    let o = [
        load(&p.o[0], half),
        load(&p.o[1], half),
        load(&p.o[2], half),
    ];
    let d = [
        load(&p.d[0], half),
        load(&p.d[1], half),
        load(&p.d[2], half),
    ];
    (o, d, load(&p.t_max, half))
}

/// Each lane's closest primitive in half `half` of the packet: (index or `u32::MAX`, t, u, v).
#[target_feature(enable = "avx")]
pub(super) fn closest(flat: &Flat, p: &Packet, half: usize) -> [(u32, f32, f32, f32); HALF] {
    let (o, d, mut t_best) = rays(p, half);
    let mut prim = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    let (mut u_best, mut v_best) = (_mm256_setzero_ps(), _mm256_setzero_ps());
    for tri in &flat.packet_tris {
        let Some((m, t, u_det, v_det, inv_det)) = test(&tri.abc, &o, &d, t_best) else {
            continue;
        };
        t_best = _mm256_blendv_ps(t_best, t, m);
        u_best = _mm256_blendv_ps(u_best, _mm256_mul_ps(u_det, inv_det), m);
        v_best = _mm256_blendv_ps(v_best, _mm256_mul_ps(v_det, inv_det), m);
        let index = _mm256_castsi256_ps(_mm256_set1_epi32(tri.prim as i32));
        prim = _mm256_blendv_ps(prim, index, m);
    }
    for sphere in &flat.packet_spheres {
        let t = sphere_test(sphere, &o, &d, t_best);
        let m = _mm256_cmp_ps::<_CMP_LT_OQ>(t, t_best);
        if _mm256_movemask_ps(m) == 0 {
            continue;
        }
        t_best = _mm256_blendv_ps(t_best, t, m);
        u_best = _mm256_blendv_ps(u_best, _mm256_setzero_ps(), m);
        v_best = _mm256_blendv_ps(v_best, _mm256_setzero_ps(), m);
        let index = _mm256_castsi256_ps(_mm256_set1_epi32(sphere.prim as i32));
        prim = _mm256_blendv_ps(prim, index, m);
    }
    let prims = store(prim).map(f32::to_bits);
    let (t, u, v) = (store(t_best), store(u_best), store(v_best));
    std::array::from_fn(|k| (prims[k], t[k], u[k], v[k]))
}

/// The lanes of half `half` (bit k for its lane k) whose segment some primitive blocks.
#[target_feature(enable = "avx")]
pub(super) fn blocked(flat: &Flat, p: &Packet, half: usize, all: u32) -> u32 {
    let (o, d, t_max) = rays(p, half);
    let mut blocked = 0u32;
    for tri in &flat.packet_tris {
        if let Some((m, ..)) = test(&tri.abc, &o, &d, t_max) {
            blocked |= _mm256_movemask_ps(m) as u32;
            if blocked & all == all {
                return all;
            }
        }
    }
    for sphere in &flat.packet_spheres {
        if blocked & all == all {
            break;
        }
        let t = sphere_test(sphere, &o, &d, t_max);
        blocked |= _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(t, t_max)) as u32;
    }
    blocked & all
}
