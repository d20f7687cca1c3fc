//! Randomness that depends on where it is used, not on what ran before: every stream derives
//! from (seed, set name, frame index, purpose) alone, so one frame re-renders by itself with
//! the same bytes, shards need no coordination, and adding noise to a set does not move its
//! occluders.

use rand::SeedableRng;
use rand_chacha::ChaCha12Rng;
use sha2::{Digest, Sha256};

/// What a stream is drawn for; each gets its own, independent of the others.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    /// Random pose positions and angles of a set.
    Poses,
    /// Light flicker.
    Lights,
    /// Colour shifts.
    Colours,
    /// Occluder places, turns and colours.
    Occluders,
    /// Image, depth and disparity noise.
    Noise,
    /// Per-axis random angles of a set's random poses.
    Angles,
}

/// The generator of one (seed, set, frame, purpose); `frame` is `None` for draws made once
/// per set. `ChaCha12` fed by SHA-256 of the four: a named algorithm, so the bytes do not change
/// with `rand`'s choice of `StdRng`.
pub fn stream(seed: u64, set: &str, frame: Option<usize>, purpose: Purpose) -> ChaCha12Rng {
    let mut hash = Sha256::new();
    hash.update(b"omnisim dataset stream v1\0");
    hash.update(seed.to_le_bytes());
    hash.update((set.len() as u64).to_le_bytes());
    hash.update(set.as_bytes());
    match frame {
        Some(index) => {
            hash.update([1]);
            hash.update((index as u64).to_le_bytes());
        }
        None => hash.update([0]),
    }
    hash.update([purpose as u8]);
    ChaCha12Rng::from_seed(hash.finalize().into())
}

/// A seed for APIs that take a `u64` (`pose_sets::random`), from the same derivation.
pub fn seed_u64(seed: u64, set: &str, purpose: Purpose) -> u64 {
    use rand::Rng;
    stream(seed, set, None, purpose).random()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    fn first(seed: u64, set: &str, frame: Option<usize>, purpose: Purpose) -> [u64; 4] {
        let mut rng = stream(seed, set, frame, purpose);
        std::array::from_fn(|_| rng.random())
    }

    #[test]
    fn streams_depend_on_their_key_only() {
        let a = first(7, "map", Some(3), Purpose::Noise);
        // The same key gives the same numbers, whatever was drawn before.
        let _ = first(7, "map", Some(2), Purpose::Noise);
        assert_eq!(first(7, "map", Some(3), Purpose::Noise), a);
        // Any part of the key changes them.
        for other in [
            first(8, "map", Some(3), Purpose::Noise),
            first(7, "mapx", Some(3), Purpose::Noise),
            first(7, "map", Some(4), Purpose::Noise),
            first(7, "map", None, Purpose::Noise),
            first(7, "map", Some(3), Purpose::Lights),
        ] {
            assert_ne!(other, a);
        }
        // Length-prefixed names: ("ab", frame) never collides with ("a", ...) shifted bytes.
        assert_ne!(
            first(7, "ab", Some(0), Purpose::Noise),
            first(7, "a", Some(0), Purpose::Noise)
        );
        // A fixed value pins the derivation: a change here changes every data set's bytes.
        assert_eq!(seed_u64(0, "map", Purpose::Poses), 7_749_322_297_093_671_726);
    }
}
