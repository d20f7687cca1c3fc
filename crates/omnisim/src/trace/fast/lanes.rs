//! f32 lanes for the fast tracer's triangle filter, four (`Vec4`) or eight ([`Lanes8`]) wide.
//!
//! The filter (`groups.rs`) is written once over [`Lanes`]: four triangles against one ray in
//! `Vec4`s, or one triangle against eight rays of a packet in `Lanes8`s. Every lane runs the
//! same IEEE single-precision operations in the same order either way, so a (ray, triangle)
//! pair gets the same answer bit for bit, whichever way it was batched.

use std::ops::{Add, Div, Mul, Neg, Sub};

use glam::Vec4;

/// Lane-wise f32 arithmetic and comparisons returning bit masks (bit i for lane i).
pub(crate) trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    fn splat(value: f32) -> Self;
    /// The absolute value (the sign bit cleared), as `f32::abs`.
    fn abs(self) -> Self;
    /// 1 for positive (+0 included), −1 for negative (−0 included), as `f32::signum`.
    fn signum(self) -> Self;
    /// Lanes where `self > other` (ordered: false where either is NaN).
    fn greater(self, other: Self) -> u32;
    /// Lanes where `self < other` (ordered).
    fn less(self, other: Self) -> u32;
    /// Lanes where `self <= other` (ordered).
    fn not_greater(self, other: Self) -> u32;
    /// Lane-wise minimum (the SSE/AVX `min`: `other` where either is NaN).
    fn min(self, other: Self) -> Self;
    /// Lane-wise maximum (the SSE/AVX `max`).
    fn max(self, other: Self) -> Self;
}

impl Lanes for Vec4 {
    #[inline(always)]
    fn splat(value: f32) -> Self {
        Vec4::splat(value)
    }
    #[inline(always)]
    fn signum(self) -> Self {
        Vec4::signum(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec4::abs(self)
    }
    #[inline(always)]
    fn greater(self, other: Self) -> u32 {
        self.cmpgt(other).bitmask()
    }
    #[inline(always)]
    fn less(self, other: Self) -> u32 {
        self.cmplt(other).bitmask()
    }
    #[inline(always)]
    fn not_greater(self, other: Self) -> u32 {
        self.cmple(other).bitmask()
    }
    #[inline(always)]
    fn min(self, other: Self) -> Self {
        Vec4::min(self, other)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        Vec4::max(self, other)
    }
}

/// Eight f32 lanes as two `Vec4` halves (lanes 0–3, then 4–7). Compiled inside the AVX2
/// walks (`fast/mod.rs`) the halves use VEX-encoded SSE; glam has no eight-lane type.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lanes8(pub(crate) [Vec4; 2]);

impl Lanes8 {
    /// The first eight values of `values`.
    #[inline(always)]
    pub(crate) fn load(values: &[f32]) -> Self {
        Self([Vec4::from_slice(&values[..4]), Vec4::from_slice(&values[4..8])])
    }

    #[inline(always)]
    fn zip(self, other: Self, f: impl Fn(Vec4, Vec4) -> Vec4) -> Self {
        Self([f(self.0[0], other.0[0]), f(self.0[1], other.0[1])])
    }
}

/// `impl $op for $lanes` whose `$method(a, b)` is `$body`: the lane types' binary operators.
macro_rules! binary_op {
    ($lanes:ty, $op:ident, $method:ident, |$a:ident, $b:ident| $body:expr) => {
        impl $op for $lanes {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                let ($a, $b) = (self, other);
                $body
            }
        }
    };
}

binary_op!(Lanes8, Add, add, |a, b| a.zip(b, |x, y| x + y));
binary_op!(Lanes8, Sub, sub, |a, b| a.zip(b, |x, y| x - y));
binary_op!(Lanes8, Mul, mul, |a, b| a.zip(b, |x, y| x * y));
binary_op!(Lanes8, Div, div, |a, b| a.zip(b, |x, y| x / y));

impl Neg for Lanes8 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self([-self.0[0], -self.0[1]])
    }
}

