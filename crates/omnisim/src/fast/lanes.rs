//! f32 lanes for the fast tracer's triangle filter, four (`Vec4`) or eight ([`Lanes8`]) wide.
//!
//! The filter (`groups.rs`) is written once over [`Lanes`]: four triangles against one ray in
//! `Vec4`s, or one triangle against eight rays of a packet in `Lanes8`s. Every lane runs the
//! same IEEE single-precision operations in the same order either way, so a (ray, triangle)
//! pair gets the same answer bit for bit, whichever way it was batched.

use std::ops::{Add, Mul, Neg, Sub};

use glam::Vec4;

/// Lane-wise f32 arithmetic and comparisons returning bit masks (bit i for lane i).
pub(crate) trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    fn splat(value: f32) -> Self;
    /// 1 for positive (+0 included), −1 for negative (−0 included), as `f32::signum`.
    fn signum(self) -> Self;
    /// Lanes where `self > other` (ordered: false where either is NaN).
    fn greater(self, other: Self) -> u32;
    /// Lanes where `self < other` (ordered).
    fn less(self, other: Self) -> u32;
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
    fn greater(self, other: Self) -> u32 {
        self.cmpgt(other).bitmask()
    }
    #[inline(always)]
    fn less(self, other: Self) -> u32 {
        self.cmplt(other).bitmask()
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

impl Add for Lanes8 {
    type Output = Self;
    #[inline(always)]
    fn add(self, other: Self) -> Self {
        self.zip(other, |a, b| a + b)
    }
}

impl Sub for Lanes8 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, other: Self) -> Self {
        self.zip(other, |a, b| a - b)
    }
}

impl Mul for Lanes8 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, other: Self) -> Self {
        self.zip(other, |a, b| a * b)
    }
}

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
    fn greater(self, other: Self) -> u32 {
        self.0[0].greater(other.0[0]) | self.0[1].greater(other.0[1]) << 4
    }
    #[inline(always)]
    fn less(self, other: Self) -> u32 {
        self.0[0].less(other.0[0]) | self.0[1].less(other.0[1]) << 4
    }
}
