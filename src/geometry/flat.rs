//! The accelerator of small scenes: no hierarchy, every primitive tested, triangles eight at a
//! time.
//!
//! A scene of a few dozen primitives (the Cornell boxes, SmallVCM's box) gains nothing from a
//! BVH: a ray visits most of its leaves anyway, and decoding compressed nodes costs more than
//! testing the triangles they hold. Here the triangles are stored as structure-of-arrays groups
//! of eight lanes (`v0`, `e1`, `e2` per axis) and tested with the same Möller-Trumbore
//! arithmetic as [`super::bvh`]'s scalar test, operation for operation, so a lane reports
//! bit for bit the distance and barycentrics the scalar test would. A group is tested in one
//! AVX register where the CPU has AVX (checked at run time, [`avx`]), else as two halves in
//! the x86-64 baseline's SSE registers; both give the same bits. Where the CPU also has
//! AVX-512 (F and VL) the same AVX test is compiled with those features as well, for their 32
//! vector registers: the search over the groups then keeps the ray, its constants and the
//! test's values in registers (with 16 its loop spilled to the stack: 15 % of the test's
//! profile samples on the Cornell box), with the same instructions' results, bit for bit.
//! Spheres are tested one by one. [`super::Accel::build`] picks this below [`FLAT_MAX_PRIMS`]
//! primitives. Batches of rays are tested sixteen at a time instead, each triangle and sphere
//! against all of them ([`packet`], with AVX-512 or AVX).

use super::prim::{Prim, SPHERE_TAG, intersect_prim};
use glam::{Vec2, Vec3A, Vec4};

mod lanes;
mod packet;
#[cfg(target_arch = "x86_64")]
mod packet_avx;

/// Scenes with at most this many primitives are tested without a hierarchy.
/// Measured (pt, one thread, bit-identical images): the Cornell box's 25 primitives render
/// 11 % faster than through the BVH, SmallVCM's 22 primitives 5 % faster under bdpt, lajolla's
/// and Bitterli's Cornell boxes (38 and 36 triangles) 1.9x faster, ajar's 87 primitives 38 %
/// slower.
pub const FLAT_MAX_PRIMS: usize = 48;

/// Triangles per group: eight, one per lane (two SSE registers, one AVX register).
const LANES: usize = 8;

/// One value per lane.
type Lanes = [f32; LANES];

/// Eight triangles, one per lane: vertex `a`, edges `b` and `c` (as in [`Prim`]), per axis.
/// Unused lanes hold zero edges, whose determinant is zero: they never report a hit.
/// Aligned to 32 bytes, so each row of eight (32 bytes) is one aligned AVX load: unaligned,
/// the x86-64-v2 build splits every 32-byte load in two.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
struct Group {
    a: [Lanes; 3],
    b: [Lanes; 3],
    c: [Lanes; 3],
}

/// Every primitive of a small scene: triangles in groups of eight, then spheres.
#[derive(Debug, Clone)]
pub struct Flat {
    groups: Vec<Group>,
    /// Index into the accelerator's primitive list of each triangle lane (`u32::MAX`: unused).
    lanes: Vec<u32>,
    /// Indices of the spheres in the primitive list.
    spheres: Vec<u32>,
    /// The triangles and spheres again, one by one, for packets of rays ([`packet`]).
    packet_tris: Vec<lanes::PacketTri>,
    packet_spheres: Vec<lanes::PacketSphere>,
    /// The instructions the running CPU has for the group test.
    isa: Isa,
}

/// The per-lane test: a mask of hits with `0 < t < t_max` and the lanes' `t`, `u`, `v`.
struct LaneHits {
    mask: u32,
    t: Lanes,
    u: Lanes,
    v: Lanes,
}

impl Flat {
    pub fn new(prims: &[Prim]) -> Flat {
        let (mut groups, mut lanes, mut spheres) = (Vec::new(), Vec::new(), Vec::new());
        let tris: Vec<u32> = (0..prims.len() as u32)
            .filter(|&i| {
                let sphere = prims[i as usize].tri == SPHERE_TAG;
                if sphere {
                    spheres.push(i);
                }
                !sphere
            })
            .collect();
        for chunk in tris.chunks(LANES) {
            let mut g = Group {
                a: [[0.0; LANES]; 3],
                b: [[0.0; LANES]; 3],
                c: [[0.0; LANES]; 3],
            };
            for (lane, &i) in chunk.iter().enumerate() {
                let p = &prims[i as usize];
                for axis in 0..3 {
                    g.a[axis][lane] = p.a[axis];
                    g.b[axis][lane] = p.b[axis];
                    g.c[axis][lane] = p.c[axis];
                }
            }
            groups.push(g);
            lanes.extend(chunk.iter().copied());
            lanes.extend(std::iter::repeat_n(u32::MAX, LANES - chunk.len()));
        }
        Flat {
            packet_tris: lanes::packet_tris(prims, &lanes),
            packet_spheres: lanes::packet_spheres(prims, &spheres),
            groups,
            lanes,
            spheres,
            isa: Isa::detect(),
        }
    }

