//! Texture filtering: bilinear within a mip level, trilinear across two, at a level of detail
//! chosen from the pixel's footprint in texels. One definition: texture coordinates in f64 here,
//! reduced by their wrap's period in f64 (exactly, so that far coordinates keep their texels),
//! then texel positions, weights and colours in f32 (the issue's "f64 coordinates, f32
//! filtering"); `shaders/texture.wgsl` is its f32 twin (same texel centres, wrap rules, level
//! choice; its coordinates are f32 from the start).

use glam::{DVec2, Vec3A};

use crate::avx2::Avx2;
use crate::scene::texture::{MipLevel, Texture, Wrap};

mod face;
pub(crate) use face::{Levels, samples};
#[cfg(target_arch = "x86_64")]
pub(crate) use face::{levels_of_detail, stored, sums_avx2};

/// The linear value of one step of a texel's 16-bit channel (`MipLevel::texels`), f32: each
/// level's share is held times it, so that a tap's weight times the channel is its linear
/// value weighted.
const UNIT: f32 = 1.0 / 65535.0;

/// How many pixels one run filters together: the f32 lanes of an AVX2 register.
pub(crate) const LANES: usize = 8;

/// The texture look-ups of `L` pixels, one a lane, laid out for filtering in lanes: each lane's
/// texture coordinates (f64, as the definition has them), its wrap, and for each of the
/// two levels its level of detail falls between (the finer, then the coarser) the level's
/// texels, size and share.
pub(crate) struct Lookups<'a, const L: usize> {
    u: [f64; L],
    v: [f64; L],
    /// By level, lane: never empty (an empty level reads [`NO_TEXELS`]). Level 1's fields here
    /// and in `last` and `size` hold only where some lane's `share[1]` is not zero
    /// ([`Lookups::set_face`] leaves them as they were otherwise). Where `shared[level]`, lane
    /// 0's slice is every lane's and the others' may be stale ([`Lookups::texels_of`] reads
    /// them; [`Lookups::set`] fills them in before it sets a lane alone): storing eight fat
    /// pointers a level cost about 30 instructions a run (docs/benchmarks.md, 2026-11-26
    /// evening (tex)).
    texels: [[&'a [u64]; L]; 2],
    /// The index of the last of those texels, by level, lane: fetches are clamped to it.
    last: [[u32; L]; 2],
    /// Width and height by level, axis, lane (texels; at most `MAX_TEXTURE_SIDE`, which the
    /// renderer enforces, exact in f32).
    size: [[[f32; L]; 2]; 2],
    /// The wrap's period in sizes by axis, lane: 1, or 2 for mirror.
    periods: [[f64; L]; 2],
    /// Whether the axis clamps, by axis, lane.
    clamp: [[bool; L]; 2],
    /// Each level's weight, by level, lane.
    share: [[f32; L]; 2],
    /// Whether every lane reads the same slice of a level, by level (then one gather from
    /// its base fetches a tap): known where the lanes were set up together
    /// ([`Lookups::set_face`]), else taken as not.
    shared: [bool; 2],
    /// Each axis's wrap where every lane has the same (then, for repeat or clamp, the lanes
    /// work out only that one; mirror is worked out lane by lane): known as `shared` is.
    wrap: [Option<Wrap>; 2],
}

impl<'a, const L: usize> Lookups<'a, L> {
    /// Look-ups whose every lane samples `texture`, wrapped by `wraps`, at `uv` and level of
    /// detail `lod` (0 = finest; clamped to the pyramid, NaN the coarsest).
    pub(crate) fn filled(texture: &'a Texture, wraps: Wraps, uv: DVec2, lod: f32) -> Self {
        let mut lookups = Self::empty();
        for lane in 0..L {
            lookups.set(lane, texture, wraps, uv, lod);
        }
        lookups
    }

    /// Look-ups whose every lane reads [`NO_TEXELS`] at coordinates 0, to be set up.
    pub(crate) fn empty() -> Self {
        Lookups {
            u: [0.0; L],
            v: [0.0; L],
            texels: [[&NO_TEXELS; L]; 2],
            last: [[0; L]; 2],
            size: [[[1.0; L]; 2]; 2],
            periods: [[1.0; L]; 2],
            clamp: [[false; L]; 2],
            share: [[0.0; L]; 2],
            shared: [false; 2],
            wrap: [None; 2],
        }
    }

    /// Sets lane `lane` to sample `texture` as [`Lookups::filled`] says: the two levels around
    /// `lod`, weighted by its fraction (a whole level repeats with weight zero). Written out
    /// field by field: a pixel's whole set-up before its lanes (the wrap's periods are
    /// multiplied out in the lanes).
    #[inline(always)]
    pub(crate) fn set(&mut self, lane: usize, texture: &'a Texture, wraps: Wraps, uv: DVec2, lod: f32) {
        let levels: &'a [MipLevel] = &texture.levels;
        let (fine, fraction) = level_below(lod, levels.len(), None);
        let coarse = fine + u32::from(fraction > 0.0);
        // The other lanes read their own slices from now on: a shared one is theirs too.
        for which in 0..2 {
            if self.shared[which] {
                self.texels[which] = [self.texels[which][0]; L];
            }
        }
        self.u[lane] = uv.x;
        self.v[lane] = uv.y;
        self.set_wraps(lane, wraps);
        for (which, at) in [fine, coarse].into_iter().enumerate() {
            self.set_level(which, lane, Level::of(&levels[at as usize]));
        }
        self.share[0][lane] = 1.0 - fraction;
        self.share[1][lane] = fraction;
        // This lane may read another slice, or wrap otherwise, than the others.
        self.shared = [false; 2];
        self.wrap = [None; 2];
    }

    /// Sets every lane k to sample the texture whose levels are `levels` ([`Level::all`]),
    /// wrapped by `wraps`, at (`u[k]`, `v[k]`) and level of detail `lod[k]`, as
    /// [`Lookups::set`] sets each: the lanes of a run of pixels on one face. The uniform parts
    /// are stored once, the level choice runs in lanes, and whether each level's lanes read
    /// one slice is found from their level indices (the pointer comparisons it replaces cost
    /// about 7 M instructions an equirect frame, docs/benchmarks.md, "tenth pass"). `avx2`
    /// as [`floor_f32`] takes it.
    #[inline(always)]
    pub(crate) fn set_face(
        &mut self,
        levels: &[Level<'a>],
        wraps: Wraps,
        u: &[f64; L],
        v: &[f64; L],
        lod: &[f32; L],
        avx2: Option<Avx2>,
    ) {
        let (mut fine, mut coarse, mut fraction) = ([0u32; L], [0u32; L], [0.0f32; L]);
        for k in 0..L {
            (fine[k], fraction[k]) = level_below(lod[k], levels.len(), avx2);
            coarse[k] = fine[k] + u32::from(fraction[k] > 0.0);
        }
        self.u = *u;
        self.v = *v;
        // Each axis's wrap stored as whole lanes, where [`Lookups::set_wraps`] lane by lane cost
        // about 25 instructions a run (docs/benchmarks.md, 2026-11-26 evening (tex)).
        let [clamp_u, clamp_v] = wraps.clamp;
        let [period_u, period_v] = wraps.periods;
        self.clamp = [[clamp_u; L], [clamp_v; L]];
        self.periods = [[period_u; L], [period_v; L]];
        self.wrap = wraps.wrap.map(Some);
        // The coarser level is read only where some lane weighs it (`trilinear_lanes`): else
        // its fields are left as they were.
        let coarser = any_nonzero(&fraction);
        for (which, at) in [fine, coarse].iter().enumerate().take(1 + usize::from(coarser)) {
            // One OR over the lanes, where `all`'s early exit was a branch a lane.
            let shared = at.iter().fold(0, |differs, &level| differs | (level ^ at[0])) == 0;
            self.shared[which] = shared;
            if shared {
                let level = levels[at[0] as usize];
                self.texels[which][0] = level.texels;
                self.last[which] = [level.last; L];
                self.size[which] = [[level.size[0]; L], [level.size[1]; L]];
            } else {
                for k in 0..L {
                    self.set_level(which, k, levels[at[k] as usize]);
                }
            }
        }
        for (k, &fraction) in fraction.iter().enumerate() {
            self.share[0][k] = 1.0 - fraction;
            self.share[1][k] = fraction;
        }
    }

    /// Lane `lane`'s texels of level `level` (0 finer, 1 coarser): lane 0's where the lanes
    /// share the level's slice.
    #[inline(always)]
    fn texels_of(&self, level: usize, lane: usize) -> &'a [u64] {
        self.texels[level][if self.shared[level] { 0 } else { lane }]
    }

    /// Sets lane `lane`'s wrap of each axis to `wraps`'s.
    #[inline(always)]
    fn set_wraps(&mut self, lane: usize, wraps: Wraps) {
        for axis in 0..2 {
            self.clamp[axis][lane] = wraps.clamp[axis];
            self.periods[axis][lane] = wraps.periods[axis];
        }
    }

    /// Sets lane `lane`'s level `which` (0 finer, 1 coarser) to `level`.
    #[inline(always)]
    fn set_level(&mut self, which: usize, lane: usize, level: Level<'a>) {
        self.texels[which][lane] = level.texels;
        self.last[which][lane] = level.last;
        self.size[which][0][lane] = level.size[0];
        self.size[which][1][lane] = level.size[1];
    }
}

/// Whether any of `values` is not zero (of either sign; NaN is not zero), as `!= 0.0` says:
/// one OR over the lanes' bits less the sign, where `any`'s early exit was a branch a lane.
#[inline(always)]
fn any_nonzero<const L: usize>(values: &[f32; L]) -> bool {
    values.iter().fold(0, |bits, value| bits | (value.to_bits() << 1)) != 0
}

/// The finer of the two levels of a pyramid of `count` levels around level of detail `lod`
/// (clamped to the pyramid; NaN the coarsest), and the weight of the level after it (zero at
/// a whole level, which then repeats); `avx2` as [`floor_f32`] takes it.
#[inline(always)]
fn level_below(lod: f32, count: usize, avx2: Option<Avx2>) -> (u32, f32) {
    let last = (count - 1) as f32;
    // As `clamp`, but -0 reads +0 (where [`floor`] gives +0 for -0), so that the fraction
    // there is +0, as it was with `f32::floor`.
    let lod = if lod.is_nan() {
        last
    } else {
        higher(lower(lod, last), 0.0)
    };
    // `lod` lies in 0..=last (below 2^22): its floor's bits give the index, where `as u32`
    // costs a saturating conversion.
    let fine = floor_f32(lod, avx2);
    (texel_index(fine) as u32, lod - fine)
}

/// A mip level as the lanes read it: its texels (never empty: an empty level, which only a
/// `Texture` built by hand can have, reads [`NO_TEXELS`]), the index of the last of them, and
/// its width and height.
#[derive(Clone, Copy)]
pub(crate) struct Level<'a> {
    texels: &'a [u64],
    last: u32,
    size: [f32; 2],
}

