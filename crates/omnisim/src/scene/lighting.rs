//! Light points, the ambient term and exposure: what the shading stage (`shade/mod.rs` and its
//! WGSL twin `shaders/shade.wgsl`) turns into colour.
//!
//! The model is photometric and stated in README: a face's linear albedo is its sRGB colour
//! decoded; a point light of luminous intensity I (candela) at distance d lights a face with
//! illuminance E = I·cosθ/d² (Lambert's cosine law, inverse-square fall-off) when nothing lies
//! between them (hard shadows); a directional light gives E = E⊥·cosθ; the ambient term adds a
//! uniform, unshadowed illuminance. The linear pixel value is albedo · ΣE / `white`, where
//! `white` (lux) is the fixed exposure at which a white face reaches full scale; sRGB encoding
//! comes last. Faces are two-sided: a face is lit only from the side the camera sees.

use glam::DVec3;
use serde::Serialize;

/// Where a light is and how its light arrives.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum LightKind {
    /// A light point radiating equally in every direction, with inverse-square fall-off.
    Point {
        /// World position, metres.
        position: DVec3,
        /// Luminous intensity, candela (lumen per steradian).
        intensity: f64,
    },
    /// A light at infinity (the sun), arriving along one direction.
    Directional {
        /// Unit direction the light travels in (from the light towards the scene), world frame.
        direction: DVec3,
        /// Illuminance on a surface facing the light, lux.
        illuminance: f64,
    },
}

/// One named light of a scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Light {
    /// Name from the scene file, unique in the scene; data-set specs switch lights by name.
    pub name: String,
    /// Geometry and strength.
    pub kind: LightKind,
    /// Linear RGB tint, each channel in [0, 1] (decoded from the file's sRGB colour).
    pub colour: DVec3,
    /// Switched-off lights stay in the scene and cost nothing.
    pub on: bool,
}

/// The lighting of a scene. A scene without one is drawn in flat face colours.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Lighting {
    /// Uniform illuminance reaching every face whatever its orientation, lux (no shadows).
    pub ambient: f64,
    /// Exposure: the illuminance, lux, at which a white face reaches full scale.
    pub white: f64,
    /// Light points and directional lights.
    pub lights: Vec<Light>,
}

impl Lighting {
    /// The lights that are switched on.
    pub fn lights_on(&self) -> impl Iterator<Item = &Light> {
        self.lights.iter().filter(|l| l.on)
    }

    /// A light by name, for switching or moving it between frames.
    pub fn light_mut(&mut self, name: &str) -> Option<&mut Light> {
        self.lights.iter_mut().find(|l| l.name == name)
    }
}

/// sRGB decoding of an 8-bit channel (IEC 61966-2-1), exact in f64. Read from a table of the
/// 256 values: shading decodes a face colour per hit (a 5 M-triangle mesh, 512×256 unlit:
/// 280 → 43 ms per image against decoding every face per frame).
pub fn srgb_to_linear(value: u8) -> f64 {
    DECODING[value as usize]
}

/// [`srgb_to_linear`] of every byte, as one table: for loops over many texels (mip building),
/// which find it once.
pub(crate) fn srgb_decoding() -> &'static [f64; 256] {
    &DECODING
}

/// [`srgb_to_linear`] of every byte.
static DECODING: std::sync::LazyLock<[f64; 256]> = std::sync::LazyLock::new(|| {
    std::array::from_fn(|i| {
        let c = i as f64 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    })
});

/// sRGB encoding of a linear value, clamped to [0, 1], rounded to 8 bits: exactly
/// [`encode_by_formula`]'s byte, found among the 255 linear values where that byte steps up
/// (a table guess and at most one step instead of a `powf`; textured and lit pixels encode every
/// pixel).
pub fn linear_to_srgb(value: f64) -> u8 {
    ENCODING.byte(value)
}

