//! A lease is checked: results for a batch never leased, a lease of another worker's, values
//! no evaluation could give, and a lease held past its lifetime by a worker that only ever
//! heartbeats change nothing of the job's results. And a worker whose connection closes
//! loses its leases at once: its batch goes back to the queue without waiting for the lease
//! to run out. A worker forging plausible results is caught by a spot check, and the
//! dashboard names it.

use hevo_proto::v1;
use hevo_tests::dashboard::{dashboard_url, request};
use hevo_tests::service::{
    CLIENT_TOKEN, SLOW_EXIT_ROOM, SMALL, WORKER_TOKEN, jobs, lease, master_with_roles, metric,
    metrics_text, runtime, submission, wait_until_final, workers,
};
use hevo_tests::{Master, Scratch, fetch, run_locally, start_worker};
use std::path::Path;
use std::time::{Duration, Instant};

/// Results shaped like the batch's, every value what `forge` makes of a plausible one.
fn forged(batch: &v1::Batch, forge: impl Fn(&mut v1::SampleResult)) -> Vec<v1::GenomeResult> {
    batch
        .genomes
        .iter()
        .map(|_| v1::GenomeResult {
            samples: batch
                .samples
                .iter()
                .map(|_| {
                    let mut result = v1::SampleResult {
                        fitness: 0.5,
                        cycles: 10,
                        // Where the robot ended: the shipped tasks' behaviour descriptor.
                        descriptor: vec![0.1, 0.2],
                        ending: v1::SampleEnding::Timeout.into(),
                        ..v1::SampleResult::default()
                    };
                    forge(&mut result);
                    result
                })
                .collect(),
        })
        .collect()
}

/// `hevo run` of the small experiment: what the job must produce, forgeries or not.
fn local_reference(scratch: &Scratch) -> std::path::PathBuf {
    let file = scratch.join("small.toml");
    std::fs::write(&file, SMALL).unwrap();
    let out = scratch.join("local");
    run_locally(&file, &out, &["--threads", "1"]);
    out
}

#[test]
fn forged_and_foreign_results_change_nothing() {
    let scratch = Scratch::new("leases-forged");
    let expected = local_reference(&scratch);
    let master = master_with_roles(&scratch, &[]);
    let job = runtime().block_on(async {
        let job = jobs(&master.url, CLIENT_TOKEN)
            .submit_job(submission(SMALL))
            .await
            .unwrap()
            .into_inner()
            .job_id;
        let mut thief = workers(&master.url, WORKER_TOKEN);
        let batch = lease(&mut thief, "thief", Duration::from_secs(10))
            .await
            .expect("a batch");
        let complete = |lease_id, batch_id, genomes| v1::CompleteBatchRequest {
            epoch: batch.epoch,
            lease_id,
            batch_id,
            worker: "thief".into(),
            genomes,
            elapsed_ms: 1,
        };
        // Values no evaluation of the task can give: refused as malformed.
        for forge in [
            |r: &mut v1::SampleResult| r.fitness = 1e30,
            |r: &mut v1::SampleResult| r.variant = 4_000_000_000,
            |r: &mut v1::SampleResult| r.stage = 9,
            |r: &mut v1::SampleResult| r.descriptor.truncate(1),
            |r: &mut v1::SampleResult| r.descriptor[0] = f32::NAN,
            // A worker older than the field, and an ending that contradicts `solved`.
            |r: &mut v1::SampleResult| r.ending = 0,
            |r: &mut v1::SampleResult| r.ending = v1::SampleEnding::Solved.into(),
        ] {
            let held = lease(&mut thief, "thief", Duration::from_secs(10))
                .await
                .unwrap_or_else(|| batch.clone());
            let refused = thief
                .complete_batch(complete(held.lease_id, held.batch_id, forged(&held, forge)))
                .await
                .unwrap_err();
            assert_eq!(refused.code(), tonic::Code::InvalidArgument, "{refused:?}");
        }
        // A guessed lease for a guessed batch, one never leased, another worker's lease.
        let mut other = workers(&master.url, WORKER_TOKEN);
        let theirs = lease(&mut other, "other", Duration::from_secs(10)).await;
        let mut guesses = vec![
            (batch.lease_id + 7919, batch.batch_id, "thief"),
            (batch.lease_id, batch.batch_id + 10_000, "thief"),
        ];
        if let Some(theirs) = &theirs {
            guesses.push((theirs.lease_id, theirs.batch_id, "thief"));
        }
        for (lease_id, batch_id, worker) in guesses {
            let mut request = complete(lease_id, batch_id, forged(&batch, |_| {}));
            request.worker = worker.into();
            let response = thief.complete_batch(request).await.unwrap().into_inner();
            assert!(
                !response.accepted,
                "lease {lease_id} batch {batch_id} accepted"
            );
        }
        job
    });
    // An honest worker finishes the job; the results are exactly the local ones.
    an_honest_worker_finishes(&master, &scratch, &job, &expected);
    let metrics = metrics_text(&master);
    assert!(
        metric(&metrics, "hevo_results_refused_total") >= 3.0,
        "{metrics}"
    );
    assert!(
        metric(&metrics, "hevo_lease_calls_refused_total") >= 2.0,
        "{metrics}"
    );
}

