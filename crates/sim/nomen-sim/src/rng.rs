//! Seeded, named random streams.
//!
//! Every random process in a scene (one IMU's noise, one camera's track-id behaviour, one person's
//! time warp) draws from its own stream, derived from the scene seed and a stable name. Adding a
//! device therefore leaves every other device's noise unchanged, and the same seed gives the same
//! bytes on every machine (ChaCha8 is portable; the name hash is FNV-1a, not `std`'s hasher).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The random generator used everywhere in the simulator.
pub type SimRng = ChaCha8Rng;

/// FNV-1a, 64 bit: a stable hash of a stream name.
fn fnv1a(name: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in name.as_bytes() {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// SplitMix64 finaliser: spreads the bits of a 64-bit value.
fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The random stream called `name` in the scene with seed `seed`, e.g.
/// `stream(seed, "imu/ana_left_wrist")`.
pub fn stream(seed: u64, name: &str) -> SimRng {
    let a = splitmix(seed ^ fnv1a(name));
    let b = splitmix(a);
    let c = splitmix(b);
    let d = splitmix(c);
    let mut key = [0u8; 32];
    for (i, w) in [a, b, c, d].into_iter().enumerate() {
        key[i * 8..i * 8 + 8].copy_from_slice(&w.to_le_bytes());
    }
    ChaCha8Rng::from_seed(key)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn same_seed_and_name_give_the_same_stream() {
        let (mut r1, mut r2) = (stream(7, "imu/a"), stream(7, "imu/a"));
        let a: Vec<u64> = (0..4).map(|_| r1.random()).collect();
        let b: Vec<u64> = (0..4).map(|_| r2.random()).collect();
        assert_eq!(a, b);
    }

    #[test]
    fn different_names_or_seeds_give_different_streams() {
        let x: u64 = stream(7, "imu/a").random();
        assert_ne!(x, stream(7, "imu/b").random::<u64>());
        assert_ne!(x, stream(8, "imu/a").random::<u64>());
    }

    #[test]
    fn streams_are_stable_across_builds() {
        // A fixed value: if this changes, every simulated scene changes. Update it only on purpose.
        let first: u64 = stream(42, "camera/cam0").random();
        assert_eq!(first, STABLE_FIRST_VALUE);
    }

    /// Recorded from this implementation (ChaCha8, rand_chacha 0.9) on first use.
    const STABLE_FIRST_VALUE: u64 = 17_643_834_413_496_103_238;
}
