//! Clients and workers hold separate credentials: a client token cannot lease or return
//! batches, a worker token cannot submit, list, read or cancel jobs, and a rotated token file
//! takes effect on SIGHUP.

use hevo_proto::v1;
use hevo_tests::Scratch;
use hevo_tests::service::{
    CLIENT_TOKEN, SMALL, WORKER_TOKEN, jobs, lease, master_with_roles, runtime, submission, workers,
};
use std::time::Duration;

#[test]
fn each_token_opens_its_own_service_only() {
    let scratch = Scratch::new("roles");
    let master = master_with_roles(&scratch, &[]);
    runtime().block_on(async {
        // A client token at the worker service: refused, however the call is made.
        let mut as_worker = workers(&master.url, CLIENT_TOKEN);
        let refused = as_worker
            .lease_batch(v1::LeaseBatchRequest {
                worker: "intruder".into(),
                threads: 1,
                wait_ms: 10,
                cached: Vec::new(),
            })
            .await
            .unwrap_err();
        assert_eq!(refused.code(), tonic::Code::PermissionDenied, "{refused:?}");
        assert!(refused.message().contains("worker token"), "{refused:?}");
        let refused = as_worker
            .complete_batch(v1::CompleteBatchRequest {
                lease_id: 1,
                batch_id: 2,
                worker: "intruder".into(),
                ..Default::default()
            })
            .await
            .unwrap_err();
        assert_eq!(refused.code(), tonic::Code::PermissionDenied);

        // A worker token at the job service: refused for every call.
        let mut as_client = jobs(&master.url, WORKER_TOKEN);
        let codes = [
            as_client
                .submit_job(submission(SMALL))
                .await
                .unwrap_err()
                .code(),
            as_client
                .list_jobs(v1::ListJobsRequest {})
                .await
                .unwrap_err()
                .code(),
            as_client
                .get_job(v1::GetJobRequest {
                    job_id: "job-x".into(),
                    include_files: true,
                })
                .await
                .unwrap_err()
                .code(),
            as_client
                .cancel_job(v1::CancelJobRequest {
                    job_id: "job-x".into(),
                })
                .await
                .unwrap_err()
                .code(),
        ];
        assert_eq!(codes, [tonic::Code::PermissionDenied; 4]);

        // Each token where it belongs works.
        let mut client = jobs(&master.url, CLIENT_TOKEN);
        let job = client
            .submit_job(submission(SMALL))
            .await
            .unwrap()
            .into_inner();
        let mut worker = workers(&master.url, WORKER_TOKEN);
        let batch = lease(&mut worker, "honest", Duration::from_secs(5)).await;
        assert!(batch.is_some_and(|b| b.job_id == job.job_id));
    });
}

#[test]
fn the_same_token_for_both_roles_is_refused_at_start() {
    let scratch = Scratch::new("roles-same");
    let file = scratch.join("token");
    std::fs::write(&file, "one-for-all\n").unwrap();
    let output = hevo_tests::hevo(
        &[
            "serve",
            "--listen",
            "127.0.0.1:0",
            "--state-dir",
            scratch.join("state").to_str().unwrap(),
            "--token-file",
            file.to_str().unwrap(),
            "--worker-token-file",
            file.to_str().unwrap(),
        ],
        None,
        Duration::from_secs(30),
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("both a client's and a worker's"),
        "{stderr}"
    );
    // Only a client token: workers need their own.
    let output = hevo_tests::hevo(
        &[
            "serve",
            "--listen",
            "127.0.0.1:0",
            "--state-dir",
            scratch.join("state").to_str().unwrap(),
            "--token-file",
            file.to_str().unwrap(),
        ],
        None,
        Duration::from_secs(30),
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("no worker token"),
        "{stderr}"
    );
}

#[test]
fn a_rotated_token_file_takes_effect_on_sighup() {
    let scratch = Scratch::new("roles-rotate");
    let master = master_with_roles(&scratch, &[]);
    let list = |token: &'static str| {
        runtime().block_on(async {
            jobs(&master.url, token)
                .list_jobs(v1::ListJobsRequest {})
                .await
                .map(|_| ())
                .map_err(|status| status.code())
        })
    };
    assert_eq!(list(CLIENT_TOKEN), Ok(()));
    assert_eq!(list("rotated-in"), Err(tonic::Code::Unauthenticated));
    // Both during the rotation, then the new one alone.
    let clients = scratch.join("client-tokens");
    for (contents, old, new) in [
        (format!("rotated-in\n{CLIENT_TOKEN}\n"), Ok(()), Ok(())),
        (
            "# rotation done\nrotated-in\n".to_string(),
            Err(tonic::Code::Unauthenticated),
            Ok(()),
        ),
    ] {
        std::fs::write(&clients, contents).unwrap();
        master.proc.signal("HUP");
        let deadline = std::time::Instant::now() + Duration::from_secs(10);
        while (list(CLIENT_TOKEN), list("rotated-in")) != (old, new) {
            assert!(
                std::time::Instant::now() < deadline,
                "the rotation did not take effect"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
    let log = std::fs::read_to_string(scratch.join("master.log")).unwrap();
    assert!(log.contains("tokens reloaded"), "{log}");
}
