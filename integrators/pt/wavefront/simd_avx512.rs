//! The lanes' numbers and flags in AVX-512 registers: [`F`] is one `__m512` (sixteen `f32`),
//! [`M`] a sixteen-bit mask register's value.
//!
//! The operations call AVX-512F intrinsics from `#[inline(always)]` functions without the
//! target feature (operator traits cannot carry one), so they must only run inlined into a
//! function compiled with `avx512f` on a CPU that has it: the kernel entry
//! `wavefront::avx512::rounds` is the only user, and its caller checks the CPU. `lanes.rs`
//! states what each operation must compute.

use crate::integrators::pt::wavefront::W;
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

/// `unsafe { $e }` for the AVX-512F intrinsics of this module.
macro_rules! simd {
    ($e:expr) => {
        // SAFETY: every function of this module runs inlined into `avx512::rounds`, compiled
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
#[derive(Clone, Copy)]
pub struct M(u16);

const SIGN: i32 = i32::MIN;

impl F {
    #[inline(always)]
    pub fn splat(v: f32) -> F {
        simd!(F(_mm512_set1_ps(v)))
    }

    #[inline(always)]
    pub fn from_array(a: &[f32; W]) -> F {
        simd!(F(_mm512_loadu_ps(a.as_ptr())))
    }

    #[inline(always)]
    pub fn to_array(self) -> [f32; W] {
        let mut out = [0.0; W];
        simd!(_mm512_storeu_ps(out.as_mut_ptr(), self.0));
        out
    }

    #[inline(always)]
    fn bits(self) -> __m512i {
        simd!(_mm512_castps_si512(self.0))
    }

    #[inline(always)]
    fn from_bits(b: __m512i) -> F {
        simd!(F(_mm512_castsi512_ps(b)))
    }

    #[inline(always)]
    pub fn sqrt(self) -> F {
        simd!(F(_mm512_sqrt_ps(self.0)))
    }

    #[inline(always)]
    pub fn abs(self) -> F {
        simd!(F(_mm512_abs_ps(self.0)))
    }

    /// `f32::floor` per lane.
    #[inline(always)]
    pub fn floor(self) -> F {
        simd!(F(_mm512_roundscale_ps::<
            { _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC },
        >(self.0)))
    }

    #[inline(always)]
    pub fn is_nan(self) -> M {
        simd!(M(_mm512_cmp_ps_mask::<_CMP_UNORD_Q>(self.0, self.0)))
    }

    /// The instruction's minimum: the second operand where either is NaN.
    #[inline(always)]
    pub fn min_raw(self, o: F) -> F {
        simd!(F(_mm512_min_ps(self.0, o.0)))
    }

    /// The instruction's maximum: the second operand where either is NaN.
    #[inline(always)]
    pub fn max_raw(self, o: F) -> F {
        simd!(F(_mm512_max_ps(self.0, o.0)))
    }

    #[inline(always)]
    pub fn copysign(self, sign: F) -> F {
        let s = simd!(_mm512_set1_epi32(SIGN));
        simd!(F::from_bits(_mm512_or_si512(
            _mm512_andnot_si512(s, self.bits()),
            _mm512_and_si512(s, sign.bits())
        )))
    }

    #[inline(always)]
    pub fn lt(self, o: F) -> M {
        simd!(M(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn le(self, o: F) -> M {
        simd!(M(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn gt(self, o: F) -> M {
        simd!(M(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn ge(self, o: F) -> M {
        simd!(M(_mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn eq(self, o: F) -> M {
        simd!(M(_mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    pub fn select(m: M, a: F, b: F) -> F {
        simd!(F(_mm512_mask_blend_ps(m.0, b.0, a.0)))
    }

    #[inline(always)]
    pub fn next_away(x: F, dir: F) -> F {
        let (bits, dir_bits) = (x.bits(), dir.bits());
        let (sign, one) = simd!((_mm512_set1_epi32(SIGN), _mm512_set1_epi32(1)));
        let disagree = simd!(_mm512_test_epi32_mask(
            _mm512_xor_si512(bits, dir_bits),
            sign
        ));
        let stepped = simd!(_mm512_mask_blend_epi32(
            disagree,
            _mm512_add_epi32(bits, one),
            _mm512_sub_epi32(bits, one)
        ));
        let smallest = simd!(_mm512_or_si512(one, _mm512_and_si512(dir_bits, sign)));
        let moved = simd!(_mm512_mask_blend_epi32(
            x.eq(F::splat(0.0)).0,
            stepped,
            smallest
        ));
        F::select(dir.eq(F::splat(0.0)), x, F::from_bits(moved))
    }
}

macro_rules! binary {
    ($tr:ident, $f:ident, $intrinsic:ident) => {
        impl $tr for F {
            type Output = F;
            #[inline(always)]
            fn $f(self, o: F) -> F {
                simd!(F($intrinsic(self.0, o.0)))
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
        simd!(F::from_bits(_mm512_xor_si512(
            self.bits(),
            _mm512_set1_epi32(SIGN)
        )))
    }
}

impl M {
    #[inline(always)]
    pub fn from_bools(a: &[bool; W]) -> M {
        M(a.iter()
            .enumerate()
            .fold(0, |m, (i, &b)| m | ((b as u16) << i)))
    }

    /// Bit `i` set where lane `i` holds.
    #[inline(always)]
    pub fn bits(self) -> u16 {
        self.0
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