/// [`linear_to_srgb`] of each channel of a linear colour (the table found once for the three).
pub fn linear_to_srgb3(linear: [f64; 3]) -> [u8; 3] {
    let encoding = &*ENCODING;
    // Written out: `array::map` was an out-of-line call per pixel (callgrind, lit images).
    [
        encoding.byte(linear[0]),
        encoding.byte(linear[1]),
        encoding.byte(linear[2]),
    ]
}

/// [`linear_to_srgb3`] of eight colours: with AVX2 (where the caller's `avx2` proves it) four
/// channels at a time in vector lanes, the bucket and step look-ups by plain loads, to the same bytes
/// (tested). Textured pixels are encoded eight at a time (`shade/textured.rs`), where one
/// channel after another cost about 56 instructions a pixel (docs/benchmarks.md, "ninth pass").
/// `avx2` is the caller's proof of AVX2 (`None`: the scalar encoder), so that a caller that
/// holds one does not check the CPU again for every eight pixels.
pub(crate) fn linear_to_srgb3_lanes(linear: &[[f64; 3]; 8], avx2: Option<crate::avx2::Avx2>) -> [[u8; 3]; 8] {
    let encoding = &*ENCODING;
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = avx2 {
        let mut bytes = [[0; 3]; 8];
        // SAFETY: `avx2` proves the CPU has AVX2, which `bytes_avx2` is compiled for.
        unsafe { encoding.bytes_avx2(avx2, linear, &mut bytes) };
        return bytes;
    }
    linear.map(linear_to_srgb3)
}

/// The steps (then +inf), and the byte at the start of each of 4096 equal buckets of [0, 1]: a
/// bucket (2.4e-4 wide) is narrower than the smallest step (3.0e-4, 1/(255 · 12.92) at the
/// dark end), so at most one step follows the guess.
struct SrgbEncoding {
    steps: [f64; 256],
    buckets: [u8; BUCKETS + 1],
}

/// The number of equal buckets of [0, 1] in [`SrgbEncoding`]: a value c's is c · `BUCKETS`,
/// 0..=`BUCKETS` (the last holds only 1.0).
const BUCKETS: usize = 4096;

static ENCODING: std::sync::LazyLock<SrgbEncoding> = std::sync::LazyLock::new(|| {
    let steps: [f64; 256] = std::array::from_fn(|k| match k {
        255 => f64::INFINITY,
        _ => first_value_encoding_to(k as u8 + 1),
    });
    let buckets = std::array::from_fn(|i| steps.partition_point(|&step| step <= i as f64 / BUCKETS as f64) as u8);
    SrgbEncoding { steps, buckets }
});

impl SrgbEncoding {
    /// [`linear_to_srgb`]: the bucket's byte, plus one where the value reaches the next step.
    /// NaN (and anything not above 0) is taken as 0, which gives byte 0, as the formula's
    /// `NaN as u8` does.
    #[inline(always)]
    fn byte(&self, value: f64) -> u8 {
        let c = if value > 0.0 { value.min(1.0) } else { 0.0 };
        // SAFETY: c lies in [0, 1] (never NaN), so c · 4096 is in 0..=4096. Unchecked because
        // `as usize`'s saturating conversion cost about 25 instructions a channel (callgrind,
        // textured frames: docs/benchmarks.md).
        let bucket = unsafe { (c * BUCKETS as f64).to_int_unchecked::<u32>() };
        let byte = self.buckets[bucket as usize];
        byte + u8::from(self.steps[byte as usize] <= c)
    }

