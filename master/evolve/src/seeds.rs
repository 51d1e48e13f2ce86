//! Every run-level seed, in one place: a run's seed from the experiment's seed, the node's name
//! and the run index, and from it the independent streams of the run (its search algorithm's
//! draws, each generation's sample seeds and light configurations, the post-evaluation seeds).
//! Stored runs were evolved from these derivations: a change here would silently make resumed
//! and repeated runs differ from the stored ones, so the tests pin their values.

use hevo_sim_core::{SimRng, derive_seed};
use rand::{RngExt, SeedableRng};

/// Tags that keep the random streams of one run apart.
#[derive(Debug, Clone, Copy)]
#[repr(u64)]
pub enum RunStream {
    /// The GA's initial population.
    Initial = 11,
    /// The GA's mutations that make generation g+1 from generation g.
    Mutation = 12,
    /// The sample seeds of a generation.
    Samples = 13,
    /// The post-evaluation samples.
    PostEvaluation = 14,
    /// The light configurations of a generation's samples, when drawn at random.
    Variants = 15,
    /// CMA-ES's samples of generation g.
    Cmaes = 16,
    /// MAP-Elites' genomes of generation g.
    MapElites = 17,
}

/// The seed of one run of one node: from the experiment's seed, the node's name and the run
/// index, never from where or when it runs.
pub fn run_seed(experiment_seed: u64, node_name: &str, run: u32) -> u64 {
    let name_hash = hevo_sim_core::fnv1a(node_name.as_bytes());
    derive_seed(experiment_seed, &[name_hash, u64::from(run)])
}

/// A generator for one stream of a run (with extra indices, e.g. the generation).
pub fn stream(run_seed: u64, stream: RunStream, indices: &[u64]) -> SimRng {
    let mut path = vec![stream as u64];
    path.extend_from_slice(indices);
    SimRng::seed_from_u64(derive_seed(run_seed, &path))
}

/// The sample seeds of one generation: shared by all its genomes.
pub fn generation_seeds(run_seed: u64, generation: u32, n_samples: u32) -> Vec<u64> {
    (0..n_samples)
        .map(|sample_idx| {
            derive_seed(
                run_seed,
                &[
                    RunStream::Samples as u64,
                    u64::from(generation),
                    u64::from(sample_idx),
                ],
            )
        })
        .collect()
}

/// How a generation's samples meet a task's light configurations (or start branches).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VariantDraw {
    /// In turn, so each gets an equal share of every generation.
    #[default]
    InTurn,
    /// Each sample draws its own, uniformly, from the run's stream for the generation.
    AtRandom,
}

/// The light configuration (or start branch) of each of a generation's samples, for a task with
/// `n_variants` of them: in turn (equal shares) or, with [`VariantDraw::AtRandom`], each drawn
/// uniformly from the run's own stream.
pub fn generation_variants(
    draw: VariantDraw,
    run_seed: u64,
    generation: u32,
    n_samples: u32,
    n_variants: u32,
) -> Vec<Option<u32>> {
    if n_variants <= 1 {
        return vec![None; n_samples as usize];
    }
    match draw {
        VariantDraw::InTurn => (0..n_samples).map(|i| Some(i % n_variants)).collect(),
        VariantDraw::AtRandom => {
            let mut rng = stream(run_seed, RunStream::Variants, &[u64::from(generation)]);
            (0..n_samples)
                .map(|_| Some(rng.random_range(0..n_variants)))
                .collect()
        }
    }
}

/// The post-evaluation seeds of a run: disjoint from every generation's.
pub fn post_evaluation_seeds(run_seed: u64, n_samples: u32) -> Vec<u64> {
    (0..n_samples)
        .map(|sample_idx| {
            derive_seed(
                run_seed,
                &[RunStream::PostEvaluation as u64, u64::from(sample_idx)],
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn training_variants_come_in_turn_or_at_random() {
        let balanced = generation_variants(VariantDraw::InTurn, 7, 3, 50, 4);
        let shares = |variants: &[Option<u32>]| {
            (0..4)
                .map(|v| variants.iter().filter(|&&x| x == Some(v)).count())
                .collect::<Vec<_>>()
        };
        assert_eq!(shares(&balanced), [13, 13, 12, 12]);
        assert_eq!(
            generation_variants(VariantDraw::AtRandom, 7, 3, 5, 1),
            vec![None; 5]
        );

        // Drawn from the run's own stream: these draws are part of every stored run made with
        // `training_variants = "random"`, so they must not change.
        let random = generation_variants(VariantDraw::AtRandom, 7, 3, 50, 4);
        let first_twelve = |variants: &[Option<u32>]| -> Vec<u32> {
            variants[..12].iter().map(|v| v.unwrap()).collect()
        };
        assert_eq!(first_twelve(&random), [0, 3, 3, 3, 0, 3, 1, 1, 1, 2, 3, 2]);
        assert_eq!(
            first_twelve(&generation_variants(VariantDraw::AtRandom, 7, 4, 50, 4)),
            [3, 1, 1, 0, 1, 2, 3, 0, 3, 0, 0, 1]
        );
        assert!(random.iter().all(|v| v.is_some_and(|v| v < 4)));
        // Over many generations every configuration gets about a quarter, but single
        // generations are uneven.
        let mut total = [0usize; 4];
        let mut uneven = 0;
        for generation in 0..200 {
            let variants = generation_variants(VariantDraw::AtRandom, 7, generation, 50, 4);
            let counts = shares(&variants);
            uneven += usize::from(counts.iter().any(|&c| !(12..=13).contains(&c)));
            for (sum, count) in total.iter_mut().zip(counts) {
                *sum += count;
            }
        }
        assert!(
            total.iter().all(|&t| (2250..=2750).contains(&t)),
            "{total:?}"
        );
        assert!(uneven > 150, "{uneven} of 200 generations uneven");
    }

    #[test]
    fn seeds_are_reproducible_and_distinct() {
        // Every stored run was evolved from these derivations: a change would silently make
        // resumed and repeated runs differ from the stored ones.
        assert_eq!(run_seed(1, "a", 0), 0x173d_0976_75ae_e7da);
        assert_eq!(run_seed(1, "a", 1), 0xe02c_b183_381b_4605);
        assert_eq!(run_seed(1, "b", 0), 0xddd4_7351_9f92_c9c1);
        assert_eq!(
            generation_seeds(7, 0, 3),
            [
                2_057_445_736_543_846_425,
                8_621_178_369_640_015_854,
                8_320_524_326_695_012_408
            ]
        );
        assert_eq!(
            post_evaluation_seeds(7, 3),
            [
                16_845_980_654_590_289_509,
                10_955_549_134_701_683_763,
                12_004_978_764_694_499_027
            ]
        );
        let gen0 = generation_seeds(7, 0, 10);
        let gen1 = generation_seeds(7, 1, 10);
        let post = post_evaluation_seeds(7, 10);
        assert!(gen0.iter().all(|s| !gen1.contains(s) && !post.contains(s)));
    }
}
