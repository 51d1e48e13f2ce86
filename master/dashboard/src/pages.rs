//! The pages' HTML: the login form, the job list (with the master's workers) and a job's
//! page (its nodes, each with its runs' progress, the fitness plot, for MAP-Elites the QD-score
//! curves and an archive's heatmap, the post-evaluation table once finished and the best
//! controller's replays). The HTML is complete without scripts;
//! `data-` attributes tell the script what to update.

use crate::html::{escape, percent, utc};
use crate::replay::{ReplayFigure, figure_html};
use crate::{JobOverview, NodeView, SpotChecksView, WorkersView};
use hevo_viz::RunLog;
use std::fmt::Write;

/// The login form; `message` says why it is shown again.
pub fn login_body(next: &str, message: Option<&str>) -> String {
    let message = message
        .map(|m| format!("<p class=\"error-message\">{}</p>\n", escape(m)))
        .unwrap_or_default();
    format!(
        r#"<h1>Sign in</h1>
{message}<p>The dashboard takes the token a client gives <code>hevo submit</code> (<code>--token</code>, <code>--token-file</code> or <code>HEVO_TOKEN</code>).</p>
<form class="login" method="post" action="/login">
<input type="hidden" name="next" value="{next}">
<label>Token <input type="password" name="token" autocomplete="current-password" autofocus required></label>
<button type="submit">Sign in</button>
</form>"#,
        next = escape(next),
    )
}

fn progress_html(job: &JobOverview) -> String {
    match job.generations_total {
        Some(total) if total > 0 => format!(
            r#"<progress max="{total}" value="{done}"></progress> <span class="progress-text">{done} of {total} generations</span>"#,
            done = job.generations_done.min(total),
        ),
        _ => format!(
            r#"<span class="progress-text">{} generations</span>"#,
            job.generations_done
        ),
    }
}

fn time_or_dash(time: Option<i64>) -> String {
    time.map_or_else(|| "–".to_string(), utc)
}

/// The job list.
pub fn jobs_body(title: &str, jobs: &[JobOverview], workers: Option<&WorkersView>) -> String {
    let mut out = format!("<h1>{}</h1>\n", escape(title));
    if jobs.is_empty() {
        out.push_str("<p>No jobs yet.</p>\n");
    } else {
        out.push_str(
            "<table class=\"jobs\">\n<thead><tr><th>job</th><th>name</th><th>state</th><th>progress</th><th>submitted</th><th>finished</th><th>nodes</th></tr></thead>\n<tbody>\n",
        );
        for job in jobs {
            let _ = writeln!(
                out,
                r#"<tr data-job="{id}"><td><a href="/jobs/{id}">{id}</a></td><td>{name}</td><td class="state state-{state_class}">{state}</td><td>{progress}</td><td>{created}</td><td>{finished}</td><td>{nodes}</td></tr>"#,
                id = escape(&job.id),
                name = escape(&job.name),
                state_class = escape(&job.state.replace(' ', "-")),
                state = escape(&job.state),
                progress = progress_html(job),
                created = time_or_dash(job.created_unix_ms),
                finished = time_or_dash(job.finished_unix_ms),
                nodes = escape(&job.nodes.join(", ")),
            );
        }
        out.push_str("</tbody>\n</table>\n");
    }
    if let Some(w) = workers {
        let _ = write!(
            out,
            r#"<h2>Workers</h2>
<table class="workers"><tbody>
<tr><th>connected workers</th><td>{}</td></tr>
<tr><th>their threads</th><td>{}</td></tr>
<tr><th>batches on lease</th><td>{}</td></tr>
<tr><th>batches waiting</th><td>{}</td></tr>
<tr><th>batches completed</th><td>{}</td></tr>
<tr><th>evaluations</th><td>{}</td></tr>
</tbody></table>
"#,
            w.active_workers,
            w.active_threads,
            w.leased_batches,
            w.queued_batches,
            w.batches_completed,
            w.evaluations
        );
        if let Some(checks) = &w.spot_checks {
            out.push_str(&spot_checks_html(checks));
        }
    }
    out
}

/// How many names of refused workers the jobs page lists before it only counts the rest.
const MAX_REFUSED_LISTED: usize = 20;

