//! The trilinear samples of a run of eight pixels on one face, in AVX2 registers from the
//! levels of detail to the sums: [`Lookups::set_face`] then [`trilinear_lanes`] (with AVX2),
//! the same operations in the same order, so the same bits (tested against the portable
//! lanes). Written in intrinsics because LLVM's code for those two, inlined into the run's
//! body, went through the look-ups' arrays in memory between its loops and set up each run's
//! levels one field at a time: with the levels of detail about 870 instructions a run of eight
//! (docs/benchmarks.md, 2026-11-26 night (tex)), about 650 here with the footprints
//! (2026-11-27 morning (tex)).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, __m256d, __m256i, _CMP_EQ_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_UNORD_Q, _mm_cvtsi128_si32,
    _mm256_add_epi32, _mm256_add_epi64, _mm256_add_pd, _mm256_add_ps, _mm256_and_pd, _mm256_and_si256,
    _mm256_andnot_pd, _mm256_blend_epi32, _mm256_blendv_ps, _mm256_castps_si256, _mm256_castps256_ps128,
    _mm256_castsi256_ps, _mm256_castsi256_si128, _mm256_cmp_pd, _mm256_cmp_ps, _mm256_cmpeq_epi32, _mm256_cvtepi32_ps,
    _mm256_cvtepu32_epi64, _mm256_cvtpd_ps, _mm256_cvtps_pd, _mm256_div_pd, _mm256_extractf128_ps,
    _mm256_extracti128_si256, _mm256_floor_pd, _mm256_floor_ps, _mm256_i32gather_epi32, _mm256_i32gather_epi64,
    _mm256_i32gather_ps, _mm256_i64gather_epi64, _mm256_loadu_pd, _mm256_loadu_ps, _mm256_max_pd, _mm256_max_ps,
    _mm256_min_epu32, _mm256_min_pd, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_pd, _mm256_mul_ps,
    _mm256_mullo_epi32, _mm256_permute4x64_epi64, _mm256_permutevar8x32_epi32, _mm256_set_epi32, _mm256_set_m128,
    _mm256_set1_epi32, _mm256_set1_pd, _mm256_set1_ps, _mm256_setzero_pd, _mm256_setzero_ps, _mm256_slli_epi64,
    _mm256_srli_epi32, _mm256_srli_epi64, _mm256_storeu_ps, _mm256_sub_epi32, _mm256_sub_pd, _mm256_sub_ps,
    _mm256_unpackhi_epi64, _mm256_unpacklo_epi64,
};

use super::{FAR, INDEX_BIAS, LOG2_BEND, Level, UNIT, Wrap, Wraps};
use crate::avx2::Avx2;

/// A texture's levels as the AVX2 lanes of a face read them: by level index, each level's
/// texels (the lanes' form, [`Level`]), and the same as tables the lanes gather from where a
/// run's lanes lie on different levels: the address of the level's first texel (exposed),
/// the index of its last, its width and its height.
pub(crate) struct Levels<'a> {
    each: Vec<Level<'a>>,
    /// `None` where the texture has no levels, or a level holds more than `i32::MAX` texels
    /// (only a texture built by hand can): the lanes index texels in i32.
    table: Option<LevelTable>,
}

/// [`Levels`]' tables, by level index.
struct LevelTable {
    address: Vec<u64>,
    last: Vec<u32>,
    width: Vec<f32>,
    height: Vec<f32>,
}

impl<'a> Levels<'a> {
    /// The levels of `texture`, finest first.
    pub(crate) fn of(texture: &'a super::Texture) -> Self {
        let each = Level::all(texture);
        // A texture without levels (only one built by hand) has no tables: the lanes' level
        // indices are below the number of levels, which must not be zero.
        let table = (!each.is_empty() && each.iter().all(|level| level.last <= i32::MAX as u32)).then(|| LevelTable {
            address: each
                .iter()
                .map(|level| level.texels.as_ptr().expose_provenance() as u64)
                .collect(),
            last: each.iter().map(|level| level.last).collect(),
            width: each.iter().map(|level| level.size[0]).collect(),
            height: each.iter().map(|level| level.size[1]).collect(),
        });
        Levels { each, table }
    }

