//! One number a lane: [`V`], eight `f64`s in one AVX-512 register, and
//! [`M`], eight truths in one mask register. Every operation is one
//! instruction that computes each lane exactly as the scalar operation
//! computes it: IEEE 754 addition, multiplication, division and square
//! root, rounded alone, neither fused nor reordered.
//!
//! Only code compiled for AVX-512 (`#[target_feature(enable =
//! "avx512f")]`), and run where the CPU has it, may use these: each
//! operation is inlined into that code, and nowhere else is it sound.

use super::LANES;
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};

/// A number a lane.
#[derive(Clone, Copy, Debug)]
pub(super) struct V(__m512d);

/// A truth a lane: bit `l` for lane `l`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub(super) struct M(pub u8);

// SAFETY (every `unsafe` block below): the intrinsics need AVX-512F, and
// this module is used only from functions compiled for it and called
// after the CPU was found to have it (`guide_lanes`). Loads and stores go
// through arrays of exactly `LANES` f64s.

impl V {
    #[inline(always)]
    pub fn splat(x: f64) -> V {
        V(unsafe { _mm512_set1_pd(x) })
    }

    #[inline(always)]
    pub fn from_array(a: [f64; LANES]) -> V {
        V(unsafe { _mm512_loadu_pd(a.as_ptr()) })
    }

    #[inline(always)]
    pub fn to_array(self) -> [f64; LANES] {
        let mut a = [0.0; LANES];
        unsafe { _mm512_storeu_pd(a.as_mut_ptr(), self.0) };
        a
    }

    #[inline(always)]
    pub fn sqrt(self) -> V {
        V(unsafe { _mm512_sqrt_pd(self.0) })
    }

    /// `f64::abs`: the sign bit cleared.
    #[inline(always)]
    pub fn abs(self) -> V {
        V(unsafe { _mm512_abs_pd(self.0) })
    }

    /// `<`, false where either side is NaN.
    #[inline(always)]
    pub fn lt(self, o: V) -> M {
        M(unsafe { _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, o.0) })
    }

    /// `==`, false where either side is NaN.
    #[inline(always)]
    pub fn eq(self, o: V) -> M {
        M(unsafe { _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(self.0, o.0) })
    }

    /// `<=`, false where either side is NaN.
    #[inline(always)]
    pub fn le(self, o: V) -> M {
        M(unsafe { _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, o.0) })
    }

    /// `>=`, false where either side is NaN.
    #[inline(always)]
    pub fn ge(self, o: V) -> M {
        M(unsafe { _mm512_cmp_pd_mask::<_CMP_GE_OQ>(self.0, o.0) })
    }

    /// `>`, false where either side is NaN.
    #[inline(always)]
    pub fn gt(self, o: V) -> M {
        M(unsafe { _mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, o.0) })
    }
}

impl M {
    /// `yes` where true, `no` elsewhere.
    #[inline(always)]
    pub fn select(self, yes: V, no: V) -> V {
        V(unsafe { _mm512_mask_blend_pd(self.0, no.0, yes.0) })
    }

    #[inline(always)]
    pub fn any(self) -> bool {
        self.0 != 0
    }

    #[inline(always)]
    pub fn get(self, l: usize) -> bool {
        self.0 >> l & 1 != 0
    }

    #[inline(always)]
    pub fn set(&mut self, l: usize) {
        self.0 |= 1 << l;
    }
}

macro_rules! arithmetic {
    ($trait:ident, $f:ident, $intrinsic:ident) => {
        impl $trait for V {
            type Output = V;
            #[inline(always)]
            fn $f(self, o: V) -> V {
                V(unsafe { $intrinsic(self.0, o.0) })
            }
        }
    };
}

arithmetic!(Add, add, _mm512_add_pd);
arithmetic!(Sub, sub, _mm512_sub_pd);
arithmetic!(Mul, mul, _mm512_mul_pd);
arithmetic!(Div, div, _mm512_div_pd);

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

impl Not for M {
    type Output = M;
    #[inline(always)]
    fn not(self) -> M {
        M(!self.0)
    }
}