impl<'a> Level<'a> {
    /// The lanes' form of `level`.
    #[inline(always)]
    fn of(level: &'a MipLevel) -> Self {
        let texels: &[u64] = if level.texels.is_empty() {
            &NO_TEXELS
        } else {
            &level.texels
        };
        Level {
            texels,
            // Within u32: a level holds at most 2^28 texels in a loaded texture; a larger one
            // built by hand reads only its first 2^32.
            last: u32::try_from(texels.len() - 1).unwrap_or(u32::MAX),
            // Exact: sides are at most `MAX_TEXTURE_SIDE` (2^14): the file loader enforces it,
            // and the renderer refuses larger textures built by hand (`Texture::oversized`).
            size: [level.width as f32, level.height as f32],
        }
    }

    /// The lanes' form of every level of `texture`, finest first: worked out once per frame
    /// (converting each lane's level as it was set up cost about 30 instructions a textured
    /// pixel, docs/benchmarks.md).
    pub(crate) fn all(texture: &'a Texture) -> Vec<Self> {
        texture.levels.iter().map(Level::of).collect()
    }
}

/// What an empty mip level (a `Texture` built by hand) reads: one black texel.
static NO_TEXELS: [u64; 1] = [0];

/// A texture's wrap of u and v as the lanes read it, worked out once per face: whether each
/// axis clamps, and its period in texture sizes (2 for mirror, else 1).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Wraps {
    wrap: [Wrap; 2],
    clamp: [bool; 2],
    periods: [f64; 2],
}

impl Wraps {
    /// The lanes' form of `wrap`.
    pub(crate) fn of(wrap: [Wrap; 2]) -> Self {
        Wraps {
            wrap,
            clamp: wrap.map(|wrap| wrap == Wrap::Clamp),
            periods: wrap.map(|wrap| if wrap == Wrap::Mirror { 2.0 } else { 1.0 }),
        }
    }
}

/// A float type [`floor`] works in: the constant whose addition and subtraction round it to
/// an integer.
trait Rounding: Copy + PartialOrd + std::ops::Add<Output = Self> + std::ops::Sub<Output = Self> {
    /// 1.5 · 2^(mantissa bits): adding and subtracting it rounds any |x| up to half of it
    /// (2^51 in f64, 2^22 in f32) to an integer (the ulp there is one), which every SIMD width
    /// has, where `f64::floor` and `f32::floor` are libm calls without SSE4.1.
    const ROUNDING: Self;
    /// One.
    const ONE: Self;
}

impl Rounding for f64 {
    const ROUNDING: f64 = 6_755_399_441_055_744.0;
    const ONE: f64 = 1.0;
}

impl Rounding for f32 {
    const ROUNDING: f32 = 12_582_912.0;
    const ONE: f32 = 1.0;
}

/// Texture coordinates are clamped to ±2^51 before they are reduced by their period: within
/// it [`floor`], and with it the reduction, is exact.
const FAR: f64 = 2_251_799_813_685_248.0;

/// floor(x) for |x| ≤ 2^51 in f64, 2^22 in f32, exactly (but +0 for -0), in operations that
/// vectorise.
#[inline(always)]
fn floor<T: Rounding>(x: T) -> T {
    let nearest = (x + T::ROUNDING) - T::ROUNDING;
    if nearest > x { nearest - T::ONE } else { nearest }
}

/// floor(x) for |x| ≤ 2^22: with `avx2` `f32::floor`, one rounding instruction in code compiled
/// for AVX2 (the lanes', [`Avx2::run`]), where [`floor`]'s four cost about 2.9 M instructions an
/// equirect textured frame (docs/benchmarks.md); without, [`floor`], where `f32::floor` is a
/// libm call.
#[inline(always)]
fn floor_f32(x: f32, avx2: Option<Avx2>) -> f32 {
    if avx2.is_some() { x.floor() } else { floor(x) }
}

/// The lesser of `a` and `b` as a select, which vectorises. A NaN `a` gives `b`; where a NaN
/// can arrive ([`reduced_by`]'s mask, [`level_of_detail`]'s NaN choice) the result is thrown away.
#[inline(always)]
fn lower<T: PartialOrd>(a: T, b: T) -> T {
    if a < b { a } else { b }
}

