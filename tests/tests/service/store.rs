//! A damaged job store is a clear error before the master says it listens, never a panic (or,
//! when redb repairs it, served with every job); a lost store beside existing jobs is refused,
//! not silently reset, and `--rebuild-store` brings the jobs back from their directories.

use hevo_proto::v1;
use hevo_tests::service::{
    CLIENT_TOKEN, SMALL, jobs, master_with_roles, role_args, runtime, submission,
};
use hevo_tests::{Proc, Scratch, binaries, hevo, lines_of};
use std::path::Path;
use std::process::{Command, Stdio};
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
        !stderr.contains("panicked at") && !stderr.contains("stack backtrace"),
        "a panic of the store library reached stderr before the clear error: {stderr}"
    );
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

/// What `hevo serve` did on a damaged store.
enum Served {
    /// It exited before saying it listens.
    Refused(std::process::Output),
    /// redb repaired the store and the master served: these are the jobs it listed.
    Listed(Vec<String>),
}

/// Starts `hevo serve` on the scratch state directory; if it listens, lists its jobs and stops
/// it, otherwise returns how it exited.
fn serve_damaged(scratch: &Scratch) -> Served {
    let log = scratch.join("serve-damaged.log");
    let mut proc = Proc::spawn(
        "hevo serve",
        Command::new(&binaries().hevo)
            .args(["serve", "--listen", "127.0.0.1:0", "--state-dir"])
            .arg(scratch.join("state"))
            .args(role_args(scratch))
            .env_remove("HEVO_TOKEN")
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&log).unwrap()),
    );
    let lines = lines_of(proc.child().stdout.take().expect("piped stdout"));
    // The channel closes when the process exits without a line.
    match lines.recv_timeout(Duration::from_secs(60)) {
        Ok(line) => {
            let address = line
                .strip_prefix("listening on ")
                .unwrap_or_else(|| panic!("unexpected first line: {line}"));
            let listed = runtime().block_on(async {
                let mut client = jobs(&format!("http://{address}"), CLIENT_TOKEN);
                let listed = client.list_jobs(v1::ListJobsRequest {}).await.unwrap();
                listed
                    .into_inner()
                    .jobs
                    .into_iter()
                    .map(|j| j.job_id)
                    .collect()
            });
            proc.signal("TERM");
            proc.wait_timeout(Duration::from_secs(20));
            Served::Listed(listed)
        }
        Err(_) => {
            let status = proc
                .wait_timeout(Duration::from_secs(30))
                .expect("hevo serve neither listened nor exited");
            Served::Refused(std::process::Output {
                status,
                stdout: Vec::new(),
                stderr: std::fs::read(&log).unwrap(),
            })
        }
    }
}

#[test]
fn a_damaged_store_is_a_clear_error_before_listening() {
    let scratch = Scratch::new("store-damaged");
    let mut ids = state_with_jobs(&scratch);
    ids.sort();
    let path = store(&scratch);
    let clean = std::fs::read(&path).unwrap();
    let middle = clean.len() / 2;
    // Where damage lands depends on the records' bytes (ids, times), which differ per run:
    // damage in free pages goes unnoticed, and damage redb repairs may be served, but only
    // with every job. The header is always live, so its damage is always refused.
    let damages: [(&str, bool, Box<Damage>); 3] = [
        (
            "a garbled header",
            true,
            Box::new(|bytes: &mut Vec<u8>| {
                for byte in &mut bytes[..64] {
                    *byte ^= 0x5A;
                }
            }),
        ),
        (
            "20 flipped bytes",
            false,
            Box::new(|bytes: &mut Vec<u8>| {
                for i in 0..20 {
                    let at = (i * 4099 + 512) % bytes.len();
                    bytes[at] ^= 0x5A;
                }
            }),
        ),
        (
            "4 KiB of garbage mid-file",
            false,
            Box::new(move |bytes: &mut Vec<u8>| {
                let end = (middle + 4096).min(bytes.len());
                for (i, byte) in bytes[middle..end].iter_mut().enumerate() {
                    *byte = (i * 131 % 251) as u8;
                }
            }),
        ),
    ];
    for (what, must_refuse, damage) in damages {
        let mut bytes = clean.clone();
        damage(&mut bytes);
        std::fs::write(&path, &bytes).unwrap();
        match serve_damaged(&scratch) {
            Served::Refused(output) => {
                assert_refused_before_listening(&output, &path, "--rebuild-store")
            }
            Served::Listed(mut listed) => {
                assert!(!must_refuse, "{what}: served on a damaged store");
                listed.sort();
                assert_eq!(listed, ids, "{what}: served without every job");
            }
        }
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