    /// Each level in the lanes' form, finest first.
    pub(crate) fn each(&self) -> &[Level<'a>] {
        &self.each
    }

    /// Whether the lanes in registers can sample these levels (they have tables).
    #[cfg(target_arch = "x86_64")]
    pub(crate) fn in_registers(&self) -> bool {
        self.table.is_some()
    }
}

/// [`samples_avx2`] where `avx2` is there (the proof that the CPU has AVX2), else `None`.
#[inline(always)]
pub(crate) fn samples(
    avx2: Option<Avx2>,
    levels: &Levels<'_>,
    wraps: Wraps,
    [u, v]: [&[f64; 8]; 2],
    lod: &[f32; 8],
) -> Option<[[f32; 8]; 3]> {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = avx2 {
        // SAFETY: `avx2` proves the CPU has AVX2, which `samples_avx2` is compiled for.
        return unsafe { samples_avx2(avx2, levels, wraps, [u, v], lod) };
    }
    None
}

/// The trilinear samples (red, green, blue by lane) of eight lanes on one face whose texture's
/// levels are `levels`, wrapped by `wraps`, at (`u[k]`, `v[k]`) and level of detail `lod[k]`:
/// the bits [`Lookups::set_face`] and [`trilinear_lanes`] give them with AVX2. `None` where
/// `levels` has no tables ([`Levels`]); the caller takes those lanes instead.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn samples_avx2(
    _: Avx2,
    levels: &Levels<'_>,
    wraps: Wraps,
    [u, v]: [&[f64; 8]; 2],
    lod: &[f32; 8],
) -> Option<[[f32; 8]; 3]> {
    levels.table.as_ref()?;
    // SAFETY: the loads read the eight f64 of `u` and `v` and the eight f32 of `lod`.
    let (u, v, lod) = unsafe {
        (
            [_mm256_loadu_pd(u.as_ptr()), _mm256_loadu_pd(u[4..].as_ptr())],
            [_mm256_loadu_pd(v.as_ptr()), _mm256_loadu_pd(v[4..].as_ptr())],
            _mm256_loadu_ps(lod.as_ptr()),
        )
    };
    sums_avx2(levels, wraps, [u, v], lod).map(|sums| stored(sums))
}

/// The red, green and blue lanes `sums` stored, as the portable samples give them.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn stored(sums: [__m256; 3]) -> [[f32; 8]; 3] {
    let mut out = [[0.0f32; 8]; 3];
    for (out, sum) in out.iter_mut().zip(sums) {
        // SAFETY: the store writes the eight f32 of `out`.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), sum) };
    }
    out
}

/// [`samples_avx2`]'s sums (red, green, blue by lane) from registers: lanes 0–3 then 4–7 of
/// the texture coordinates, and the levels of detail; `None` where `levels` has no tables.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn sums_avx2(
    levels: &Levels<'_>,
    wraps: Wraps,
    [u, v]: [[__m256d; 2]; 2],
    lod: __m256,
) -> Option<[__m256; 3]> {
    let table = levels.table.as_ref()?;
    // `level_below`: the level of detail clamped to the pyramid (NaN, which `min` passes on
    // as its second operand, reads the coarsest), its floor and fraction.
    let coarsest = _mm256_set1_ps((levels.each.len() - 1) as f32);
    let lod = _mm256_max_ps(_mm256_min_ps(lod, coarsest), _mm256_setzero_ps());
    let floor = _mm256_floor_ps(lod);
    let fraction = _mm256_sub_ps(lod, floor);
    let fine = texel_indices(floor);
    // The coarser level is one up where the fraction is not zero (it is never negative).
    let weighs = _mm256_cmp_ps::<_CMP_GT_OQ>(fraction, _mm256_setzero_ps());
    let coarse = _mm256_sub_epi32(fine, _mm256_castps_si256(weighs));
    // The rest with the face's wraps.
    let u = wraps.wrap[0].reduce(u, wraps.periods[0]);
    let v = wraps.wrap[1].reduce(v, wraps.periods[1]);
    let finer = LevelLanes::new(levels, table, fine, _mm256_sub_ps(_mm256_set1_ps(1.0), fraction));
    let finer = finer.taps([u, v], wraps);
    // Where every lane's coarser level weighs zero its taps are left out, as
    // `trilinear_lanes` leaves them; else each tap is the finer's plus the coarser's.
    Some(if _mm256_movemask_ps(weighs) == 0 {
        summed(|tap| finer.weighted(tap))
    } else {
        let coarser = LevelLanes::new(levels, table, coarse, fraction).taps([u, v], wraps);
        summed(|tap| {
            let (finer, coarser) = (finer.weighted(tap), coarser.weighted(tap));
            [0, 1, 2].map(|channel| _mm256_add_ps(finer[channel], coarser[channel]))
        })
    })
}

