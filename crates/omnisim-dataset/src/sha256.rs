//! SHA-256 of a frame's files, two files at a time where the CPU has the SHA extensions.
//!
//! One SHA-256 stream is bound by the latency of `sha256rnds2` (each pair of rounds waits on
//! the last), not by the CPU's throughput: `sha2` hashes 1.5–1.8 GB/s here whether the bytes
//! are hot or not. Two messages' rounds interleaved keep the unit busy while each waits, as
//! Linux's `sha256_ni_finup2x` does for dm-verity: 2.2 against 1.5 GB/s on two 480 kB
//! messages (docs/benchmarks.md, "2026-11-26 evening (data)"). The digests are SHA-256's,
//! checked against `sha2` in the tests.

use sha2::{Digest, Sha256};

/// SHA-256 of each of `messages`, in their order.
pub(crate) fn digests(messages: &[&[u8]]) -> Vec<[u8; 32]> {
    #[cfg(target_arch = "x86_64")]
    if shani::available() {
        return shani::digests(messages);
    }
    messages.iter().map(|m| Sha256::digest(m).into()).collect()
}

#[cfg(target_arch = "x86_64")]
mod shani {
    use std::arch::x86_64::{
        __m128i, _mm_add_epi32, _mm_alignr_epi8, _mm_blend_epi16, _mm_loadu_si128, _mm_set_epi32, _mm_set_epi64x,
        _mm_setzero_si128, _mm_sha256msg1_epu32, _mm_sha256msg2_epu32, _mm_sha256rnds2_epu32, _mm_shuffle_epi8,
        _mm_shuffle_epi32, _mm_storeu_si128,
    };
    use std::collections::VecDeque;

    /// SHA-256's initial state.
    const H0: [u32; 8] = [
        0x6a09_e667,
        0xbb67_ae85,
        0x3c6e_f372,
        0xa54f_f53a,
        0x510e_527f,
        0x9b05_688c,
        0x1f83_d9ab,
        0x5be0_cd19,
    ];

    /// SHA-256's round constants.
    const K: [u32; 64] = [
        0x428a_2f98,
        0x7137_4491,
        0xb5c0_fbcf,
        0xe9b5_dba5,
        0x3956_c25b,
        0x59f1_11f1,
        0x923f_82a4,
        0xab1c_5ed5,
        0xd807_aa98,
        0x1283_5b01,
        0x2431_85be,
        0x550c_7dc3,
        0x72be_5d74,
        0x80de_b1fe,
        0x9bdc_06a7,
        0xc19b_f174,
        0xe49b_69c1,
        0xefbe_4786,
        0x0fc1_9dc6,
        0x240c_a1cc,
        0x2de9_2c6f,
        0x4a74_84aa,
        0x5cb0_a9dc,
        0x76f9_88da,
        0x983e_5152,
        0xa831_c66d,
        0xb003_27c8,
        0xbf59_7fc7,
        0xc6e0_0bf3,
        0xd5a7_9147,
        0x06ca_6351,
        0x1429_2967,
        0x27b7_0a85,
        0x2e1b_2138,
        0x4d2c_6dfc,
        0x5338_0d13,
        0x650a_7354,
        0x766a_0abb,
        0x81c2_c92e,
        0x9272_2c85,
        0xa2bf_e8a1,
        0xa81a_664b,
        0xc24b_8b70,
        0xc76c_51a3,
        0xd192_e819,
        0xd699_0624,
        0xf40e_3585,
        0x106a_a070,
        0x19a4_c116,
        0x1e37_6c08,
        0x2748_774c,
        0x34b0_bcb5,
        0x391c_0cb3,
        0x4ed8_aa4a,
        0x5b9c_ca4f,
        0x682e_6ff3,
        0x748f_82ee,
        0x78a5_636f,
        0x84c8_7814,
        0x8cc7_0208,
        0x90be_fffa,
        0xa450_6ceb,
        0xbef9_a3f7,
        0xc671_78f2,
    ];

    /// Bytes of a block.
    const BLOCK: usize = 64;

    /// Whether this CPU has what [`compress`] uses.
    pub(super) fn available() -> bool {
        std::arch::is_x86_feature_detected!("sha")
            && std::arch::is_x86_feature_detected!("ssse3")
            && std::arch::is_x86_feature_detected!("sse4.1")
    }

