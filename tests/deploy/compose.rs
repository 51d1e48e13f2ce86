//! deploy/compose.yaml: the master service (published ports, state on a named volume, a
//! healthcheck that is a real client call), the workers (told where the master is, waiting for
//! it to be healthy, given time to hand back their batch), and one token per role: the master
//! gets the clients' and the workers', each worker only the workers' (as its `HEVO_TOKEN`) and
//! the client service only the clients'.

use super::invocation::{Program, container_invocation, port_of, url_host_port};
use super::yaml::{Lines, at, parse_docs, scalar, str_at, strings};
use super::{Concern, DeployFiles, Facts, Problems, record_serve, shell};
use crate::repo_root;
use serde_norway::Value;
use std::collections::{BTreeMap, BTreeSet};

/// The compose file's path.
pub const PATH: &str = "deploy/compose.yaml";

/// Compose durations (`90s`, `1m30s`, `2m`, `500ms`) in seconds.
pub fn duration_seconds(text: &str) -> Option<f64> {
    let mut total = 0.0;
    let mut number = String::new();
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_ascii_digit() || c == '.' {
            number.push(c);
            continue;
        }
        let value: f64 = std::mem::take(&mut number).parse().ok()?;
        total += value
            * match c {
                'h' => 3600.0,
                'm' if chars.peek() == Some(&'s') => {
                    chars.next();
                    0.001
                }
                'm' => 60.0,
                's' => 1.0,
                _ => return None,
            };
    }
    if !number.is_empty() {
        return None;
    }
    Some(total)
}

/// Where a token comes from, comparable across services: the variable of a `${VAR:?message}`
/// reference (`${VAR}`), else the value as written.
fn token_source(value: &str) -> String {
    match value.strip_prefix("${") {
        Some(rest) => {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            format!("${{{name}}}")
        }
        None => value.to_string(),
    }
}

/// A command line's token of one role: its file flag, its value flag, or its variable.
fn role_token(
    invocation: &super::invocation::Invocation,
    (file_flag, flag, var): (&str, &str, &str),
    env_values: &BTreeMap<String, String>,
) -> Option<String> {
    invocation
        .flag(file_flag)
        .map(str::to_string)
        .or_else(|| invocation.flag(flag).map(str::to_string))
        .or_else(|| env_values.get(var).map(|v| token_source(v)))
}

/// The clients' token: what `hevo` clients and the master's `--token` side read, and what
/// hevo-worker reads as its (worker) token.
const CLIENT_ROLE: (&str, &str, &str) = ("--token-file", "--token", "HEVO_TOKEN");
/// The workers' token on the master's side.
const WORKER_ROLE: (&str, &str, &str) =
    ("--worker-token-file", "--worker-token", "HEVO_WORKER_TOKEN");

/// A service's `command`/`entrypoint`: a list, or a string split as a shell would.
fn argv_of(value: Option<&Value>) -> Option<Vec<String>> {
    match value? {
        Value::String(s) => shell::first_command_words(s),
        other => Some(strings(Some(other))),
    }
}

