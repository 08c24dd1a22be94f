//! The lanes' numbers and flags in AVX registers: [`F`] is two `__m256` (lanes 0-7 and
//! 8-15), [`M`] two `__m256` of all-ones or all-zero lanes (AVX has no mask registers).
//!
//! Every operation is the AVX-512 one's (`simd_avx512.rs`) on each half: the same IEEE
//! operations, the same instruction semantics for `min` and `max`, so a lane's bits are the
//! same under either instruction set. The operations call AVX and AVX2 intrinsics from
//! `#[inline(always)]` functions without the target feature, so they must only run inlined
//! into a function compiled with `avx2` on a CPU that has it: the kernel entry
//! `wavefront::avx2::rounds` is the only user, and its caller checks the CPU. `lanes.rs`
//! states what each operation must compute.

use crate::integrators::pt::wavefront::W;
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

/// `unsafe { $e }` for the AVX and AVX2 intrinsics of this module.
macro_rules! simd {
    ($e:expr) => {
        // SAFETY: every function of this module runs inlined into `avx2::rounds`, compiled
        // with `avx2` (which implies `avx`) and called only after the CPU was found to have
        // it (module doc); the intrinsics used have no other requirement (unaligned loads
        // and stores of arrays of sixteen f32 or i32, at offsets 0 and 8).
        {
            #[allow(unused_unsafe)]
            let v = unsafe { $e };
            v
        }
    };
}

/// `F` or `M` from the same operation on both halves: `$e` is evaluated with `$h` false for
/// lanes 0-7 and true for lanes 8-15, and reads its operands' halves with `Halves::half`.
macro_rules! halves {
    ($t:ident, |$h:ident| $e:expr) => {{
        $t {
            lo: {
                let $h = false;
                $e
            },
            hi: {
                let $h = true;
                $e
            },
        }
    }};
}

/// The register of lanes 0-7 (`hi` false) or 8-15 (`hi` true).
trait Halves {
    fn half(&self, hi: bool) -> __m256;
}

impl Halves for F {
    #[inline(always)]
    fn half(&self, hi: bool) -> __m256 {
        if hi { self.hi } else { self.lo }
    }
}

impl Halves for M {
    #[inline(always)]
    fn half(&self, hi: bool) -> __m256 {
        if hi { self.hi } else { self.lo }
    }
}

/// One `f32` per lane.
#[derive(Clone, Copy)]
pub struct F {
    lo: __m256,
    hi: __m256,
}

/// One flag per lane: all bits set where it holds.
#[derive(Clone, Copy)]
pub struct M {
    lo: __m256,
    hi: __m256,
}

const SIGN: i32 = i32::MIN;

#[inline(always)]
fn sign() -> __m256 {
    simd!(_mm256_castsi256_ps(_mm256_set1_epi32(SIGN)))
}

impl F {
    #[inline(always)]
    pub fn splat(v: f32) -> F {
        let r = simd!(_mm256_set1_ps(v));
        F { lo: r, hi: r }
    }

    #[inline(always)]
    pub fn from_array(a: &[f32; W]) -> F {
        simd!(F {
            lo: _mm256_loadu_ps(a.as_ptr()),
            hi: _mm256_loadu_ps(a.as_ptr().add(8)),
        })
    }

    #[inline(always)]
    pub fn to_array(self) -> [f32; W] {
        let mut out = [0.0; W];
        simd!(_mm256_storeu_ps(out.as_mut_ptr(), self.lo));
        simd!(_mm256_storeu_ps(out.as_mut_ptr().add(8), self.hi));
        out
    }

    #[inline(always)]
    pub fn sqrt(self) -> F {
        halves!(F, |h| simd!(_mm256_sqrt_ps(self.half(h))))
    }

    /// `f32::floor` per lane.
    #[inline(always)]
    pub fn floor(self) -> F {
        halves!(F, |h| simd!(_mm256_floor_ps(self.half(h))))
    }

    #[inline(always)]
    pub fn abs(self) -> F {
        halves!(F, |h| simd!(_mm256_andnot_ps(sign(), self.half(h))))
    }

    #[inline(always)]
    pub fn is_nan(self) -> M {
        halves!(M, |h| simd!(_mm256_cmp_ps::<_CMP_UNORD_Q>(
            self.half(h),
            self.half(h)
        )))
    }

    /// The instruction's minimum: the second operand where either is NaN.
    #[inline(always)]
    pub fn min_raw(self, o: F) -> F {
        halves!(F, |h| simd!(_mm256_min_ps(self.half(h), o.half(h))))
    }

    /// The instruction's maximum: the second operand where either is NaN.
    #[inline(always)]
    pub fn max_raw(self, o: F) -> F {
        halves!(F, |h| simd!(_mm256_max_ps(self.half(h), o.half(h))))
    }

    #[inline(always)]
    pub fn copysign(self, s: F) -> F {
        halves!(F, |h| simd!(_mm256_or_ps(
            _mm256_andnot_ps(sign(), self.half(h)),
            _mm256_and_ps(sign(), s.half(h))
        )))
    }

