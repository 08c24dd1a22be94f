//! Many rays through the BVH at once, interleaved: [`Accel::intersect_many`] and
//! [`Accel::unoccluded_many`] give, ray for ray and bit for bit, what [`Accel::intersect`] and
//! [`Accel::unoccluded`] give, and take less time per ray on large scenes.
//!
//! Why: one incoherent ray through a large BVH is a chain of dependent loads (a node, then the
//! child it picks, then a leaf's primitives), each a cache miss the core waits out. Here
//! [`LANES`] rays advance in turn, one step each: a step tests the node (or the leaf's
//! primitives) that the previous step of the same ray asked the memory system for with a
//! prefetch, then picks what comes next and prefetches it, so the misses of the lanes overlap
//! instead of queueing. Each ray visits its nodes and primitives in exactly the order obvhs'
//! own traversal does (primitives of a leaf before the next node, children in the ray's octant
//! order), so the closest hit, its barycentrics and every shorter `t_max` along the way are the
//! single-ray traversal's.
//!
//! Scenes small enough to skip the BVH (`geometry/flat.rs`) are tested in packets of sixteen rays
//! where the CPU has AVX (`flat/packet.rs`), else ray by ray; scenes with grid meshes
//! (`geometry/grid.rs`) are traced ray by ray.

use super::bvh::{Accel, Index, ShapeGeometry, canonical_dir, count_ray, surface_hit};
use super::prim::{Prim, intersect_prim};
use super::{Hit, Ray};
use crate::prefetch;
use glam::{UVec2, Vec2, Vec3, Vec3A};
use obvhs::cwbvh::{CwBvh, Traversal, firstbithigh};
use obvhs::faststack::FastStack;

/// Rays in flight per thread: the best of 4 to 32 on the 1M-triangle mesh of `cargo bench
/// --bench bvh` (closest hits, one thread, Mrays/s: 4 lanes 1.44, 8 1.54, 12 1.70, 16
/// 1.64-1.72, 32 1.65; docs/results.md compares the traversal with Embree).
pub const LANES: usize = 16;

/// No node waits to be tested.
const NONE: u32 = u32::MAX;

/// One ray's traversal state.
struct Lane {
    /// Index of the ray in the caller's slice.
    ray: usize,
    /// The ray in the BVH's scaled coordinates; `tmax` shrinks with each closer hit.
    r: obvhs::ray::Ray,
    /// Origin and (canonical) direction in world space, for the primitive tests.
    o: Vec3A,
    d: Vec3A,
    state: Traversal,
    /// The node prefetched by the previous step, tested by the next one.
    pending: u32,
    /// Closest hit so far: primitive (BVH order), scaled t, barycentrics.
    prim: u32,
    t: f32,
    uv: Vec2,
    /// Primitive tests end the ray at its first hit (occlusion).
    any_hit: bool,
}

/// What a step left the lane in.
enum Step {
    Running,
    Done,
}

impl Lane {
    fn new(
        bvh: &CwBvh,
        ray: usize,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        scale: f32,
        any_hit: bool,
    ) -> Lane {
        let r = obvhs::ray::Ray::new(o * scale, d, 0.0, t_max * scale);
        Lane {
            ray,
            r,
            o,
            d,
            state: bvh.new_traversal(r.direction),
            pending: NONE,
            prim: 0,
            t: f32::INFINITY,
            uv: Vec2::ZERO,
            any_hit,
        }
    }