    /// [`SrgbEncoding::byte`] of each of `values`, four in a vector: the same clamp, bucket
    /// and step test, in lanes, the buckets' guesses and their steps read by plain loads (four
    /// of each a vector), where two four-lane gathers took about 0.023 ms more of an omni 250²
    /// textured frame on this AMD EPYC (Zen 4; docs/benchmarks.md, 2026-11-27 night2 (tex)).
    /// The token proves the CPU has AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn bytes_avx2(&self, _: crate::avx2::Avx2, linear: &[[f64; 3]; 8], bytes: &mut [[u8; 3]; 8]) {
        use std::arch::x86_64::_mm256_loadu_pd;
        // 24 values, six chunks of four: no remainder is left out.
        let (values, bytes) = (linear.as_flattened(), bytes.as_flattened_mut());
        for (values, bytes) in values.chunks_exact(4).zip(bytes.chunks_exact_mut(4)) {
            // SAFETY: the load reads the chunk's four values.
            let four = self.four_bytes(unsafe { _mm256_loadu_pd(values.as_ptr()) });
            bytes.copy_from_slice(&four.to_le_bytes());
        }
    }

    /// [`SrgbEncoding::byte`] of each of the four values `value`, packed in order (lane 0 the
    /// low byte).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn four_bytes(&self, value: std::arch::x86_64::__m256d) -> u32 {
        use std::arch::x86_64::{
            _CMP_LE_OQ, _mm_cvtsi128_si32, _mm_setr_epi8, _mm_setr_epi32, _mm_shuffle_epi8, _mm_storeu_si128,
            _mm_sub_epi32, _mm256_castpd_si256, _mm256_castsi256_si128, _mm256_cmp_pd, _mm256_cvttpd_epi32,
            _mm256_max_pd, _mm256_min_pd, _mm256_mul_pd, _mm256_permutevar8x32_epi32, _mm256_set1_pd,
            _mm256_setr_epi32, _mm256_setr_pd, _mm256_setzero_pd,
        };
        // Each c lies in [0, 1] (`max` takes a NaN, its first operand, to its second, 0, and
        // anything not above 0 to 0; `min` keeps 1 as the bound), so its bucket is in
        // 0..=4096, inside `buckets` (4097).
        let c = _mm256_min_pd(_mm256_max_pd(value, _mm256_setzero_pd()), _mm256_set1_pd(1.0));
        let mut bucket = [0u32; 4];
        // SAFETY: the store writes the four i32 of `bucket`.
        unsafe {
            _mm_storeu_si128(
                bucket.as_mut_ptr().cast(),
                _mm256_cvttpd_epi32(_mm256_mul_pd(c, _mm256_set1_pd(BUCKETS as f64))),
            );
        }
        // SAFETY: each bucket is in 0..=4096 (above), inside `buckets`.
        let [g0, g1, g2, g3] = bucket.map(|bucket| unsafe { *self.buckets.get_unchecked(bucket as usize) });
        let step = |guess: u8| self.steps[usize::from(guess)];
        let guess = _mm_setr_epi32(g0.into(), g1.into(), g2.into(), g3.into());
        let step = _mm256_setr_pd(step(g0), step(g1), step(g2), step(g3));
        // All ones (-1) in each 64-bit lane whose value reaches the next step, its low halves
        // gathered into four i32: the guess minus -1 is the byte, at most 255 (the step after
        // 255 is +inf). The four bytes packed into one u32, in order, where a store per byte
        // cost about 10 instructions a textured pixel.
        let reached = _mm256_castpd_si256(_mm256_cmp_pd::<_CMP_LE_OQ>(step, c));
        let low = _mm256_permutevar8x32_epi32(reached, _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0));
        let bytes = _mm_sub_epi32(guess, _mm256_castsi256_si128(low));
        let packed = _mm_shuffle_epi8(
            bytes,
            _mm_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1),
        );
        _mm_cvtsi128_si32(packed) as u32
    }

    /// [`SrgbEncoding::byte`] of eight colours held by channel (red, green, blue; lanes 0–3
    /// then 4–7), as colours (the bytes `bytes_avx2` gives them in lane order).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn channel_bytes_avx2(&self, channels: [[std::arch::x86_64::__m256d; 2]; 3]) -> [[u8; 3]; 8] {
        use std::arch::x86_64::{
            _mm_or_si128, _mm_set_epi64x, _mm_setr_epi8, _mm_shuffle_epi8, _mm_storel_epi64, _mm_storeu_si128,
        };
        // Each channel's eight bytes in a u64, lane 0 the low byte.
        let [[red_low, red_high], [green_low, green_high], [blue_low, blue_high]] = channels;
        let eight = |low: u32, high: u32| (u64::from(low) | u64::from(high) << 32) as i64;
        let red = eight(self.four_bytes(red_low), self.four_bytes(red_high));
        let green = eight(self.four_bytes(green_low), self.four_bytes(green_high));
        let blue = eight(self.four_bytes(blue_low), self.four_bytes(blue_high));
        // Byte 3k + c of the colours is channel c's byte k: red's k and green's 8 + k from one
        // register, blue's k from another (-1: none), bytes 0–15 then 16–23.
        let (red_green, blue) = (_mm_set_epi64x(green, red), _mm_set_epi64x(0, blue));
        let first = _mm_or_si128(
            _mm_shuffle_epi8(
                red_green,
                _mm_setr_epi8(0, 8, -1, 1, 9, -1, 2, 10, -1, 3, 11, -1, 4, 12, -1, 5),
            ),
            _mm_shuffle_epi8(
                blue,
                _mm_setr_epi8(-1, -1, 0, -1, -1, 1, -1, -1, 2, -1, -1, 3, -1, -1, 4, -1),
            ),
        );
        let last = _mm_or_si128(
            _mm_shuffle_epi8(
                red_green,
                _mm_setr_epi8(13, -1, 6, 14, -1, 7, 15, -1, -1, -1, -1, -1, -1, -1, -1, -1),
            ),
            _mm_shuffle_epi8(
                blue,
                _mm_setr_epi8(-1, 5, -1, -1, 6, -1, -1, 7, -1, -1, -1, -1, -1, -1, -1, -1),
            ),
        );
        let mut colours = [[0u8; 3]; 8];
        let bytes = colours.as_flattened_mut();
        // SAFETY: the stores write bytes 0–15 and 16–23 of the 24 of `colours`.
        unsafe {
            _mm_storeu_si128(bytes.as_mut_ptr().cast(), first);
            _mm_storel_epi64(bytes[16..].as_mut_ptr().cast(), last);
        }
        colours
    }
}

