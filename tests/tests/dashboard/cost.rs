//! The dashboard's cost, as a benchmark (opt-in: `cargo test --release -p hevo-tests --test
//! dashboard -- cost:: --ignored --nocapture`): a master with its dashboard on and one worker
//! using every core run a long job, while, in alternating phases of `HEVO_COST_PHASE`
//! generations (default 16), either no dashboard or `HEVO_DASHBOARDS` of them (default 20)
//! are open on the job's page. An open dashboard does what the page's script does: it loads
//! the page, keeps the event stream open and fetches the node's plot again after every `run`
//! event. The job's generations and control cycles per second are measured per phase from the
//! master's own watch stream; each phase with dashboards is compared with the mean of the
//! phases without on either side, and the median of those ratios is printed. Nothing is
//! asserted about speed (the machine may be shared); what is asserted is that the dashboards
//! really were open and updating.

use hevo_proto::v1;
use hevo_tests::dashboard::{dashboard_url, master_with_dashboard, submit};
use hevo_tests::service::{CLIENT_TOKEN, SlowExitRoom, WORKER_TOKEN, jobs, runtime};
use hevo_tests::{Scratch, start_worker_with_threads};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// Generations before the first phase, while the worker warms up.
const WARM_UP_GENERATIONS: u64 = 4;

fn env_number(name: &str, default: u64) -> u64 {
    match std::env::var(name) {
        Ok(text) => text
            .parse()
            .unwrap_or_else(|_| panic!("{name} must be a whole number, not {text:?}")),
        Err(_) => default,
    }
}

/// One exit-room node with generations of about half a second on two cores.
fn experiment(generations: u64) -> String {
    SlowExitRoom {
        name: "dashboard_cost",
        seed: 5,
        population: 100,
        elites: 5,
        generations,
    }
    .toml()
}

/// What the open dashboards did, summed over all of them.
#[derive(Debug, Default)]
struct DashboardCounts {
    pages: AtomicUsize,
    run_events: AtomicUsize,
    plots: AtomicUsize,
}

fn request_text(address: &str, path: &str) -> String {
    format!(
        "GET {path} HTTP/1.1\r\nHost: {address}\r\nAuthorization: Bearer {CLIENT_TOKEN}\r\nConnection: close\r\n\r\n"
    )
}

/// A whole GET; panics unless it answers 200.
async fn get(address: &str, path: &str) {
    let mut stream = TcpStream::connect(address).await.expect("a connection");
    stream
        .write_all(request_text(address, path).as_bytes())
        .await
        .expect("the request is sent");
    let mut answer = Vec::new();
    stream
        .read_to_end(&mut answer)
        .await
        .expect("the answer is read");
    assert!(
        answer.starts_with(b"HTTP/1.1 200"),
        "GET {path}: {}",
        String::from_utf8_lossy(&answer[..answer.len().min(200)])
    );
}

/// One dashboard on the job's page, as its script behaves, until the task is aborted.
async fn open_dashboard(address: String, job: String, counts: Arc<DashboardCounts>) {
    get(&address, &format!("/jobs/{job}")).await;
    counts.pages.fetch_add(1, Ordering::SeqCst);
    let mut stream = TcpStream::connect(&address).await.expect("a connection");
    stream
        .write_all(request_text(&address, &format!("/jobs/{job}/events")).as_bytes())
        .await
        .expect("the request is sent");
    let marker = "event: run\n";
    let mut pending = String::new();
    let mut chunk = vec![0u8; 16 * 1024];
    loop {
        let n = stream.read(&mut chunk).await.expect("the stream is read");
        if n == 0 {
            return;
        }
        pending.push_str(&String::from_utf8_lossy(&chunk[..n]));
        let n_run_events = pending.matches(marker).count();
        // Keeps a tail that may hold the start of a marker split between reads.
        let keep_from = pending
            .rfind(marker)
            .map_or(0, |at| at + marker.len())
            .max(pending.len().saturating_sub(marker.len()));
        let keep_from = (keep_from..=pending.len())
            .find(|&at| pending.is_char_boundary(at))
            .unwrap_or(pending.len());
        pending.drain(..keep_from);
        if n_run_events > 0 {
            counts.run_events.fetch_add(n_run_events, Ordering::SeqCst);
            // The page fetches the plot once per burst of updates.
            get(&address, &format!("/jobs/{job}/plot.svg?node=exit_room")).await;
            counts.plots.fetch_add(1, Ordering::SeqCst);
        }
    }
}

/// A finished generation as the watch stream reported it.
struct Generation {
    at: Instant,
    done: u64,
    cycles: u64,
}

/// One phase's throughput.
struct Phase {
    dashboards: u64,
    generations_per_second: f64,
    cycles_per_second: f64,
}

fn phase_of(generations: &[Generation], first_done: u64, last_done: u64, dashboards: u64) -> Phase {
    let start = generations
        .iter()
        .find(|g| g.done == first_done)
        .expect("the phase's first generation");
    let end = generations
        .iter()
        .find(|g| g.done == last_done)
        .expect("the phase's last generation");
    let seconds = (end.at - start.at).as_secs_f64();
    let cycles: u64 = generations
        .iter()
        .filter(|g| g.done > first_done && g.done <= last_done)
        .map(|g| g.cycles)
        .sum();
    Phase {
        dashboards,
        generations_per_second: (last_done - first_done) as f64 / seconds,
        cycles_per_second: cycles as f64 / seconds,
    }
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let middle = values.len() / 2;
    if values.len() % 2 == 1 {
        values[middle]
    } else {
        (values[middle - 1] + values[middle]) / 2.0
    }
}