/// Checks the compose file and records its facts (after the Dockerfile's: a service without a
/// command runs the image's `CMD`).
pub fn check(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let problems = &mut problems.scoped(Concern::Compose);
    let path = PATH;
    let text = files.get(path);
    problems.check(
        text.starts_with('#'),
        path,
        "starts with no comment saying what it is for",
    );
    let (docs, errors) = parse_docs(text);
    for error in errors {
        problems.add(path, error);
    }
    let Some(compose) = docs.first() else { return };
    let Some(Value::Mapping(services)) = compose.get("services") else {
        problems.add(path, "no services");
        return;
    };
    let top_volumes: BTreeSet<String> = match compose.get("volumes") {
        Some(Value::Mapping(m)) => m.keys().filter_map(scalar).collect(),
        _ => BTreeSet::new(),
    };
    let mut serve_services: BTreeMap<String, u16> = BTreeMap::new();
    let mut worker_masters: Vec<(String, String)> = Vec::new();
    // (origin, clients' token, workers' token) of the master; (origin, token, every source
    // in the environment) of each worker and client service.
    let mut master_tokens: Option<(String, Option<String>, Option<String>)> = None;
    let mut worker_tokens: Vec<(String, Option<String>, BTreeSet<String>)> = Vec::new();
    let mut client_tokens: Vec<(String, Option<String>, BTreeSet<String>)> = Vec::new();
    let lines = Lines::new(text);
    let services_line = lines.line(1, "services:").unwrap_or(1);
    for (name, service) in services {
        let name = scalar(name).unwrap_or_default();
        let service_line = lines.find(services_line, |l| l == format!("  {name}:"));
        let origin = match service_line {
            Some(line) => format!("{path}:{line}: services.{name}"),
            None => format!("{path}: services.{name}"),
        };
        let service_line = service_line.unwrap_or(services_line);
        if let Some(build) = service.get("build") {
            let context = str_at(build, &["context"]).unwrap_or_else(|| ".".into());
            let dockerfile = str_at(build, &["dockerfile"]).unwrap_or_else(|| "Dockerfile".into());
            let file = repo_root().join("deploy").join(&context).join(&dockerfile);
            problems.check(
                file.exists(),
                &origin,
                format!("build: {} does not exist", file.display()),
            );
        }
        let mut env: BTreeSet<String> = facts.dockerfile_env.clone();
        let mut env_values: BTreeMap<String, String> = BTreeMap::new();
        match service.get("environment") {
            Some(Value::Mapping(m)) => {
                for (k, v) in m {
                    let k = scalar(k).unwrap_or_default();
                    env_values.insert(k.clone(), scalar(v).unwrap_or_default());
                    env.insert(k);
                }
            }
            Some(Value::Sequence(items)) => {
                for item in items.iter().filter_map(scalar) {
                    let (k, v) = item.split_once('=').unwrap_or((&item, ""));
                    env_values.insert(k.to_string(), v.to_string());
                    env.insert(k.to_string());
                }
            }
            _ => {}
        }
        let mut argv = argv_of(service.get("entrypoint")).unwrap_or_default();
        argv.extend(
            argv_of(service.get("command")).unwrap_or_else(|| facts.dockerfile_cmd.clone()),
        );
        let argv_lines = lines.items(service_line, &argv);
        let Some(invocation) =
            container_invocation(origin.clone(), &argv, &argv_lines, env.clone())
        else {
            continue;
        };
        // hevo-worker reads its (the workers') token where clients read theirs.
        let token = role_token(&invocation, CLIENT_ROLE, &env_values);
        let sources: BTreeSet<String> = env_values.values().map(|v| token_source(v)).collect();
        if invocation.is_serve() {
            master_tokens = Some((
                origin.clone(),
                token.clone(),
                role_token(&invocation, WORKER_ROLE, &env_values),
            ));
        } else if invocation.program == Program::Worker {
            worker_tokens.push((origin.clone(), token.clone(), sources));
        } else {
            client_tokens.push((origin.clone(), token.clone(), sources));
        }
        if invocation.is_serve() {
            record_serve(&invocation, problems, facts);
            let grpc = invocation.flag("--listen").and_then(port_of).unwrap_or(0);
            let metrics = invocation.flag("--metrics-listen").and_then(port_of);
            serve_services.insert(name.clone(), grpc);
            facts.compose_master_argv = Some((argv.clone(), env.clone()));
            for port in strings(service.get("ports")) {
                let container = port
                    .rsplit(':')
                    .next()
                    .and_then(|p| p.split('/').next()?.parse::<u16>().ok());
                problems.check(
                    container == Some(grpc) || container == metrics,
                    &origin,
                    format!("publishes {port}, but the master listens on {grpc} and {metrics:?}"),
                );
            }
            let state_dir = invocation
                .flag("--state-dir")
                .unwrap_or_default()
                .to_string();
            let mounted = strings(service.get("volumes")).iter().any(|v| {
                let mut parts = v.split(':');
                let (source, target) = (
                    parts.next().unwrap_or_default(),
                    parts.next().unwrap_or_default(),
                );
                target == state_dir && top_volumes.contains(source)
            });
            problems.check(
                mounted,
                &origin,
                format!("the state directory {state_dir} is not on a named volume"),
            );
            match service.get("healthcheck").and_then(|h| h.get("test")) {
                None => problems.add(
                    &origin,
                    "the master has no healthcheck (workers wait for it to be healthy)",
                ),
                Some(test) => {
                    let test = strings(Some(test));
                    let argv: Vec<String> = match test.first().map(String::as_str) {
                        Some("CMD") => test[1..].to_vec(),
                        Some("CMD-SHELL") => {
                            shell::first_command_words(&test[1..].join(" ")).unwrap_or_default()
                        }
                        _ => test.clone(),
                    };
                    let test_line = lines
                        .find(service_line, |l| l.trim_start().starts_with("test:"))
                        .unwrap_or(service_line);
                    let healthcheck = format!("{path}:{test_line}: services.{name}.healthcheck");
                    let argv_lines = lines.items(test_line, &argv);
                    match container_invocation(healthcheck, &argv, &argv_lines, env.clone()) {
                        None => problems.add(&origin,
                            format!("healthcheck {test:?} does not run hevo (the image has no shell or curl)"),
                        ),
                        Some(check) => {
                            let port = check
                                .flag("--master")
                                .and_then(url_host_port)
                                .map(|(_, p)| p);
                            problems.check(port == Some(grpc),
                                &origin,
                                format!("healthcheck dials port {port:?}, the master listens on {grpc}"),
                            );
                            facts.compose_healthcheck = Some(argv.clone());
                            facts.invocations.push(check);
                        }
                    }
                }
            }
        }
        if invocation.program == Program::Worker {
            let master = invocation
                .flag("--master")
                .map(str::to_string)
                .or_else(|| env_values.get("HEVO_MASTER").cloned());
            match master {
                Some(url) => worker_masters.push((origin.clone(), url)),
                None => problems.add(
                    &origin,
                    "the worker is not told where the master is (--master or HEVO_MASTER)",
                ),
            }
            let grace = service
                .get("stop_grace_period")
                .and_then(scalar)
                .and_then(|d| duration_seconds(&d));
            problems.check(grace.is_some_and(|g| g >= 60.0),
                &origin,
                format!("stop_grace_period {grace:?} s is less than the minute a worker needs to hand back its batch"),
            );
            let waits = at(service, &["depends_on"])
                .is_some_and(|d| serve_services.keys().any(|m| d.get(m.as_str()).is_some()));
            problems.check(waits, &origin, "the worker does not depend_on the master");
        }
        facts.invocations.push(invocation);
    }
    for (origin, url) in worker_masters {
        match url_host_port(&url) {
            Some((host, port)) => problems.check(
                serve_services.get(&host) == Some(&port),
                &origin,
                format!("the worker dials {url}, but the master service(s) are {serve_services:?}"),
            ),
            None => problems.add(&origin, format!("{url} is not a URL with a port")),
        }
    }
    check_roles(master_tokens, &worker_tokens, &client_tokens, problems);
}

