//! The CWBVH node test, eight children in one AVX2 register.
//!
//! obvhs' own test (`CwBvhNode::intersect_ray`, SSE) widens each child's quantised plane
//! bytes to floats one scalar conversion at a time, four children per register, and extracts
//! the hit children's meta bytes one by one: on a BVH that stays in the caches that is most of
//! a node visit (perf on a 49k-triangle mesh put 40 % of the traversal there). Here each of the
//! six planes of all eight children is one 8-byte load widened by `VPMOVZXBD` and converted by
//! `VCVTDQ2PS` (exact for bytes), followed by the same multiplies, adds, maxima and minima in
//! the same operand order as obvhs' test and no fused multiply-add, so every child's hit bit
//! is obvhs' bit for bit and a traversal visits the same nodes in the same order.
//!
//! The test is compiled for AVX2 and must only run where the CPU has it ([`has_avx2`]); the
//! interleaved traversal calling it is compiled for AVX2 as a whole (`interleaved::run_avx2`),
//! so it inlines there. Batches gain from it (their lanes keep the core busy, so the test's
//! instruction count is what limits them); single rays, which wait on each node's load before
//! the next, do not (`cargo bench --bench bvh`; docs/results.md has the figures).

use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray;

/// obvhs' lower bound on a child's entry distance (`cwbvh::node::EPSILON`, not exported).
const EPSILON: f32 = 0.0001;

/// Whether the running CPU has AVX2 (checked once per accelerator).
pub(super) fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The children of `node` that `ray` (in the BVH's coordinates) enters, as obvhs'
/// `intersect_ray` returns them: per hit child its meta bits, placed by the ray's octant.
///
/// # Safety
/// The CPU must have AVX2 ([`has_avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn hits(node: &CwBvhNode, ray: &Ray, oct_inv4: u32) -> u32 {
    use glam::Vec3A;
    use std::arch::x86_64::*;
    let adj_dir_inv = node.compute_extent() * ray.inv_direction;
    let adj_origin = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    // Eight plane bytes widened to eight exact floats.
    let planes = |bytes: &[u8; 8]| {
        // SAFETY: reads the array's eight bytes (an unaligned 64-bit load).
        let b = unsafe { _mm_loadl_epi64(bytes.as_ptr() as *const __m128i) };
        _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(b))
    };
    let axis = |lo: &[u8; 8], hi: &[u8; 8], negative: bool, scale: f32, offset: f32| {
        let (q_lo, q_hi) = (planes(lo), planes(hi));
        let (near, far) = if negative { (q_hi, q_lo) } else { (q_lo, q_hi) };
        let (s, o) = (_mm256_set1_ps(scale), _mm256_set1_ps(offset));
        (
            _mm256_add_ps(_mm256_mul_ps(near, s), o),
            _mm256_add_ps(_mm256_mul_ps(far, s), o),
        )
    };
    let d = ray.direction;
    let (tmin_x, tmax_x) = axis(
        &node.child_min_x,
        &node.child_max_x,
        d.x < 0.0,
        adj_dir_inv.x,
        adj_origin.x,
    );
    let (tmin_y, tmax_y) = axis(
        &node.child_min_y,
        &node.child_max_y,
        d.y < 0.0,
        adj_dir_inv.y,
        adj_origin.y,
    );
    let (tmin_z, tmax_z) = axis(
        &node.child_min_z,
        &node.child_max_z,
        d.z < 0.0,
        adj_dir_inv.z,
        adj_origin.z,
    );
    // obvhs' operand order: max(x, max(y, z)), then against EPSILON and tmax (which operand
    // wins on NaN matters for equality with its test).
    let tmin = _mm256_max_ps(tmin_x, _mm256_max_ps(tmin_y, tmin_z));
    let tmax = _mm256_min_ps(tmax_x, _mm256_min_ps(tmax_y, tmax_z));
    let tmin = _mm256_max_ps(tmin, _mm256_set1_ps(EPSILON));
    let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(ray.tmax));
    let mut mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut hit_mask = 0u32;
    while mask != 0 {
        let j = mask.trailing_zeros();
        mask &= mask - 1;
        let child_bits = ((child_bits8 >> (j * 8)) as u32) & 0xff;
        let bit_index = ((bit_index8 >> (j * 8)) as u32) & 0xff;
        hit_mask |= child_bits << bit_index;
    }
    hit_mask
}

/// Never called: the AVX2 path is only taken on x86-64.
///
/// # Safety
/// None needed; it panics.
#[cfg(not(target_arch = "x86_64"))]
pub(super) unsafe fn hits(_: &CwBvhNode, _: &Ray, _: u32) -> u32 {
    unreachable!("AVX2 is x86-64 only")
}