    /// This list tested by the code for any x86-64 (for tests that compare both).
    #[cfg(test)]
    pub(super) fn without_avx(mut self) -> Flat {
        self.isa = Isa::Baseline;
        self
    }

    /// This list tested with AVX but without AVX-512 (where the CPU has AVX; for tests that
    /// compare the variants).
    #[cfg(test)]
    pub(super) fn without_avx512(mut self) -> Flat {
        self.isa = self.isa.min(Isa::Avx);
        self
    }

    /// The closest primitive along `o + t d` with `t < t_max`: its index in the primitive list,
    /// `t` and barycentrics.
    pub fn closest(
        &self,
        prims: &[Prim],
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
    ) -> Option<(usize, f32, Vec2)> {
        #[cfg(target_arch = "x86_64")]
        match self.isa {
            // SAFETY: `isa` names only features the running CPU reports (`Isa::detect`).
            Isa::Avx512 => return unsafe { self.closest_avx512(prims, o, d, t_max) },
            Isa::Avx => return unsafe { self.closest_avx(prims, o, d, t_max) },
            Isa::Baseline => {}
        }
        self.closest_lanes(prims, o, d, t_max, Group::test)
    }

    /// True if no primitive is hit along `o + t d` with `0 < t < t_max`.
    pub fn unoccluded(&self, prims: &[Prim], o: Vec3A, d: Vec3A, t_max: f32) -> bool {
        #[cfg(target_arch = "x86_64")]
        match self.isa {
            // SAFETY: as in `closest`.
            Isa::Avx512 => return unsafe { self.unoccluded_avx512(prims, o, d, t_max) },
            Isa::Avx => return unsafe { self.unoccluded_avx(prims, o, d, t_max) },
            Isa::Baseline => {}
        }
        self.unoccluded_lanes(prims, o, d, t_max, Group::test)
    }

    /// [`Flat::closest`] with each group tested in AVX registers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn closest_avx(
        &self,
        prims: &[Prim],
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
    ) -> Option<(usize, f32, Vec2)> {
        self.closest_lanes(prims, o, d, t_max, |g, o, d, t| avx::test(g, o, d, t))
    }

    /// [`Flat::unoccluded`] with each group tested in AVX registers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn unoccluded_avx(&self, prims: &[Prim], o: Vec3A, d: Vec3A, t_max: f32) -> bool {
        self.unoccluded_lanes(prims, o, d, t_max, |g, o, d, t| avx::test(g, o, d, t))
    }

    /// [`Flat::closest_avx`] compiled with AVX-512's registers at hand.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx512f,avx512vl")]
    fn closest_avx512(
        &self,
        prims: &[Prim],
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
    ) -> Option<(usize, f32, Vec2)> {
        self.closest_lanes(prims, o, d, t_max, |g, o, d, t| avx::test(g, o, d, t))
    }

    /// [`Flat::unoccluded_avx`] compiled with AVX-512's registers at hand.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx512f,avx512vl")]
    fn unoccluded_avx512(&self, prims: &[Prim], o: Vec3A, d: Vec3A, t_max: f32) -> bool {
        self.unoccluded_lanes(prims, o, d, t_max, |g, o, d, t| avx::test(g, o, d, t))
    }

    #[inline(always)]
    fn closest_lanes(
        &self,
        prims: &[Prim],
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        test: impl Fn(&Group, Vec3A, Vec3A, f32) -> LaneHits,
    ) -> Option<(usize, f32, Vec2)> {
        let mut best: Option<(usize, f32, Vec2)> = None;
        let mut t_best = t_max;
        for (gi, g) in self.groups.iter().enumerate() {
            let hits = test(g, o, d, t_best);
            if hits.mask == 0 {
                continue;
            }
            // The hit lanes in increasing order (usually one or two of the eight).
            let mut mask = hits.mask;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                // Strictly closer only, as the scalar test's `t < t_max`.
                if hits.t[lane] < t_best {
                    t_best = hits.t[lane];
                    let uv = Vec2::new(hits.u[lane], hits.v[lane]);
                    best = Some((self.lanes[LANES * gi + lane] as usize, t_best, uv));
                }
            }
        }
        for &i in &self.spheres {
            let (t, uv) = intersect_prim(&prims[i as usize], o, d, t_best);
            if t < t_best {
                t_best = t;
                best = Some((i as usize, t, uv));
            }
        }
        best
    }

    #[inline(always)]
    fn unoccluded_lanes(
        &self,
        prims: &[Prim],
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        test: impl Fn(&Group, Vec3A, Vec3A, f32) -> LaneHits,
    ) -> bool {
        self.groups.iter().all(|g| test(g, o, d, t_max).mask == 0)
            && self
                .spheres
                .iter()
                .all(|&i| intersect_prim(&prims[i as usize], o, d, t_max).0 >= t_max)
    }
}