/// The master's spot checks: what share it re-evaluates, how many results it compared, and
/// the workers it caught (names escaped, at most [`MAX_REFUSED_LISTED`] of them).
fn spot_checks_html(checks: &SpotChecksView) -> String {
    let refused = if checks.refused_workers.is_empty() {
        "none".to_string()
    } else {
        let mut names: Vec<String> = checks
            .refused_workers
            .iter()
            .take(MAX_REFUSED_LISTED)
            .map(|name| format!("<code>{}</code>", escape(name)))
            .collect();
        let more = checks
            .refused_workers
            .len()
            .saturating_sub(MAX_REFUSED_LISTED);
        if more > 0 {
            names.push(format!("and {more} more"));
        }
        names.join(", ")
    };
    format!(
        r#"<h2>Spot checks</h2>
<table class="spot-checks"><tbody>
<tr><th>batches re-evaluated by the master</th><td>{share} % (and every worker's first)</td></tr>
<tr><th>results checked</th><td>{checked}</td></tr>
<tr><th>workers caught and refused</th><td class="refused-count">{n_refused}</td></tr>
<tr><th>refused workers</th><td class="refused-workers">{refused}</td></tr>
</tbody></table>
"#,
        share = checks.share * 100.0,
        checked = checks.checked,
        n_refused = checks.refused_workers.len(),
    )
}

/// The run logs of a node, labelled for the plot's legend.
pub fn run_logs(node: &NodeView) -> Vec<RunLog> {
    node.runs
        .iter()
        .filter(|r| !r.rows.is_empty())
        .map(|r| RunLog {
            label: format!("run {}", r.run),
            rows: r.rows.clone(),
        })
        .collect()
}

/// The fitness plot of a node (hevo-viz's); while it runs, its generation axis reaches the
/// planned end of a run and its title says how many of the planned generations are done.
pub fn plot_svg(node: &NodeView) -> String {
    let planned_generations = node
        .planned
        .filter(|_| !node.finished())
        .map(|(_, generations)| generations);
    hevo_viz::fitness_plot_svg(&plot_title(node), &run_logs(node), planned_generations)
}

/// A MAP-Elites node's QD-score and coverage curves and the heatmap of one run's archive: the
/// best run's once the node is finished, else the latest run's; nothing for other algorithms.
fn archive_html(node: &NodeView) -> String {
    let qd: Vec<(String, Vec<hevo_rundir::archive::QdRow>)> = node
        .runs
        .iter()
        .filter(|r| !r.qd.is_empty())
        .map(|r| (format!("run {}", r.run), r.qd.clone()))
        .collect();
    let best_run = node.summary.as_ref().map(|s| s.best_run);
    let shown = node
        .runs
        .iter()
        .filter(|r| r.archive.is_some())
        .find(|r| Some(r.run) == best_run)
        .or_else(|| node.runs.iter().rev().find(|r| r.archive.is_some()));
    let mut out = String::new();
    if !qd.is_empty() {
        let svg = hevo_viz::qd_plot_svg(&format!("{}: QD-score and coverage", node.name), &qd);
        let _ = writeln!(out, "<figure class=\"qd\">\n{svg}\n</figure>");
    }
    if let Some(run) = shown
        && let Some(archive) = &run.archive
    {
        let title = format!(
            "{} run {}: archive after {} generations ({} of {} cells)",
            node.name,
            run.run,
            archive.generation,
            archive.elites.len(),
            archive.n_cells()
        );
        match hevo_viz::archive_heatmap_svg(&title, archive) {
            Ok(svg) => {
                let _ = writeln!(
                    out,
                    "<figure class=\"archive\" data-run=\"{}\">\n{svg}\n</figure>",
                    run.run
                );
            }
            Err(reason) => {
                let _ = writeln!(
                    out,
                    "<p class=\"error-message\">No archive picture: {}</p>",
                    escape(&reason)
                );
            }
        }
    }
    out
}

/// `follow_wall: fitness per generation (137 of 500 generations)`.
fn plot_title(node: &NodeView) -> String {
    let planned = match node.planned {
        Some((runs, generations)) if !node.finished() => format!(
            " ({} of {} generations)",
            node.generations_done(),
            u64::from(runs) * u64::from(generations)
        ),
        _ => String::new(),
    };
    format!("{}: fitness per generation{planned}", node.name)
}

/// One run's line of progress: `run 0: generation 12 of 50, best 1.234, mean 0.567`.
pub fn run_progress_text(node: &NodeView, run: &crate::RunView) -> String {
    let of = node
        .planned
        .map(|(_, generations)| format!(" of {generations}"))
        .unwrap_or_default();
    match run.rows.last() {
        Some(last) => format!(
            "run {}: {} generation{}{of}, best {:.3}, mean {:.3}{}",
            run.run,
            run.rows.len(),
            if run.rows.len() == 1 { "" } else { "s" },
            last.best,
            last.mean,
            if run.summary.is_some() {
                ", finished"
            } else {
                ""
            }
        ),
        None => format!("run {}: no generation yet", run.run),
    }
}

fn post_evaluation_table(node: &NodeView) -> String {
    let Some(summary) = &node.summary else {
        return String::new();
    };
    let variants: Vec<u32> = summary
        .runs
        .iter()
        .flat_map(|r| r.post_evaluation.per_variant.iter().map(|v| v.variant))
        .collect::<std::collections::BTreeSet<u32>>()
        .into_iter()
        .collect();
    let stages = summary
        .runs
        .iter()
        .any(|r| r.post_evaluation.stages.is_some());
    let mut out = String::from(
        "<table class=\"post-evaluation\">\n<caption>Post-evaluation of each run's best controller</caption>\n<thead><tr><th>run</th><th>generations</th><th>final best fitness</th><th>samples</th><th>solved</th><th>collided</th><th>mean cycles</th>",
    );
    for variant in &variants {
        let _ = write!(out, "<th>solved, light configuration {variant}</th>");
    }
    if stages {
        out.push_str("<th>exited room</th><th>reached teammate</th><th>returned</th>");
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    for run in &summary.runs {
        let report = &run.post_evaluation;
        let best = run.run == summary.best_run;
        let _ = write!(
            out,
            "<tr{}><td>{}{}</td><td>{}</td><td>{:.3}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td>",
            if best { " class=\"best-run\"" } else { "" },
            run.run,
            if best { " (best)" } else { "" },
            run.generations,
            run.final_best_fitness,
            report.samples,
            percent(Some(report.solve_rate)),
            percent(Some(report.collision_rate)),
            report.mean_cycles,
        );
        for variant in &variants {
            let share = report
                .per_variant
                .iter()
                .find(|v| v.variant == *variant)
                .map(|v| v.solve_rate);
            let _ = write!(out, "<td>{}</td>", percent(share));
        }
        if stages {
            match &report.stages {
                Some(s) => {
                    let _ = write!(
                        out,
                        "<td>{}</td><td>{}</td><td>{}</td>",
                        percent(Some(s.exited_room)),
                        percent(Some(s.reached_teammate)),
                        percent(Some(s.returned))
                    );
                }
                None => out.push_str("<td>–</td><td>–</td><td>–</td>"),
            }
        }
        out.push_str("</tr>\n");
    }
    let _ = write!(
        out,
        "</tbody>\n<tfoot><tr><td colspan=\"{}\">solved on average {}, best run {} solved {}</td></tr></tfoot>\n</table>\n",
        7 + variants.len() + if stages { 3 } else { 0 },
        percent(Some(summary.mean_solve_rate)),
        summary.best_run,
        percent(Some(summary.best_solve_rate)),
    );
    out
}

/// A node's state in words. An unfinished node is `running` only while its job runs: a
/// stopped job's, or a run directory's (which cannot tell whether a process still writes it),
/// says how far it got.
pub fn node_state(node: &NodeView, job_running: bool) -> String {
    if node.finished() {
        "finished".to_string()
    } else if node.runs.is_empty() {
        "not started".to_string()
    } else if job_running {
        "running".to_string()
    } else {
        let finished_runs = node.runs.iter().filter(|r| r.summary.is_some()).count();
        format!("unfinished ({finished_runs} run(s) finished)")
    }
}

/// A node's section of the job page; `replays` are its best controller's, or the reason
/// there are none; `job_running` whether its job is running (see [`node_state`]).
pub fn node_section(
    job_id: &str,
    node: &NodeView,
    job_running: bool,
    replays: Option<Result<&[ReplayFigure], &str>>,
) -> String {
    let mut out = format!(
        "<section class=\"node\" id=\"node-{name}\" data-node=\"{name}\" data-finished=\"{finished}\">\n<h2>{name}</h2>\n",
        name = escape(&node.name),
        finished = u8::from(node.finished()),
    );
    let planned = node
        .planned
        .map(|(runs, generations)| format!(", {runs} runs of {generations} generations planned"))
        .unwrap_or_default();
    let _ = writeln!(
        out,
        "<p class=\"node-state\">{}{planned}</p>",
        node_state(node, job_running)
    );
    out.push_str("<ul class=\"runs\">\n");
    for run in &node.runs {
        let _ = writeln!(
            out,
            "<li data-run=\"{}\">{}</li>",
            run.run,
            escape(&run_progress_text(node, run))
        );
    }
    out.push_str("</ul>\n");
    let _ = writeln!(
        out,
        "<figure class=\"fitness\" data-node=\"{name}\" data-plot=\"/jobs/{job}/plot.svg?node={name}\">\n{svg}\n</figure>",
        name = escape(&node.name),
        job = escape(job_id),
        svg = plot_svg(node),
    );
    out.push_str(&archive_html(node));
    // Scrolls inside its card rather than overflowing it (the rescue's stage columns).
    out.push_str("<div class=\"table-scroll\">\n");
    out.push_str(&post_evaluation_table(node));
    out.push_str("</div>\n");
    match replays {
        Some(Ok(figures)) => {
            out.push_str("<h3>The best controller's replays</h3>\n<div class=\"replays\">\n");
            for figure in figures {
                out.push_str(&figure_html(&node.name, figure));
                out.push('\n');
            }
            out.push_str("</div>\n");
        }
        Some(Err(reason)) => {
            let _ = writeln!(
                out,
                "<p class=\"error-message\">No replay: {}</p>",
                escape(reason)
            );
        }
        None => {}
    }
    out.push_str("</section>\n");
    out
}

/// The top of a job's page: its state, times and the cancel button, whose form carries the
/// session's CSRF token `csrf` when a browser is signed in.
pub fn job_header(job: &JobOverview, seed: u64, csrf: Option<&str>) -> String {
    let mut out = format!(
        "<h1>{name}</h1>\n<div class=\"job\" data-job=\"{id}\" data-finished=\"{finished}\" data-events=\"/jobs/{id}/events\">\n<table class=\"job-facts\"><tbody>\n<tr><th>job</th><td>{id}</td></tr>\n<tr><th>state</th><td class=\"job-state\">{state}</td></tr>\n<tr><th>progress</th><td class=\"job-progress\">{progress}</td></tr>\n<tr><th>submitted</th><td>{created}</td></tr>\n<tr><th>finished</th><td class=\"job-finished\">{finished_at}</td></tr>\n<tr><th>files</th><td><code>{location}</code></td></tr>\n<tr><th>replay seed</th><td>{seed} (<a href=\"?seed={next_seed}\">another sample</a>)</td></tr>\n",
        name = escape(&job.name),
        id = escape(&job.id),
        finished = u8::from(job.finished),
        state = escape(&job.state),
        progress = progress_html(job),
        created = time_or_dash(job.created_unix_ms),
        finished_at = time_or_dash(job.finished_unix_ms),
        location = escape(&job.location),
        next_seed = seed.wrapping_add(1),
    );
    if let Some(error) = &job.error {
        let _ = writeln!(
            out,
            "<tr><th>error</th><td class=\"error-message\">{}</td></tr>",
            escape(error)
        );
    }
    out.push_str("</tbody></table>\n");
    if job.cancellable && !job.finished {
        let _ = writeln!(
            out,
            "<form class=\"cancel\" method=\"post\" action=\"/jobs/{}/cancel\">{}<button type=\"submit\">Cancel job</button></form>",
            escape(&job.id),
            csrf.map(|token| format!(
                "<input type=\"hidden\" name=\"csrf\" value=\"{}\">",
                escape(token)
            ))
            .unwrap_or_default()
        );
    }
    out.push_str("</div>\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RunView;
    use hevo_rundir::FitnessRow;

    fn overview() -> JobOverview {
        JobOverview {
            id: "job-1".into(),
            name: "<small>".into(),
            state: "running".into(),
            finished: false,
            generations_done: 3,
            generations_total: Some(10),
            created_unix_ms: Some(0),
            finished_unix_ms: None,
            error: None,
            nodes: vec!["follow_wall".into()],
            cancellable: true,
            location: "/tmp/x".into(),
        }
    }

    #[test]
    fn the_job_list_links_each_job_and_escapes_names() {
        let html = jobs_body("hevo master", &[overview()], None);
        assert!(html.contains(r#"<a href="/jobs/job-1">job-1</a>"#));
        assert!(html.contains("&lt;small&gt;"));
        assert!(html.contains("3 of 10 generations"));
    }

    fn workers(spot_checks: Option<SpotChecksView>) -> WorkersView {
        WorkersView {
            active_workers: 2,
            active_threads: 4,
            leased_batches: 1,
            queued_batches: 0,
            evaluations: 100,
            batches_completed: 7,
            spot_checks,
        }
    }

    #[test]
    fn the_job_list_shows_what_the_spot_checks_caught_and_only_when_there_are_any() {
        let html = jobs_body("hevo master", &[], Some(&workers(None)));
        assert!(html.contains("connected workers"), "{html}");
        assert!(!html.contains("Spot checks"), "{html}");

        let clean = workers(Some(SpotChecksView {
            share: 0.1,
            checked: 3,
            refused_workers: vec![],
        }));
        let html = jobs_body("hevo master", &[], Some(&clean));
        assert!(html.contains("<h2>Spot checks</h2>"), "{html}");
        assert!(html.contains("10 % (and every worker's first)"), "{html}");
        assert!(html.contains("<td>3</td>"), "{html}");
        assert!(
            html.contains(r#"<td class="refused-workers">none</td>"#),
            "{html}"
        );

        let mut names: Vec<String> = (0..25).map(|i| format!("w{i:02}")).collect();
        names[0] = "<liar>".into();
        let caught = workers(Some(SpotChecksView {
            share: 0.1,
            checked: 9,
            refused_workers: names,
        }));
        let html = jobs_body("hevo master", &[], Some(&caught));
        assert!(
            html.contains(r#"<td class="refused-count">25</td>"#),
            "{html}"
        );
        assert!(html.contains("<code>&lt;liar&gt;</code>"), "{html}");
        assert!(html.contains("<code>w19</code>, and 5 more"), "{html}");
        assert!(!html.contains("<code>w20</code>"), "{html}");
    }

    #[test]
    fn a_running_job_can_be_cancelled_and_a_finished_one_not() {
        let mut job = overview();
        assert!(job_header(&job, 1, None).contains("Cancel job"));
        assert!(
            job_header(&job, 1, Some("abc123"))
                .contains("<input type=\"hidden\" name=\"csrf\" value=\"abc123\">")
        );
        job.finished = true;
        assert!(!job_header(&job, 1, None).contains("Cancel job"));
    }

    #[test]
    fn a_map_elites_node_shows_its_qd_curves_and_its_archive() {
        use hevo_rundir::archive::{ARCHIVE_FORMAT, ArchiveElite, ArchiveFile, QdRow};
        let run = |run: u32, fitness: f64| RunView {
            run,
            rows: Vec::new(),
            summary: None,
            archive: Some(ArchiveFile {
                format: ARCHIVE_FORMAT.into(),
                generation: 2,
                descriptor: vec!["final.x".into(), "final.y".into()],
                bins: vec![4, 4],
                ranges: vec![[-1.0, 1.0]; 2],
                elites: vec![ArchiveElite {
                    cell: 5,
                    bins: vec![1, 1],
                    fitness,
                    descriptor: vec![-0.4, -0.4],
                    genes: vec![0.5],
                }],
            }),
            qd: vec![QdRow {
                generation: 0,
                filled: 1,
                cells: 16,
                qd_score: fitness,
                best: fitness,
            }],
        };
        let node = NodeView {
            name: "maze".into(),
            runs: vec![run(0, 0.25), run(1, 0.75)],
            summary: None,
            planned: Some((2, 5)),
        };
        let html = node_section("job-1", &node, true, None);
        assert!(html.contains("<figure class=\"qd\">"), "{html}");
        // Unfinished: the latest run's archive.
        assert!(
            html.contains("<figure class=\"archive\" data-run=\"1\">"),
            "{html}"
        );
        assert!(html.contains("maze run 1: archive after 2 generations (1 of 16 cells)"));
        // The other algorithms' nodes have neither.
        let plain = node_section(
            "job-1",
            &NodeView {
                runs: vec![],
                ..node
            },
            true,
            None,
        );
        assert!(!plain.contains("class=\"qd\"") && !plain.contains("class=\"archive\""));
    }

    #[test]
    fn a_node_shows_its_runs_and_plot() {
        let node = NodeView {
            name: "follow_wall".into(),
            runs: vec![RunView {
                archive: None,
                qd: Vec::new(),
                run: 0,
                rows: vec![FitnessRow {
                    generation: 0,
                    best: 1.0,
                    mean: 0.5,
                    min: 0.0,
                    max: 1.0,
                    std: 0.1,
                }],
                summary: None,
            }],
            summary: None,
            planned: Some((1, 5)),
        };
        let html = node_section("job-1", &node, true, None);
        assert!(html.contains("run 0: 1 generation of 5, best 1.000, mean 0.500"));
        assert!(html.contains("<p class=\"node-state\">running,"));
        assert_eq!(node_state(&node, false), "unfinished (0 run(s) finished)");
        assert_eq!(
            plot_title(&node),
            "follow_wall: fitness per generation (1 of 5 generations)"
        );
        assert!(html.contains("data-plot=\"/jobs/job-1/plot.svg?node=follow_wall\""));
        assert!(html.contains("<svg"));
        assert!(!html.contains("post-evaluation"));
    }
}
