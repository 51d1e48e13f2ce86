//! A master held to 1,024 open files, sent more idle TCP connections than it can hold on its
//! gRPC port and connections trickling a request's headers on its dashboard's port, serves its
//! health check and its dashboard again once the connections that made no request in time are
//! closed; and says so in its log.

use hevo_tests::service::{health_status, role_args};
use hevo_tests::{Scratch, http_get, start_master_with_open_files};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// How long the test gives the master to serve again after the flood, well past its
/// first-request timeout (5 s here).
const RECOVERY: Duration = Duration::from_secs(15);

const SERVING: i32 = tonic_health::pb::health_check_response::ServingStatus::Serving as i32;

/// Opens `n` connections to `address`; those the kernel refuses outright are left out.
fn connect_many(address: &str, n: usize) -> Vec<TcpStream> {
    (0..n)
        .filter_map(|_| TcpStream::connect(address).ok())
        .collect()
}

/// Whether the master closed `stream` (end of file or a reset) within `bound`.
fn closed_within(stream: &mut TcpStream, bound: Duration) -> bool {
    stream.set_read_timeout(Some(bound)).unwrap();
    let mut buf = [0u8; 256];
    loop {
        match stream.read(&mut buf) {
            Ok(0) => return true,
            Ok(_) => continue,
            Err(error)
                if matches!(
                    error.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                return false;
            }
            Err(_) => return true,
        }
    }
}

/// A GET of `path`, or `None` when the connection was refused or closed (a full port).
fn try_get(address: &str, path: &str) -> Option<String> {
    let mut stream = TcpStream::connect(address).ok()?;
    stream.set_read_timeout(Some(Duration::from_secs(5))).ok()?;
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: {address}\r\nConnection: close\r\n\r\n"
    )
    .ok()?;
    let mut response = String::new();
    stream.read_to_string(&mut response).ok()?;
    Some(response)
}

#[test]
fn idle_and_trickling_connections_cannot_starve_a_master_of_descriptors() {
    let scratch = Scratch::new("service-connections");
    let mut args = role_args(&scratch);
    args.extend(
        [
            "--state-dir",
            &scratch.join("state").to_string_lossy(),
            "--http-listen",
            "127.0.0.1:0",
            "--first-request-timeout-seconds",
            "5",
        ]
        .map(str::to_string),
    );
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let log = scratch.join("master.log");
    let master = start_master_with_open_files(1024, &args, &log);
    let grpc = master.url.trim_start_matches("http://").to_string();
    let dashboard = master
        .dashboard
        .clone()
        .expect("a dashboard address")
        .trim_start_matches("http://")
        .to_string();
    let runtime = hevo_tests::service::runtime();
    assert_eq!(health_status(&runtime, &grpc, ""), Ok(SERVING));

    // 1,100 idle connections to the gRPC port, and 200 to the dashboard's port that send the
    // start of a request and then trickle a header byte now and then.
    let mut idle = connect_many(&grpc, 1100);
    let mut trickling = connect_many(&dashboard, 200);
    assert!(idle.len() >= 1000, "only {} connections opened", idle.len());
    for stream in &mut trickling {
        let _ = stream.write_all(b"GET / HTTP/1.1\r\nHost: x\r\nX-Slow: ");
    }
    let flooded = Instant::now();

    // Health and the dashboard answer again within the bound.
    let mut health = Err(String::from("not asked"));
    while flooded.elapsed() < RECOVERY {
        for stream in trickling.iter_mut().take(20) {
            let _ = stream.write_all(b"a");
        }
        health = health_status(&runtime, &grpc, "");
        if health == Ok(SERVING) {
            break;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    let log_text = || std::fs::read_to_string(&log).unwrap_or_default();
    assert_eq!(
        health,
        Ok(SERVING),
        "no health {RECOVERY:?} after the flood; the master's log:\n{}",
        log_text()
    );
    let mut login = None;
    while flooded.elapsed() < RECOVERY {
        login = try_get(&dashboard, "/login");
        if login
            .as_deref()
            .is_some_and(|l| l.starts_with("HTTP/1.1 200"))
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    assert!(
        login
            .as_deref()
            .is_some_and(|l| l.starts_with("HTTP/1.1 200")),
        "the dashboard does not answer {RECOVERY:?} after the flood: {login:?}; the log:\n{}",
        log_text()
    );
    assert!(http_get(&dashboard, "/login").starts_with("HTTP/1.1 200"));

    // The connections that made no request were closed, on both ports.
    let left = RECOVERY.saturating_sub(flooded.elapsed()) + Duration::from_secs(1);
    assert!(
        closed_within(idle.last_mut().unwrap(), left),
        "an idle gRPC connection is still open"
    );
    assert!(
        closed_within(trickling.last_mut().unwrap(), left),
        "a trickling dashboard connection is still open"
    );
    let text = log_text();
    for wanted in [
        "connection limit reached",
        "closed connections that made no request",
    ] {
        assert!(text.contains(wanted), "the log lacks '{wanted}':\n{text}");
    }
    drop(idle);
    drop(trickling);
    assert_eq!(health_status(&runtime, &grpc, ""), Ok(SERVING));
}

#[test]
fn watch_streams_beyond_the_cap_are_refused() {
    use hevo_tests::service::{CLIENT_TOKEN, SMALL, jobs, master_with_roles, submission};
    let scratch = Scratch::new("service-streams");
    let master = master_with_roles(&scratch, &["--max-event-streams", "2"]);
    let runtime = hevo_tests::service::runtime();
    runtime.block_on(async {
        let mut client = jobs(&master.url, CLIENT_TOKEN);
        let job_id = client
            .submit_job(submission(SMALL))
            .await
            .unwrap()
            .into_inner()
            .job_id;
        let watch = || hevo_proto::v1::WatchJobRequest {
            job_id: job_id.clone(),
        };
        // No worker runs the job, so its watches stay open.
        let first = client.watch_job(watch()).await.expect("a first watch");
        let second = client.watch_job(watch()).await.expect("a second watch");
        let status = client.watch_job(watch()).await.unwrap_err();
        assert_eq!(status.code(), tonic::Code::ResourceExhausted, "{status:?}");
        assert!(status.message().contains("2 watch streams"), "{status:?}");
        drop(first);
        // Its place comes free once the master sees the stream gone.
        let mut third = None;
        for _ in 0..100 {
            if let Ok(stream) = client.watch_job(watch()).await {
                third = Some(stream);
                break;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        assert!(third.is_some(), "no place came free");
        drop(second);
    });
}