/// [`linear_to_srgb3`] of eight colours held in AVX2 registers by channel (red, green, blue;
/// lanes 0–3 then 4–7): the same bytes as [`linear_to_srgb3_lanes`] of the same values in lane
/// order (tested), without moving them into lane order first.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn channels_to_srgb3_avx2(channels: [[std::arch::x86_64::__m256d; 2]; 3]) -> [[u8; 3]; 8] {
    ENCODING.channel_bytes_avx2(channels)
}

/// sRGB encoding (IEC 61966-2-1) of a linear value clamped to [0, 1], rounded to 8 bits, by
/// the formula.
fn encode_by_formula(value: f64) -> u8 {
    let c = value.clamp(0.0, 1.0);
    let encoded = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (encoded * 255.0).round() as u8
}

/// The smallest f64 in [0, 1] that [`encode_by_formula`] takes to `byte` or more: a bisection
/// over the bit patterns of non-negative f64s, which order as the values do.
fn first_value_encoding_to(byte: u8) -> f64 {
    let (mut below, mut at) = (0u64, 1f64.to_bits());
    while at - below > 1 {
        let middle = below + (at - below) / 2;
        if encode_by_formula(f64::from_bits(middle)) >= byte {
            at = middle;
        } else {
            below = middle;
        }
    }
    f64::from_bits(at)
}