#[test]
fn a_worker_that_only_heartbeats_loses_its_batch_at_the_lease_lifetime() {
    let scratch = Scratch::new("leases-lifetime");
    let master = master_with_roles(
        &scratch,
        &["--lease-seconds", "1", "--max-lease-seconds", "3"],
    );
    runtime().block_on(async {
        let job = jobs(&master.url, CLIENT_TOKEN)
            .submit_job(submission(SMALL))
            .await
            .unwrap()
            .into_inner()
            .job_id;
        let mut squatter = workers(&master.url, WORKER_TOKEN);
        let mut held = Vec::new();
        while let Some(batch) = lease(&mut squatter, "squatter", Duration::from_millis(500)).await {
            held.push(batch);
        }
        assert!(!held.is_empty());
        // Heartbeats every 300 ms: accepted until the lifetime, refused from then on.
        let started = Instant::now();
        let mut refused_after = None;
        while refused_after.is_none() && started.elapsed() < Duration::from_secs(10) {
            tokio::time::sleep(Duration::from_millis(300)).await;
            let valid = squatter
                .extend_lease(v1::ExtendLeaseRequest {
                    epoch: held[0].epoch,
                    lease_id: held[0].lease_id,
                    worker: "squatter".into(),
                })
                .await
                .unwrap()
                .into_inner()
                .valid;
            if !valid {
                refused_after = Some(started.elapsed());
            }
        }
        let refused_after = refused_after.expect("the lease was extended for ever");
        assert!(
            refused_after >= Duration::from_secs(2),
            "refused after {refused_after:?}, before its lifetime"
        );
        // Another worker gets the batch and the job finishes.
        let _worker = start_worker(
            &master.url,
            WORKER_TOKEN,
            "honest",
            &[],
            &scratch.join("honest.log"),
        );
        let info = wait_until_final(
            &mut jobs(&master.url, CLIENT_TOKEN),
            &job,
            Duration::from_secs(120),
        )
        .await;
        assert_eq!(info.state, v1::JobState::Succeeded as i32, "{}", info.error);
    });
    assert!(metric(&metrics_text(&master), "hevo_lease_revocations_total") >= 1.0);
}

