//! Sixteen lanes of `f32` in an AVX-512 register: the value type of the wavefront kernel
//! (`shade.rs`).
//!
//! [`F`] holds one number of each of sixteen paths, [`M`] one flag of each (a mask), [`V3`]
//! one vector of each (three [`F`], structure of arrays). Each operation is the scalar
//! operation lane by lane (no fused multiply-add, no reassociation; `min` and `max` treat NaN
//! as `f32::min` does), so a lane computes exactly what scalar code computes. [`V3`]'s
//! products and sums are glam's `Vec3` ones term for term (`dot` is `(x x') + (y y') + (z
//! z')`), so the kernel can repeat scalar pt's arithmetic bit for bit.
//!
//! **Only under AVX-512.** The operations call AVX-512F intrinsics from `#[inline(always)]`
//! functions without the target feature (operator traits cannot carry one), so they must
//! only run inlined into a function compiled with `avx512f` on a CPU that has it: the kernel
//! (`PathTracer::rounds_avx512`) is the only user, and its caller checks the CPU. Written
//! with the portable arrays of `std::array::from_fn`, the same kernel compiled to scalar
//! code (LLVM unrolled the lanes before vectorising) and ran 1.3x slower than shading path
//! by path; these intrinsics are what make the lanes vector instructions.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

/// Paths per kernel call: one AVX-512 register of `f32`.
pub const W: usize = 16;

/// `unsafe { $e }` for the AVX-512F intrinsics of this module.
macro_rules! avx512 {
    ($e:expr) => {
        // SAFETY: every function of this module runs inlined into `rounds_avx512`, compiled
        // with `avx512f` and called only after the CPU was found to have it (module doc);
        // the intrinsics used have no other requirement (unaligned loads and stores of
        // arrays of sixteen f32).
        {
            #[allow(unused_unsafe)]
            let v = unsafe { $e };
            v
        }
    };
}

/// One `f32` per lane.
#[derive(Clone, Copy)]
pub struct F(__m512);

/// One flag per lane (bit `i` for lane `i`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct M(pub u16);

/// Sixteen vectors in memory, component by component (what [`V3`] loads and stores).
#[derive(Clone, Copy, Default)]
pub struct Soa3 {
    pub x: [f32; W],
    pub y: [f32; W],
    pub z: [f32; W],
}

impl Soa3 {
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: glam::Vec3) {
        (self.x[i], self.y[i], self.z[i]) = (v.x, v.y, v.z);
    }

    #[inline(always)]
    pub fn get(&self, i: usize) -> glam::Vec3 {
        glam::Vec3::new(self.x[i], self.y[i], self.z[i])
    }
}

/// One vector per lane.
#[derive(Clone, Copy)]
pub struct V3 {
    pub x: F,
    pub y: F,
    pub z: F,
}

const SIGN: i32 = i32::MIN;

impl F {
    #[inline(always)]
    pub fn splat(v: f32) -> F {
        avx512!(F(_mm512_set1_ps(v)))
    }

    #[inline(always)]
    pub fn zero() -> F {
        F::splat(0.0)
    }

    #[inline(always)]
    pub fn one() -> F {
        F::splat(1.0)
    }

    #[inline(always)]
    pub fn from_array(a: &[f32; W]) -> F {
        avx512!(F(_mm512_loadu_ps(a.as_ptr())))
    }

    #[inline(always)]
    pub fn to_array(self) -> [f32; W] {
        let mut out = [0.0; W];
        avx512!(_mm512_storeu_ps(out.as_mut_ptr(), self.0));
        out
    }

    #[inline(always)]
    fn bits(self) -> __m512i {
        avx512!(_mm512_castps_si512(self.0))
    }

    #[inline(always)]
    fn from_bits(b: __m512i) -> F {
        avx512!(F(_mm512_castsi512_ps(b)))
    }

    #[inline(always)]
    pub fn sqrt(self) -> F {
        avx512!(F(_mm512_sqrt_ps(self.0)))
    }

    #[inline(always)]
    pub fn abs(self) -> F {
        avx512!(F(_mm512_abs_ps(self.0)))
    }