/// Linear RGB of an sRGB colour.
pub fn linear_rgb(colour: [u8; 3]) -> DVec3 {
    let decoding = &*DECODING;
    let [r, g, b] = colour;
    DVec3::new(
        decoding[usize::from(r)],
        decoding[usize::from(g)],
        decoding[usize::from(b)],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_directional_light_points_the_same_way_at_any_scale() {
        let direction = |d: &str| {
            let text = format!(
                r#"Scene(name: "s", objects: [Floor(name: "f", corners: [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], colour: (9, 9, 9))],
                lighting: (lights: [Directional(name: "sun", direction: {d}, illuminance: 1000.0)]))"#
            );
            let scene = crate::scene::Scene::from_ron(&text, std::path::Path::new("s.ron")).unwrap();
            match scene.lighting.unwrap().lights[0].kind {
                LightKind::Directional { direction, .. } => direction,
                LightKind::Point { .. } => panic!("directional"),
            }
        };
        let unit = direction("(1.0, 0.0, -1.0)");
        for scaled in ["(1e308, 0.0, -1e308)", "(1e-300, 0.0, -1e-300)"] {
            assert!((direction(scaled) - unit).length() < 1e-15, "{scaled}");
        }
    }

    #[test]
    fn the_table_encodes_exactly_as_the_formula() {
        use rand::{Rng, SeedableRng};
        let mut random = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut values: Vec<f64> = (0..1_000_000).map(|_| random.random_range(-0.1..1.1)).collect();
        // Every step and its neighbours, a few ulps either side.
        for byte in 1..=255u8 {
            let step = first_value_encoding_to(byte).to_bits();
            values.extend((step - 4..=step + 4).map(f64::from_bits));
        }
        values.extend([
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -0.0,
            0.0,
            1.0,
            f64::MIN_POSITIVE,
        ]);
        for value in values {
            assert_eq!(linear_to_srgb(value), encode_by_formula(value), "{value:e}");
        }
    }

    #[test]
    fn the_lanes_encode_as_one_value_at_a_time() {
        let mut values: Vec<f64> = vec![
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -0.0,
            0.0,
            1.0,
            -1.0,
            2.0,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::from_bits(1),
            -f64::from_bits(1),
            -1e-300,
        ];
        // Every bucket's edge and every step, a few ulps either side.
        for edge in (0..=BUCKETS)
            .map(|i| i as f64 / BUCKETS as f64)
            .chain((1..=255).map(first_value_encoding_to))
        {
            let bits = edge.to_bits();
            values.extend((bits.saturating_sub(2)..=bits + 2).map(f64::from_bits));
        }
        values.resize(values.len().next_multiple_of(24), 0.5);
        // Each value in every lane position: the list again, shifted by one to 23 places.
        let shifted: Vec<f64> = (0..24)
            .flat_map(|shift| values[shift..].iter().chain(&values[..shift]))
            .copied()
            .collect();
        let avx2 = crate::avx2::Avx2::detected();
        if avx2.is_none() {
            eprintln!("no AVX2 on this CPU: the lanes' scalar fallback is what is checked");
        }
        for colours in shifted.chunks_exact(24) {
            let colours: [[f64; 3]; 8] = std::array::from_fn(|k| std::array::from_fn(|c| colours[3 * k + c]));
            let want = colours.map(linear_to_srgb3);
            assert_eq!(linear_to_srgb3_lanes(&colours, None), want, "{colours:?}");
            assert_eq!(linear_to_srgb3_lanes(&colours, avx2), want, "{colours:?}");
            #[cfg(target_arch = "x86_64")]
            if let Some(avx2) = avx2 {
                let mut bytes = [[0; 3]; 8];
                // SAFETY: `avx2` proves the CPU has AVX2.
                unsafe { ENCODING.bytes_avx2(avx2, &colours, &mut bytes) };
                assert_eq!(bytes, want, "AVX2 lanes, {colours:?}");
                // SAFETY: as above.
                assert_eq!(
                    unsafe { by_channel(avx2, &colours) },
                    want,
                    "AVX2 by channel, {colours:?}"
                );
            }
        }
    }

    /// [`channels_to_srgb3_avx2`] of `colours` put in registers by channel.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn by_channel(_: crate::avx2::Avx2, colours: &[[f64; 3]; 8]) -> [[u8; 3]; 8] {
        use std::arch::x86_64::_mm256_setr_pd;
        channels_to_srgb3_avx2(std::array::from_fn(|channel| {
            std::array::from_fn(|half| {
                let four = &colours[4 * half..];
                _mm256_setr_pd(four[0][channel], four[1][channel], four[2][channel], four[3][channel])
            })
        }))
    }

    #[test]
    fn every_byte_survives_decoding_and_encoding() {
        for value in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(value)), value);
        }
    }
}
