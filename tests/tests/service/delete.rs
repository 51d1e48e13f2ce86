//! What a job keeps, and for how long: a submission carries only the files its experiment
//! reads (a file it never reads is refused, not kept for the job's life), and `hevo delete`
//! forgets a finished job, its record and its files, while a job that has not finished is
//! refused until it is cancelled; with `--retain-finished-hours` the master deletes finished
//! jobs by itself once their retention runs out, and never an unfinished one.

use hevo_proto::v1;
use hevo_tests::service::{CLIENT_TOKEN, SMALL, jobs, master_with_roles, runtime, submission};
use hevo_tests::{Scratch, hevo};
use std::time::Duration;

#[test]
fn a_file_the_experiment_does_not_read_is_refused() {
    let scratch = Scratch::new("delete-files");
    let master = master_with_roles(&scratch, &[]);
    let status = runtime().block_on(async {
        let mut request = submission(SMALL);
        request
            .files
            .insert("padding.bin".into(), "x".repeat(1 << 20));
        jobs(&master.url, CLIENT_TOKEN)
            .submit_job(request)
            .await
            .unwrap_err()
    });
    assert_eq!(status.code(), tonic::Code::InvalidArgument, "{status:?}");
    assert!(
        status.message().starts_with("files:")
            && status
                .message()
                .contains("'padding.bin' is not read by the experiment"),
        "{}",
        status.message()
    );
}

#[test]
fn a_finished_job_can_be_deleted_and_a_running_one_not() {
    let scratch = Scratch::new("delete-job");
    let master = master_with_roles(&scratch, &[]);
    let job = runtime().block_on(async {
        jobs(&master.url, CLIENT_TOKEN)
            .submit_job(submission(SMALL))
            .await
            .unwrap()
            .into_inner()
            .job_id
    });
    let job_dir = scratch.join("state").join("jobs").join(&job);
    assert!(job_dir.is_dir());
    let delete = |expect_ok: bool| {
        let output = hevo(
            &["delete", "--master", &master.url, &job],
            Some(CLIENT_TOKEN),
            Duration::from_secs(30),
        );
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert_eq!(output.status.success(), expect_ok, "{stderr}");
        stderr
    };
    // No worker runs it, so it is still queued or running: refused, and kept.
    let refused = delete(false);
    assert!(
        refused.contains("FAILED_PRECONDITION") || refused.contains("cancel it first"),
        "{refused}"
    );
    assert!(job_dir.is_dir());
    let cancelled = hevo(
        &["cancel", "--master", &master.url, &job],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    assert!(cancelled.status.success(), "{cancelled:?}");
    delete(true);
    assert!(!job_dir.exists(), "its directory is gone");
    runtime().block_on(async {
        let mut client = jobs(&master.url, CLIENT_TOKEN);
        let status = client
            .get_job(v1::GetJobRequest {
                job_id: job.clone(),
                include_files: false,
            })
            .await
            .unwrap_err();
        assert_eq!(status.code(), tonic::Code::NotFound, "{status:?}");
        let listed = client
            .list_jobs(v1::ListJobsRequest {})
            .await
            .unwrap()
            .into_inner();
        assert!(listed.jobs.is_empty());
    });
}

#[test]
fn finished_jobs_are_deleted_once_their_retention_runs_out() {
    let scratch = Scratch::new("delete-retention");
    // 0.0002 hours: 0.72 s.
    let master = master_with_roles(&scratch, &["--retain-finished-hours", "0.0002"]);
    let (cancelled, waiting) = runtime().block_on(async {
        let mut client = jobs(&master.url, CLIENT_TOKEN);
        let submit = |request_id: &str| {
            let mut request = submission(SMALL);
            request.request_id = request_id.into();
            request
        };
        let first = client
            .submit_job(submit("a"))
            .await
            .unwrap()
            .into_inner()
            .job_id;
        let second = client
            .submit_job(submit("b"))
            .await
            .unwrap()
            .into_inner()
            .job_id;
        client
            .cancel_job(v1::CancelJobRequest {
                job_id: first.clone(),
            })
            .await
            .unwrap();
        (first, second)
    });
    let state_dir = scratch.join("state").join("jobs");
    assert!(state_dir.join(&cancelled).is_dir());
    // No worker runs the second job, so it never finishes: it must stay.
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    let listed = loop {
        let listed: Vec<String> = runtime().block_on(async {
            let mut client = jobs(&master.url, CLIENT_TOKEN);
            let response = client.list_jobs(v1::ListJobsRequest {}).await.unwrap();
            response
                .into_inner()
                .jobs
                .into_iter()
                .map(|j| j.job_id)
                .collect()
        });
        if !listed.contains(&cancelled) || std::time::Instant::now() > deadline {
            break listed;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(
        listed,
        std::slice::from_ref(&waiting),
        "the cancelled job is gone within 30 s, the waiting one kept"
    );
    assert!(
        !state_dir.join(&cancelled).exists(),
        "its directory is gone"
    );
    assert!(state_dir.join(&waiting).is_dir());
    let log = std::fs::read_to_string(scratch.join("master.log")).unwrap_or_default();
    assert!(log.contains("past their retention"), "{log}");
}
