//! A damaged job store is a clear error before the master says it listens, never a panic; a
//! lost store beside existing jobs is refused, not silently reset, and `--rebuild-store`
//! brings the jobs back from their directories.

use hevo_proto::v1;
use hevo_tests::service::{
    CLIENT_TOKEN, SMALL, jobs, master_with_roles, role_args, runtime, submission,
};
use hevo_tests::{Scratch, hevo};
use std::path::Path;
use std::time::Duration;

/// `hevo serve` on a state directory; the exit status, stdout and stderr.
fn serve_once(scratch: &Scratch, extra: &[&str]) -> std::process::Output {
    let mut args: Vec<String> = vec![
        "serve".into(),
        "--listen".into(),
        "127.0.0.1:0".into(),
        "--state-dir".into(),
        scratch.join("state").to_string_lossy().into_owned(),
    ];
    args.extend(role_args(scratch));
    args.extend(extra.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    hevo(&args, None, Duration::from_secs(30))
}

/// A state directory with a few jobs, and the master stopped.
fn state_with_jobs(scratch: &Scratch) -> Vec<String> {
    let mut master = master_with_roles(scratch, &[]);
    let ids = runtime().block_on(async {
        let mut client = jobs(&master.url, CLIENT_TOKEN);
        let mut ids = Vec::new();
        for _ in 0..3 {
            ids.push(
                client
                    .submit_job(submission(SMALL))
                    .await
                    .unwrap()
                    .into_inner()
                    .job_id,
            );
        }
        ids
    });
    master.proc.signal("TERM");
    master.proc.wait_timeout(Duration::from_secs(20));
    ids
}

fn store(scratch: &Scratch) -> std::path::PathBuf {
    scratch.join("state").join("hevo.redb")
}

fn assert_refused_before_listening(output: &std::process::Output, store: &Path, wanted: &str) {
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "it served: {stdout}");
    assert_ne!(output.status.code(), Some(101), "a panic: {stderr}");
    assert!(
        !stdout.contains("listening on"),
        "it said it listens: {stdout}"
    );
    assert!(
        stderr.contains(&store.display().to_string()) && stderr.contains(wanted),
        "{stderr}"
    );
}

/// A change made to the store file's bytes.
type Damage = dyn Fn(&mut Vec<u8>);

#[test]
fn a_damaged_store_is_a_clear_error_before_listening() {
    let scratch = Scratch::new("store-damaged");
    state_with_jobs(&scratch);
    let path = store(&scratch);
    let clean = std::fs::read(&path).unwrap();
    let middle = clean.len() / 2;
    let damages: [(&str, Box<Damage>); 2] = [
        (
            "20 flipped bytes",
            Box::new(|bytes: &mut Vec<u8>| {
                for i in 0..20 {
                    let at = (i * 4099 + 512) % bytes.len();
                    bytes[at] ^= 0x5A;
                }
            }),
        ),
        (
            "4 KiB of garbage mid-file",
            Box::new(move |bytes: &mut Vec<u8>| {
                let end = (middle + 4096).min(bytes.len());
                for (i, byte) in bytes[middle..end].iter_mut().enumerate() {
                    *byte = (i * 131 % 251) as u8;
                }
            }),
        ),
    ];
    for (what, damage) in damages {
        let mut bytes = clean.clone();
        damage(&mut bytes);
        std::fs::write(&path, &bytes).unwrap();
        let output = serve_once(&scratch, &["--insecure-no-token"]);
        let stdout = String::from_utf8_lossy(&output.stdout);
        if output.status.success() || stdout.contains("listening on") {
            // Only acceptable when redb repaired the file and every record reads back.
            let stderr = String::from_utf8_lossy(&output.stderr);
            panic!("{what}: served on a damaged store:\n{stdout}\n{stderr}");
        }
        assert_refused_before_listening(&output, &path, "--rebuild-store");
    }
}

#[test]
fn a_lost_store_beside_jobs_is_refused_and_can_be_rebuilt() {
    let scratch = Scratch::new("store-lost");
    let ids = state_with_jobs(&scratch);
    let path = store(&scratch);
    std::fs::write(&path, b"").unwrap();
    assert_refused_before_listening(&serve_once(&scratch, &[]), &path, "missing or empty");
    std::fs::remove_file(&path).unwrap();
    assert_refused_before_listening(&serve_once(&scratch, &[]), &path, "missing or empty");

    // Rebuilt from jobs/*/job.json: the same jobs, and new ids never collide with them.
    let master = master_with_roles(&scratch, &["--rebuild-store"]);
    runtime().block_on(async {
        let mut client = jobs(&master.url, CLIENT_TOKEN);
        let listed = client
            .list_jobs(v1::ListJobsRequest {})
            .await
            .unwrap()
            .into_inner();
        let mut found: Vec<String> = listed.jobs.iter().map(|j| j.job_id.clone()).collect();
        found.sort();
        let mut expected = ids.clone();
        expected.sort();
        assert_eq!(found, expected);
        let new = client
            .submit_job(submission(SMALL))
            .await
            .unwrap()
            .into_inner()
            .job_id;
        assert!(!ids.contains(&new) && new > *ids.iter().max().unwrap());
    });
}
