//! Remote evaluation (`EvaluateGenomes`) on a real master and real workers: the results
//! `hevo_client::evaluate_genomes` streams back are the engine's own local evaluation bit for
//! bit, with a worker killed while it holds a batch and spot checks on, and with a worker
//! forging results that a spot check catches (the evaluation ends and the client evaluates
//! again); dropping the stream or cancelling the evaluation by its id takes its batches off
//! the queue, and the client stops at a cancel; a worker's token and requests over a limit or
//! with a bad gene are refused naming the field; a task whose group runs a controller file
//! travels with the file's text.

use hevo_client::EvaluationEvent;
use hevo_engine::dispatch::{EvaluationRequest, RequestShared};
use hevo_proto::client::ClientOptions;
use hevo_proto::convert as wire;
use hevo_proto::v1;
use hevo_sim_core::{ControllerFile, SampleSummary, TaskConfig};
use hevo_tests::service::{
    CLIENT_TOKEN, WORKER_TOKEN, jobs, lease, master_with_roles, metric, metrics_text, runtime,
    workers,
};
use hevo_tests::{Master, Scratch, repo_root, start_worker};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The shipped maze controller with its arbitrator (the root) free, and the maze task.
fn maze_template() -> (ControllerFile, TaskConfig) {
    let path = repo_root().join("controllers/solve_maze.json");
    let mut template = hevo_engine::inputs::read_controller(&path).unwrap();
    let genome = template.root.genome.take().unwrap();
    assert!(!genome.is_empty());
    (template, TaskConfig::shipped("solve_maze").unwrap())
}

/// `n` genomes near the shipped arbitrator's, each moved by a different small pattern.
fn genomes_near(n: usize) -> Vec<Arc<[f32]>> {
    let path = repo_root().join("controllers/solve_maze.json");
    let complete = hevo_engine::inputs::read_controller(&path).unwrap();
    let genes = complete.root.genome.unwrap();
    (0..n)
        .map(|genome_idx| {
            genes
                .iter()
                .enumerate()
                .map(|(gene_idx, &gene)| {
                    let step = ((genome_idx * 31 + gene_idx * 7) % 13) as f32 - 6.0;
                    (gene + 0.05 * step).clamp(-10.0, 10.0)
                })
                .collect::<Vec<f32>>()
                .into()
        })
        .collect()
}

fn options(master: &Master, token: &str) -> ClientOptions {
    ClientOptions {
        url: master.url.clone(),
        token: Some(token.to_string()),
        tls_ca: None,
    }
}