/// The greater of `a` and `b`, as [`lower`].
#[inline(always)]
fn higher<T: PartialOrd>(a: T, b: T) -> T {
    if a > b { a } else { b }
}

/// 2^23: added to an integer n in 0..2^23 held in f32, it leaves n as the low mantissa bits.
const INDEX_BIAS: f32 = 8_388_608.0;

/// The integer `n` in 0..2^23 held in f32 (a texel's column or row, a level's width, or a
/// level index), as
/// `n as i32` gives it: read off the bits of n + 2^23, an add and an integer subtract in lanes,
/// where `as i32`'s saturating checks cost about 70 instructions a pixel (docs/benchmarks.md).
#[inline(always)]
fn texel_index(n: f32) -> i32 {
    (n + INDEX_BIAS).to_bits().wrapping_sub(INDEX_BIAS.to_bits()) as i32
}

/// What [`reduced_by`] and [`neighbours_by`] work out: each lane's wrap by its `clamp`, or
/// every lane's repeated or clamped ones.
#[derive(Clone, Copy)]
enum Taken {
    ByLane,
    Repeated,
    Clamped,
}

/// Each lane's texture coordinate `t` on an axis, reduced (in f64, exactly) to one its wrap
/// reads the same: for repeat and mirror, t less a whole number of periods (`periods` texture
/// sizes: 1, or 2 for mirror), in 0..=period, with which the wrapped texels repeat (exact for
/// |t| ≥ 1; nearer 0 within one rounding of t, which the wraps read the same); for clamp, t
/// clamped to -1..=2 (beyond either end both texels are the edge's, as they were). NaN or
/// infinite reads coordinate 0 (for repeat, the mean of the last and the first texel); a
/// finite coordinate beyond ±2^51 reads as ±2^51. Each level then works in f32 from it
/// ([`neighbours`]): f32 holds a reduced texel position, at most 2^15 (a mirrored side of `MAX_TEXTURE_SIDE`), within 2^-9 texel,
/// where the f64 floors and wraps of far positions were most of the filter's cost
/// (docs/benchmarks.md, 2026-11-26 (tex)). Where every lane has the same `wrap` and it is
/// repeat or clamp, only that wrap's reduction is worked out (the same values).
#[inline(always)]
fn reduced<const L: usize>(t: &[f64; L], periods: &[f64; L], clamp: &[bool; L], wrap: Option<Wrap>) -> [f64; L] {
    by_wrap(
        wrap,
        #[inline(always)]
        |taken| reduced_by(t, periods, clamp, taken),
    )
}

/// `work` with what every lane takes where they share `wrap` (repeat or clamp), else each its
/// own: one call a constant, inlined, so that only that wrap's lanes are worked out.
#[inline(always)]
fn by_wrap<R>(wrap: Option<Wrap>, work: impl Fn(Taken) -> R) -> R {
    match wrap {
        Some(Wrap::Repeat) => work(Taken::Repeated),
        Some(Wrap::Clamp) => work(Taken::Clamped),
        _ => work(Taken::ByLane),
    }
}

/// [`reduced`], taking the reduction `taken` says (a constant where it is inlined, so the
/// others are never worked out).
#[inline(always)]
fn reduced_by<const L: usize>(t: &[f64; L], periods: &[f64; L], clamp: &[bool; L], taken: Taken) -> [f64; L] {
    let mut reduced = [0.0f64; L];
    for k in 0..L {
        // Non-finite (NaN and ±∞, where the comparison fails) masked to +0: as a branch per
        // lane (`is_finite`, or a select LLVM turned into one) it kept this loop one lane at
        // a time (docs/benchmarks.md, 2026-11-26 (tex)).
        let finite = u64::from(t[k].abs() <= f64::MAX).wrapping_neg();
        let t = f64::from_bits(higher(lower(t[k], FAR), -FAR).to_bits() & finite);
        let clamped = higher(lower(t, 2.0), -1.0);
        // Exact: the period is 1 or 2, so the quotient and the product are scalings by powers
        // of two, and the remainder needs no bits below t's last.
        let period = match taken {
            Taken::Repeated => 1.0,
            _ => periods[k],
        };
        let wrapped = t - period * floor(t / period);
        reduced[k] = match taken {
            Taken::Clamped => clamped,
            Taken::Repeated => wrapped,
            Taken::ByLane => {
                if clamp[k] {
                    clamped
                } else {
                    wrapped
                }
            }
        };
    }
    reduced
}

/// Each lane's two neighbouring texels on an axis (indices, integers in f32) and the weight
/// of the second.
type Neighbours<const L: usize> = ([f32; L], [f32; L], [f32; L]);

/// Each lane's [`Neighbours`] at its reduced coordinate `reduced` ([`reduced`]) on an axis of
/// `size` texels (texel centres at integer + 0.5), wrapped with period `periods` sizes or
/// clamped (`clamp`): as [`reduced`], only `wrap`'s where every lane has that one and it is
/// repeat or clamp.
#[inline(always)]
fn neighbours<const L: usize>(
    reduced: &[f64; L],
    size: &[f32; L],
    periods: &[f64; L],
    clamp: &[bool; L],
    wrap: Option<Wrap>,
    avx2: Option<Avx2>,
) -> Neighbours<L> {
    by_wrap(
        wrap,
        #[inline(always)]
        |taken| neighbours_by(reduced, size, periods, clamp, taken, avx2),
    )
}

/// [`neighbours`], taking the texels `taken` says.
#[inline(always)]
fn neighbours_by<const L: usize>(
    reduced: &[f64; L],
    size: &[f32; L],
    periods: &[f64; L],
    clamp: &[bool; L],
    taken: Taken,
    avx2: Option<Avx2>,
) -> Neighbours<L> {
    // Rounded to f32 once, from f64.
    let mut x = [0.0f32; L];
    for k in 0..L {
        x[k] = (reduced[k] * f64::from(size[k]) - 0.5) as f32;
    }
    let (mut first, mut second, mut weight) = ([0.0; L], [0.0; L], [0.0; L]);
    for k in 0..L {
        let size = size[k];
        // |x| is at most 2^15 + 1, within [`floor`]'s 2^22: the same floor either way.
        let i = floor_f32(x[k], avx2);
        weight[k] = x[k] - i;
        let last = size - 1.0;
        let (clamped0, clamped1) = (higher(lower(i, last), 0.0), higher(lower(i + 1.0, last), 0.0));
        // The reduced coordinate lies in 0..=period, so i in -1..period: -1 is the period's
        // last texel, and i + 1 wraps to the first at the period.
        let period = match taken {
            Taken::Repeated => size,
            _ => periods[k] as f32 * size,
        };
        let wrapped0 = if i < 0.0 { period - 1.0 } else { i };
        let wrapped1 = if i + 1.0 == period { 0.0 } else { i + 1.0 };
        (first[k], second[k]) = match taken {
            Taken::Clamped => (clamped0, clamped1),
            // Repeat's period is one size, so both lie below it: the fold leaves them.
            Taken::Repeated => (wrapped0, wrapped1),
            Taken::ByLane => {
                // Mirror's second half runs backwards; repeat never reaches it.
                let fold = |j: f32| if j < size { j } else { 2.0 * size - 1.0 - j };
                if clamp[k] {
                    (clamped0, clamped1)
                } else {
                    (fold(wrapped0), fold(wrapped1))
                }
            }
        };
    }
    (first, second, weight)
}

