//! `OpenEXR`'s RLE compression of one block of scan lines, byte for byte what the `exr` crate
//! writes. Hand-written because `exr` compresses a byte at a time with bounds checks on every
//! step, and that loop was the largest single cost of a data set's range EXR (0.3 of 0.6
//! core-ms a 250 × 250 frame, docs/benchmarks.md); this one separates the bytes and looks for
//! the next run sixteen at a time (SSE2, which every x86-64 CPU has; a byte at a time
//! elsewhere). `exr` offers no way to plug in another encoder for a block, so `write_exr` hands
//! it finished chunks.

/// Runs shorter than this are stored as literal bytes.
const MIN_RUN: usize = 3;
/// The longest run one token holds (its count byte stores the length − 1).
const MAX_RUN: usize = 128;
/// The most literal bytes one token holds (its count byte stores −length).
const MAX_LITERAL: usize = 127;

/// Compresses blocks one after another, reusing its buffer.
#[derive(Default)]
pub(crate) struct RleEncoder {
    /// A block's even bytes, then its odd ones, each as its difference from the one before.
    predicted: Vec<u8>,
}

impl RleEncoder {
    /// The RLE stream of a block's little-endian bytes (each scan line's channels in name
    /// order): `OpenEXR`'s predictor ([`predict`]), then runs and literals ([`pack`]).
    pub(crate) fn compress(&mut self, block_le: &[u8]) -> Vec<u8> {
        predict(block_le, &mut self.predicted);
        let mut packed = Vec::with_capacity(block_le.len() + block_le.len() / MAX_LITERAL + 2);
        pack(&self.predicted, &mut packed);
        packed
    }
}

/// `OpenEXR`'s predictor, in `predicted` alone: the block's even bytes, then its odd ones,
/// each then replaced by its difference from the one before plus 128, wrapping (the first
/// byte is kept). The differences are taken in place from the end back, a vector of
/// [`LANES`] at a time: each step reads bytes no later step has changed.
fn predict(block_le: &[u8], predicted: &mut Vec<u8>) {
    let delta = |current: u8, previous: u8| current.wrapping_sub(previous).wrapping_add(128);
    let n = block_le.len();
    predicted.clear();
    predicted.resize(n, 0);
    let (even, odd) = predicted.split_at_mut(n.div_ceil(2));
    let done = separate_simd(block_le, even, odd);
    for ((e, o), pair) in
        (even[done..].iter_mut().zip(odd[done..].iter_mut())).zip(block_le[2 * done..].chunks_exact(2))
    {
        *e = pair[0];
        *o = pair[1];
    }
    if n % 2 == 1 {
        even[n / 2] = block_le[n - 1];
    }
    let mut end = n;
    while end > LANES {
        let start = end - LANES;
        let current: [u8; LANES] = predicted[start..end].try_into().expect("a whole vector");
        let before: [u8; LANES] = predicted[start - 1..end - 1].try_into().expect("a whole vector");
        for ((out, c), b) in predicted[start..end].iter_mut().zip(current).zip(before) {
            *out = delta(c, b);
        }
        end = start;
    }
    for i in (1..end).rev() {
        predicted[i] = delta(predicted[i], predicted[i - 1]);
    }
}

/// The first pairs of `block` separated into `even` and `odd`, 32 bytes a step; returns how
/// many pairs (the rest is the caller's).
#[cfg(target_arch = "x86_64")]
fn separate_simd(block: &[u8], even: &mut [u8], odd: &mut [u8]) -> usize {
    use std::arch::x86_64::{
        __m128i, _mm_and_si128, _mm_loadu_si128, _mm_packus_epi16, _mm_set1_epi16, _mm_srli_epi16, _mm_storeu_si128,
    };
    // SAFETY: SSE2 is part of x86-64 (every CPU of the target has it).
    let low_bytes = unsafe { _mm_set1_epi16(0x00ff) };
    let steps = (block.len() / 32).min(even.len() / 16).min(odd.len() / 16);
    for step in 0..steps {
        let (from, to) = (32 * step, 16 * step);
        // SAFETY: SSE2 is part of x86-64; 32 bytes from `from` lie in `block`, 16 from `to`
        // in `even` and `odd` (`steps` above); unaligned loads and stores.
        unsafe {
            let first = _mm_loadu_si128(block.as_ptr().add(from).cast::<__m128i>());
            let second = _mm_loadu_si128(block.as_ptr().add(from + 16).cast::<__m128i>());
            // Each 16-bit lane's low byte is an even byte, its high byte an odd one: the
            // lanes (at most 255 each after the mask or shift) pack to bytes unsaturated.
            let evens = _mm_packus_epi16(_mm_and_si128(first, low_bytes), _mm_and_si128(second, low_bytes));
            let odds = _mm_packus_epi16(_mm_srli_epi16::<8>(first), _mm_srli_epi16::<8>(second));
            _mm_storeu_si128(even.as_mut_ptr().add(to).cast::<__m128i>(), evens);
            _mm_storeu_si128(odd.as_mut_ptr().add(to).cast::<__m128i>(), odds);
        }
    }
    16 * steps
}

/// No vector separation off x86-64: every pair is the caller's.
#[cfg(not(target_arch = "x86_64"))]
fn separate_simd(_: &[u8], _: &mut [u8], _: &mut [u8]) -> usize {
    0
}

