//! A strategy's own cost per generation at the paper's settings, to set beside a generation's
//! evaluation time: MAP-Elites' tell (which files the generation's 100 results into the
//! archive and draws the next 100 genomes; ask only hands them out) on an archive already
//! filled, for the single-network maze's genome (6-10-2, the paper's largest free network)
//! on a 20 x 20 grid and a 100 x 100 one; and what the runner adds per generation for it,
//! the state serialised into the checkpoint. The paper's GA, CMA-ES (full and separable) and
//! novelty search (its archive full) are measured the same way.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use hevo_evolve::cmaes::{Cmaes, CmaesSettings, CmaesVariant};
use hevo_evolve::ga::{Ga, GaSettings};
use hevo_evolve::map_elites::{MapElites, MapElitesSettings, Variation};
use hevo_evolve::novelty::{Novelty, NoveltySettings};
use hevo_evolve::{Evaluation, Strategy};
use hevo_sim_core::{InputGroup, NodeSpec, SimRng};
use rand::{RngExt, SeedableRng};

/// The paper's population.
const POPULATION: u32 = 100;

fn n_genes() -> usize {
    NodeSpec::primitive("maze", vec![InputGroup::IR, InputGroup::LIGHT], 10)
        .topology()
        .n_genes()
}

/// A generation's results: random fitness, and descriptors spread over the grid's range.
fn results(rng: &mut SimRng) -> Vec<Evaluation> {
    (0..POPULATION)
        .map(|_| {
            Evaluation::with_descriptor(
                rng.random_range(0.0..2.0),
                vec![rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)],
            )
        })
        .collect()
}

/// A MAP-Elites run on a grid of `bins` x `bins`, told random results until the archive is
/// nearly full.
fn filled(bins: u32, variation: Variation) -> MapElites {
    let settings = MapElitesSettings {
        population: POPULATION,
        bins: vec![bins, bins],
        ranges: vec![[-1.0, 1.0]; 2],
        variation,
        ..MapElitesSettings::default()
    };
    let mut strategy = MapElites::start(settings, n_genes(), 1).unwrap();
    let mut rng = SimRng::seed_from_u64(2);
    let generations = (5 * bins * bins / POPULATION).max(20);
    for _ in 0..generations {
        strategy.tell(&results(&mut rng)).unwrap();
    }
    strategy
}

fn bench(c: &mut Criterion) {
    let mut rng = SimRng::seed_from_u64(3);
    let told = results(&mut rng);
    for (bins, variation) in [
        (20, Variation::Gaussian),
        (20, Variation::IsoLine),
        (100, Variation::IsoLine),
    ] {
        let strategy = filled(bins, variation);
        let cells = strategy.archive().elites().count();
        let name = format!("map_elites {bins}x{bins} {variation:?} ({cells} filled)");
        c.bench_function(&format!("{name}: tell"), |b| {
            b.iter_batched(
                || strategy.clone(),
                |mut s| s.tell(&told).unwrap(),
                BatchSize::SmallInput,
            )
        });
        c.bench_function(&format!("{name}: state as checkpoint JSON"), |b| {
            b.iter(|| serde_json::to_vec(&strategy.state()).unwrap().len())
        });
    }
    let ga = Ga::start(GaSettings::default(), n_genes(), 1).unwrap();
    c.bench_function("ga: tell", |b| {
        b.iter_batched(
            || ga.clone(),
            |mut s| s.tell(&told).unwrap(),
            BatchSize::SmallInput,
        )
    });
    // CMA-ES decomposes C anew every generation (a function of C alone, so a resumed run
    // draws the same genomes), so one tell from any generation costs what every one does.
    for variant in [CmaesVariant::Full, CmaesVariant::Separable] {
        let settings = CmaesSettings {
            variant,
            ..CmaesSettings::default()
        };
        let cmaes = Cmaes::start(settings, n_genes(), 1).unwrap();
        c.bench_function(&format!("cmaes {variant:?}: tell"), |b| {
            b.iter_batched(
                || cmaes.clone(),
                |mut s| s.tell(&told).unwrap(),
                BatchSize::SmallInput,
            )
        });
        c.bench_function(
            &format!("cmaes {variant:?}: state as checkpoint JSON"),
            |b| b.iter(|| serde_json::to_vec(&cmaes.state()).unwrap().len()),
        );
    }
    // Novelty search with its archive full (2,000 behaviours by default): a tell measures each
    // of the generation's 100 genomes against the archive and the generation.
    let settings = NoveltySettings::default();
    let generations_to_fill = settings.archive_size / settings.archive_per_generation;
    let mut novelty = Novelty::start(settings, n_genes(), 1).unwrap();
    let mut fill_rng = SimRng::seed_from_u64(4);
    for _ in 0..generations_to_fill {
        novelty.tell(&results(&mut fill_rng)).unwrap();
    }
    c.bench_function("novelty (archive full): tell", |b| {
        b.iter_batched(
            || novelty.clone(),
            |mut s| s.tell(&told).unwrap(),
            BatchSize::SmallInput,
        )
    });
    c.bench_function("novelty (archive full): state as checkpoint JSON", |b| {
        b.iter(|| serde_json::to_vec(&novelty.state()).unwrap().len())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