    /// A message's last bytes padded as SHA-256 pads: the bytes after its whole blocks, 0x80,
    /// zeros, and its length in bits (big-endian), one block or two.
    struct Tail {
        bytes: [u8; 2 * BLOCK],
        len: usize,
    }

    impl Tail {
        fn of(message: &[u8]) -> Self {
            let rest = &message[message.len() / BLOCK * BLOCK..];
            let len = if rest.len() < BLOCK - 8 { BLOCK } else { 2 * BLOCK };
            let mut bytes = [0; 2 * BLOCK];
            bytes[..rest.len()].copy_from_slice(rest);
            bytes[rest.len()] = 0x80;
            bytes[len - 8..len].copy_from_slice(&(message.len() as u64 * 8).to_be_bytes());
            Self { bytes, len }
        }
    }

    /// The messages' digests: the longest first, each given to the lane (of two) with fewer
    /// bytes so far, and the two lanes' blocks compressed together while both have some.
    pub(super) fn digests(messages: &[&[u8]]) -> Vec<[u8; 32]> {
        let tails: Vec<Tail> = messages.iter().map(|m| Tail::of(m)).collect();
        let mut order: Vec<usize> = (0..messages.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(messages[i].len()));
        // Each lane: (message, its blocks still to compress), in order.
        let mut lanes: [VecDeque<(usize, &[u8])>; 2] = Default::default();
        let mut loads = [0; 2];
        for i in order {
            let lane = usize::from(loads[1] < loads[0]);
            loads[lane] += messages[i].len();
            let whole = &messages[i][..messages[i].len() / BLOCK * BLOCK];
            if !whole.is_empty() {
                lanes[lane].push_back((i, whole));
            }
            lanes[lane].push_back((i, &tails[i].bytes[..tails[i].len]));
        }
        let mut states = vec![H0; messages.len()];
        loop {
            let [first, second] = &mut lanes;
            match (first.front_mut(), second.front_mut()) {
                (Some((a, blocks_a)), Some((b, blocks_b))) => {
                    let n = blocks_a.len().min(blocks_b.len());
                    let mut pair = [states[*a], states[*b]];
                    let (now_a, later_a) = blocks_a.split_at(n);
                    let (now_b, later_b) = blocks_b.split_at(n);
                    // SAFETY: `available` said the CPU has the features `compress` is built for.
                    unsafe { compress(&mut pair, [now_a, now_b]) };
                    [states[*a], states[*b]] = pair;
                    (*blocks_a, *blocks_b) = (later_a, later_b);
                }
                (Some((i, blocks)), None) | (None, Some((i, blocks))) => {
                    let mut one = [states[*i]];
                    // SAFETY: as above.
                    unsafe { compress(&mut one, [*blocks]) };
                    states[*i] = one[0];
                    *blocks = &[];
                }
                (None, None) => break,
            }
            for lane in &mut lanes {
                if lane.front().is_some_and(|(_, blocks)| blocks.is_empty()) {
                    lane.pop_front();
                }
            }
        }
        (states.iter())
            .map(|state| {
                let mut digest = [0; 32];
                for (bytes, word) in digest.chunks_exact_mut(4).zip(state) {
                    bytes.copy_from_slice(&word.to_be_bytes());
                }
                digest
            })
            .collect()
    }

