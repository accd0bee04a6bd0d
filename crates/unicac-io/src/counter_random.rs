//! The one counter-based random source of unicac: the SplitMix64 finaliser (Steele, Lea & Flood, "Fast
//! splittable pseudorandom number generators", OOPSLA 2014). The n-th number is a pure function of
//! (seed, n), so results do not depend on thread scheduling, and a GPU kernel reproduces them with the
//! same integer arithmetic (`counter_hash` of shaders/common.wgsl). Hand-written for that reason:
//! general-purpose RNG crates are stream-based. Where a stream is fine (the ISP's noise), crates use
//! `rand`'s ChaCha8 seeded from here.

/// The golden-ratio increment of SplitMix64.
const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's output function: a bijective mix of all 64 bits.
#[inline]
pub fn finalise(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The `counter`-th number of the stream `seed` (pupil samples, design restarts, test draws).
#[inline]
pub fn counter_hash(seed: u64, counter: u64) -> u64 {
    finalise((seed ^ counter.wrapping_mul(GOLDEN_GAMMA)).wrapping_add(GOLDEN_GAMMA))
}

/// An independent seed for sub-stream `stream` of `seed` (SplitMix64's state after `stream` steps).
pub fn derive_seed(seed: u64, stream: u64) -> u64 {
    finalise(seed.wrapping_add(stream.wrapping_mul(GOLDEN_GAMMA)))
}

/// Top 53 bits as a uniform f64 in [0, 1).
#[inline]
pub fn unit_interval(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_streams_are_pinned() {
        // SplitMix64's published first output for state 0 + gamma: 0xE220A8397B1DCDAF.
        assert_eq!(finalise(GOLDEN_GAMMA), 0xE220_A839_7B1D_CDAF);
        assert_eq!(derive_seed(0, 1), 0xE220_A839_7B1D_CDAF);
        // A change here changes every pupil sample, design and dataset built with a seed.
        assert_eq!(counter_hash(0, 0), 0xE220_A839_7B1D_CDAF);
        assert_ne!(counter_hash(1, 0), counter_hash(0, 1));
        assert!((0..1000)
            .map(|i| unit_interval(counter_hash(3, i)))
            .all(|u| (0.0..1.0).contains(&u)));
    }
}
