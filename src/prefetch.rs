//! Cache prefetch hints: ask the memory system for data a few hundred nanoseconds before it is
//! read, so that a cache miss overlaps other work instead of stalling it.
//!
//! vcm's merging reads a photon grid written a whole pass earlier (about 100 MB on SmallVCM's
//! box at 512 x 512: out of the nearer caches and, with 4 KiB pages, out of the TLB); a
//! plain early load stalls the core just the same once its reorder window fills (measured), a
//! prefetch instruction does not. The interleaved BVH traversal (`geometry/interleaved.rs`)
//! prefetches each ray's next node or leaf while the other rays take their steps; the guided
//! density `p_g` prefetches the guide data of the candidate a few ahead of the one it
//! evaluates (`cargo bench --bench guided_pg`: 8 % less time per `p_g` at 10k guide paths, 22 %
//! at 100k); the heightfield walk asks for a hit triangle's vertex normals when it finds it.
//! Hints only:
//! no fault, nothing written, no effect on results.

/// Ask for the cache line holding `p`.
#[inline(always)]
pub fn line<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: PREFETCHT0 is a hint: it never faults and reads or writes nothing the program
    // can observe, whatever `p` points at (even a dangling or unmapped address); SSE is part
    // of the x86-64 baseline. For vcm's merging (about 8 % of its time on SmallVCM's box)
    // and the interleaved BVH traversal (1.35-1.4x the rays per second on a 1M-triangle
    // mesh; docs/results.md). lodestar's other `unsafe`: the AVX
    // triangle test of small scenes (`geometry/flat.rs`, about 9 % of pt's time on the
    // Cornell box).
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p as *const i8)
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Ask for every cache line of `items` (at most `max_lines` of them).
#[inline(always)]
pub fn slice<T>(items: &[T], max_lines: usize) {
    let bytes = std::mem::size_of_val(items);
    let start = items.as_ptr() as *const u8;
    let mut offset = 0;
    while offset < bytes && offset < max_lines * 64 {
        line(start.wrapping_add(offset));
        offset += 64;
    }
}