    /// Compresses `L` messages' blocks (the same whole number of blocks each) into their
    /// states, the lanes' rounds interleaved: Intel's SHA-NI sequence for one block, once per
    /// lane at each step.
    #[target_feature(enable = "sha,sse2,ssse3,sse4.1")]
    fn compress<const L: usize>(states: &mut [[u32; 8]; L], blocks: [&[u8]; L]) {
        let big_endian = _mm_set_epi64x(0x0C0D_0E0F_0809_0A0B, 0x0405_0607_0001_0203);
        let load = |bytes: &[u8]| -> __m128i {
            let bytes: &[u8; 16] = bytes.try_into().expect("16 bytes");
            // SAFETY: an unaligned load of 16 bytes that `bytes` holds.
            unsafe { _mm_loadu_si128(bytes.as_ptr().cast()) }
        };
        // Four words in lanes 0 to 3.
        let words = |w: &[u32]| _mm_set_epi32(w[3] as i32, w[2] as i32, w[1] as i32, w[0] as i32);
        let mut abef = [_mm_setzero_si128(); L];
        let mut cdgh = abef;
        for (l, state) in states.iter().enumerate() {
            let cdab = _mm_shuffle_epi32(words(&state[..4]), 0xB1);
            let efgh = _mm_shuffle_epi32(words(&state[4..]), 0x1B);
            abef[l] = _mm_alignr_epi8(cdab, efgh, 8);
            cdgh[l] = _mm_blend_epi16(efgh, cdab, 0xF0);
        }
        let count = blocks[0].len() / BLOCK;
        debug_assert!(blocks.iter().all(|b| b.len() == count * BLOCK));
        for block in 0..count {
            let saved = (abef, cdgh);
            let mut w = [[abef[0]; 4]; L];
            for l in 0..L {
                let bytes = &blocks[l][block * BLOCK..(block + 1) * BLOCK];
                for (i, word) in w[l].iter_mut().enumerate() {
                    *word = _mm_shuffle_epi8(load(&bytes[16 * i..16 * (i + 1)]), big_endian);
                }
            }
            for step in 0..16 {
                let k = words(&K[4 * step..4 * step + 4]);
                for l in 0..L {
                    if step >= 4 {
                        let [w0, w1, w2, w3] = [0, 1, 2, 3].map(|j| w[l][(step + j) % 4]);
                        let scheduled = _mm_add_epi32(_mm_sha256msg1_epu32(w0, w1), _mm_alignr_epi8(w3, w2, 4));
                        w[l][step % 4] = _mm_sha256msg2_epu32(scheduled, w3);
                    }
                    let message = _mm_add_epi32(w[l][step % 4], k);
                    cdgh[l] = _mm_sha256rnds2_epu32(cdgh[l], abef[l], message);
                    abef[l] = _mm_sha256rnds2_epu32(abef[l], cdgh[l], _mm_shuffle_epi32(message, 0x0E));
                }
            }
            for l in 0..L {
                abef[l] = _mm_add_epi32(abef[l], saved.0[l]);
                cdgh[l] = _mm_add_epi32(cdgh[l], saved.1[l]);
            }
        }
        for (l, state) in states.iter_mut().enumerate() {
            let feba = _mm_shuffle_epi32(abef[l], 0x1B);
            let dchg = _mm_shuffle_epi32(cdgh[l], 0xB1);
            let mut words = [0u32; 8];
            // SAFETY: unaligned stores of 16 bytes each into `words`' 32.
            unsafe {
                _mm_storeu_si128(words.as_mut_ptr().cast(), _mm_blend_epi16(feba, dchg, 0xF0));
                _mm_storeu_si128(words.as_mut_ptr().add(4).cast(), _mm_alignr_epi8(dchg, feba, 8));
            }
            *state = words;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The digests tested: the two-lane kernel's where this CPU has SHA-NI, otherwise the
    /// fallback's, said on stderr past the test harness's capture (so a green run on a CPU
    /// without SHA-NI says that the kernel went untested).
    fn tested() -> fn(&[&[u8]]) -> Vec<[u8; 32]> {
        #[cfg(target_arch = "x86_64")]
        if shani::available() {
            return shani::digests;
        }
        let _ = std::io::Write::write_all(
            &mut std::io::stderr(),
            b"sha256 tests: NO SHA-NI on this CPU: the two-lane kernel is NOT tested, only the sha2 fallback\n",
        );
        digests
    }

    /// Every length around the padding's edges (55, 56, 63, 64, 119, 120) and long ones, alone,
    /// in pairs of equal and unequal lengths and in odd-sized groups, give `sha2`'s digests,
    /// taken one message at a time.
    #[test]
    fn digests_are_sha2s_for_any_lengths_and_groupings() {
        let digests = tested();
        let bytes: Vec<u8> = (0..5000_u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        let lengths = [0, 1, 55, 56, 57, 63, 64, 65, 119, 120, 128, 1000, 4999, 5000];
        let expected =
            |messages: &[&[u8]]| -> Vec<[u8; 32]> { messages.iter().map(|m| Sha256::digest(m).into()).collect() };
        for &a in &lengths {
            let one = [&bytes[..a]];
            assert_eq!(digests(&one), expected(&one), "{a}");
            for &b in &lengths {
                let two = [&bytes[..a], &bytes[b / 3..b]];
                assert_eq!(digests(&two), expected(&two), "{a} {b}");
            }
        }
        let group: Vec<&[u8]> = lengths.iter().map(|&n| &bytes[5000 - n..]).collect();
        assert_eq!(digests(&group), expected(&group));
        assert!(digests(&[]).is_empty());
    }
}
