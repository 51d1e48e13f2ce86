//! Seeded random streams for one sample. Every random choice in sim-core comes from a stream
//! derived here from the sample's seed, never from a global or thread-local generator, so one
//! (controller, task, seed) always gives the same trajectory on every machine.

use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// The generator used for every stream in the simulator: small, fast and of good quality.
pub type SimRng = rand_xoshiro::Xoshiro256PlusPlus;

/// Mixes a 64-bit value (SplitMix64 finaliser); used to derive independent seeds.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Derives a seed from a base seed and a path of indices (for example run, generation, sample),
/// so that every index combination gets its own independent stream: `mix64(base)`, then each
/// index folded in, in order, as `acc = mix64(acc ^ mix64(index + 0xA5A5_A5A5))` (wrapping).
pub fn derive_seed(base: u64, path: &[u64]) -> u64 {
    path.iter().fold(mix64(base), |acc, &index| {
        mix64(acc ^ mix64(index.wrapping_add(0xA5A5_A5A5)))
    })
}

/// Which stream of a sample a random draw belongs to. Keeping the environment's layout apart
/// from the sensor and motor noise means the same seed gives the same room or light
/// configuration whatever the controller does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Room size, obstacles, exit, start pose, light configuration.
    Environment = 1,
    /// Per-sample sensor choices: calibration curve and offset noise of each sensor.
    SensorSetup = 2,
    /// Per-cycle sensor and wheel noise.
    Noise = 3,
    /// A wandering teammate's own walk (its first heading, how long it keeps each heading,
    /// its turns). Its own stream, so that adding the walk left every other draw as it was.
    Teammate = 4,
    /// A team's other robots (`[[robots]]`): each robot's own streams derive from this one
    /// and its index (`member_rng`, `member_seed`), apart from the focal robot's and from
    /// one another's.
    Team = 5,
}

/// The seed of the `member`-th other robot of a team (from 0) in the sample with seed
/// `sample_seed`: what its scripted motion draws from, and where its streams derive from.
pub fn member_seed(sample_seed: u64, member: usize) -> u64 {
    derive_seed(sample_seed, &[Stream::Team as u64, member as u64])
}

/// Creates the generator for one stream (its sensor setup, its noise) of the `member`-th other
/// robot of a team.
pub fn member_rng(sample_seed: u64, member: usize, stream: Stream) -> SimRng {
    stream_rng(member_seed(sample_seed, member), stream)
}

/// Creates the generator for one stream of the sample with seed `sample_seed`.
pub fn stream_rng(sample_seed: u64, stream: Stream) -> SimRng {
    SimRng::seed_from_u64(derive_seed(sample_seed, &[stream as u64]))
}

/// One draw from the standard normal distribution N(0, 1).
#[inline]
pub fn standard_normal(rng: &mut SimRng) -> f32 {
    StandardNormal.sample(rng)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `mix64(k * 0x9E37_79B9_7F4A_7C15)` is output k + 1 of SplitMix64 seeded with 0 (it
    /// adds the increment, then finalises): these are that generator's published first outputs
    /// (Vigna's reference `splitmix64.c`, also the seeding values of the xoshiro family), not
    /// values this code printed.
    #[test]
    fn mix64_is_the_splitmix64_output_function() {
        const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;
        let published: [u64; 4] = [
            0xE220_A839_7B1D_CDAF,
            0x6E78_9E6A_A1B9_65F4,
            0x06C4_5D18_8009_454F,
            0xF88B_B8A8_724C_81EC,
        ];
        for (k, expected) in published.into_iter().enumerate() {
            assert_eq!(mix64(GAMMA.wrapping_mul(k as u64)), expected, "output {k}");
        }
    }

    /// The documented construction, spelled out with the (independently pinned) mix64: the
    /// base mixed, then each index folded in as `mix64(acc ^ mix64(index + 0xA5A5_A5A5))`. Run
    /// seeds, and so every checkpoint, depend on it never changing.
    #[test]
    fn derived_seeds_follow_the_documented_construction() {
        let fold = |acc: u64, index: u64| mix64(acc ^ mix64(index.wrapping_add(0xA5A5_A5A5)));
        assert_eq!(derive_seed(7, &[]), mix64(7));
        assert_eq!(derive_seed(7, &[3]), fold(mix64(7), 3));
        assert_eq!(derive_seed(7, &[3, 4]), fold(fold(mix64(7), 3), 4));
        assert_eq!(
            derive_seed(u64::MAX, &[u64::MAX, 0]),
            fold(fold(mix64(u64::MAX), u64::MAX), 0)
        );
        // Order, base, index and path length each matter.
        assert_ne!(derive_seed(1, &[0, 1]), derive_seed(1, &[1, 0]));
        assert_ne!(derive_seed(1, &[0]), derive_seed(2, &[0]));
        assert_ne!(derive_seed(1, &[0]), derive_seed(1, &[1]));
        assert_ne!(derive_seed(1, &[]), derive_seed(1, &[0]));
    }

    /// A sample's stream k is the generator seeded with `derive_seed(sample seed, [k])`, k = 1
    /// environment, 2 sensor setup, 3 noise, 4 teammate: the numbering is part of every
    /// trajectory.
    #[test]
    fn streams_are_numbered_and_independent() {
        use rand::RngExt;
        for (stream, k) in [
            (Stream::Environment, 1),
            (Stream::SensorSetup, 2),
            (Stream::Noise, 3),
            (Stream::Teammate, 4),
        ] {
            let mut got = stream_rng(42, stream);
            let mut expected = SimRng::seed_from_u64(derive_seed(42, &[k]));
            assert_eq!(got.random::<u64>(), expected.random::<u64>(), "{stream:?}");
        }
        let first = |seed, stream| stream_rng(seed, stream).random::<u64>();
        assert_ne!(first(42, Stream::Environment), first(42, Stream::Noise));
        assert_ne!(
            first(42, Stream::Environment),
            first(42, Stream::SensorSetup)
        );
        assert_ne!(
            first(42, Stream::Environment),
            first(43, Stream::Environment)
        );
        assert_ne!(first(42, Stream::Teammate), first(42, Stream::Noise));
    }

    #[test]
    fn standard_normal_has_unit_spread() {
        let mut rng = stream_rng(5, Stream::Noise);
        let n = 20_000;
        let draws: Vec<f32> = (0..n).map(|_| standard_normal(&mut rng)).collect();
        let mean = draws.iter().sum::<f32>() / n as f32;
        let var = draws.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>() / n as f32;
        assert!(mean.abs() < 0.03, "mean {mean}");
        assert!((var - 1.0).abs() < 0.05, "variance {var}");
    }
}