/// Each lane's channel (shift 0, 16 or 32 of its texel: a 16-bit linear value), in f32 (exact).
#[inline(always)]
fn linear_channel<const L: usize>(texels: &[u64; L], shift: u32) -> [f32; L] {
    std::array::from_fn(|k| f32::from((texels[k] >> shift) as u16))
}

/// The slice every lane reads of level `level` (0 finer, 1 coarser), where `lookups` knows
/// that they read one (a run of pixels on one face, at one level: the usual case) and it
/// holds at most `i32::MAX` texels, so that one gather from its base reaches each lane's texel.
#[inline(always)]
fn shared_texels<'a, const L: usize>(lookups: &Lookups<'a, L>, level: usize) -> Option<&'a [u64]> {
    let first = *lookups.texels[level].first()?;
    (lookups.shared[level] && first.len() <= i32::MAX as usize).then_some(first)
}

/// Each lane's texel `index` of its level `level` (0 finer, 1 coarser) of `lookups`, clamped
/// to the level's last texel (what a consistent level's indices already are): with `avx2`
/// (and eight lanes) where every lane reads `shared` ([`shared_texels`]), one gather from its
/// base; where the lanes' slices differ, two gathers of their texels' exposed addresses,
/// where a bounds-checked look-up per lane cost 3.3 M instructions more an equirect textured
/// frame (docs/benchmarks.md, "eighth pass" and "tenth pass").
#[inline(always)]
fn fetched<const L: usize>(
    lookups: &Lookups<'_, L>,
    level: usize,
    shared: Option<&[u64]>,
    index: &[i32; L],
    avx2: Option<Avx2>,
) -> [u64; L] {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = avx2
        && let Ok(eight) = <&[i32; 8]>::try_from(&index[..])
    {
        let mut out = [0; L];
        if let Some(texels) = shared {
            // Clamped to the shared slice's own last texel (`Lookups::last` holds the same
            // index), so the bound the gather needs is checked here: below its length, in i32.
            let last = (texels.len() - 1) as u32;
            let index: [u32; 8] = std::array::from_fn(|k| (eight[k] as u32).min(last));
            // SAFETY: every index is at most `last`, inside `texels` and within i32 (see
            // `shared_texels`); `out` holds eight u64 (L = 8, as `eight` shows).
            unsafe { gather_avx2(avx2, texels, &index, out.as_mut_ptr()) };
        } else {
            let last = &lookups.last[level];
            let addresses: [u64; 8] = std::array::from_fn(|k| {
                let index = (eight[k] as u32).min(last[k]);
                lookups.texels_of(level, k).as_ptr().expose_provenance() as u64 + 8 * u64::from(index)
            });
            // SAFETY: each address is that of a texel of its lane's slice (`texels_of`), whose
            // provenance was exposed just above: `Lookups` keeps `last` the index of the last
            // of that slice (never empty), and the index is clamped to it; `out` holds eight
            // u64.
            unsafe { gather_exposed_avx2(avx2, &addresses, out.as_mut_ptr()) };
        }
        return out;
    }
    let last = &lookups.last[level];
    std::array::from_fn(|k| {
        lookups
            .texels_of(level, k)
            .get((index[k] as u32).min(last[k]) as usize)
            .copied()
            .unwrap_or_default()
    })
}

/// [`fetched`] for eight lanes that read one slice: `texels[index[k]]` for each lane k,
/// gathered from the slice's base, written to `out`. The token proves the CPU has AVX2.
///
/// # Safety
/// Every index must be below `texels.len()` and at most `i32::MAX`; `out` must be valid for
/// eight u64 writes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn gather_avx2(_: Avx2, texels: &[u64], index: &[u32; 8], out: *mut u64) {
    use std::arch::x86_64::{__m128i, __m256i, _mm_loadu_si128, _mm256_i32gather_epi64, _mm256_storeu_si256};
    // SAFETY: the loads read the eight indices; each gathered u64 is `texels[index]`, inside
    // the slice (the caller's promise; as i32 the indices keep their value); the stores write
    // the eight u64 of `out`.
    unsafe {
        for (half, first) in [0, 4].into_iter().enumerate() {
            let lanes = _mm_loadu_si128(index[first..].as_ptr().cast::<__m128i>());
            let gathered = _mm256_i32gather_epi64::<8>(texels.as_ptr().cast::<i64>(), lanes);
            _mm256_storeu_si256(out.add(4 * half).cast::<__m256i>(), gathered);
        }
    }
}

/// [`fetched`] for eight lanes that read different slices: the u64 at each of `addresses`,
/// written to `out`, gathered as offsets from a base of address 0 that takes its provenance
/// from [`std::ptr::with_exposed_provenance`] (so each access has the exposed provenance of
/// the slice holding it). The token proves the CPU has AVX2.
///
/// # Safety
/// Every address must be that of a u64 inside an allocation whose provenance was exposed
/// (`expose_provenance`) and which is readable for the call; `out` must be valid for eight
/// u64 writes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn gather_exposed_avx2(_: Avx2, addresses: &[u64; 8], out: *mut u64) {
    use std::arch::x86_64::{__m256i, _mm256_i64gather_epi64, _mm256_loadu_si256, _mm256_storeu_si256};
    let base = std::ptr::with_exposed_provenance::<i64>(0);
    // SAFETY: the loads read the eight addresses; the gathers read the u64 the caller promised
    // (address 0 plus each address, with exposed provenance); the stores write the eight u64
    // of `out`.
    unsafe {
        for (half, first) in [0, 4].into_iter().enumerate() {
            let lanes = _mm256_loadu_si256(addresses[first..].as_ptr().cast::<__m256i>());
            let gathered = _mm256_i64gather_epi64::<1>(base, lanes);
            _mm256_storeu_si256(out.add(4 * half).cast::<__m256i>(), gathered);
        }
    }
}

/// The trilinear samples of every lane (see [`trilinear`]), red, green and blue by lane: the
/// eight taps of each (corners (x0, y0), (x1, y0), (x0, y1), (x1, y1) of the finer level, then
/// of the coarser) mixed as one weighted sum per channel, summed in one order: taps k and
/// k + 4, then those sums' 0 + 2 and 1 + 3, then the two. The same operations in every lane, so
/// any lane count, with `avx2` or without, gives the same bits (tested). With `avx2` the
/// fetches are gathered; the caller compiles the lanes for AVX2
/// ([`Avx2::run`]) so that their coordinates, wraps, weights and mixing run in vector lanes.
#[inline(always)]
pub(crate) fn trilinear_lanes<const L: usize>(lookups: &Lookups<'_, L>, avx2: Option<Avx2>) -> [[f32; L]; 3] {
    let u = reduced(&lookups.u, &lookups.periods[0], &lookups.clamp[0], lookups.wrap[0]);
    let v = reduced(&lookups.v, &lookups.periods[1], &lookups.clamp[1], lookups.wrap[1]);
    // Whether each level's lanes read one slice, found once for its four taps.
    let shared = match avx2 {
        Some(_) => [shared_texels(lookups, 0), shared_texels(lookups, 1)],
        None => [None; 2],
    };
    let finer = weighted_taps(lookups, 0, [&u, &v], shared[0], avx2);
    let mut sums = [[0.0f32; L]; 3];
    // Where every lane's coarser level weighs zero (a whole level of detail: magnified, or at
    // either end of the pyramid), its taps would add zeros (every weighted tap is at least
    // +0): they are left out, the same bits.
    if lookups.share[1].iter().any(|&share| share != 0.0) {
        let coarser = weighted_taps(lookups, 1, [&u, &v], shared[1], avx2);
        for ((sum, f), c) in sums.iter_mut().zip(&finer).zip(&coarser) {
            for k in 0..L {
                sum[k] = ((f[0][k] + c[0][k]) + (f[2][k] + c[2][k])) + ((f[1][k] + c[1][k]) + (f[3][k] + c[3][k]));
            }
        }
    } else {
        for (sum, f) in sums.iter_mut().zip(&finer) {
            for k in 0..L {
                sum[k] = (f[0][k] + f[2][k]) + (f[1][k] + f[3][k]);
            }
        }
    }
    sums
}