    #[inline(always)]
    fn is_nan(self) -> M {
        avx512!(M(_mm512_cmp_ps_mask::<_CMP_UNORD_Q>(self.0, self.0)))
    }

    /// `f32::min` per lane (a NaN operand gives the other one).
    #[inline(always)]
    pub fn min(self, o: F) -> F {
        let m = avx512!(F(_mm512_min_ps(self.0, o.0)));
        F::select(self.is_nan(), o, F::select(o.is_nan(), self, m))
    }

    /// `f32::max` per lane (a NaN operand gives the other one).
    #[inline(always)]
    pub fn max(self, o: F) -> F {
        let m = avx512!(F(_mm512_max_ps(self.0, o.0)));
        F::select(self.is_nan(), o, F::select(o.is_nan(), self, m))
    }

    /// `f32::copysign` per lane.
    #[inline(always)]
    pub fn copysign(self, sign: F) -> F {
        let s = avx512!(_mm512_set1_epi32(SIGN));
        avx512!(F::from_bits(_mm512_or_si512(
            _mm512_andnot_si512(s, self.bits()),
            _mm512_and_si512(s, sign.bits())
        )))
    }

    /// `f32::signum` per lane: +-1 by the sign bit, NaN stays NaN.
    #[inline(always)]
    pub fn signum(self) -> F {
        F::select(self.is_nan(), self, F::one().copysign(self))
    }