#[test]
fn a_killed_workers_batch_is_queued_again_at_once() {
    let scratch = Scratch::new("leases-killed");
    // A 60 s lease: what must not be waited for.
    let master = master_with_roles(&scratch, &["--lease-seconds", "60"]);
    runtime().block_on(async {
        let job = jobs(&master.url, CLIENT_TOKEN)
            .submit_job(submission(SLOW_EXIT_ROOM))
            .await
            .unwrap()
            .into_inner()
            .job_id;
        // A worker process that leases and then never answers: SIGSTOP keeps it from
        // heartbeating, SIGKILL then closes its connection.
        let mut doomed = start_worker(
            &master.url,
            WORKER_TOKEN,
            "doomed",
            &[],
            &scratch.join("doomed.log"),
        );
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let metrics = metrics_text(&master);
            if metric(&metrics, "hevo_batches_leased") >= 1.0 {
                doomed.signal("STOP");
                // Still leased once it stopped: the kill lands on a held lease.
                if metric(&metrics_text(&master), "hevo_batches_leased") >= 1.0 {
                    break;
                }
                doomed.signal("CONT");
            }
            assert!(Instant::now() < deadline, "the worker never held a lease");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        let killed_at = Instant::now();
        doomed.kill();
        // The revocation comes with the closed connection, long before the 60 s lease.
        loop {
            if metric(&metrics_text(&master), "hevo_lease_revocations_total") >= 1.0 {
                break;
            }
            assert!(
                killed_at.elapsed() < Duration::from_secs(5),
                "no revocation 5 s after the kill"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let _worker = start_worker(
            &master.url,
            WORKER_TOKEN,
            "survivor",
            &[],
            &scratch.join("survivor.log"),
        );
        let info = wait_until_final(
            &mut jobs(&master.url, CLIENT_TOKEN),
            &job,
            Duration::from_secs(50),
        )
        .await;
        assert_eq!(info.state, v1::JobState::Succeeded as i32, "{}", info.error);
        assert!(
            killed_at.elapsed() < Duration::from_secs(55),
            "the job waited for the lease to run out"
        );
    });
}

/// A worker with a valid token that returns plausible but false results (in range, shaped
/// right) is caught by a spot check under `--verify-share 0.1` (every worker's first result is
/// checked), refused from then on, and the job's results are exactly a local run's.
#[test]
fn a_worker_forging_plausible_results_is_caught_by_a_spot_check() {
    let scratch = Scratch::new("leases-spot-check");
    let expected = local_reference(&scratch);
    let master = master_with_roles(
        &scratch,
        &["--verify-share", "0.1", "--http-listen", "127.0.0.1:0"],
    );
    let job = runtime().block_on(async {
        let job = jobs(&master.url, CLIENT_TOKEN)
            .submit_job(submission(SMALL))
            .await
            .unwrap()
            .into_inner()
            .job_id;
        let mut forger = workers(&master.url, WORKER_TOKEN);
        let mut forged_batches = 0;
        // It forges every batch it gets until the master gives it none.
        while let Some(batch) = lease(&mut forger, "forger", Duration::from_secs(3)).await {
            let response = forger
                .complete_batch(v1::CompleteBatchRequest {
                    worker: "forger".into(),
                    lease_id: batch.lease_id,
                    batch_id: batch.batch_id,
                    epoch: batch.epoch,
                    genomes: forged(&batch, |_| {}),
                    elapsed_ms: 1,
                })
                .await;
            forged_batches += 1;
            assert!(
                forged_batches < 50,
                "the forger is never refused: {response:?}"
            );
        }
        assert!(forged_batches >= 1, "the forger got no batch");
        job
    });
    an_honest_worker_finishes(&master, &scratch, &job, &expected);
    let metrics = metrics_text(&master);
    assert_eq!(
        metric(&metrics, "hevo_lying_workers_total"),
        1.0,
        "{metrics}"
    );
    assert!(
        metric(&metrics, "hevo_spot_checks_total") >= 1.0,
        "{metrics}"
    );
    // The dashboard's job list names the worker it caught.
    let page = request(
        dashboard_url(&master),
        "GET",
        "/",
        &[&format!("Authorization: Bearer {CLIENT_TOKEN}")],
        "",
    );
    assert_eq!(page.status, 200, "{page:?}");
    assert!(page.body.contains("<h2>Spot checks</h2>"), "{}", page.body);
    // A worker is known by its name and its connection's address.
    assert!(
        page.body
            .contains(r#"<td class="refused-workers"><code>forger@127.0.0.1:"#),
        "{}",
        page.body
    );
}

/// An honest worker joins and finishes `job`, whose fetched results must be exactly
/// `expected`, the local run's.
fn an_honest_worker_finishes(master: &Master, scratch: &Scratch, job: &str, expected: &Path) {
    let _worker = start_worker(
        &master.url,
        WORKER_TOKEN,
        "honest",
        &[],
        &scratch.join("honest.log"),
    );
    runtime().block_on(async {
        let info = wait_until_final(
            &mut jobs(&master.url, CLIENT_TOKEN),
            job,
            Duration::from_secs(120),
        )
        .await;
        assert_eq!(info.state, v1::JobState::Succeeded as i32, "{}", info.error);
    });
    let fetched = scratch.join("fetched");
    fetch(&master.url, CLIENT_TOKEN, job, &fetched, &[]);
    hevo_tests::assert_same_results(expected, &fetched, None);
}