/// Bytes [`predict`] differences at once.
const LANES: usize = 32;

/// Greedy tokens, as `OpenEXR` and `exr` make them: at each position a run of at least
/// [`MIN_RUN`] equal bytes (at most [`MAX_RUN`]) becomes a count and the byte; otherwise the
/// bytes up to the next such run (at most [`MAX_LITERAL`]) are stored after a negative count.
fn pack(bytes: &[u8], out: &mut Vec<u8>) {
    let n = bytes.len();
    let mut start = 0;
    while start < n {
        let run = run_length(bytes, start);
        if run >= MIN_RUN {
            // run − 1 ≤ 127: fits the count byte.
            out.extend_from_slice(&[(run - 1) as u8, bytes[start]]);
            start += run;
            continue;
        }
        let end = next_run(bytes, start + run, (start + MAX_LITERAL).min(n));
        // −(end − start), as a two's-complement byte.
        out.push((end - start).wrapping_neg() as u8);
        out.extend_from_slice(&bytes[start..end]);
        start = end;
    }
}

/// How many bytes from `start` equal the first, at most [`MAX_RUN`].
fn run_length(bytes: &[u8], start: usize) -> usize {
    let first = bytes[start];
    let rest = &bytes[start..(start + MAX_RUN).min(bytes.len())];
    rest.iter().position(|&b| b != first).unwrap_or(rest.len())
}

/// The first position in `from..limit` where three equal bytes start (all three inside
/// `bytes`), or `limit`: sixteen positions a step where [`run_starts`] can, then one at a time.
fn next_run(bytes: &[u8], from: usize, limit: usize) -> usize {
    let mut p = from;
    #[cfg(target_arch = "x86_64")]
    while p < limit && p + 18 <= bytes.len() {
        let starts = run_starts(&bytes[p..p + 18]);
        if starts != 0 {
            return (p + starts.trailing_zeros() as usize).min(limit);
        }
        p += 16;
    }
    while p < limit {
        if p + 2 < bytes.len() && bytes[p] == bytes[p + 1] && bytes[p + 1] == bytes[p + 2] {
            return p;
        }
        p += 1;
    }
    limit
}

/// Bit j set where `bytes[j..j + 3]` are equal, for j < 16 (`bytes` holds 18).
#[cfg(target_arch = "x86_64")]
fn run_starts(bytes: &[u8]) -> u32 {
    use std::arch::x86_64::{__m128i, _mm_and_si128, _mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8};
    assert!(bytes.len() >= 18);
    // SAFETY: SSE2 is part of x86-64; 16 bytes from offsets 0, 1 and 2 lie in `bytes`
    // (checked above); unaligned loads.
    unsafe {
        let [x, y, z] = [0, 1, 2].map(|at| _mm_loadu_si128(bytes.as_ptr().add(at).cast::<__m128i>()));
        _mm_movemask_epi8(_mm_and_si128(_mm_cmpeq_epi8(x, y), _mm_cmpeq_epi8(y, z))) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `OpenEXR`'s predictor as its definition reads: separate the bytes, then difference them.
    fn predicted_by_definition(block: &[u8]) -> Vec<u8> {
        let separated: Vec<u8> = block
            .iter()
            .step_by(2)
            .chain(block.iter().skip(1).step_by(2))
            .copied()
            .collect();
        (separated.iter().enumerate())
            .map(|(i, &b)| match i {
                0 => b,
                _ => b.wrapping_sub(separated[i - 1]).wrapping_add(128),
            })
            .collect()
    }

    /// The vector scan for the next run finds what a byte-by-byte scan finds, from every start
    /// to every limit, with runs at and across each vector's edges.
    #[test]
    fn next_run_is_the_first_run_of_three() {
        let mut seed = 11_u32;
        let bytes: Vec<u8> = (0..90)
            .map(|i| {
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                // Runs of two (never a start), of three and more, at varied offsets.
                match i % 23 {
                    5 | 6 => 9,
                    14..=16 => 200,
                    _ => (seed >> 24) as u8 % 4,
                }
            })
            .collect();
        let by_definition = |from: usize, limit: usize| {
            (from..limit)
                .find(|&p| p + 2 < bytes.len() && bytes[p] == bytes[p + 1] && bytes[p + 1] == bytes[p + 2])
                .unwrap_or(limit)
        };
        for from in 0..bytes.len() {
            for limit in from..=bytes.len() {
                assert_eq!(
                    next_run(&bytes, from, limit),
                    by_definition(from, limit),
                    "{from}..{limit}"
                );
            }
        }
    }

    /// The one-pass predictor equals the definition at every length (odd ones too, which
    /// EXR's f32 blocks never have), and the encoder's reused buffer holds no earlier block.
    #[test]
    fn one_pass_predictor_is_the_definition_at_every_length() {
        let mut seed = 7_u32;
        let block: Vec<u8> = (0..300)
            .map(|i| {
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                // Stretches of equal bytes among random ones, and the wrap at 0 and 255.
                if i % 11 < 4 { 255 } else { (seed >> 24) as u8 }
            })
            .collect();
        let mut predicted = Vec::new();
        for n in (0..=64).chain([299, 300]) {
            predict(&block[..n], &mut predicted);
            assert_eq!(predicted, predicted_by_definition(&block[..n]), "length {n}");
        }
    }
}