#[test]
#[ignore = "a benchmark: run it with --release -- cost:: --ignored --nocapture"]
fn open_dashboards_cost_a_running_job_little() {
    let n_dashboards = env_number("HEVO_DASHBOARDS", 20);
    let phase_generations = env_number("HEVO_COST_PHASE", 16);
    let n_pairs = env_number("HEVO_COST_PAIRS", 4);
    let threads = std::thread::available_parallelism().map_or(2, usize::from);
    // Phases without, with, without, ... and one more without at the end.
    let n_phases = 2 * n_pairs + 1;
    let total = WARM_UP_GENERATIONS + n_phases * phase_generations + 1;

    let scratch = Scratch::new("dashboard-cost");
    let master = master_with_dashboard(&scratch);
    let address = dashboard_url(&master)
        .strip_prefix("http://")
        .expect("an http address")
        .to_string();
    let counts = Arc::new(DashboardCounts::default());
    let phases = runtime().block_on(async {
        let job = submit(&master, &experiment(total)).await;
        let mut events = jobs(&master.url, CLIENT_TOKEN)
            .watch_job(v1::WatchJobRequest {
                job_id: job.clone(),
            })
            .await
            .expect("the job can be watched")
            .into_inner();
        let _worker = start_worker_with_threads(
            &master.url,
            WORKER_TOKEN,
            "cost-worker",
            threads,
            &[],
            &scratch.join("worker.log"),
        );

        let mut generations = Vec::new();
        let mut open: Vec<tokio::task::JoinHandle<()>> = Vec::new();
        let last_done = WARM_UP_GENERATIONS + n_phases * phase_generations;
        while let Some(event) = events.message().await.expect("the watch stream") {
            let Some(v1::job_event::Event::Generation(generation)) = event.event else {
                continue;
            };
            let done = generation.job_generations_done;
            generations.push(Generation {
                at: Instant::now(),
                done,
                cycles: generation.cycles,
            });
            if done >= WARM_UP_GENERATIONS
                && (done - WARM_UP_GENERATIONS).is_multiple_of(phase_generations)
            {
                let phase = (done - WARM_UP_GENERATIONS) / phase_generations;
                let with_dashboards = phase < n_phases && phase % 2 == 1;
                if with_dashboards && open.is_empty() {
                    for _ in 0..n_dashboards {
                        open.push(tokio::spawn(open_dashboard(
                            address.clone(),
                            job.clone(),
                            counts.clone(),
                        )));
                    }
                } else if !with_dashboards {
                    for dashboard in open.drain(..) {
                        dashboard.abort();
                    }
                }
            }
            if done >= last_done {
                break;
            }
        }
        for dashboard in open.drain(..) {
            dashboard.abort();
        }
        (0..n_phases)
            .map(|phase| {
                let first = WARM_UP_GENERATIONS + phase * phase_generations;
                let dashboards = if phase % 2 == 1 { n_dashboards } else { 0 };
                phase_of(&generations, first, first + phase_generations, dashboards)
            })
            .collect::<Vec<_>>()
    });

    println!("phase  dashboards  generations/s  Mcycles/s");
    for (index, phase) in phases.iter().enumerate() {
        println!(
            "{index:>5}  {:>10}  {:>13.3}  {:>9.3}",
            phase.dashboards,
            phase.generations_per_second,
            phase.cycles_per_second / 1e6
        );
    }
    let ratios = |rate: fn(&Phase) -> f64| {
        (1..phases.len())
            .step_by(2)
            .map(|on| rate(&phases[on]) / ((rate(&phases[on - 1]) + rate(&phases[on + 1])) / 2.0))
            .collect::<Vec<_>>()
    };
    let generation_ratio = median(ratios(|p| p.generations_per_second));
    let cycle_ratio = median(ratios(|p| p.cycles_per_second));
    println!(
        "with {n_dashboards} dashboards open, {threads} worker threads: generations/s x{generation_ratio:.3} \
         (a change of {:+.1} %), cycles/s x{cycle_ratio:.3} ({:+.1} %), medians of {n_pairs} paired phases",
        (generation_ratio - 1.0) * 100.0,
        (cycle_ratio - 1.0) * 100.0
    );
    println!(
        "the dashboards loaded {} pages, saw {} run events and fetched {} plots",
        counts.pages.load(Ordering::SeqCst),
        counts.run_events.load(Ordering::SeqCst),
        counts.plots.load(Ordering::SeqCst)
    );

    let n_opened = (n_pairs * n_dashboards) as usize;
    assert_eq!(
        counts.pages.load(Ordering::SeqCst),
        n_opened,
        "every dashboard loaded the job's page"
    );
    // Every open dashboard saw most of its phase's generations and redrew the plot for them.
    let n_expected_updates = n_opened * (phase_generations as usize / 2);
    assert!(
        counts.plots.load(Ordering::SeqCst) >= n_expected_updates,
        "the dashboards were updating: {counts:?}"
    );
}