    /// One step of obvhs' `traverse!` loop, split at the loads: test the pending node (and
    /// stop there if it has primitives to test, prefetching them), or test the current leaf's
    /// primitives, then pick the next node and prefetch it.
    /// `AVX2`: the node test of [`super::node_avx2`] (only inside [`run_avx2`], compiled for
    /// AVX2).
    #[inline(always)]
    fn step<const AVX2: bool>(&mut self, accel: &Accel, bvh: &CwBvh) -> Step {
        let s = accel.scale;
        let st = &mut self.state;
        if self.pending != NONE {
            let node = &bvh.nodes[self.pending as usize];
            self.pending = NONE;
            let hitmask = if AVX2 {
                // SAFETY: `AVX2` steps run only in `run_avx2`, called where the CPU has AVX2.
                unsafe { super::node_avx2::hits(node, &self.r, st.oct_inv4) }
            } else {
                node.intersect_ray(&self.r, st.oct_inv4)
            };
            st.current_group.x = node.child_base_idx;
            st.primitive_group.x = node.primitive_base_idx;
            st.current_group.y = (hitmask & 0xff00_0000) | node.imask as u32;
            st.primitive_group.y = hitmask & 0x00ff_ffff;
            if st.primitive_group.y != 0 {
                let mut bits = st.primitive_group.y;
                while bits != 0 {
                    let k = bits.trailing_zeros();
                    bits &= bits - 1;
                    if let Some(p) = accel.prims.get((st.primitive_group.x + k) as usize) {
                        // 64 bytes, not necessarily on one line.
                        prefetch::line(p);
                        prefetch::line((p as *const Prim as *const u8).wrapping_add(63));
                    }
                }
                return Step::Running;
            }
        }
        // The leaf's primitives, highest bit first (as `traverse!`).
        while st.primitive_group.y != 0 {
            let k = firstbithigh(st.primitive_group.y);
            st.primitive_group.y &= !(1u32 << k);
            let id = st.primitive_group.x + k;
            let t_max = self.r.tmax / s;
            let (t, uv) = intersect_prim(&accel.prims[id as usize], self.o, self.d, t_max);
            if t < t_max {
                self.uv = uv;
            }
            let ts = t * s;
            if ts < self.r.tmax {
                if self.any_hit {
                    self.t = ts;
                    return Step::Done;
                }
                self.prim = id;
                self.t = ts;
                self.r.tmax = ts;
            }
        }
        st.primitive_group = UVec2::ZERO;
        // The next node: from the current group, else from the stack.
        loop {
            if st.current_group.y & 0xff00_0000 != 0 {
                let hits_imask = st.current_group.y;
                let child_index_offset = firstbithigh(hits_imask);
                let child_index_base = st.current_group.x;
                st.current_group.y &= !(1u32 << child_index_offset);
                if st.current_group.y & 0xff00_0000 != 0 {
                    st.stack.push(st.current_group);
                }
                let slot_index = (child_index_offset - 24) ^ (st.oct_inv4 & 0xff);
                let relative_index = (hits_imask & !(0xffff_ffffu32 << slot_index)).count_ones();
                let child = child_index_base + relative_index;
                if let Some(node) = bvh.nodes.get(child as usize) {
                    // A node is 80 bytes: it may straddle two lines.
                    let p = node as *const _ as *const u8;
                    prefetch::line(p);
                    prefetch::line(p.wrapping_add(79));
                }
                self.pending = child;
                return Step::Running;
            }
            if st.stack.is_empty() {
                return Step::Done;
            }
            st.current_group = st.stack.pop_fast();
        }
    }
}

/// Runs every ray of `count` through `bvh` in [`LANES`] interleaved lanes; `start(i)` makes
/// ray i's lane, `finish(lane)` takes a finished one. Nodes are tested in AVX2 where the CPU
/// has it (`Accel::avx2`).
fn run(
    accel: &Accel,
    bvh: &CwBvh,
    count: usize,
    start: impl FnMut(usize) -> Lane,
    finish: impl FnMut(&Lane),
) {
    #[cfg(target_arch = "x86_64")]
    if accel.avx2 {
        // SAFETY: `avx2` is set only where the running CPU reports AVX2.
        return unsafe { run_avx2(accel, bvh, count, start, finish) };
    }
    run_lanes::<false>(accel, bvh, count, start, finish)
}

/// [`run_lanes`] compiled for AVX2, with its node test.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn run_avx2(
    accel: &Accel,
    bvh: &CwBvh,
    count: usize,
    start: impl FnMut(usize) -> Lane,
    finish: impl FnMut(&Lane),
) {
    run_lanes::<true>(accel, bvh, count, start, finish)
}

#[inline(always)]
fn run_lanes<const AVX2: bool>(
    accel: &Accel,
    bvh: &CwBvh,
    count: usize,
    mut start: impl FnMut(usize) -> Lane,
    mut finish: impl FnMut(&Lane),
) {
    let mut lanes: Vec<Lane> = Vec::with_capacity(LANES);
    let mut next = 0;
    while next < count && lanes.len() < LANES {
        lanes.push(start(next));
        next += 1;
    }
    while !lanes.is_empty() {
        let mut i = 0;
        while i < lanes.len() {
            match lanes[i].step::<AVX2>(accel, bvh) {
                Step::Running => i += 1,
                Step::Done => {
                    finish(&lanes[i]);
                    if next < count {
                        lanes[i] = start(next);
                        next += 1;
                        i += 1;
                    } else {
                        lanes.swap_remove(i);
                    }
                }
            }
        }
    }
}

/// The size of a BVH (nodes and primitives) from which [`Accel::batches_pay`]. Below it the
/// BVH stays in the caches, a single ray rarely waits on memory, and the interleaved
/// traversal's bookkeeping costs more than it hides (`cargo bench --bench pt_batch`, pt on
/// noisy spheres in the Cornell box, batched against one path at a time, with the AVX2 node
/// test: 0.94x at 3.4 MB, 0.97x at 8.3 MB, 1.14x at 21 MB, 1.29x at 69 MB).
pub const BATCH_MIN_BYTES: usize = 16 << 20;