impl Lanes for Lanes8 {
    #[inline(always)]
    fn splat(value: f32) -> Self {
        Self([Vec4::splat(value); 2])
    }
    #[inline(always)]
    fn signum(self) -> Self {
        Self([self.0[0].signum(), self.0[1].signum()])
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Self([self.0[0].abs(), self.0[1].abs()])
    }
    #[inline(always)]
    fn greater(self, other: Self) -> u32 {
        self.0[0].greater(other.0[0]) | self.0[1].greater(other.0[1]) << 4
    }
    #[inline(always)]
    fn less(self, other: Self) -> u32 {
        self.0[0].less(other.0[0]) | self.0[1].less(other.0[1]) << 4
    }
    #[inline(always)]
    fn not_greater(self, other: Self) -> u32 {
        self.0[0].not_greater(other.0[0]) | self.0[1].not_greater(other.0[1]) << 4
    }
    #[inline(always)]
    fn min(self, other: Self) -> Self {
        self.zip(other, Vec4::min)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        self.zip(other, Vec4::max)
    }
}

/// Eight-lane types the packet walk and the single-ray walk's paired leaf filter run on:
/// [`Lanes8`] everywhere, [`Avx8`] where the CPU has AVX2.
pub(crate) trait Wide: Lanes {
    /// Whether code running on this type may use AVX (the box test of the single-ray walk).
    const AVX: bool;
    /// The first eight values of `values`.
    fn load(values: &[f32]) -> Self;
    /// The eight values of two `Vec4`s (a wide node's coordinate, `accel/wide.rs`), lanes
    /// 0–3 then 4–7.
    fn from_halves(halves: &[Vec4; 2]) -> Self;
    /// Lane `k` (below eight), read where the lanes lie: a packet's rays are in memory, and a
    /// lane read from there is one load (a single ray taken from the packet: `rays.rs`).
    fn lane(&self, k: usize) -> f32;
    /// The eight lanes in order.
    fn to_array(self) -> [f32; 8];
    /// Lane i from `self` where bit i of `lanes` is set, else from `other`.
    fn keep(self, lanes: u32, other: Self) -> Self;
    /// The lanes whose sign bit is set (−0 included), bit i for lane i.
    fn sign_bits(self) -> u32;
}