/// Polls `condition` every 20 ms, at most a minute.
fn wait_for(what: &str, mut condition: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(60);
    while !condition() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn remote_results_are_the_local_ones_with_a_worker_killed_mid_batch() {
    let scratch = Scratch::new("remote-evaluate");
    let master = master_with_roles(&scratch, &["--verify-share", "0.2"]);
    let (template, task) = maze_template();
    let genomes = genomes_near(40);
    let (samples, seed) = (3, 11);

    let (remote, _) = std::thread::scope(|scope| {
        let evaluation =
            scope.spawn(|| evaluate_remotely(&master, &template, &task, &genomes, samples, seed));
        // One worker first, so a leased batch is its own; stopped (SIGSTOP) before the kill so
        // it cannot finish the batch while the test looks, and still holding it once stopped.
        let mut doomed = start_worker(
            &master.url,
            WORKER_TOKEN,
            "w0",
            &[],
            &scratch.join("w0.log"),
        );
        wait_for("the worker to be stopped holding a batch", || {
            if metric(&metrics_text(&master), "hevo_batches_leased") < 1.0 {
                return false;
            }
            doomed.signal("STOP");
            // Results sent just before the stop reach the master within this pause.
            std::thread::sleep(Duration::from_millis(200));
            let holding = metric(&metrics_text(&master), "hevo_batches_leased") >= 1.0;
            if !holding {
                doomed.signal("CONT");
            }
            holding
        });
        doomed.kill();
        let _survivor = start_worker(
            &master.url,
            WORKER_TOKEN,
            "w1",
            &[],
            &scratch.join("w1.log"),
        );
        evaluation.join().unwrap()
    });
    let after = metrics_text(&master);
    assert!(
        metric(&after, "hevo_lease_revocations_total")
            + metric(&after, "hevo_lease_expiries_total")
            >= 1.0,
        "the killed worker's lease was not taken back:\n{after}"
    );
    assert_local_results(&remote, &template, &task, &genomes, samples, seed);
    // Why each sample ended came over the wire too (compared with the rest above): these
    // genomes end their samples in more than one way, so a lost field would show.
    let endings: std::collections::BTreeSet<u8> =
        remote.iter().flatten().map(|s| s.ending.code()).collect();
    assert!(endings.len() >= 2, "endings {endings:?}");
}

/// A task whose group runs a controller file (`scenarios/swarm/mixed_aggregation.toml`)
/// reaches the worker as text, the file's text with it, and comes back as the local
/// evaluation's results, bit for bit.
#[test]
fn a_group_running_a_controller_file_is_evaluated_remotely_as_locally() {
    let scratch = Scratch::new("remote-group-file");
    let master = master_with_roles(&scratch, &[]);
    let scenario = repo_root().join("scenarios/swarm/mixed_aggregation.toml");
    let scenario = hevo_engine::inputs::read_scenario(&scenario.to_string_lossy()).unwrap();
    assert_eq!(scenario.controller_files.len(), 1);
    let task = TaskConfig::from_scenario(Arc::new(scenario));
    let path = repo_root().join("controllers/aggregation.json");
    let mut template = hevo_engine::inputs::read_controller(&path).unwrap();
    let genes = template.root.genome.take().unwrap();
    let genomes: Vec<Arc<[f32]>> = (0..3)
        .map(|idx| {
            let moved: Vec<f32> = genes
                .iter()
                .map(|&gene| (gene + 0.3 * idx as f32).clamp(-10.0, 10.0))
                .collect();
            moved.into()
        })
        .collect();
    let (samples, seed) = (2, 5);
    let (remote, _) = std::thread::scope(|scope| {
        let evaluation =
            scope.spawn(|| evaluate_remotely(&master, &template, &task, &genomes, samples, seed));
        let _worker = start_worker(
            &master.url,
            WORKER_TOKEN,
            "w0",
            &[],
            &scratch.join("w0.log"),
        );
        evaluation.join().unwrap()
    });
    assert_local_results(&remote, &template, &task, &genomes, samples, seed);
}

/// `hevo_client::evaluate_genomes` on `master`: the results, `[genome][sample]`, and how many
/// attempts the master started.
fn evaluate_remotely(
    master: &Master,
    template: &ControllerFile,
    task: &TaskConfig,
    genomes: &[Arc<[f32]>],
    samples: u32,
    seed: u64,
) -> (Vec<Vec<SampleSummary>>, usize) {
    let mut results: Vec<Vec<SampleSummary>> = Vec::new();
    let mut attempts = 0;
    runtime()
        .block_on(hevo_client::evaluate_genomes(
            &options(master, CLIENT_TOKEN),
            template,
            task,
            genomes,
            samples,
            seed,
            |event| match event {
                EvaluationEvent::Started(_) => {
                    attempts += 1;
                    results.clear();
                }
                EvaluationEvent::Results {
                    first_genome,
                    results: chunk,
                } => {
                    assert_eq!(first_genome, results.len());
                    results.extend(chunk);
                }
            },
        ))
        .unwrap();
    (results, attempts)
}

/// Asserts that `remote` is the engine's local evaluation of the same genomes, bit for bit.
fn assert_local_results(
    remote: &[Vec<SampleSummary>],
    template: &ControllerFile,
    task: &TaskConfig,
    genomes: &[Arc<[f32]>],
    samples: u32,
    seed: u64,
) {
    let samples = hevo_engine::post_evaluation::post_evaluation_samples(task, samples, seed);
    let dispatcher = hevo_engine::local::local_dispatcher(2);
    let local = hevo_engine::local::run_local(dispatcher, 2, async |dispatcher| {
        dispatcher
            .evaluate(EvaluationRequest {
                job: "local".into(),
                shared: Arc::new(RequestShared::new(template.clone(), task.clone())),
                genomes: genomes.to_vec(),
                samples: samples.into(),
            })
            .await
    })
    .unwrap()
    .unwrap();
    assert_eq!(remote.len(), genomes.len());
    for (genome_idx, (remote, local)) in remote.iter().zip(&local).enumerate() {
        assert_eq!(remote, local, "genome {genome_idx}");
        for (r, l) in remote.iter().zip(local) {
            assert_eq!(
                r.fitness.to_bits(),
                l.fitness.to_bits(),
                "genome {genome_idx}"
            );
        }
    }
}

/// Results a worker makes up for every sample of `batch` without evaluating it: plausible
/// (in range, of the sample's variant, ending where the maze's behaviour descriptor may), so
/// only a spot check can catch them; `ending` as given (`None`: unset, as hevo sent before
/// the field existed).
fn made_up_results(batch: &v1::Batch, ending: Option<v1::SampleEnding>) -> Vec<v1::GenomeResult> {
    let sample_result = |sample: &v1::SampleSpec| v1::SampleResult {
        fitness: 0.5,
        cycles: 10,
        variant: sample.variant.unwrap_or(0),
        descriptor: vec![0.1, 0.2],
        ending: ending.map_or(0, Into::into),
        ..v1::SampleResult::default()
    };
    let samples: Vec<v1::SampleResult> = batch.samples.iter().map(sample_result).collect();
    batch
        .genomes
        .iter()
        .map(|_| v1::GenomeResult {
            samples: samples.clone(),
        })
        .collect()
}

#[test]
fn a_forging_worker_caught_by_a_spot_check_makes_the_client_evaluate_again() {
    let scratch = Scratch::new("remote-evaluate-forged");
    let master = master_with_roles(&scratch, &["--verify-share", "0.1"]);
    let (template, task) = maze_template();
    let genomes = genomes_near(12);
    let (remote, attempts) = std::thread::scope(|scope| {
        let evaluation =
            scope.spawn(|| evaluate_remotely(&master, &template, &task, &genomes, 2, 5));
        runtime().block_on(async {
            let mut forger = workers(&master.url, WORKER_TOKEN);
            let mut forged_batches = 0;
            // Plausible results (in range, of the sample's variant) for every batch it gets, until the master gives it none.
            while let Some(batch) = lease(&mut forger, "forger", Duration::from_secs(3)).await {
                let forged = made_up_results(&batch, Some(v1::SampleEnding::Timeout));
                let _ = forger
                    .complete_batch(v1::CompleteBatchRequest {
                        worker: "forger".into(),
                        lease_id: batch.lease_id,
                        batch_id: batch.batch_id,
                        epoch: batch.epoch,
                        genomes: forged,
                        elapsed_ms: 1,
                    })
                    .await;
                forged_batches += 1;
                assert!(forged_batches < 50, "the forger is never refused");
            }
            assert!(forged_batches >= 1, "the forger got no batch");
        });
        let _honest = start_worker(
            &master.url,
            WORKER_TOKEN,
            "honest",
            &[],
            &scratch.join("honest.log"),
        );
        evaluation.join().unwrap()
    });
    let metrics = metrics_text(&master);
    assert_eq!(
        metric(&metrics, "hevo_lying_workers_total"),
        1.0,
        "{metrics}"
    );
    assert!(attempts >= 2, "the caught evaluation was not started again");
    assert_local_results(&remote, &template, &task, &genomes, 2, 5);
}

#[test]
fn a_worker_older_than_the_ending_field_is_refused_naming_it() {
    let scratch = Scratch::new("remote-evaluate-old-worker");
    let master = master_with_roles(&scratch, &[]);
    let (template, task) = maze_template();
    let genomes = genomes_near(4);
    let (remote, _) = std::thread::scope(|scope| {
        let evaluation =
            scope.spawn(|| evaluate_remotely(&master, &template, &task, &genomes, 1, 3));
        runtime().block_on(async {
            let mut old = workers(&master.url, WORKER_TOKEN);
            let batch = lease(&mut old, "old", Duration::from_secs(30))
                .await
                .expect("a batch for the old worker");
            // What a worker built before the field sends: everything but the ending.
            let results = made_up_results(&batch, None);
            let refused = old
                .complete_batch(v1::CompleteBatchRequest {
                    worker: "old".into(),
                    lease_id: batch.lease_id,
                    batch_id: batch.batch_id,
                    epoch: batch.epoch,
                    genomes: results,
                    elapsed_ms: 1,
                })
                .await
                .unwrap_err();
            assert_eq!(refused.code(), tonic::Code::InvalidArgument, "{refused:?}");
            assert!(
                refused.message().contains(
                    "genomes[0].samples[0].ending: not set: the sender is a hevo older than this one"
                ),
                "{refused:?}"
            );
            // Handed back, so the current worker need not wait for the lease to run out
            // (the master may have taken it back already).
            let _ = old
                .release_batch(v1::ReleaseBatchRequest {
                    epoch: batch.epoch,
                    lease_id: batch.lease_id,
                    worker: "old".into(),
                })
                .await;
        });
        let _current = start_worker(
            &master.url,
            WORKER_TOKEN,
            "current",
            &[],
            &scratch.join("current.log"),
        );
        evaluation.join().unwrap()
    });
    assert_local_results(&remote, &template, &task, &genomes, 1, 3);
}

/// A request for `genomes` of the maze template, as the client builds it.
fn request(genomes: &[Arc<[f32]>], samples: u32) -> v1::EvaluateGenomesRequest {
    let (template, task) = maze_template();
    v1::EvaluateGenomesRequest {
        template_json: wire::template_to_json(&template),
        template_hash: template.content_hash(),
        task_json: wire::task_to_json(&task),
        task_hash: hevo_sim_core::task_content_hash(&task),
        genomes: genomes.len() as u32,
        genes: genomes.iter().flat_map(|g| g.iter().copied()).collect(),
        samples,
        seed: 1,
    }
}

#[test]
fn a_dropped_stream_or_a_cancel_takes_the_batches_off_the_queue() {
    let scratch = Scratch::new("remote-evaluate-cancel");
    // No workers: the batches stay queued until the evaluation ends.
    let master = master_with_roles(&scratch, &[]);
    let queued = || metric(&metrics_text(&master), "hevo_batches_queued");
    runtime().block_on(async {
        let mut client = jobs(&master.url, CLIENT_TOKEN);
        let mut stream = client
            .evaluate_genomes(request(&genomes_near(8), 2))
            .await
            .unwrap()
            .into_inner();
        let first = stream.message().await.unwrap().unwrap();
        assert!(first.evaluation_id.starts_with("eval-") && first.results.is_empty());
        assert!(queued() > 0.0);
        let cancelled = client
            .cancel_job(v1::CancelJobRequest {
                job_id: first.evaluation_id.clone(),
            })
            .await
            .unwrap()
            .into_inner()
            .job
            .unwrap();
        assert_eq!(cancelled.state, v1::JobState::Cancelled as i32);
        let ended = tokio::time::timeout(Duration::from_secs(30), stream.message())
            .await
            .unwrap()
            .unwrap_err();
        assert_eq!(ended.code(), tonic::Code::Cancelled, "{ended:?}");
        assert_eq!(queued(), 0.0);

        let mut stream = client
            .evaluate_genomes(request(&genomes_near(8), 2))
            .await
            .unwrap()
            .into_inner();
        stream.message().await.unwrap().unwrap();
        assert!(queued() > 0.0);
        drop(stream);
    });
    wait_for("the dropped evaluation's batches to go", || queued() == 0.0);
}

#[test]
fn refusals_name_the_field() {
    let scratch = Scratch::new("remote-evaluate-refusals");
    let master = master_with_roles(&scratch, &[]);
    runtime().block_on(async {
        let refusal = |request: v1::EvaluateGenomesRequest, token: &'static str| {
            let url = master.url.clone();
            async move {
                jobs(&url, token)
                    .evaluate_genomes(request)
                    .await
                    .map(|_| ())
                    .unwrap_err()
            }
        };
        let genomes = genomes_near(2);
        let status = refusal(request(&genomes, 1), WORKER_TOKEN).await;
        assert_eq!(status.code(), tonic::Code::PermissionDenied, "{status:?}");

        let mut bad_gene = request(&genomes, 1);
        bad_gene.genes[5] = 10.5;
        let status = refusal(bad_gene, CLIENT_TOKEN).await;
        assert_eq!(status.code(), tonic::Code::InvalidArgument);
        assert!(
            status
                .message()
                .starts_with("genes[5]: genome 0, gene 5 is 10.5, outside [-10, 10]"),
            "{}",
            status.message()
        );

        let mut short = request(&genomes, 1);
        short.genes.pop();
        let status = refusal(short, CLIENT_TOKEN).await;
        assert!(
            status.message().starts_with("genes: "),
            "{}",
            status.message()
        );

        let status = refusal(request(&genomes, 0), CLIENT_TOKEN).await;
        assert_eq!(status.message(), "samples: must be at least 1");

        // 2,000 genomes x 200 samples x 4 variants: more than a generation may evaluate.
        let many = vec![genomes[0].clone(); 2_000];
        let status = refusal(request(&many, 200), CLIENT_TOKEN).await;
        assert!(
            status
                .message()
                .starts_with("genomes: 1600000 evaluations at once"),
            "{}",
            status.message()
        );

        let mut other_hash = request(&genomes, 1);
        other_hash.task_hash = "0000000000000000".into();
        let status = refusal(other_hash, CLIENT_TOKEN).await;
        assert!(
            status.message().starts_with("task_hash: "),
            "{}",
            status.message()
        );
    });
}