/// The sum of the weighted taps `tap(k)` (red, green, blue by lane) in `trilinear_lanes`'
/// order: (0 + 2) + (1 + 3), each tap worked out once (its texels fetched once).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn summed(tap: impl Fn(usize) -> [__m256; 3]) -> [__m256; 3] {
    let (first, third) = (tap(0), tap(2));
    let even = [0, 1, 2].map(|channel| _mm256_add_ps(first[channel], third[channel]));
    let (second, fourth) = (tap(1), tap(3));
    let odd = [0, 1, 2].map(|channel| _mm256_add_ps(second[channel], fourth[channel]));
    [0, 1, 2].map(|channel| _mm256_add_ps(even[channel], odd[channel]))
}

/// `level_of_detail` of eight lanes whose footprints' longer axes are `length`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn levels_of_detail(texels_per_metre_squared: f32, length: __m256) -> __m256 {
    let squared = _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(texels_per_metre_squared), length), length);
    // `log2_by_bits` of the square (+0 below it, NaN too).
    let bits = _mm256_castps_si256(_mm256_max_ps(squared, _mm256_setzero_ps()));
    let exponent = _mm256_cvtepi32_ps(_mm256_sub_epi32(_mm256_srli_epi32::<23>(bits), _mm256_set1_epi32(127)));
    let fraction = _mm256_mul_ps(
        _mm256_cvtepi32_ps(_mm256_and_si256(bits, _mm256_set1_epi32(0x7f_ffff))),
        _mm256_set1_ps(1.0 / 8_388_608.0),
    );
    let bend = _mm256_mul_ps(
        _mm256_set1_ps(LOG2_BEND),
        _mm256_mul_ps(fraction, _mm256_sub_ps(_mm256_set1_ps(1.0), fraction)),
    );
    let log2 = _mm256_add_ps(exponent, _mm256_add_ps(fraction, bend));
    let lod = _mm256_max_ps(_mm256_mul_ps(_mm256_set1_ps(0.5), log2), _mm256_setzero_ps());
    let nan = _mm256_cmp_ps::<_CMP_UNORD_Q>(squared, squared);
    _mm256_blendv_ps(lod, _mm256_set1_ps(f32::INFINITY), nan)
}

/// The integers (0..2^23) held in `n`'s lanes, as `texel_index` reads them.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn texel_indices(n: __m256) -> __m256i {
    let biased = _mm256_castps_si256(_mm256_add_ps(n, _mm256_set1_ps(INDEX_BIAS)));
    _mm256_sub_epi32(biased, _mm256_set1_epi32(INDEX_BIAS.to_bits() as i32))
}

/// One level of each lane (its index by lane) as its taps read it: its size, share (times
/// [`UNIT`]), and where its texels lie.
#[cfg(target_arch = "x86_64")]
struct LevelLanes<'a> {
    width: __m256,
    height: __m256,
    last: __m256i,
    share: __m256,
    texels: Texels<'a>,
}

/// Where the lanes' texels of a level lie.
#[cfg(target_arch = "x86_64")]
enum Texels<'a> {
    /// Every lane on one level: its texels (at most `i32::MAX + 1`).
    Shared(&'a [u64]),
    /// Lanes on different levels: the exposed address of each lane's level's first texel,
    /// lanes 0–3 then 4–7.
    Addressed([__m256i; 2]),
}

/// Each lane's four taps on a level: their texel indices and weights, by tap (corners (x0, y0),
/// (x1, y0), (x0, y1), (x1, y1)).
#[cfg(target_arch = "x86_64")]
struct Taps<'a> {
    level: LevelLanes<'a>,
    index: [__m256i; 4],
    weight: [__m256; 4],
}