impl Wide for Lanes8 {
    const AVX: bool = false;
    #[inline(always)]
    fn load(values: &[f32]) -> Self {
        Lanes8::load(values)
    }
    #[inline(always)]
    fn from_halves(halves: &[Vec4; 2]) -> Self {
        Self(*halves)
    }
    #[inline(always)]
    fn lane(&self, k: usize) -> f32 {
        self.0[k / 4][k % 4]
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        let ([a, b, c, d], [e, f, g, h]) = (self.0[0].to_array(), self.0[1].to_array());
        [a, b, c, d, e, f, g, h]
    }
    #[inline(always)]
    fn keep(self, lanes: u32, other: Self) -> Self {
        let half = |h: usize| {
            let bit = |k: usize| lanes >> (4 * h + k) & 1 != 0;
            Vec4::select(glam::BVec4A::new(bit(0), bit(1), bit(2), bit(3)), self.0[h], other.0[h])
        };
        Self([half(0), half(1)])
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        self.0[0].is_negative_bitmask() | self.0[1].is_negative_bitmask() << 4
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx::Avx8;

#[cfg(target_arch = "x86_64")]
mod avx {
    //! SAFETY, for every `unsafe` block here: `Avx8` values are made and used only inside
    //! the fast tracer's functions compiled with AVX2 enabled (`fast/mod.rs`: `avx2,popcnt,bmi1`,
    //! run only where `use_avx2` detected all three); every method is
    //! `#[inline(always)]`, so its intrinsics are compiled into such a function (in tests too:
    //! AVX2 test helpers are `#[target_feature]` functions called after the same detection).
    //! Loads read exactly eight f32s from slices checked to hold them or from two `Vec4`s;
    //! the store (`to_array`) writes an `[f32; 8]`; `lane` reads one of the register's own.

    use std::arch::x86_64::{
        __m256, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_UNORD_Q, _mm256_add_ps, _mm256_and_ps, _mm256_and_si256,
        _mm256_andnot_ps, _mm256_blendv_ps, _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_cmpeq_epi32, _mm256_div_ps,
        _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps,
        _mm256_set1_epi32, _mm256_set1_ps, _mm256_setr_epi32, _mm256_storeu_ps, _mm256_sub_ps, _mm256_xor_ps,
    };
    use std::ops::{Add, Div, Mul, Neg, Sub};

    use glam::Vec4;

    use super::{Lanes, Wide};

    /// Eight f32 lanes in one 256-bit register: [`super::Lanes8`]'s operations, one AVX
    /// instruction each instead of two SSE ones, with the same IEEE results (signum and
    /// negation as glam computes them).
    #[derive(Debug, Clone, Copy)]
    #[repr(transparent)]
    pub(crate) struct Avx8(__m256);

    binary_op!(Avx8, Add, add, |a, b| Avx8(unsafe { _mm256_add_ps(a.0, b.0) }));
    binary_op!(Avx8, Sub, sub, |a, b| Avx8(unsafe { _mm256_sub_ps(a.0, b.0) }));
    binary_op!(Avx8, Mul, mul, |a, b| Avx8(unsafe { _mm256_mul_ps(a.0, b.0) }));
    binary_op!(Avx8, Div, div, |a, b| Avx8(unsafe { _mm256_div_ps(a.0, b.0) }));

    impl Neg for Avx8 {
        type Output = Self;
        #[inline(always)]
        fn neg(self) -> Self {
            Self(unsafe { _mm256_xor_ps(_mm256_set1_ps(-0.0), self.0) })
        }
    }

    impl Lanes for Avx8 {
        #[inline(always)]
        fn splat(value: f32) -> Self {
            Self(unsafe { _mm256_set1_ps(value) })
        }
        #[inline(always)]
        fn signum(self) -> Self {
            // glam's: the sign bit of x on 1.0, and NaN where x is NaN.
            unsafe {
                let one = _mm256_or_ps(_mm256_and_ps(self.0, _mm256_set1_ps(-1.0)), _mm256_set1_ps(1.0));
                let nan = _mm256_cmp_ps::<_CMP_UNORD_Q>(self.0, self.0);
                Self(_mm256_blendv_ps(one, self.0, nan))
            }
        }
        #[inline(always)]
        fn abs(self) -> Self {
            Self(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
        }
        #[inline(always)]
        fn greater(self, other: Self) -> u32 {
            unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, other.0)) as u32 }
        }
        #[inline(always)]
        fn less(self, other: Self) -> u32 {
            unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, other.0)) as u32 }
        }
        #[inline(always)]
        fn not_greater(self, other: Self) -> u32 {
            unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, other.0)) as u32 }
        }
        #[inline(always)]
        fn min(self, other: Self) -> Self {
            Self(unsafe { _mm256_min_ps(self.0, other.0) })
        }
        #[inline(always)]
        fn max(self, other: Self) -> Self {
            Self(unsafe { _mm256_max_ps(self.0, other.0) })
        }
    }

    impl Wide for Avx8 {
        const AVX: bool = true;
        #[inline(always)]
        fn load(values: &[f32]) -> Self {
            let values = &values[..8];
            Self(unsafe { _mm256_loadu_ps(values.as_ptr()) })
        }
        #[inline(always)]
        fn from_halves(halves: &[Vec4; 2]) -> Self {
            // Two `Vec4`s are 32 contiguous bytes (16 each, no padding): checked here.
            const { assert!(size_of::<[Vec4; 2]>() == 32) };
            Self(unsafe { _mm256_loadu_ps(halves.as_ptr().cast::<f32>()) })
        }
        #[inline(always)]
        fn lane(&self, k: usize) -> f32 {
            // The register's bytes as eight f32s (`Avx8` is a transparent `__m256`, 32 bytes),
            // indexed with a bounds check (none where k is known below eight).
            let lanes = unsafe { &*std::ptr::from_ref(self).cast::<[f32; 8]>() };
            lanes[k]
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            let mut values = [0.0; 8];
            unsafe { _mm256_storeu_ps(values.as_mut_ptr(), self.0) };
            values
        }
        #[inline(always)]
        fn keep(self, lanes: u32, other: Self) -> Self {
            // Lane i's bit of `lanes` spread to a whole-lane mask: (lanes & 2^i) == 2^i.
            unsafe {
                let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
                let chosen = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(lanes as i32), bits), bits);
                Self(_mm256_blendv_ps(other.0, self.0, _mm256_castsi256_ps(chosen)))
            }
        }
        #[inline(always)]
        fn sign_bits(self) -> u32 {
            unsafe { _mm256_movemask_ps(self.0) as u32 }
        }
    }
}