#[test]
fn the_client_stops_at_a_cancel_and_does_not_evaluate_again() {
    let scratch = Scratch::new("remote-evaluate-client-cancel");
    // No workers: the evaluation waits until it is cancelled.
    let master = master_with_roles(&scratch, &[]);
    let (template, task) = maze_template();
    let genomes = genomes_near(4);
    let (started, ids) = std::sync::mpsc::channel();
    let outcome = std::thread::scope(|scope| {
        let evaluation = scope.spawn(|| {
            let mut attempts = 0;
            let outcome = runtime().block_on(hevo_client::evaluate_genomes(
                &options(&master, CLIENT_TOKEN),
                &template,
                &task,
                &genomes,
                1,
                1,
                |event| {
                    if let EvaluationEvent::Started(id) = event {
                        attempts += 1;
                        let _ = started.send(id);
                    }
                },
            ));
            (outcome, attempts)
        });
        let id = ids.recv_timeout(Duration::from_secs(60)).unwrap();
        runtime().block_on(async {
            jobs(&master.url, CLIENT_TOKEN)
                .cancel_job(v1::CancelJobRequest { job_id: id })
                .await
                .unwrap();
        });
        evaluation.join().unwrap()
    });
    let (outcome, attempts) = outcome;
    let error = format!("{:#}", outcome.unwrap_err());
    assert!(error.starts_with("CANCELLED: "), "{error}");
    assert_eq!(attempts, 1);
}