impl Accel {
    /// Whether batches of rays ([`Self::intersect_many`], [`Self::unoccluded_many`]) are
    /// worth what their callers pay to form them: the scene has no grids (those are traced
    /// ray by ray) and is searched through a BVH of at least [`BATCH_MIN_BYTES`], or tested
    /// flat in packets (the CPU has AVX: pt, 16 spp, one thread, batched against one path
    /// at a time, side by side: 0.88x-0.90x the time on the Cornell boxes and SmallVCM's box
    /// with AVX-512 packets, 0.88x-0.93x with AVX ones).
    pub fn batches_pay(&self) -> bool {
        self.grids.is_empty()
            && match &self.index {
                Index::Bvh(_) => self.bvh_bytes() >= BATCH_MIN_BYTES,
                Index::Flat(flat) => flat.has_packets(),
            }
    }

    /// Bytes of the BVH's nodes (none when primitives are tested flat) and primitives.
    pub fn bvh_bytes(&self) -> usize {
        let nodes = match &self.index {
            Index::Bvh(bvh) => std::mem::size_of_val(bvh.nodes.as_slice()),
            Index::Flat(_) => 0,
        };
        nodes + std::mem::size_of_val(self.prims.as_slice())
    }

    /// Closest hits of `rays` into `out` (cleared first; `out[i]` for `rays[i]`): the same as
    /// [`Accel::intersect`] ray by ray, bit for bit, with the rays' traversals interleaved
    /// (module doc).
    pub fn intersect_many(
        &self,
        rays: &[Ray],
        shapes: &[ShapeGeometry],
        out: &mut Vec<Option<Hit>>,
    ) {
        out.clear();
        if let (Index::Flat(flat), true) = (&self.index, self.grids.is_empty()) {
            let ray = |i: usize| {
                count_ray();
                let r = &rays[i];
                (Vec3A::from(r.o), canonical_dir(r.d), r.t_max)
            };
            flat.closest_many(&self.prims, rays.len(), ray, |i, closest| {
                let hit =
                    closest.map(|(p, t, uv)| surface_hit(&self.prims[p], &rays[i], t, uv, shapes));
                out.push(hit);
            });
            return;
        }
        let (Index::Bvh(bvh), true) = (&self.index, self.grids.is_empty()) else {
            out.extend(rays.iter().map(|r| self.intersect(r, shapes)));
            return;
        };
        out.resize(rays.len(), None);
        let s = self.scale;
        run(
            self,
            bvh,
            rays.len(),
            |i| {
                count_ray();
                let r = &rays[i];
                Lane::new(
                    bvh,
                    i,
                    Vec3A::from(r.o),
                    canonical_dir(r.d),
                    r.t_max,
                    s,
                    false,
                )
            },
            |lane| {
                let ray = &rays[lane.ray];
                if lane.t < ray.t_max * s {
                    let prim = &self.prims[lane.prim as usize];
                    out[lane.ray] = Some(surface_hit(prim, ray, lane.t / s, lane.uv, shapes));
                }
            },
        );
    }