/// The four taps of level `level` (0 finer, 1 coarser) of each lane at its reduced
/// coordinates `uv` ([`reduced`]), each channel times its weight (its bilinear weight
/// times the level's share), by channel (red, green, blue), tap (corners (x0, y0), (x1, y0),
/// (x0, y1), (x1, y1)), lane; `shared` as [`fetched`] takes it.
#[inline(always)]
fn weighted_taps<const L: usize>(
    lookups: &Lookups<'_, L>,
    level: usize,
    uv: [&[f64; L]; 2],
    shared: Option<&[u64]>,
    avx2: Option<Avx2>,
) -> [[[f32; L]; 4]; 3] {
    let [width, height] = &lookups.size[level];
    let (periods, clamp, wrap) = (&lookups.periods, &lookups.clamp, lookups.wrap);
    let (x0, x1, fx) = neighbours(uv[0], width, &periods[0], &clamp[0], wrap[0], avx2);
    let (y0, y1, fy) = neighbours(uv[1], height, &periods[1], &clamp[1], wrap[1], avx2);
    // Texel indices (below 2^28, the texel limit: exact in i32) and weights by tap.
    let (mut indices, mut weights) = ([[0i32; L]; 4], [[0.0f32; L]; 4]);
    for k in 0..L {
        let width = texel_index(width[k]);
        let (row0, row1) = (
            texel_index(y0[k]).wrapping_mul(width),
            texel_index(y1[k]).wrapping_mul(width),
        );
        let (x0, x1) = (texel_index(x0[k]), texel_index(x1[k]));
        indices[0][k] = row0.wrapping_add(x0);
        indices[1][k] = row0.wrapping_add(x1);
        indices[2][k] = row1.wrapping_add(x0);
        indices[3][k] = row1.wrapping_add(x1);
        let share = lookups.share[level][k] * UNIT;
        let (top, bottom) = (share * (1.0 - fy[k]), share * fy[k]);
        weights[0][k] = top * (1.0 - fx[k]);
        weights[1][k] = top * fx[k];
        weights[2][k] = bottom * (1.0 - fx[k]);
        weights[3][k] = bottom * fx[k];
    }
    let mut weighted = [[[0.0f32; L]; 4]; 3];
    for tap in 0..4 {
        let texels = fetched(lookups, level, shared, &indices[tap], avx2);
        for (channel, shift) in [0, 16, 32].into_iter().enumerate() {
            let linear = linear_channel(&texels, shift);
            for k in 0..L {
                weighted[channel][tap][k] = weights[tap][k] * linear[k];
            }
        }
    }
    weighted
}

/// Trilinear sample at level of detail `lod` (0 = finest; clamped to the pyramid): the two
/// levels around it, bilinear each, mixed by its fraction, in linear light. One lane of
/// [`trilinear_lanes`], for pixels shaded one at a time.
pub(crate) fn trilinear(texture: &Texture, wrap: [Wrap; 2], uv: DVec2, lod: f32) -> Vec3A {
    let [[red], [green], [blue]] = trilinear_lanes::<1>(&Lookups::filled(texture, Wraps::of(wrap), uv, lod), None);
    Vec3A::new(red, green, blue)
}

/// The level of detail of a footprint whose longer axis is `length` metres on a face of
/// `texels_per_metre_squared` (`UvMap::texels_per_metre_squared`): log2 of that axis in texels of
/// the finest level (the isotropic rule of OpenGL's `textureLod` selection), taken as half
/// the log2 of its square. A NaN length (a degenerate footprint) gives the coarsest level.
///
/// The log2 is read off the square's f32 bits ([`log2_by_bits`], exact at powers of two, within
/// 0.004 levels between them), as GPUs' own level selection approximates it, and
/// `shaders/texture.wgsl` computes the same formula: libm's `log2f` cost a textured pixel about
/// 30 instructions (docs/benchmarks.md, "eighth pass").
///
/// Written as selects of values all worked out (the log2 of any bits is harmless), so that the
/// textured runs' loop over their lanes vectorises: its branches (or a select LLVM made one)
/// kept it one lane at a time (docs/benchmarks.md, 2026-11-26 (tex)).
#[inline(always)]
pub(crate) fn level_of_detail(texels_per_metre_squared: f32, length: f32) -> f32 {
    let squared = texels_per_metre_squared * length * length;
    // 0 where the square is at most 1 (magnified textures: most of a room's pixels), whose
    // log2 by bits is at most 0 (increasing, exact at 1; -0 and below read as +0), else its
    // half log2.
    let lod = higher(0.5 * log2_by_bits(higher(squared, 0.0)), 0.0);
    // As the GPU's `squared < FAR`.
    if squared.is_nan() { f32::INFINITY } else { lod }
}

/// log2 of `x` (positive, normal or infinite; +0 and subnormals read below −126) from its f32
/// bits: for x = 2^e · (1 + f), 0 ≤ f < 1, the exponent e plus log2(1 + f) ≈ f + c · f ·
/// (1 − f), the quadratic through both ends with the least largest error (c = 0.34655: within
/// 0.0077 of log2, where f alone is 0.086 off). Exact at powers of two, continuous and
/// increasing in exact arithmetic (slope at least 1 − c); in f32 it never decreases, which is
/// what [`level_of_detail`] needs.
#[inline(always)]
fn log2_by_bits(x: f32) -> f32 {
    let bits = x.to_bits();
    let exponent = (bits >> 23) as i32 - 127;
    // Below 2^23: exact in f32, as is the scaling by a power of two.
    let fraction = (bits & 0x7f_ffff) as f32 * (1.0 / 8_388_608.0);
    exponent as f32 + (fraction + LOG2_BEND * (fraction * (1.0 - fraction)))
}