/// The instructions a group test may use, in increasing order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Isa {
    /// The x86-64 baseline (two SSE halves), or any other architecture.
    Baseline,
    /// One AVX register per group.
    Avx,
    /// The AVX test with AVX-512 F and VL enabled around it (32 vector registers).
    Avx512,
}

impl Isa {
    /// What the running CPU has (checked once per accelerator).
    fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("avx") && has!("avx512f") && has!("avx512vl") {
                return Isa::Avx512;
            }
            if has!("avx") {
                return Isa::Avx;
            }
        }
        Isa::Baseline
    }
}

/// `p x q` for lanes, written as glam's `Vec3A::cross` computes each component (no fused
/// operations), so each lane's value is the scalar test's.
#[inline(always)]
fn cross(p: [Vec4; 3], q: [Vec4; 3]) -> [Vec4; 3] {
    [
        p[1] * q[2] - p[2] * q[1],
        p[2] * q[0] - p[0] * q[2],
        p[0] * q[1] - p[1] * q[0],
    ]
}

/// `p . q` for lanes in glam's `Vec3A::dot` order: `(x x' + y y') + z z'`.
#[inline(always)]
fn dot(p: [Vec4; 3], q: [Vec4; 3]) -> Vec4 {
    (p[0] * q[0] + p[1] * q[1]) + p[2] * q[2]
}

impl Group {
    /// Möller-Trumbore on eight lanes, exactly [`super::bvh`]'s scalar test per lane: two
    /// halves of four in SSE registers (the x86-64 baseline).
    #[inline(always)]
    fn test(&self, o: Vec3A, d: Vec3A, t_max: f32) -> LaneHits {
        let lo = self.test4(0, o, d, t_max);
        let hi = self.test4(4, o, d, t_max);
        let join = |l: Vec4, h: Vec4| -> Lanes {
            std::array::from_fn(|i| if i < 4 { l[i] } else { h[i - 4] })
        };
        LaneHits {
            mask: lo.0 | hi.0 << 4,
            t: join(lo.1, hi.1),
            u: join(lo.2, hi.2),
            v: join(lo.3, hi.3),
        }
    }

    /// Lanes `first .. first + 4`: their hit mask, `t`, `u` and `v`.
    #[inline(always)]
    fn test4(&self, first: usize, o: Vec3A, d: Vec3A, t_max: f32) -> (u32, Vec4, Vec4, Vec4) {
        let half = |x: &[Lanes; 3]| x.map(|axis| Vec4::from_slice(&axis[first..first + 4]));
        let (a, b, c) = (half(&self.a), half(&self.b), half(&self.c));
        let ds = [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)];
        let pvec = cross(ds, c);
        let det = dot(b, pvec);
        let tvec = [
            Vec4::splat(o.x) - a[0],
            Vec4::splat(o.y) - a[1],
            Vec4::splat(o.z) - a[2],
        ];
        let u_det = dot(tvec, pvec);
        let qvec = cross(tvec, b);
        let v_det = dot(ds, qvec);
        let t_det = dot(c, qvec);
        let (sign, abs_det) = (det.signum(), det.abs());
        let (u_s, v_s, t_s) = (u_det * sign, v_det * sign, t_det * sign);
        let usable = det.cmpne(Vec4::ZERO) & det.is_finite_mask();
        let inside = u_s.cmpge(Vec4::ZERO)
            & v_s.cmpge(Vec4::ZERO)
            & (u_s + v_s).cmple(abs_det)
            & t_s.cmpgt(Vec4::ZERO);
        let mask = (usable & inside).bitmask();
        if mask == 0 {
            return (0, Vec4::ZERO, Vec4::ZERO, Vec4::ZERO);
        }
        let inv_det = Vec4::ONE / det;
        let t = t_det * inv_det;
        let mask = mask & t.cmplt(Vec4::splat(t_max)).bitmask();
        (mask, t, u_det * inv_det, v_det * inv_det)
    }
}