#[cfg(target_arch = "x86_64")]
impl<'a> LevelLanes<'a> {
    /// Level `at[k]` of lane k (each below the number of levels), weighing `share[k]` (held
    /// times [`UNIT`], as `weighted_taps` holds it).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(levels: &Levels<'a>, table: &LevelTable, at: __m256i, share: __m256) -> Self {
        let first = _mm_cvtsi128_si32(_mm256_castsi256_si128(at));
        let same = _mm256_cmpeq_epi32(at, _mm256_set1_epi32(first));
        let shared = _mm256_movemask_ps(_mm256_castsi256_ps(same)) == 0xff;
        // Every lane on one level (most runs): its numbers read once and broadcast, where
        // gathering them cost more time (AMD Zen 3, same process: docs/benchmarks.md,
        // 2026-11-27 afternoon (tex)).
        let (width, height, last, texels) = if shared {
            let level = levels.each[first as usize];
            (
                _mm256_set1_ps(level.size[0]),
                _mm256_set1_ps(level.size[1]),
                _mm256_set1_epi32(level.last as i32),
                Texels::Shared(level.texels),
            )
        } else {
            let halves = [_mm256_castsi256_si128(at), _mm256_extracti128_si256::<1>(at)];
            // SAFETY: every index in `at` is below the number of levels, the tables' length
            // (one entry a level): the level of detail is clamped to the coarsest, and the
            // coarser level is one up only where the fraction is not zero, so below the
            // coarsest.
            unsafe {
                (
                    _mm256_i32gather_ps::<4>(table.width.as_ptr(), at),
                    _mm256_i32gather_ps::<4>(table.height.as_ptr(), at),
                    _mm256_i32gather_epi32::<4>(table.last.as_ptr().cast::<i32>(), at),
                    Texels::Addressed(
                        halves.map(|half| _mm256_i32gather_epi64::<8>(table.address.as_ptr().cast::<i64>(), half)),
                    ),
                )
            }
        };
        LevelLanes {
            width,
            height,
            last,
            share: _mm256_mul_ps(share, _mm256_set1_ps(UNIT)),
            texels,
        }
    }

    /// The lanes' taps at reduced coordinates `uv` ([`Wrap::reduce`]), wrapped by `wraps`:
    /// `weighted_taps`' indices and weights.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn taps(self, uv: [[__m256d; 2]; 2], wraps: Wraps) -> Taps<'a> {
        let (x0, x1, fx) = wraps.wrap[0].neighbours(uv[0], self.width, wraps.periods[0]);
        let (y0, y1, fy) = wraps.wrap[1].neighbours(uv[1], self.height, wraps.periods[1]);
        let width = texel_indices(self.width);
        let (row0, row1) = (
            _mm256_mullo_epi32(texel_indices(y0), width),
            _mm256_mullo_epi32(texel_indices(y1), width),
        );
        let (x0, x1) = (texel_indices(x0), texel_indices(x1));
        let one = _mm256_set1_ps(1.0);
        let (top, bottom) = (
            _mm256_mul_ps(self.share, _mm256_sub_ps(one, fy)),
            _mm256_mul_ps(self.share, fy),
        );
        let left = _mm256_sub_ps(one, fx);
        Taps {
            level: self,
            index: [
                _mm256_add_epi32(row0, x0),
                _mm256_add_epi32(row0, x1),
                _mm256_add_epi32(row1, x0),
                _mm256_add_epi32(row1, x1),
            ],
            weight: [
                _mm256_mul_ps(top, left),
                _mm256_mul_ps(top, fx),
                _mm256_mul_ps(bottom, left),
                _mm256_mul_ps(bottom, fx),
            ],
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Taps<'_> {
    /// Tap `tap`'s red, green and blue (16-bit linear values, `MipLevel::texels`) weighted, by
    /// lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn weighted(&self, tap: usize) -> [__m256; 3] {
        let [even, odd] = self.fetched(self.index[tap]);
        // Lane k's low 32 bits (red, green) and high 32 (blue) from its texel in `even` or `odd`.
        let red_green = _mm256_blend_epi32::<0b1010_1010>(even, _mm256_slli_epi64::<32>(odd));
        let blue = _mm256_blend_epi32::<0b1010_1010>(_mm256_srli_epi64::<32>(even), odd);
        // Masked as the portable lanes' `as u16` (a texel built by hand may set bits 48–63).
        let channel = _mm256_set1_epi32(0xffff);
        let channels = [
            _mm256_and_si256(red_green, channel),
            _mm256_srli_epi32::<16>(red_green),
            _mm256_and_si256(blue, channel),
        ];
        channels.map(|channel| _mm256_mul_ps(self.weight[tap], _mm256_cvtepi32_ps(channel)))
    }

    /// Each lane's texel `index` of its level, clamped to the level's last (as `fetched`): the
    /// even lanes' four texels, then the odd lanes'.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn fetched(&self, index: __m256i) -> [__m256i; 2] {
        let index = _mm256_min_epu32(index, self.level.last);
        match self.level.texels {
            Texels::Shared(texels) => {
                let index = _mm256_permutevar8x32_epi32(index, _mm256_set_epi32(7, 5, 3, 1, 6, 4, 2, 0));
                let halves = [_mm256_castsi256_si128(index), _mm256_extracti128_si256::<1>(index)];
                // SAFETY: every index is at most the level's last, inside `texels` and within
                // i32 (`Levels` has tables only where every level's last is).
                halves.map(|half| unsafe { _mm256_i32gather_epi64::<8>(texels.as_ptr().cast::<i64>(), half) })
            }
            Texels::Addressed(first) => {
                let halves = [_mm256_castsi256_si128(index), _mm256_extracti128_si256::<1>(index)];
                let base = std::ptr::with_exposed_provenance::<i64>(0);
                // Lanes 0–3, then 4–7.
                let [low, high]: [__m256i; 2] = std::array::from_fn(|half| {
                    let offset = _mm256_slli_epi64::<3>(_mm256_cvtepu32_epi64(halves[half]));
                    // SAFETY: the address is that of texel `index` (at most the level's last,
                    // so inside its texels, never empty) of the lane's level, whose first
                    // texel's address was exposed when the tables were made (`Levels::of`).
                    unsafe { _mm256_i64gather_epi64::<1>(base, _mm256_add_epi64(first[half], offset)) }
                });
                // Lanes 0, 4, 2, 6 and 1, 5, 3, 7, each put in order.
                [_mm256_unpacklo_epi64(low, high), _mm256_unpackhi_epi64(low, high)]
                    .map(|lanes| _mm256_permute4x64_epi64::<0b11_01_10_00>(lanes))
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Wrap {
    /// `reduced` of four lanes' coordinates `t` (by half: lanes 0–3, 4–7) wrapped by this,
    /// with period `period` (1, or 2 for mirror).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn reduce(self, t: [__m256d; 2], period: f64) -> [__m256d; 2] {
        t.map(|t| {
            let magnitude = _mm256_andnot_pd(_mm256_set1_pd(-0.0), t);
            let finite = _mm256_cmp_pd::<_CMP_LE_OQ>(magnitude, _mm256_set1_pd(f64::MAX));
            let t = _mm256_max_pd(_mm256_min_pd(t, _mm256_set1_pd(FAR)), _mm256_set1_pd(-FAR));
            let t = _mm256_and_pd(t, finite);
            // `floor`'s +0 for -0: the floor plus +0.
            let floor = |x: __m256d| _mm256_add_pd(_mm256_floor_pd(x), _mm256_setzero_pd());
            match self {
                Wrap::Clamp => _mm256_max_pd(_mm256_min_pd(t, _mm256_set1_pd(2.0)), _mm256_set1_pd(-1.0)),
                Wrap::Repeat => _mm256_sub_pd(t, floor(t)),
                Wrap::Mirror => {
                    let period = _mm256_set1_pd(period);
                    _mm256_sub_pd(t, _mm256_mul_pd(period, floor(_mm256_div_pd(t, period))))
                }
            }
        })
    }

    /// `neighbours` of eight lanes at reduced coordinates `reduced` on an axis of `size`
    /// texels, wrapped by this with period `period` sizes.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn neighbours(self, reduced: [__m256d; 2], size: __m256, period: f64) -> (__m256, __m256, __m256) {
        let half = _mm256_set1_pd(0.5);
        let sizes = [
            _mm256_cvtps_pd(_mm256_castps256_ps128(size)),
            _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(size)),
        ];
        let [low, high] =
            std::array::from_fn(|k| _mm256_cvtpd_ps(_mm256_sub_pd(_mm256_mul_pd(reduced[k], sizes[k]), half)));
        let x = _mm256_set_m128(high, low);
        let i = _mm256_floor_ps(x);
        let weight = _mm256_sub_ps(x, i);
        let one = _mm256_set1_ps(1.0);
        let next = _mm256_add_ps(i, one);
        let zero = _mm256_setzero_ps();
        let (first, second) = match self {
            Wrap::Clamp => {
                let last = _mm256_sub_ps(size, one);
                (
                    _mm256_max_ps(_mm256_min_ps(i, last), zero),
                    _mm256_max_ps(_mm256_min_ps(next, last), zero),
                )
            }
            Wrap::Repeat | Wrap::Mirror => {
                let period = match self {
                    Wrap::Mirror => _mm256_mul_ps(_mm256_set1_ps(period as f32), size),
                    _ => size,
                };
                // -1 is the period's last texel; i + 1 wraps to the first at the period.
                let before = _mm256_cmp_ps::<_CMP_LT_OQ>(i, zero);
                let wrapped0 = _mm256_blendv_ps(i, _mm256_sub_ps(period, one), before);
                let at_period = _mm256_cmp_ps::<_CMP_EQ_OQ>(next, period);
                let wrapped1 = _mm256_blendv_ps(next, zero, at_period);
                match self {
                    // Mirror's second half runs backwards.
                    Wrap::Mirror => {
                        let end = _mm256_sub_ps(_mm256_mul_ps(_mm256_set1_ps(2.0), size), one);
                        let fold = |j: __m256| {
                            let beyond = _mm256_cmp_ps::<_CMP_LT_OQ>(j, size);
                            _mm256_blendv_ps(_mm256_sub_ps(end, j), j, beyond)
                        };
                        (fold(wrapped0), fold(wrapped1))
                    }
                    _ => (wrapped0, wrapped1),
                }
            }
        };
        (first, second, weight)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shade::filter::level_of_detail;

    /// The levels of detail of eight lanes in registers are `level_of_detail`'s bits, across
    /// the log2's range and at zero, -0, subnormal, infinite and NaN lengths and scales.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn levels_of_detail_in_registers_are_level_of_detail_bits() {
        let Some(avx2) = Avx2::detected() else {
            eprintln!("no AVX2 on this CPU: nothing to compare");
            return;
        };
        let subnormal = f32::from_bits(1);
        let mut lengths: Vec<f32> = (0..=100_000).map(|k| (1.0 + k as f32 * 0.000_63) / 256.0).collect();
        lengths.extend([
            0.0,
            -0.0,
            subnormal,
            -1.0,
            1e-20,
            1e20,
            f32::MAX,
            f32::INFINITY,
            f32::NAN,
        ]);
        for scale in [
            65_536.0,
            1.0,
            0.999_999_94,
            -0.0,
            -1.0,
            subnormal,
            f32::INFINITY,
            f32::NAN,
        ] {
            for eight in lengths.chunks(8) {
                let length: [f32; 8] = std::array::from_fn(|k| eight[k % eight.len()]);
                // SAFETY: `avx2` proves the CPU has AVX2; the load reads the eight lengths, the
                // store writes the eight levels.
                let lanes = unsafe { levels_of_detail_of(avx2, scale, &length) };
                let want = length.map(|length| level_of_detail(scale, length).to_bits());
                assert_eq!(lanes.map(f32::to_bits), want, "scale {scale}, lengths {length:?}");
            }
        }
    }

    /// [`levels_of_detail`] of `length`, through memory.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn levels_of_detail_of(_: Avx2, scale: f32, length: &[f32; 8]) -> [f32; 8] {
        let mut out = [0.0; 8];
        // SAFETY: the load reads the eight f32 of `length`, the store writes those of `out`.
        unsafe {
            let levels = levels_of_detail(scale, _mm256_loadu_ps(length.as_ptr()));
            _mm256_storeu_ps(out.as_mut_ptr(), levels);
        }
        out
    }
}