/// The bend of [`log2_by_bits`]'s quadratic (`LOG2_BEND` in `shaders/texture.wgsl`).
const LOG2_BEND: f32 = 0.34655;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::surface::UvMap;
    use glam::DVec3;

    /// The lanes as textured frames run them: compiled for AVX2 and gathering where the CPU
    /// has it, else portable.
    fn with_avx2_where_detected(lookups: &Lookups<'_, LANES>) -> [[f32; LANES]; 3] {
        let detected = Avx2::detected();
        if detected.is_none() {
            eprintln!("no AVX2 on this CPU: the portable lanes are checked against themselves");
        }
        match detected {
            Some(avx2) => avx2.run(
                #[inline(always)]
                || trilinear_lanes(lookups, Some(avx2)),
            ),
            None => trilinear_lanes(lookups, None),
        }
    }

    /// The filter's linear value of sRGB byte `byte` at a texel centre (weight one).
    fn filtered(byte: u8) -> f32 {
        UNIT * f32::from(crate::scene::texture::linear16(byte))
    }

    fn ramp() -> Texture {
        // 4×1 texels 0, 85, 170, 255 in sRGB.
        Texture::from_rgb(4, 1, &[[0; 3], [85; 3], [170; 3], [255; 3]])
    }

    /// The rounding trick's floor is the library's within its range, in f32 and in f64, at
    /// and around integers, halves and both ends (only -0 differs: it gives +0).
    #[test]
    fn floor_by_rounding_is_the_library_floor_within_its_range() {
        let (f32_end, f64_end) = (4_194_304.0f32, 2_251_799_813_685_248.0f64);
        let mut f32_points = vec![0.0f32, f32_end, -f32_end, f32_end - 0.5, 1.0 - f32::EPSILON / 2.0];
        let mut f64_points = vec![0.0f64, f64_end, -f64_end, f64_end - 0.5, 1.0 - f64::EPSILON / 2.0];
        for i in -70_000..70_000 {
            let x = i as f32 / 4.0;
            f32_points.extend([x, x.next_up(), x.next_down()]);
            let x = f64::from(i) / 4.0;
            f64_points.extend([x, x.next_up(), x.next_down()]);
        }
        for x in f32_points
            .into_iter()
            .flat_map(|x| [x, -x])
            .filter(|x| x.abs() <= f32_end)
        {
            assert_eq!(floor(x), x.floor() + 0.0, "{x}");
        }
        for x in f64_points
            .into_iter()
            .flat_map(|x| [x, -x])
            .filter(|x| x.abs() <= f64_end)
        {
            assert_eq!(floor(x), x.floor() + 0.0, "{x}");
        }
        assert_eq!(floor(-0.0f32).to_bits(), 0.0f32.to_bits());
    }

    #[test]
    fn bilinear_hits_texel_centres_and_interpolates_between() {
        let t = ramp();
        let wrap = [Wrap::Clamp; 2];
        let at = |u: f64| f64::from(trilinear(&t, wrap, DVec2::new(u, 0.5), 0.0).x);
        let linear = |b: u8| f64::from(filtered(b));
        assert_eq!(at(0.125), linear(0));
        assert_eq!(at(0.375), linear(85));
        // Within the 16-bit values' rounding (and f32's) of the exact decoding; white is 1.
        let exact = crate::scene::lighting::srgb_to_linear(85);
        assert!(
            (at(0.375) - exact).abs() <= 0.5 / 65535.0 + 1e-7,
            "{} vs {exact}",
            at(0.375)
        );
        assert_eq!(filtered(255), 1.0);
        let halfway = (linear(85) + linear(170)) / 2.0;
        assert!((at(0.5) - halfway).abs() < 1e-7);
        // Repeat wraps the left edge onto the last texel.
        let repeat = f64::from(trilinear(&t, [Wrap::Repeat; 2], DVec2::new(0.0, 0.5), 0.0).x);
        assert!((repeat - (linear(0) + 1.0) / 2.0).abs() < 1e-7);
        // Coordinates far out and negative wrap as near ones do (the integer floor).
        let far = trilinear(&t, [Wrap::Repeat; 2], DVec2::new(-1e6 + 0.375, 0.5), 0.0).x;
        assert_eq!(f64::from(far), linear(85));
        // Between levels: the levels' bilinear samples mixed by the fraction (level 1 of the
        // ramp is two texels, the means of 0, 85 and of 170, 255 in linear light).
        let (u, fraction) = (0.3, 0.25);
        let mixed = f64::from(trilinear(&t, wrap, DVec2::new(u, 0.5), 1.0 + fraction).x);
        let level = |l: f32| f64::from(trilinear(&t, wrap, DVec2::new(u, 0.5), l).x);
        let expected = level(1.0) * (1.0 - f64::from(fraction)) + level(2.0) * f64::from(fraction);
        assert!((mixed - expected).abs() < 1e-6, "{mixed} vs {expected}");
    }

    /// Eight lanes of mixed textures, wraps, sizes (powers of two and not), levels and
    /// coordinates (near, far, negative, NaN): the AVX2 lanes give the portable lanes' bits, and
    /// every lane the bits of the one-lane sample.
    #[test]
    fn lanes_give_the_one_lane_sample_bit_for_bit_with_and_without_avx2() {
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let textures: Vec<Texture> = [(4, 1), (5, 3), (16, 16), (7, 12)]
            .into_iter()
            .map(|(w, h)| {
                let texels: Vec<[u8; 3]> = (0..w * h)
                    .map(|_| next().to_le_bytes()[..3].try_into().unwrap())
                    .collect();
                Texture::from_rgb(w, h, &texels)
            })
            .collect();
        let wraps = [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror];
        for _ in 0..2_000 {
            let coordinate = |kind: u64, value: u64| match kind % 16 {
                0 => f64::NAN,
                1 => -1e7 + (value % 1000) as f64 / 997.0,
                2 => f64::INFINITY,
                _ => (value % 100_000) as f64 / 9_973.0 - 5.0,
            };
            let lanes_in: [_; LANES] = std::array::from_fn(|_| {
                let texture = &textures[next() as usize % textures.len()];
                let wrap = [0, 1].map(|_| wraps[next() as usize % 3]);
                let uv = DVec2::new(coordinate(next(), next()), coordinate(next(), next()));
                let lod = match next() % 8 {
                    0 => f32::NAN,
                    _ => (next() % 5000) as f32 / 1000.0 - 0.5,
                };
                (texture, wrap, uv, lod)
            });
            let (texture, wrap, uv, lod) = lanes_in[0];
            let mut lookups = Lookups::<LANES>::filled(texture, Wraps::of(wrap), uv, lod);
            for (lane, &(texture, wrap, uv, lod)) in lanes_in.iter().enumerate() {
                lookups.set(lane, texture, Wraps::of(wrap), uv, lod);
            }
            let bits = |samples: [[f32; LANES]; 3]| samples.map(|channel| channel.map(f32::to_bits));
            let portable = bits(trilinear_lanes(&lookups, None));
            assert_eq!(bits(with_avx2_where_detected(&lookups)), portable);
            for (k, &(texture, wrap, uv, lod)) in lanes_in.iter().enumerate() {
                let one = trilinear(texture, wrap, uv, lod).to_array().map(f32::to_bits);
                assert_eq!(one, [0, 1, 2].map(|c| portable[c][k]), "lane {k}");
            }
            // The lanes of a run on one face (the first lane's texture and wrap), set up
            // together: the bits of each lane set up alone. Every third run at one level, so
            // that its lanes share their slices.
            let levels = Level::all(texture);
            let one_level = next() % 3 == 0;
            let lod: [f32; LANES] = std::array::from_fn(|k| if one_level { lod } else { lanes_in[k].3 });
            let (u, v) = (lanes_in.map(|lane| lane.2.x), lanes_in.map(|lane| lane.2.y));
            lookups.set_face(&levels, Wraps::of(wrap), &u, &v, &lod, Avx2::detected());
            // The finer level's lanes share its slice (the coarser is set up only where weighed).
            assert!(!one_level || (lookups.shared[0] && (lookups.share[1] == [0.0; LANES] || lookups.shared[1])));
            let together = bits(trilinear_lanes(&lookups, None));
            assert_eq!(bits(with_avx2_where_detected(&lookups)), together);
            // The face's lanes in AVX2 registers throughout, where the CPU has AVX2: the bits of
            // the lanes set up together (on one level they read one slice, else each lane's).
            let face_levels = Levels::of(texture);
            let face_samples = |lod| samples(Avx2::detected(), &face_levels, Wraps::of(wrap), [&u, &v], lod);
            let face = face_samples(&lod);
            assert!(face.is_some() || Avx2::detected().is_none());
            assert_eq!(face.map(bits).unwrap_or(together), together);
            // At the levels of detail of footprints' longer axes near, far, zero, infinite and
            // NaN (the coarsest level): the bits of the lanes set up together.
            let scale = (next() % 100_000) as f32 + 0.5;
            let length: [f32; LANES] = std::array::from_fn(|_| match next() % 8 {
                0 => f32::NAN,
                1 => f32::INFINITY,
                2 => 0.0,
                _ => (next() % 10_000) as f32 / 1e5,
            });
            let of_lengths = length.map(|length| level_of_detail(scale, length));
            let mut of_footprints = Lookups::<LANES>::empty();
            of_footprints.set_face(&levels, Wraps::of(wrap), &u, &v, &of_lengths, None);
            let of_footprints = bits(trilinear_lanes(&of_footprints, None));
            let face = face_samples(&of_lengths);
            assert!(face.is_some() || Avx2::detected().is_none());
            assert_eq!(face.map(bits).unwrap_or(of_footprints), of_footprints);
            for k in 0..LANES {
                let one = trilinear(texture, wrap, DVec2::new(u[k], v[k]), lod[k])
                    .to_array()
                    .map(f32::to_bits);
                assert_eq!(one, [0, 1, 2].map(|c| together[c][k]), "lane {k} of a face");
            }
        }
    }

    /// A lane set alone after a face's lanes were set together (one level, so they share its
    /// slice, and one wrap): it samples its own texture with its own wrap, as the one-lane
    /// sample does, with and without AVX2; the others keep the face's samples.
    #[test]
    fn a_lane_set_after_a_face_reads_its_own_texture_and_wrap() {
        let face_texture = ramp();
        let texels: Vec<[u8; 3]> = (0..15u8).map(|i| [17 * i, 255 - 13 * i, 40 + 9 * i]).collect();
        let own_texture = Texture::from_rgb(5, 3, &texels);
        let face_wrap = [Wrap::Repeat; 2];
        let lanes_in: [DVec2; LANES] = std::array::from_fn(|k| DVec2::new(k as f64 / 5.0 - 0.3, 0.5));
        let mut lookups = Lookups::<LANES>::empty();
        lookups.set_face(
            &Level::all(&face_texture),
            Wraps::of(face_wrap),
            &lanes_in.map(|uv| uv.x),
            &lanes_in.map(|uv| uv.y),
            &[0.0; LANES],
            None,
        );
        assert!(lookups.shared[0]);
        // Outside the texture, where clamping and repeating differ.
        let (lane, own_wrap, own_uv, own_lod) = (3, [Wrap::Clamp, Wrap::Mirror], DVec2::new(1.3, -0.4), 0.6);
        lookups.set(lane, &own_texture, Wraps::of(own_wrap), own_uv, own_lod);
        let portable = trilinear_lanes(&lookups, None);
        assert_eq!(with_avx2_where_detected(&lookups), portable);
        for (k, &uv) in lanes_in.iter().enumerate() {
            let one = match k == lane {
                true => trilinear(&own_texture, own_wrap, own_uv, own_lod),
                false => trilinear(&face_texture, face_wrap, uv, 0.0),
            };
            assert_eq!(one.to_array(), [0, 1, 2].map(|c| portable[c][k]), "lane {k}");
        }
    }

    /// A texture built by hand whose levels hold fewer texels than their sizes say, or none:
    /// fetches are clamped to each level's last texel (an empty level reads black), in lanes
    /// with and without AVX2 as in one lane, and never read outside the level; a texel's bits
    /// 48–63, set by hand, are read as zero on every path.
    #[test]
    fn short_and_empty_levels_read_their_last_texel_or_black() {
        let texel = |rgb: [u8; 3]| crate::scene::texture::pack(rgb);
        let mut texture = Texture {
            levels: vec![
                MipLevel::from_srgb(
                    4,
                    4,
                    &[texel([10, 20, 30]), texel([200, 100, 50]), texel([255, 255, 255])],
                ),
                MipLevel {
                    width: 2,
                    height: 2,
                    texels: Vec::new(),
                },
            ],
        };
        texture.levels[0].texels[1] |= 0xabcd << 48;
        let white = f64::from(filtered(255));
        // Texel (3, 3) of the finest level: index 15, clamped to the last texel, white.
        let corner = trilinear(&texture, [Wrap::Clamp; 2], DVec2::splat(0.99), 0.0);
        for channel in corner.to_array() {
            // Its four taps' f32 weights sum to 1 within rounding.
            assert!((f64::from(channel) - white).abs() < 1e-6, "{corner}");
        }
        // The empty level: black.
        assert_eq!(
            trilinear(&texture, [Wrap::Repeat; 2], DVec2::splat(0.3), 1.0),
            Vec3A::ZERO
        );
        let wraps = Wraps::of([Wrap::Repeat; 2]);
        let mut lookups = Lookups::<LANES>::filled(&texture, wraps, DVec2::ZERO, 0.0);
        let lanes_in: [(DVec2, f32); LANES] =
            std::array::from_fn(|k| (DVec2::new(k as f64 / 7.0, 0.61), k as f32 / 7.0));
        for (lane, &(uv, lod)) in lanes_in.iter().enumerate() {
            lookups.set(lane, &texture, wraps, uv, lod);
        }
        let portable = trilinear_lanes(&lookups, None);
        assert_eq!(with_avx2_where_detected(&lookups), portable);
        for (k, &(uv, lod)) in lanes_in.iter().enumerate() {
            let one = trilinear(&texture, [Wrap::Repeat; 2], uv, lod).to_array();
            assert_eq!(one, [0, 1, 2].map(|c| portable[c][k]), "lane {k}");
        }
        // Every lane on the short finest level (with AVX2 one gather from it a tap), indices
        // past its three texels among them: clamped as in one lane.
        let lanes_in: [DVec2; LANES] = std::array::from_fn(|k| DVec2::new(k as f64 / 7.0, 0.1 + k as f64 / 9.0));
        let levels = Level::all(&texture);
        lookups.set_face(
            &levels,
            wraps,
            &lanes_in.map(|uv| uv.x),
            &lanes_in.map(|uv| uv.y),
            &[0.0; LANES],
            None,
        );
        assert!(shared_texels(&lookups, 0).is_some_and(|texels| texels.len() == 3));
        let portable = trilinear_lanes(&lookups, None);
        assert_eq!(with_avx2_where_detected(&lookups), portable);
        let (u, v) = (lanes_in.map(|uv| uv.x), lanes_in.map(|uv| uv.y));
        let face = samples(Avx2::detected(), &Levels::of(&texture), wraps, [&u, &v], &[0.0; LANES]);
        assert!(face.is_some() || Avx2::detected().is_none());
        assert_eq!(face.unwrap_or(portable), portable);
        for (k, &uv) in lanes_in.iter().enumerate() {
            let one = trilinear(&texture, [Wrap::Repeat; 2], uv, 0.0).to_array();
            assert_eq!(one, [0, 1, 2].map(|c| portable[c][k]), "lane {k}");
        }
        // Lanes between the short level and the empty one, some on each: each lane's own.
        let lod: [f32; LANES] = std::array::from_fn(|k| k as f32 / 5.0);
        lookups.set_face(&levels, wraps, &u, &v, &lod, None);
        let portable = trilinear_lanes(&lookups, None);
        let face = samples(Avx2::detected(), &Levels::of(&texture), wraps, [&u, &v], &lod);
        assert!(face.is_some() || Avx2::detected().is_none());
        assert_eq!(face.unwrap_or(portable), portable);
        // A texture without levels has no tables: the lanes are not asked.
        let no_levels = Texture { levels: Vec::new() };
        assert!(samples(Avx2::detected(), &Levels::of(&no_levels), wraps, [&u, &v], &lod).is_none());
    }

    /// The wraps' texel pairs, in lanes: each index i (its coordinate a quarter texel past i's
    /// centre) and i + 1 folded by remainders, for sizes 1, 3 (remainders) and 4 (powers of two).
    #[test]
    fn wrap_modes_fold_indices() {
        let folded = |wrap: Wrap, size: u32, i: i64| -> f64 {
            let n = i64::from(size);
            (match wrap {
                Wrap::Repeat => i.rem_euclid(n),
                Wrap::Clamp => i.clamp(0, n - 1),
                Wrap::Mirror => {
                    let k = i.rem_euclid(2 * n);
                    if k < n { k } else { 2 * n - 1 - k }
                }
            }) as f64
        };
        for wrap in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror] {
            for size in [1, 3, 4] {
                let side = size as f32;
                let periods = if wrap == Wrap::Mirror { 2.0 } else { 1.0 };
                // Lane by lane, and as every lane's one wrap: the same indices (a test of the
                // one-wrap paths of repeat and clamp; mirror takes the lane-by-lane path both ways).
                let axis = |t: f64| {
                    let clamp = [wrap == Wrap::Clamp];
                    let by_lane = |wrap| {
                        neighbours(
                            &reduced(&[t], &[periods], &clamp, wrap),
                            &[side],
                            &[periods],
                            &clamp,
                            wrap,
                            None,
                        )
                    };
                    let (uniform, by_lane) = (by_lane(Some(wrap)), by_lane(None));
                    let bits = |(first, second, weight): Neighbours<1>| {
                        (first[0].to_bits(), second[0].to_bits(), weight[0].to_bits())
                    };
                    assert_eq!(bits(by_lane), bits(uniform), "{wrap:?} {size} {t}");
                    by_lane
                };
                for i in (-9..11).chain([-4_000_000_001, 1 << 40]) {
                    let t = (i as f64 + 0.75) / f64::from(size);
                    let (first, second, weight) = axis(t);
                    let want = (folded(wrap, size, i), folded(wrap, size, i + 1));
                    assert_eq!((f64::from(first[0]), f64::from(second[0])), want, "{wrap:?} {size} {i}");
                    // Clamp's far coordinates are reduced to -1..=2, which moves the weight
                    // between two texels that are both the edge's (it reads nothing there).
                    if wrap != Wrap::Clamp || (-1.0..=2.0).contains(&t) {
                        assert!((weight[0] - 0.25).abs() < 1e-3, "{wrap:?} {size} {i}: {}", weight[0]);
                    }
                }
                // Coordinates beyond 2^51 texels, infinite or NaN still read texels of the image.
                for t in [1e300, -1e300, f64::INFINITY, f64::NAN] {
                    let (first, second, _) = axis(t);
                    assert!(first[0] >= 0.0 && first[0] < side, "{wrap:?} {t}");
                    assert!(second[0] >= 0.0 && second[0] < side, "{wrap:?} {t}");
                }
            }
        }
    }

    /// What a coordinate no texel position can hold reduces to, for every wrap, as every lane's
    /// wrap and lane by lane: +0 (bits) for NaN of any sign or payload and ±∞, -1 and 2 for clamp
    /// of ±`f64::MAX`, and -0 kept by every reduction.
    #[test]
    fn coordinates_beyond_f64_reduce_to_plus_zero() {
        let odd_nan = f64::from_bits(0x7ff0_0000_0000_0001);
        for wrap in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror] {
            let period = if wrap == Wrap::Mirror { 2.0 } else { 1.0 };
            let clamp = wrap == Wrap::Clamp;
            for every_lane in [Some(wrap), None] {
                let reduce = |t: f64| reduced(&[t], &[period], &[clamp], every_lane)[0];
                for t in [f64::NAN, -f64::NAN, odd_nan, f64::INFINITY, f64::NEG_INFINITY] {
                    assert_eq!(reduce(t).to_bits(), 0, "{wrap:?} {every_lane:?} {t}");
                }
                assert_eq!(reduce(-0.0).to_bits(), (-0.0f64).to_bits(), "{wrap:?} {every_lane:?}");
                if clamp {
                    assert_eq!(reduce(f64::MAX), 2.0);
                    assert_eq!(reduce(-f64::MAX), -1.0);
                }
            }
        }
    }

    /// The level of a square at most 1 is +0 exactly (bits), below and at 1, for negative,
    /// -0 and subnormal squares too (whose sign and exponent bits would read as a level near
    /// 64 or 127 if they reached the log unclamped).
    #[test]
    fn magnified_and_degenerate_footprints_take_level_plus_zero() {
        let subnormal = f32::from_bits(1);
        for (scale, length) in [
            (-0.0, 1.0),
            (-1.0, 1.0),
            (1.0, 1.0),
            (0.999_999_94, 1.0),
            (subnormal, 1.0),
            (1.0, 0.0),
        ] {
            let lod = level_of_detail(scale, length);
            assert_eq!(lod.to_bits(), 0, "scale {scale}, length {length}: {lod}");
        }
    }

    #[test]
    fn level_of_detail_is_log2_of_the_longer_footprint_axis_in_texels() {
        // 256 texels per metre along u, 64 along v (an anisotropic map takes the larger).
        let map = |gradient| UvMap {
            texture: 0,
            wrap: [Wrap::Repeat; 2],
            at_anchor: DVec2::ZERO,
            gradient,
        };
        let scale = map([DVec3::X, DVec3::Y * 0.25]).texels_per_metre_squared((256, 256));
        assert_eq!(scale, 256.0 * 256.0);
        let rotated = map([DVec3::new(0.6, 0.8, 0.0), DVec3::new(-0.8, 0.6, 0.0)]);
        assert!((rotated.texels_per_metre_squared((256, 256)) - 256.0 * 256.0).abs() < 1e-9);
        assert_eq!(level_of_detail(scale as f32, 4.0 / 256.0), 2.0);
        // Between powers of two: within 0.004 levels of half the log2, and increasing.
        let mut previous = 0.0;
        for k in 0..=100_000 {
            let length = 1.0 + f64::from(k) * 0.000_63;
            let lod = level_of_detail(scale as f32, (length / 256.0) as f32);
            let exact = length.log2();
            assert!((f64::from(lod) - exact).abs() < 0.004, "{length}: {lod} vs {exact}");
            assert!(lod >= previous, "{length}: {lod} after {previous}");
            previous = lod;
        }
        assert_eq!(level_of_detail(scale as f32, 0.0), 0.0);
        // Infinite: 2^128's level, beyond every pyramid (at most 15 levels), as the GPU's
        // coarsest.
        assert_eq!(level_of_detail(scale as f32, f32::INFINITY), 64.0);
        // NaN: the coarsest level too.
        assert_eq!(level_of_detail(scale as f32, f32::NAN), f32::INFINITY);
        let t = ramp();
        // Beyond the pyramid: the 1×1 level, the mean in linear light (its four taps' f32
        // weights sum to 1 within rounding).
        let coarsest = trilinear(&t, [Wrap::Repeat; 2], DVec2::splat(0.3), 99.0).x;
        let mean = filtered(t.levels[2].texel(0, 0)[0]);
        assert!(
            (coarsest - mean).abs() <= 2.0 * f32::EPSILON * mean,
            "{coarsest} vs {mean}"
        );
    }
}