    /// For each segment `(o, d, dist)`, whether nothing blocks it: the same as
    /// [`Accel::unoccluded`] segment by segment, with the traversals interleaved (module doc).
    pub fn unoccluded_many(&self, segments: &[(Vec3, Vec3, f32)], out: &mut Vec<bool>) {
        out.clear();
        if let (Index::Flat(flat), true) = (&self.index, self.grids.is_empty()) {
            let segment = |i: usize| {
                count_ray();
                let (o, d, dist) = segments[i];
                (Vec3A::from(o), canonical_dir(d), dist)
            };
            flat.unoccluded_many(&self.prims, segments.len(), segment, |_, free| {
                out.push(free)
            });
            return;
        }
        let (Index::Bvh(bvh), true) = (&self.index, self.grids.is_empty()) else {
            let one_by_one = segments.iter().map(|&(o, d, l)| self.unoccluded(o, d, l));
            out.extend(one_by_one);
            return;
        };
        out.resize(segments.len(), true);
        let s = self.scale;
        run(
            self,
            bvh,
            segments.len(),
            |i| {
                count_ray();
                let (o, d, dist) = segments[i];
                Lane::new(bvh, i, Vec3A::from(o), canonical_dir(d), dist, s, true)
            },
            |lane| out[lane.ray] = lane.t >= lane.r.tmax, // t is infinite unless a hit set it
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Sphere, TriangleMesh};
    use crate::math::{Sampler, warp::square_to_uniform_sphere};

    /// A closed box (quads) holding a wavy 24 x 24 grid of triangles with vertex normals and
    /// two spheres: 1,166 primitives, so the BVH is several levels deep.
    fn scene() -> (Vec<ShapeGeometry>, Accel) {
        let mut shapes = crate::geometry::bvh::tests::closed_box();
        const N: u32 = 24;
        let mut grid = TriangleMesh::default();
        let height = |u: f32, v: f32| 0.15 * (9.0 * u).sin() * (7.0 * v + 0.5).cos();
        let mut normals = Vec::new();
        for j in 0..=N {
            for i in 0..=N {
                let (u, v) = (
                    i as f32 / N as f32 * 1.8 - 0.9,
                    j as f32 / N as f32 * 1.8 - 0.9,
                );
                grid.positions.push(Vec3::new(u, height(u, v), v));
                let (du, dv) = (
                    1.35 * (9.0 * u).cos() * (7.0 * v + 0.5).cos(),
                    -1.05 * (9.0 * u).sin() * (7.0 * v + 0.5).sin(),
                );
                normals.push(Vec3::new(-du, 1.0, -dv).normalize());
            }
        }
        grid.normals = Some(normals);
        for j in 0..N {
            for i in 0..N {
                let k = |i: u32, j: u32| j * (N + 1) + i;
                grid.indices.push([k(i, j), k(i + 1, j), k(i + 1, j + 1)]);
                grid.indices.push([k(i, j), k(i + 1, j + 1), k(i, j + 1)]);
            }
        }
        shapes.push(ShapeGeometry::Mesh(grid));
        for (c, r) in [
            (Vec3::new(-0.4, 0.5, 0.2), 0.3),
            (Vec3::new(0.5, -0.5, -0.3), 0.3),
        ] {
            shapes.push(ShapeGeometry::Sphere(Sphere {
                center: c,
                radius: r,
            }));
        }
        let accel = Accel::build(&shapes);
        assert!(matches!(accel.index, Index::Bvh(_)));
        (shapes, accel)
    }

    /// Every field of the hit, as bits.
    fn key(h: &Option<Hit>) -> Option<[u32; 17]> {
        h.map(|h| {
            let v = [h.p, h.p_err, h.ng, h.ns];
            let mut k = [0; 17];
            k[0] = h.t.to_bits();
            for (i, c) in v.iter().flat_map(|v| v.to_array()).enumerate() {
                k[1 + i] = c.to_bits();
            }
            k[13] = h.uv.x.to_bits();
            k[14] = h.uv.y.to_bits();
            (k[15], k[16]) = (h.shape, h.prim);
            k
        })
    }

    /// 20k random rays (random origins inside the box, random directions and `t_max`, a tenth
    /// of them infinite) in batches of random size: `intersect_many` and `unoccluded_many`
    /// give what `intersect` and `unoccluded` give ray by ray, every hit field bit for bit.
    #[test]
    fn interleaved_traversal_agrees_with_single_rays_bit_for_bit() {
        // Batches with the AVX2 node test (where the CPU has it) and with obvhs' own.
        let (shapes, accel) = scene();
        agrees(&shapes, &accel);
        agrees(&shapes, &accel.without_avx2());
    }

    fn agrees(shapes: &[ShapeGeometry], accel: &Accel) {
        let mut rng = crate::math::IndependentSampler::new(5, 0, 0);
        let (mut hits, mut occluded, mut done) = (0, 0, 0);
        let (mut out, mut free) = (Vec::new(), Vec::new());
        while done < 20_000 {
            let n = 1 + (rng.next_1d() * 40.0) as usize;
            let rays: Vec<Ray> = (0..n)
                .map(|_| {
                    let o = (Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) - 0.5) * 1.9;
                    let mut r = Ray::new(o, square_to_uniform_sphere(rng.next_2d()));
                    if rng.next_1d() < 0.9 {
                        r.t_max = 0.2 + 3.0 * rng.next_1d();
                    }
                    r
                })
                .collect();
            accel.intersect_many(&rays, shapes, &mut out);
            let segments: Vec<_> = rays.iter().map(|r| (r.o, r.d, r.t_max)).collect();
            accel.unoccluded_many(&segments, &mut free);
            assert_eq!((out.len(), free.len()), (n, n));
            for (i, r) in rays.iter().enumerate() {
                assert_eq!(key(&out[i]), key(&accel.intersect(r, shapes)), "ray {r:?}");
                assert_eq!(free[i], accel.unoccluded(r.o, r.d, r.t_max), "ray {r:?}");
                hits += out[i].is_some() as u32;
                occluded += !free[i] as u32;
            }
            done += n;
        }
        // Both outcomes of each query occur often enough to mean something.
        assert!((4_000..18_000).contains(&hits), "{hits} hits");
        assert!((4_000..18_000).contains(&occluded), "{occluded} occluded");
    }
}