    #[inline(always)]
    pub fn lt(self, o: F) -> M {
        halves!(M, |h| simd!(_mm256_cmp_ps::<_CMP_LT_OQ>(
            self.half(h),
            o.half(h)
        )))
    }

    #[inline(always)]
    pub fn le(self, o: F) -> M {
        halves!(M, |h| simd!(_mm256_cmp_ps::<_CMP_LE_OQ>(
            self.half(h),
            o.half(h)
        )))
    }

    #[inline(always)]
    pub fn gt(self, o: F) -> M {
        halves!(M, |h| simd!(_mm256_cmp_ps::<_CMP_GT_OQ>(
            self.half(h),
            o.half(h)
        )))
    }

    #[inline(always)]
    pub fn ge(self, o: F) -> M {
        halves!(M, |h| simd!(_mm256_cmp_ps::<_CMP_GE_OQ>(
            self.half(h),
            o.half(h)
        )))
    }

    #[inline(always)]
    pub fn eq(self, o: F) -> M {
        halves!(M, |h| simd!(_mm256_cmp_ps::<_CMP_EQ_OQ>(
            self.half(h),
            o.half(h)
        )))
    }

    #[inline(always)]
    pub fn select(m: M, a: F, b: F) -> F {
        F {
            lo: simd!(_mm256_blendv_ps(b.lo, a.lo, m.lo)),
            hi: simd!(_mm256_blendv_ps(b.hi, a.hi, m.hi)),
        }
    }

    #[inline(always)]
    pub fn next_away(x: F, dir: F) -> F {
        let (zero, at_rest) = (x.eq(F::splat(0.0)), dir.eq(F::splat(0.0)));
        halves!(F, |h| next_away_half(
            x.half(h),
            dir.half(h),
            zero.half(h),
            at_rest.half(h)
        ))
    }
}

/// [`F::next_away`] on one half, given where `x` and `dir` are zero.
#[inline(always)]
fn next_away_half(x: __m256, dir: __m256, zero: __m256, at_rest: __m256) -> __m256 {
    simd!({
        let (bits, dir_bits) = (_mm256_castps_si256(x), _mm256_castps_si256(dir));
        let one = _mm256_set1_epi32(1);
        // The sign bit of `disagree` is set where x and dir have opposite signs, which is
        // what `blendv` reads.
        let disagree = _mm256_castsi256_ps(_mm256_xor_si256(bits, dir_bits));
        let stepped = _mm256_blendv_ps(
            _mm256_castsi256_ps(_mm256_add_epi32(bits, one)),
            _mm256_castsi256_ps(_mm256_sub_epi32(bits, one)),
            disagree,
        );
        let smallest = _mm256_castsi256_ps(_mm256_or_si256(
            one,
            _mm256_and_si256(dir_bits, _mm256_set1_epi32(SIGN)),
        ));
        let moved = _mm256_blendv_ps(stepped, smallest, zero);
        _mm256_blendv_ps(moved, x, at_rest)
    })
}

macro_rules! binary {
    ($tr:ident, $f:ident, $intrinsic:ident) => {
        impl $tr for F {
            type Output = F;
            #[inline(always)]
            fn $f(self, o: F) -> F {
                halves!(F, |h| simd!($intrinsic(self.half(h), o.half(h))))
            }
        }
    };
}
binary!(Add, add, _mm256_add_ps);
binary!(Sub, sub, _mm256_sub_ps);
binary!(Mul, mul, _mm256_mul_ps);
binary!(Div, div, _mm256_div_ps);

impl Neg for F {
    type Output = F;
    #[inline(always)]
    fn neg(self) -> F {
        halves!(F, |h| simd!(_mm256_xor_ps(self.half(h), sign())))
    }
}

impl M {
    #[inline(always)]
    pub fn from_bools(a: &[bool; W]) -> M {
        let words: [i32; W] = std::array::from_fn(|i| -(a[i] as i32));
        simd!(M {
            lo: _mm256_castsi256_ps(_mm256_loadu_si256(words.as_ptr().cast())),
            hi: _mm256_castsi256_ps(_mm256_loadu_si256(words.as_ptr().add(8).cast())),
        })
    }

    /// Bit `i` set where lane `i` holds.
    #[inline(always)]
    pub fn bits(self) -> u16 {
        let (lo, hi) = simd!((_mm256_movemask_ps(self.lo), _mm256_movemask_ps(self.hi)));
        (lo as u16) | (hi as u16) << 8
    }
}

macro_rules! logic {
    ($tr:ident, $f:ident, $intrinsic:ident) => {
        impl $tr for M {
            type Output = M;
            #[inline(always)]
            fn $f(self, o: M) -> M {
                halves!(M, |h| simd!($intrinsic(self.half(h), o.half(h))))
            }
        }
    };
}
logic!(BitAnd, bitand, _mm256_and_ps);
logic!(BitOr, bitor, _mm256_or_ps);
logic!(BitXor, bitxor, _mm256_xor_ps);

impl Not for M {
    type Output = M;
    #[inline(always)]
    fn not(self) -> M {
        let ones = simd!(_mm256_castsi256_ps(_mm256_set1_epi32(-1)));
        halves!(M, |h| simd!(_mm256_xor_ps(self.half(h), ones)))
    }
}