    #[inline(always)]
    pub fn lt(self, o: F) -> M {
        avx512!(M(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn le(self, o: F) -> M {
        avx512!(M(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn gt(self, o: F) -> M {
        avx512!(M(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn ge(self, o: F) -> M {
        avx512!(M(_mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn eq(self, o: F) -> M {
        avx512!(M(_mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, o.0)))
    }

    /// `f32::is_finite` per lane.
    #[inline(always)]
    pub fn is_finite(self) -> M {
        self.abs().lt(F::splat(f32::INFINITY))
    }

    /// `m ? a : b` per lane.
    #[inline(always)]
    pub fn select(m: M, a: F, b: F) -> F {
        avx512!(F(_mm512_mask_blend_ps(m.0, b.0, a.0)))
    }

    /// `geometry::next_away(x, dir)` per lane: `x` moved one ulp in the direction of `dir`
    /// (unchanged for `dir == 0`, the smallest subnormal with `dir`'s sign for `x == 0`).
    #[inline(always)]
    pub fn next_away(x: F, dir: F) -> F {
        let (bits, dir_bits) = (x.bits(), dir.bits());
        let (sign, one) = avx512!((_mm512_set1_epi32(SIGN), _mm512_set1_epi32(1)));
        let disagree = avx512!(_mm512_test_epi32_mask(
            _mm512_xor_si512(bits, dir_bits),
            sign
        ));
        let stepped = avx512!(_mm512_mask_blend_epi32(
            disagree,
            _mm512_add_epi32(bits, one),
            _mm512_sub_epi32(bits, one)
        ));
        let smallest = avx512!(_mm512_or_si512(one, _mm512_and_si512(dir_bits, sign)));
        let moved = avx512!(_mm512_mask_blend_epi32(
            x.eq(F::zero()).0,
            stepped,
            smallest
        ));
        F::select(dir.eq(F::zero()), x, F::from_bits(moved))
    }
}

macro_rules! binary {
    ($tr:ident, $f:ident, $intrinsic:ident) => {
        impl $tr for F {
            type Output = F;
            #[inline(always)]
            fn $f(self, o: F) -> F {
                avx512!(F($intrinsic(self.0, o.0)))
            }
        }
        impl $tr<f32> for F {
            type Output = F;
            #[inline(always)]
            fn $f(self, o: f32) -> F {
                self.$f(F::splat(o))
            }
        }
        impl $tr<F> for f32 {
            type Output = F;
            #[inline(always)]
            fn $f(self, o: F) -> F {
                F::splat(self).$f(o)
            }
        }
    };
}
binary!(Add, add, _mm512_add_ps);
binary!(Sub, sub, _mm512_sub_ps);
binary!(Mul, mul, _mm512_mul_ps);
binary!(Div, div, _mm512_div_ps);

impl Neg for F {
    type Output = F;
    #[inline(always)]
    fn neg(self) -> F {
        avx512!(F::from_bits(_mm512_xor_si512(
            self.bits(),
            _mm512_set1_epi32(SIGN)
        )))
    }
}

impl M {
    /// Lane `i` is `a[i]`.
    #[inline(always)]
    pub fn from_bools(a: &[bool; W]) -> M {
        M(a.iter()
            .enumerate()
            .fold(0, |m, (i, &b)| m | ((b as u16) << i)))
    }

    #[inline(always)]
    pub fn lane(self, i: usize) -> bool {
        self.0 >> i & 1 != 0
    }
}

impl BitAnd for M {
    type Output = M;
    #[inline(always)]
    fn bitand(self, o: M) -> M {
        M(self.0 & o.0)
    }
}

impl BitOr for M {
    type Output = M;
    #[inline(always)]
    fn bitor(self, o: M) -> M {
        M(self.0 | o.0)
    }
}

impl BitXor for M {
    type Output = M;
    #[inline(always)]
    fn bitxor(self, o: M) -> M {
        M(self.0 ^ o.0)
    }
}

impl Not for M {
    type Output = M;
    #[inline(always)]
    fn not(self) -> M {
        M(!self.0)
    }
}

impl V3 {
    #[inline(always)]
    pub fn new(x: F, y: F, z: F) -> V3 {
        V3 { x, y, z }
    }

    #[inline(always)]
    pub fn zero() -> V3 {
        V3::new(F::zero(), F::zero(), F::zero())
    }

    #[inline(always)]
    pub fn splat(v: F) -> V3 {
        V3::new(v, v, v)
    }

    #[inline(always)]
    pub fn load(a: &Soa3) -> V3 {
        V3::new(
            F::from_array(&a.x),
            F::from_array(&a.y),
            F::from_array(&a.z),
        )
    }

    #[inline(always)]
    pub fn store(self) -> Soa3 {
        Soa3 {
            x: self.x.to_array(),
            y: self.y.to_array(),
            z: self.z.to_array(),
        }
    }

    #[inline(always)]
    pub fn dot(self, o: V3) -> F {
        (self.x * o.x) + (self.y * o.y) + (self.z * o.z)
    }

    #[inline(always)]
    pub fn length_squared(self) -> F {
        self.dot(self)
    }

    #[inline(always)]
    pub fn length(self) -> F {
        self.dot(self).sqrt()
    }

    #[inline(always)]
    pub fn abs(self) -> V3 {
        V3::new(self.x.abs(), self.y.abs(), self.z.abs())
    }

    /// Every component of the lane is finite.
    #[inline(always)]
    pub fn is_finite(self) -> M {
        self.x.is_finite() & self.y.is_finite() & self.z.is_finite()
    }

    /// All three components of the lane are zero (glam's `== Vec3::ZERO`).
    #[inline(always)]
    pub fn is_zero(self) -> M {
        let z = F::zero();
        self.x.eq(z) & self.y.eq(z) & self.z.eq(z)
    }

    #[inline(always)]
    pub fn select(m: M, a: V3, b: V3) -> V3 {
        V3 {
            x: F::select(m, a.x, b.x),
            y: F::select(m, a.y, b.y),
            z: F::select(m, a.z, b.z),
        }
    }
}

impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

/// Componentwise (glam's `Vec3 * Vec3`).
impl Mul for V3 {
    type Output = V3;
    #[inline(always)]
    fn mul(self, o: V3) -> V3 {
        V3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

/// Each lane's vector times the lane's number (glam's `Vec3 * f32`).
impl Mul<F> for V3 {
    type Output = V3;
    #[inline(always)]
    fn mul(self, s: F) -> V3 {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Div<F> for V3 {
    type Output = V3;
    #[inline(always)]
    fn div(self, s: F) -> V3 {
        V3::new(self.x / s, self.y / s, self.z / s)
    }
}

impl Neg for V3 {
    type Output = V3;
    #[inline(always)]
    fn neg(self) -> V3 {
        V3::new(-self.x, -self.y, -self.z)
    }
}
