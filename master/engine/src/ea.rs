//! The evolutionary algorithm of the paper (SPEC section 6): a simple generational algorithm
//! without crossover. The best `elites` genomes are copied unchanged and each also gets
//! `population / elites - 1` mutated copies; a copy's every gene is mutated with probability
//! `mutation_probability` by a Gaussian offset and clamped to the gene range. Pure: every
//! random draw comes from the seeds passed in, so a run is reproducible from its seed alone.

use crate::experiment::{EvolutionParams, TrainingVariants};
use hevo_sim_core::{SimRng, derive_seed};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

/// Tags that keep the random streams of one run apart.
#[derive(Debug, Clone, Copy)]
#[repr(u64)]
pub enum RunStream {
    /// The initial population.
    Initial = 11,
    /// The mutations that make generation g+1 from generation g.
    Mutation = 12,
    /// The sample seeds of a generation.
    Samples = 13,
    /// The post-evaluation samples.
    PostEvaluation = 14,
    /// The light configurations of a generation's samples, when drawn at random.
    Variants = 15,
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

/// The initial population: genes drawn from N(0, initial_sigma^2), clamped to the gene range.
pub fn initial_population(
    n_genes: usize,
    params: &EvolutionParams,
    run_seed: u64,
) -> Vec<Vec<f32>> {
    let mut rng = stream(run_seed, RunStream::Initial, &[]);
    let normal =
        Normal::new(0.0, params.initial_sigma).expect("sigma validated non-negative and finite");
    let [low, high] = params.gene_range;
    (0..params.population)
        .map(|_| {
            (0..n_genes)
                .map(|_| normal.sample(&mut rng).clamp(low, high) as f32)
                .collect()
        })
        .collect()
}

/// Genome indices from best to worst; ties keep the lower index first, so the order is fully
/// determined by the fitness values.
pub fn ranking(fitness: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..fitness.len()).collect();
    order.sort_by(|&a, &b| fitness[b].total_cmp(&fitness[a]).then(a.cmp(&b)));
    order
}

