//! Sixteen lanes of `f32`: the value type of the wavefront kernel (`shade.rs`).
//!
//! [`F`] holds one number of each of sixteen paths, [`M`] one flag of each (a mask), [`V3`]
//! one vector of each (three [`F`], structure of arrays). Each operation is the scalar
//! operation lane by lane (no fused multiply-add, no reassociation; `min` and `max` treat NaN
//! as `f32::min` does), so a lane computes exactly what scalar code computes. [`V3`]'s
//! products and sums are glam's `Vec3` ones term for term (`dot` is `(x x') + (y y') + (z
//! z')`), so the kernel can repeat scalar pt's arithmetic bit for bit.
//!
//! `F` and `M` and their primitive operations come from the instruction set the kernel is
//! compiled for (`super::simd`: `simd_avx512.rs`, one register of sixteen lanes, or
//! `simd_avx2.rs`, two registers of eight); what is built from them, the same for both, is
//! here. Written with the portable arrays of `std::array::from_fn` instead, the same kernel
//! compiled to scalar code (LLVM unrolled the lanes before vectorising) and ran 1.3x slower
//! than shading path by path; the intrinsics are what make the lanes vector instructions.
//!
//! Primitive operations of `super::simd` (each lane as the scalar operation):
//! `F::splat`, `from_array`, `to_array`, `sqrt`, `abs`, `is_nan`, `min_raw` / `max_raw` (the
//! instruction's: the second operand where either is NaN), `copysign`, `lt` `le` `gt` `ge`
//! `eq` (ordered), `select` (`m ? a : b`), `next_away` (`geometry::next_away`: `x` moved one
//! ulp in the direction of `dir`, unchanged for `dir == 0`, the smallest subnormal with
//! `dir`'s sign for `x == 0`), `+ - * /` and negation of `F`; `M::from_bools`, `bits` (bit `i` for lane `i`), and
//! `& | ^ !` of `M`.

pub use super::simd::{F, M};
pub use crate::integrators::pt::wavefront::W;
use std::ops::{Add, Div, Mul, Neg, Sub};

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

impl F {
    #[inline(always)]
    pub fn zero() -> F {
        F::splat(0.0)
    }

    #[inline(always)]
    pub fn one() -> F {
        F::splat(1.0)
    }

    /// `f32::min` per lane (a NaN operand gives the other one).
    #[inline(always)]
    pub fn min(self, o: F) -> F {
        let m = self.min_raw(o);
        F::select(self.is_nan(), o, F::select(o.is_nan(), self, m))
    }

    /// `f32::max` per lane (a NaN operand gives the other one).
    #[inline(always)]
    pub fn max(self, o: F) -> F {
        let m = self.max_raw(o);
        F::select(self.is_nan(), o, F::select(o.is_nan(), self, m))
    }

    /// `f32::signum` per lane: +-1 by the sign bit, NaN stays NaN.
    #[inline(always)]
    pub fn signum(self) -> F {
        F::select(self.is_nan(), self, F::one().copysign(self))
    }

    /// `f32::is_finite` per lane.
    #[inline(always)]
    pub fn is_finite(self) -> M {
        self.abs().lt(F::splat(f32::INFINITY))
    }
}

impl M {
    /// Whether lane `i` holds.
    #[inline(always)]
    pub fn lane(self, i: usize) -> bool {
        self.bits() >> i & 1 != 0
    }
}

/// `F op f32` and `f32 op F`: the number splatted to every lane.
macro_rules! with_f32 {
    ($tr:ident, $f:ident) => {
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
with_f32!(Add, add);
with_f32!(Sub, sub);
with_f32!(Mul, mul);
with_f32!(Div, div);

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
