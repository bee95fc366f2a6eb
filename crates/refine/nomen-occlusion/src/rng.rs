//! The particle filters' random streams.
//!
//! A filter step draws about ten normal variates per particle, so the generator's cost shows in
//! the step's. [`Xoshiro256PlusPlus`] (Blackman and Vigna, *Scrambled linear pseudorandom number
//! generators*, 2021) makes a 64-bit word in a handful of instructions and passes BigCrush;
//! ChaCha8 is kept for Rebecchi's filter, whose figures in `nomen experiment occlusion` stay
//! those of the stream they were first measured with. [`ParticleRng`] is either, chosen by
//! [`RandomStream`].

use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Which generator a filter draws from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RandomStream {
    /// ChaCha with 8 rounds (`rand_chacha`).
    ChaCha8,
    /// xoshiro256++, seeded through SplitMix64.
    Xoshiro256PlusPlus,
}

/// xoshiro256++: 256 bits of state, period 2²⁵⁶ − 1.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Xoshiro256PlusPlus {
    s: [u64; 4],
}

impl Xoshiro256PlusPlus {
    /// A generator with this exact state (not all zero; an all-zero state is replaced by the
    /// state seeded from 0).
    pub fn from_state(s: [u64; 4]) -> Self {
        if s == [0; 4] {
            Self::seed_from_u64(0)
        } else {
            Self { s }
        }
    }
}

/// SplitMix64's step (Steele, Lea and Flood 2014), the seeding Vigna recommends.
fn splitmix64(x: &mut u64) -> u64 {
    *x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *x;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl RngCore for Xoshiro256PlusPlus {
    #[inline]
    fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    #[inline]
    fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    fn fill_bytes(&mut self, dst: &mut [u8]) {
        for chunk in dst.chunks_mut(8) {
            let bytes = self.next_u64().to_le_bytes();
            chunk.copy_from_slice(&bytes[..chunk.len()]);
        }
    }
}

impl SeedableRng for Xoshiro256PlusPlus {
    type Seed = [u8; 32];

    fn from_seed(seed: [u8; 32]) -> Self {
        let mut s = [0u64; 4];
        for (w, chunk) in s.iter_mut().zip(seed.chunks_exact(8)) {
            let mut b = [0u8; 8];
            b.copy_from_slice(chunk);
            *w = u64::from_le_bytes(b);
        }
        Self::from_state(s)
    }

    fn seed_from_u64(seed: u64) -> Self {
        let mut x = seed;
        Self {
            s: std::array::from_fn(|_| splitmix64(&mut x)),
        }
    }
}

/// The generator of one filter.
#[derive(Debug, Clone)]
pub enum ParticleRng {
    /// ChaCha8 (boxed: its block buffer is ten times xoshiro's state).
    ChaCha8(Box<ChaCha8Rng>),
    /// xoshiro256++.
    Xoshiro(Xoshiro256PlusPlus),
}

impl ParticleRng {
    /// The stream `kind` seeded with `seed`.
    pub fn new(kind: RandomStream, seed: u64) -> Self {
        match kind {
            RandomStream::ChaCha8 => Self::ChaCha8(Box::new(ChaCha8Rng::seed_from_u64(seed))),
            RandomStream::Xoshiro256PlusPlus => {
                Self::Xoshiro(Xoshiro256PlusPlus::seed_from_u64(seed))
            }
        }
    }
}

impl RngCore for ParticleRng {
    #[inline]
    fn next_u32(&mut self) -> u32 {
        match self {
            Self::ChaCha8(r) => r.next_u32(),
            Self::Xoshiro(r) => r.next_u32(),
        }
    }

    #[inline]
    fn next_u64(&mut self) -> u64 {
        match self {
            Self::ChaCha8(r) => r.next_u64(),
            Self::Xoshiro(r) => r.next_u64(),
        }
    }

    fn fill_bytes(&mut self, dst: &mut [u8]) {
        match self {
            Self::ChaCha8(r) => r.fill_bytes(dst),
            Self::Xoshiro(r) => r.fill_bytes(dst),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xoshiro_matches_the_reference_implementation() {
        // Vigna's xoshiro256plusplus.c from the state {1, 2, 3, 4}, worked by hand: the first
        // output is rotl(1 + 4, 23) + 1; the state becomes {7, 0, 2¹⁸ + 2, 6·2⁴⁵}, so the second
        // is rotl(7 + 6·2⁴⁵, 23) + 7 = 7·2²³ + 6·2⁴ + 7.
        let mut r = Xoshiro256PlusPlus::from_state([1, 2, 3, 4]);
        assert_eq!(r.next_u64(), (5u64 << 23) + 1);
        assert_eq!(r.next_u64(), (7u64 << 23) + (6 << 4) + 7);
        // SplitMix64 from 0 gives 0xE220A8397B1DCDAF first (Vigna's splitmix64.c).
        let mut x = 0u64;
        assert_eq!(splitmix64(&mut x), 0xE220_A839_7B1D_CDAF);
    }

    #[test]
    fn xoshiro_words_are_balanced() {
        let mut r = ParticleRng::new(RandomStream::Xoshiro256PlusPlus, 7);
        let n = 20_000;
        let ones: u32 = (0..n).map(|_| r.next_u64().count_ones()).sum();
        // 64 fair bits per word: mean 32, σ of the mean 4/√n.
        let mean = f64::from(ones) / f64::from(n);
        assert!(
            (mean - 32.0).abs() < 6.0 * 4.0 / f64::from(n).sqrt(),
            "{mean}"
        );
    }
}
