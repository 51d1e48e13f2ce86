//! Simulator throughput: control cycles per second on one core for solve_maze with the paper's
//! 6-10-3 arbitrator over three 4-3-2 primitives and the full sensor model (28 IR rays, light
//! flashes, wheel noise). Collisions do not end the sample here, so every sample runs its full
//! 1000 cycles and the figure measures the simulator, not how soon a random genome crashes.
//! The scalar reference and the lockstep evaluator run the same 16 samples, one after the other
//! within one run, so their ratio is a paired comparison.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use hevo_sim_core::InputGroup;
use hevo_sim_core::SimRng;
use hevo_sim_core::{BatchEvaluator, EvaluatorKind};
use hevo_sim_core::{ControllerFile, NodeSpec};
use hevo_sim_core::{Sample, TaskConfig};
use rand::{RngExt, SeedableRng};

fn random_genes(rng: &mut SimRng, n: usize) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-3.0..3.0)).collect()
}

fn primitive(name: &str, rng: &mut SimRng) -> NodeSpec {
    NodeSpec::primitive(name, vec![InputGroup::IR], 3).with_genome(random_genes(rng, 35))
}

fn maze_arbitrator() -> (ControllerFile, Vec<f32>) {
    let mut rng = SimRng::seed_from_u64(7);
    let children = vec![
        primitive("follow_wall", &mut rng),
        primitive("turn_left", &mut rng),
        primitive("turn_right", &mut rng),
    ];
    let root = NodeSpec::arbitrator(
        "solve_maze",
        vec![InputGroup::IR, InputGroup::LIGHT],
        10,
        children,
    );
    let genes = random_genes(&mut rng, 213);
    (ControllerFile::new(root), genes)
}

fn bench_cycles(c: &mut Criterion) {
    let (file, genes) = maze_arbitrator();
    let mut task = TaskConfig::shipped("solve_maze").unwrap();
    task.end_on_collision = false;
    let samples: Vec<Sample> = (0..16)
        .map(|k| Sample {
            seed: 100 + k,
            variant: Some(k as u32 % 4),
        })
        .collect();
    let mut group = c.benchmark_group("simulator");
    for (label, kind) in [
        ("scalar", EvaluatorKind::Scalar),
        ("lockstep", EvaluatorKind::Lockstep),
    ] {
        let batch = BatchEvaluator::new(file.clone(), task.clone())
            .expect("valid benchmark setup")
            .with_kind(kind);
        let cycles: u64 = batch
            .evaluate_genome(Some(&genes), &samples)
            .expect("genome fits")
            .iter()
            .map(|o| u64::from(o.cycles))
            .sum();
        group.throughput(Throughput::Elements(cycles));
        group.bench_function(format!("solve_maze_6-10-3_over_3x4-3-2/{label}"), |b| {
            b.iter(|| {
                batch
                    .evaluate_genome(Some(&genes), &samples)
                    .expect("genome fits")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_cycles);
criterion_main!(benches);