/// The master gets two different tokens; each worker the master's workers' token and nothing
/// of the clients'; each client the master's clients' token and nothing of the workers'.
fn check_roles(
    master: Option<(String, Option<String>, Option<String>)>,
    workers: &[(String, Option<String>, BTreeSet<String>)],
    clients: &[(String, Option<String>, BTreeSet<String>)],
    problems: &mut super::Scoped,
) {
    let Some((origin, client_token, worker_token)) = master else {
        return;
    };
    let (Some(client_token), Some(worker_token)) = (client_token.clone(), worker_token.clone())
    else {
        problems.check(
            client_token.is_some(),
            &origin,
            "the master gets no clients' token (HEVO_TOKEN, --token or --token-file)",
        );
        problems.check(
            worker_token.is_some(),
            &origin,
            "the master gets no workers' token (HEVO_WORKER_TOKEN, --worker-token or --worker-token-file)",
        );
        return;
    };
    if client_token == worker_token {
        problems.add(
            &origin,
            format!("the master gets one token, {client_token}, for both roles"),
        );
        return;
    }
    for (role, holders, own, other) in [
        ("worker", workers, &worker_token, &client_token),
        ("client", clients, &client_token, &worker_token),
    ] {
        for (origin, token, sources) in holders {
            match token {
                None => problems.add(
                    origin,
                    format!("the {role} gets no token (HEVO_TOKEN, --token or --token-file)"),
                ),
                Some(token) => problems.check(
                    token == own,
                    origin,
                    format!("the {role}'s token is {token}, not the master's {role}s' token {own}"),
                ),
            }
            problems.check(
                !sources.contains(other),
                origin,
                format!("the {role} is given {other}, the other role's token"),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations() {
        assert_eq!(duration_seconds("1m30s"), Some(90.0));
        assert_eq!(duration_seconds("90s"), Some(90.0));
        assert_eq!(duration_seconds("1h"), Some(3600.0));
        assert_eq!(duration_seconds("500ms"), Some(0.5));
        assert_eq!(duration_seconds("90"), None);
        assert_eq!(duration_seconds("1d"), None);
    }
}