/// The next generation from the current one and its fitness: for each elite in rank order,
/// the elite itself and then its mutated copies.
pub fn next_generation(
    population: &[Vec<f32>],
    fitness: &[f64],
    params: &EvolutionParams,
    run_seed: u64,
    generation: u32,
) -> Vec<Vec<f32>> {
    let mut rng = stream(run_seed, RunStream::Mutation, &[u64::from(generation)]);
    let normal =
        Normal::new(0.0, params.mutation_sigma).expect("sigma validated non-negative and finite");
    let copies_per_elite = (params.population / params.elites) as usize - 1;
    let [low, high] = params.gene_range;
    let mut next = Vec::with_capacity(params.population as usize);
    for &elite_idx in ranking(fitness).iter().take(params.elites as usize) {
        let elite = &population[elite_idx];
        next.push(elite.clone());
        for _ in 0..copies_per_elite {
            next.push(
                elite
                    .iter()
                    .map(|&gene| {
                        if rng.random::<f64>() < params.mutation_probability {
                            (f64::from(gene) + normal.sample(&mut rng)).clamp(low, high) as f32
                        } else {
                            gene
                        }
                    })
                    .collect(),
            );
        }
    }
    next
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

/// The light configuration (or start branch) of each of a generation's samples, for a task with
/// `n_variants` of them: in turn (equal shares) or, with [`TrainingVariants::Random`], each drawn
/// uniformly from the run's own stream.
pub fn generation_variants(
    allocation: TrainingVariants,
    run_seed: u64,
    generation: u32,
    n_samples: u32,
    n_variants: u32,
) -> Vec<Option<u32>> {
    if n_variants <= 1 {
        return vec![None; n_samples as usize];
    }
    match allocation {
        TrainingVariants::Balanced => (0..n_samples).map(|i| Some(i % n_variants)).collect(),
        TrainingVariants::Random => {
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
        let balanced = generation_variants(TrainingVariants::Balanced, 7, 3, 50, 4);
        let shares = |variants: &[Option<u32>]| {
            (0..4)
                .map(|v| variants.iter().filter(|&&x| x == Some(v)).count())
                .collect::<Vec<_>>()
        };
        assert_eq!(shares(&balanced), [13, 13, 12, 12]);
        assert_eq!(
            generation_variants(TrainingVariants::Random, 7, 3, 5, 1),
            vec![None; 5]
        );

        // Drawn from the run's own stream: these draws are part of every stored run made with
        // `training_variants = "random"`, so they must not change.
        let random = generation_variants(TrainingVariants::Random, 7, 3, 50, 4);
        let first_twelve = |variants: &[Option<u32>]| -> Vec<u32> {
            variants[..12].iter().map(|v| v.unwrap()).collect()
        };
        assert_eq!(first_twelve(&random), [0, 3, 3, 3, 0, 3, 1, 1, 1, 2, 3, 2]);
        assert_eq!(
            first_twelve(&generation_variants(TrainingVariants::Random, 7, 4, 50, 4)),
            [3, 1, 1, 0, 1, 2, 3, 0, 3, 0, 0, 1]
        );
        assert!(random.iter().all(|v| v.is_some_and(|v| v < 4)));
        // Over many generations every configuration gets about a quarter, but single
        // generations are uneven.
        let mut total = [0usize; 4];
        let mut uneven = 0;
        for generation in 0..200 {
            let variants = generation_variants(TrainingVariants::Random, 7, generation, 50, 4);
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

    fn params() -> EvolutionParams {
        EvolutionParams::default()
    }

    /// The parent of a genome of [`marked_population`]: the marker most of its genes still carry
    /// (a copy's genes are mutated with probability 0.1, so most are left as they were).
    fn parent_of(genome: &[f32], population: &[Vec<f32>]) -> Option<usize> {
        population.iter().position(|parent| {
            let kept = genome.iter().zip(parent).filter(|(a, b)| a == b).count();
            2 * kept > genome.len()
        })
    }

    /// `n` genomes of 50 genes; genome i has every gene equal to its own marker i / 10 - 5, so
    /// any gene a copy still has unmutated names its parent.
    fn marked_population(n: usize) -> Vec<Vec<f32>> {
        (0..n).map(|i| vec![i as f32 / 10.0 - 5.0; 50]).collect()
    }

    #[test]
    fn the_five_fittest_are_kept_in_rank_order_each_with_nineteen_mutated_copies() {
        // The paper's scheme (SPEC section 6): population 100, 5 elites, each copied unchanged
        // and followed by 19 mutated copies.
        let population = marked_population(100);
        let mut fitness = vec![-1.0; 100];
        for (genome, value) in [
            (63, 0.97),
            // A tie inside the elites: the lower index ranks first.
            (70, 0.9),
            (7, 0.9),
            // A tie across the cut after the fifth: 12 and 40 are kept, 88 is not.
            (88, 0.5),
            (40, 0.5),
            (12, 0.5),
            (99, 0.49),
            (0, 0.0),
            (1, -0.5),
        ] {
            fitness[genome] = value;
        }
        const ELITES: [usize; 5] = [63, 7, 70, 12, 40];

        let next = next_generation(&population, &fitness, &params(), 1, 0);
        assert_eq!(next.len(), 100);
        let mut mutated_genes = 0;
        for (rank, &elite) in ELITES.iter().enumerate() {
            let block = &next[20 * rank..20 * (rank + 1)];
            assert_eq!(
                block[0], population[elite],
                "elite {rank} is genome {elite}"
            );
            for (copy, genome) in block[1..].iter().enumerate() {
                assert_eq!(
                    parent_of(genome, &population),
                    Some(elite),
                    "copy {copy} of elite {rank}"
                );
                mutated_genes += genome
                    .iter()
                    .zip(&population[elite])
                    .filter(|(a, b)| a != b)
                    .count();
            }
        }
        // Every genome of the next generation descends from one of the five: 20 each.
        let mut children = [0; 100];
        for genome in &next {
            children[parent_of(genome, &population).expect("a parent")] += 1;
        }
        let parents: Vec<(usize, usize)> = children
            .iter()
            .enumerate()
            .filter(|&(_, &n)| n > 0)
            .map(|(genome, &n)| (genome, n))
            .collect();
        assert_eq!(parents, [(7, 20), (12, 20), (40, 20), (63, 20), (70, 20)]);
        // The copies are mutated copies: 95 copies x 50 genes at probability 0.1 is 475 genes
        // expected, with a standard deviation of about 21.
        assert!(
            (380..=570).contains(&mutated_genes),
            "{mutated_genes} genes mutated"
        );
    }

    #[test]
    fn a_smaller_scheme_keeps_its_elites_with_population_over_elites_minus_one_copies() {
        // Population 10 with 2 elites: each elite and 4 mutated copies.
        let params = EvolutionParams {
            population: 10,
            elites: 2,
            ..params()
        };
        let population = marked_population(10);
        let fitness = [0.1, 0.7, -0.2, 0.3, 0.7, 0.0, 0.69, 0.2, 0.1, 0.0];
        let next = next_generation(&population, &fitness, &params, 3, 5);
        let parents: Vec<Option<usize>> = next.iter().map(|g| parent_of(g, &population)).collect();
        assert_eq!(
            parents,
            [1, 1, 1, 1, 1, 4, 4, 4, 4, 4].map(Some),
            "genomes 1 and 4 tie at 0.7 for first; 6 at 0.69 is third and not kept"
        );
        assert_eq!(next[0], population[1]);
        assert_eq!(next[5], population[4]);
    }

    #[test]
    fn ranking_orders_best_first_with_ties_by_index() {
        assert_eq!(ranking(&[]), Vec::<usize>::new());
        assert_eq!(ranking(&[0.4]), [0]);
        assert_eq!(ranking(&[0.1, 0.9, 0.5]), [1, 2, 0]);
        // Ties keep the lower index first, wherever they fall.
        assert_eq!(ranking(&[0.5, 0.5, 0.9, 0.5]), [2, 0, 1, 3]);
        // Negative fitness ranks below zero; large and tiny magnitudes keep their order.
        assert_eq!(
            ranking(&[-3.0, 1e-300, -1e-300, 2.5e6, -2.5e6, 0.25]),
            [3, 5, 1, 2, 0, 4]
        );
        // The order is IEEE 754's total order (`f64::total_cmp`), so 0.0 ranks above -0.0 even
        // though they compare equal: a "tie" between them is not broken by index.
        assert_eq!(ranking(&[-0.0, 0.0, -0.0]), [1, 0, 2]);
        // Fitness is a mean of finite sample values (the dispatcher refuses non-finite ones),
        // so infinities and NaN do not reach here; for completeness, the total order puts
        // +inf first and -inf last.
        assert_eq!(
            ranking(&[0.0, f64::NEG_INFINITY, f64::INFINITY, 1.0]),
            [2, 3, 0, 1]
        );
    }

    #[test]
    fn mutation_statistics_match_the_parameters() {
        // One elite repeated: count mutated genes and measure their offsets.
        let population = vec![vec![0.0f32; 200]; 100];
        let fitness = vec![1.0; 100];
        let mut mutated = 0usize;
        let mut total = 0usize;
        let mut sum_sq = 0.0f64;
        for generation in 0..20 {
            let next = next_generation(&population, &fitness, &params(), 9, generation);
            for (genome_idx, genome) in next.iter().enumerate() {
                if genome_idx % 20 == 0 {
                    assert!(genome.iter().all(|&g| g == 0.0), "elites are not mutated");
                    continue;
                }
                for &gene in genome {
                    total += 1;
                    if gene != 0.0 {
                        mutated += 1;
                        sum_sq += f64::from(gene) * f64::from(gene);
                    }
                }
            }
        }
        let rate = mutated as f64 / total as f64;
        assert!((rate - 0.1).abs() < 0.005, "mutation rate {rate}");
        let sigma = (sum_sq / mutated as f64).sqrt();
        assert!((sigma - 1.0).abs() < 0.03, "mutation sigma {sigma}");
    }

    #[test]
    fn genes_stay_in_range() {
        let mut p = params();
        p.initial_sigma = 50.0;
        let population = initial_population(30, &p, 4);
        assert!(
            population
                .iter()
                .flatten()
                .all(|&g| (-10.0..=10.0).contains(&g))
        );
        assert!(
            population.iter().flatten().any(|&g| g == 10.0),
            "clamping happens at the edge"
        );
    }

    #[test]
    fn initial_genes_have_the_configured_spread() {
        let population = initial_population(100, &params(), 5);
        let genes: Vec<f64> = population.iter().flatten().map(|&g| f64::from(g)).collect();
        let mean = genes.iter().sum::<f64>() / genes.len() as f64;
        let var = genes.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / genes.len() as f64;
        assert!(mean.abs() < 0.05, "{mean}");
        assert!((var.sqrt() - 2.0).abs() < 0.05, "{}", var.sqrt());
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