/// [`Group::test`] in AVX registers: the same operations in the same order on all eight lanes
/// at once (no fused multiply-add), so every lane's `t`, `u`, `v` and mask are bit for bit
/// the portable test's.
#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{Group, LANES, LaneHits, Lanes};
    use glam::Vec3A;
    use std::arch::x86_64::*;

    #[inline]
    #[target_feature(enable = "avx")]
    fn load(x: &Lanes) -> __m256 {
        debug_assert_eq!(x.as_ptr() as usize % 32, 0);
        // SAFETY: `x` is eight readable f32s, a row of a `Group`: 32-byte aligned, as the
        // aligned load requires (a `Group` is `align(32)` and its rows are 32 bytes each).
        unsafe { _mm256_load_ps(x.as_ptr()) }
    }

    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) fn store(x: __m256) -> Lanes {
        let mut out = [0.0; LANES];
        // SAFETY: `out` is eight writable f32s; the store has no alignment requirement.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), x) };
        out
    }

    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) fn cross(p: [__m256; 3], q: [__m256; 3]) -> [__m256; 3] {
        let m = _mm256_mul_ps;
        [
            _mm256_sub_ps(m(p[1], q[2]), m(p[2], q[1])),
            _mm256_sub_ps(m(p[2], q[0]), m(p[0], q[2])),
            _mm256_sub_ps(m(p[0], q[1]), m(p[1], q[0])),
        ]
    }

    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) fn dot(p: [__m256; 3], q: [__m256; 3]) -> __m256 {
        let m = _mm256_mul_ps;
        _mm256_add_ps(_mm256_add_ps(m(p[0], q[0]), m(p[1], q[1])), m(p[2], q[2]))
    }

    /// The lanes (all bits set) whose ray crosses the triangle at `t > 0`, decided from `det`,
    /// `u_det`, `v_det` and `t_det` as the scalar test decides (a usable `det`, then the
    /// scaled barycentrics and distance compared after flipping them to `det`'s sign).
    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) fn inside_mask(det: __m256, u_det: __m256, v_det: __m256, t_det: __m256) -> __m256 {
        // signum (±1 with det's sign; NaN lanes are dropped by `usable`) and |det|.
        let neg_zero = _mm256_set1_ps(-0.0);
        let sign = _mm256_or_ps(_mm256_and_ps(det, neg_zero), _mm256_set1_ps(1.0));
        let abs_det = _mm256_andnot_ps(neg_zero, det);
        let (u_s, v_s, t_s) = (
            _mm256_mul_ps(u_det, sign),
            _mm256_mul_ps(v_det, sign),
            _mm256_mul_ps(t_det, sign),
        );
        let zero = _mm256_setzero_ps();
        let usable = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_NEQ_OQ>(det, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(abs_det, _mm256_set1_ps(f32::INFINITY)),
        );
        let inside = _mm256_and_ps(
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(u_s, zero),
                _mm256_cmp_ps::<_CMP_GE_OQ>(v_s, zero),
            ),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_add_ps(u_s, v_s), abs_det),
                _mm256_cmp_ps::<_CMP_GT_OQ>(t_s, zero),
            ),
        );
        _mm256_and_ps(usable, inside)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) fn test(g: &Group, o: Vec3A, d: Vec3A, t_max: f32) -> LaneHits {
        let ld3 = |x: &[Lanes; 3]| [load(&x[0]), load(&x[1]), load(&x[2])];
        let (a, b, c) = (ld3(&g.a), ld3(&g.b), ld3(&g.c));
        let ds = [
            _mm256_set1_ps(d.x),
            _mm256_set1_ps(d.y),
            _mm256_set1_ps(d.z),
        ];
        let pvec = cross(ds, c);
        let det = dot(b, pvec);
        let tvec = [
            _mm256_sub_ps(_mm256_set1_ps(o.x), a[0]),
            _mm256_sub_ps(_mm256_set1_ps(o.y), a[1]),
            _mm256_sub_ps(_mm256_set1_ps(o.z), a[2]),
        ];
        let u_det = dot(tvec, pvec);
        let qvec = cross(tvec, b);
        let v_det = dot(ds, qvec);
        let t_det = dot(c, qvec);
        let mut mask = _mm256_movemask_ps(inside_mask(det, u_det, v_det, t_det)) as u32;
        if mask == 0 {
            return LaneHits {
                mask,
                t: [0.0; LANES],
                u: [0.0; LANES],
                v: [0.0; LANES],
            };
        }
        let inv_det = _mm256_div_ps(_mm256_set1_ps(1.0), det);
        let t = _mm256_mul_ps(t_det, inv_det);
        mask &= _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(t_max))) as u32;
        LaneHits {
            mask,
            t: store(t),
            u: store(_mm256_mul_ps(u_det, inv_det)),
            v: store(_mm256_mul_ps(v_det, inv_det)),
        }
    }
}
