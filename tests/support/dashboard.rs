//! Helpers for the dashboard tests: a master with its dashboard on (`--http-listen`), a local
//! `hevo dashboard` over run directories, an experiment slow enough to watch its curve grow,
//! the page scripts that read what the browser shows, and a raw HTTP request for the
//! statuses and headers a browser does not expose.

use crate::service::{CLIENT_TOKEN, SlowExitRoom, jobs, master_with_roles, submission};
use crate::{Master, Proc, Scratch, binaries, lines_of};
use std::io::{Read, Write};
use std::process::{Command, Stdio};
use std::time::Duration;

/// One exit-room node whose generations take a few tenths of a second each (40 genomes on
/// 20 samples that never end early), so a page sees its curve grow.
pub fn watchable() -> String {
    SlowExitRoom {
        name: "watchable",
        seed: 11,
        population: 40,
        elites: 4,
        generations: 15,
    }
    .toml()
}

/// A master with separate client and worker tokens and its dashboard on port 0.
pub fn master_with_dashboard(scratch: &Scratch) -> Master {
    let master = master_with_roles(scratch, &["--http-listen", "127.0.0.1:0"]);
    assert!(
        master.dashboard.is_some(),
        "the master printed no dashboard address"
    );
    master
}

/// The dashboard's `http://127.0.0.1:PORT`.
pub fn dashboard_url(master: &Master) -> &str {
    master
        .dashboard
        .as_deref()
        .expect("a master with its dashboard on")
}

/// Submits `toml` as the client; returns the job id.
pub async fn submit(master: &Master, toml: &str) -> String {
    jobs(&master.url, CLIENT_TOKEN)
        .submit_job(submission(toml))
        .await
        .expect("the submission is accepted")
        .into_inner()
        .job_id
}

/// A running `hevo dashboard` and its URL.
#[derive(Debug)]
pub struct LocalDashboard {
    /// The process.
    pub proc: Proc,
    /// `http://127.0.0.1:PORT`.
    pub url: String,
}

/// Starts `hevo dashboard DIRS... --listen 127.0.0.1:0` with `extra` flags.
pub fn local_dashboard(dirs: &[&std::path::Path], extra: &[&str]) -> LocalDashboard {
    let mut proc = Proc::spawn(
        "hevo dashboard",
        Command::new(&binaries().hevo)
            .arg("dashboard")
            .args(dirs)
            .args(["--listen", "127.0.0.1:0"])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit()),
    );
    let lines = lines_of(proc.child().stdout.take().expect("piped stdout"));
    let first = lines
        .recv_timeout(Duration::from_secs(20))
        .expect("hevo dashboard printed no URL");
    let url = first
        .strip_prefix("dashboard on ")
        .unwrap_or_else(|| panic!("unexpected first line: {first}"))
        .to_string();
    LocalDashboard { proc, url }
}

/// An HTTP/1.1 answer.
#[derive(Debug)]
pub struct Answer {
    /// The status code.
    pub status: u16,
    /// The header lines, as sent.
    pub headers: String,
    /// The body (the first 64 KiB of a stream that does not end within a second).
    pub body: String,
}

/// A raw `method` request for `path` at `url` (`http://127.0.0.1:PORT`) with extra header
/// lines; the connection is closed after the answer, and a stream is read for a second.
pub fn request(url: &str, method: &str, path: &str, headers: &[&str], body: &str) -> Answer {
    let address = url.strip_prefix("http://").unwrap_or(url);
    let mut stream = std::net::TcpStream::connect(address)
        .unwrap_or_else(|e| panic!("cannot connect to {address}: {e}"));
    stream
        .set_read_timeout(Some(Duration::from_secs(1)))
        .expect("a read timeout can be set");
    let mut text = format!(
        "{method} {path} HTTP/1.1\r\nHost: {address}\r\nConnection: close\r\nContent-Length: {}\r\n",
        body.len()
    );
    for header in headers {
        text.push_str(header);
        text.push_str("\r\n");
    }
    text.push_str("\r\n");
    text.push_str(body);
    stream
        .write_all(text.as_bytes())
        .expect("the request is sent");
    let mut bytes = Vec::new();
    let mut chunk = [0u8; 8192];
    while bytes.len() < 64 * 1024 {
        match stream.read(&mut chunk) {
            Ok(0) | Err(_) => break,
            Ok(n) => bytes.extend_from_slice(&chunk[..n]),
        }
    }
    let response = String::from_utf8_lossy(&bytes).into_owned();
    let (head, body) = response.split_once("\r\n\r\n").unwrap_or((&response, ""));
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no status in the answer to {method} {path}: {response}"));
    Answer {
        status,
        headers: head.to_string(),
        body: body.to_string(),
    }
}

/// A script: the number of points of run `run`'s best-fitness line in the plot of `node`.
pub fn plot_points_script(node: &str, run: u32) -> String {
    format!(
        r#"var f = document.querySelector('figure.fitness[data-node="{node}"]');
if (!f) return -1;
var best = f.querySelectorAll('polyline.run-best');
if (best.length <= {run}) return 0;
return best[{run}].points.numberOfItems;"#
    )
}
