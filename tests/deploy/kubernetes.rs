//! deploy/k8s/: what the kustomizations pull in exists and every manifest is pulled in; the
//! master is a StatefulSet running `hevo serve` with its state on a volume claim, gRPC probes on
//! its port and scrape annotations on its metrics port; the workers are a Deployment that dials
//! a Service in front of the master's gRPC port and gets a minute and more to stop; the token
//! comes from the generated Secret; selectors, volumes, `$(VAR)` references and patch targets
//! resolve; every container has requests and runs as a non-root uid.
//!
//! This follows kustomize's rules for what this base uses (resources, components, a
//! secretGenerator, patches); `tests/tests/deploy/kubernetes.rs` also renders it with the real
//! kustomize and validates the output against the Kubernetes API schemas.

use super::invocation::{Program, container_invocation, port_of, url_host_port};
use super::yaml::{Lines, at, labels_match, parse_docs, scalar, seq, str_at, strings};
use super::{Concern, DeployFiles, Facts, Problems, Scoped, record_serve};
use serde_norway::Value;
use std::collections::{BTreeMap, BTreeSet};

/// The kustomize base.
pub const BASE: &str = "deploy/k8s/";

fn parse_yaml(path: &str, text: &str, problems: &mut Scoped) -> Vec<Value> {
    let (docs, errors) = parse_docs(text);
    for error in errors {
        problems.add(path, error);
    }
    docs
}

/// One object of a manifest, with the file it is in.
#[derive(Debug, Clone)]
pub struct K8sObject {
    /// The file.
    pub origin: String,
    /// The object.
    pub value: Value,
}

impl K8sObject {
    /// `kind`.
    pub fn kind(&self) -> String {
        str_at(&self.value, &["kind"]).unwrap_or_default()
    }

    /// `metadata.name`.
    pub fn name(&self) -> String {
        str_at(&self.value, &["metadata", "name"]).unwrap_or_default()
    }
}

/// Checks the manifests and kustomizations and records their facts (after the Dockerfile's: a
/// container without a command runs the image's `CMD`).
pub fn check(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let problems = &mut problems.scoped(Concern::Kubernetes);
    let base = BASE;
    // Every kustomization and what it pulls in.
    let mut objects: Vec<K8sObject> = Vec::new();
    let mut referenced: BTreeSet<String> = BTreeSet::new();
    let mut secret_keys: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut patch_targets: Vec<(String, Option<String>, Option<String>)> = Vec::new();
    let kustomizations: Vec<&String> = files
        .files
        .keys()
        .filter(|p| p.starts_with(base) && p.ends_with("/kustomization.yaml"))
        .collect();
    problems.check(
        kustomizations.contains(&&format!("{base}kustomization.yaml")),
        base,
        "no kustomization.yaml",
    );
    for path in &kustomizations {
        let text = files.get(path);
        problems.check(
            text.starts_with('#'),
            path,
            "starts with no comment saying what it is for",
        );
        let dir = path.trim_end_matches("kustomization.yaml");
        let docs = parse_yaml(path, text, problems);
        let Some(kustomization) = docs.first() else {
            continue;
        };
        for resource in strings(kustomization.get("resources")) {
            let target = normalize(&format!("{dir}{resource}"));
            if files.files.contains_key(&target) {
                referenced.insert(target.clone());
                for value in parse_yaml(&target, files.get(&target), problems) {
                    objects.push(K8sObject {
                        origin: target.clone(),
                        value,
                    });
                }
            } else {
                problems.check(
                    files.files.contains_key(&format!(
                        "{}/kustomization.yaml",
                        target.trim_end_matches('/')
                    )),
                    path,
                    format!("resource {resource} does not exist"),
                );
            }
        }
        for component in strings(kustomization.get("components")) {
            let target = normalize(&format!("{dir}{component}/kustomization.yaml"));
            problems.check(
                files.files.contains_key(&target),
                path,
                format!("component {component} does not exist"),
            );
        }
        if str_at(kustomization, &["kind"]).as_deref() == Some("Component") {
            // A component must be reachable from the base, if only by a commented-out line.
            let name = dir
                .trim_end_matches('/')
                .rsplit('/')
                .next()
                .unwrap_or_default();
            problems.check(
                files
                    .get(&format!("{base}kustomization.yaml"))
                    .contains(name),
                path,
                format!("the component {name} is not mentioned in {base}kustomization.yaml"),
            );
        }
        for generator in seq(kustomization.get("secretGenerator")) {
            let name = str_at(generator, &["name"]).unwrap_or_default();
            let keys = secret_keys.entry(name).or_default();
            for file in strings(generator.get("files")) {
                keys.insert(file.split_once('=').map_or_else(
                    || file.rsplit('/').next().unwrap().to_string(),
                    |(k, _)| k.to_string(),
                ));
            }
            for literal in strings(generator.get("literals")) {
                keys.insert(literal.split('=').next().unwrap().to_string());
            }
        }
        for patch in seq(kustomization.get("patches")) {
            patch_targets.push((
                path.to_string(),
                str_at(patch, &["target", "kind"]),
                str_at(patch, &["target", "name"]),
            ));
        }
    }
    for path in files.files.keys().filter(|p| {
        p.starts_with(base) && p.ends_with(".yaml") && !p.ends_with("/kustomization.yaml")
    }) {
        problems.check(
            referenced.contains(path),
            path,
            "no kustomization lists this manifest",
        );
        problems.check(
            files.get(path).starts_with('#'),
            path,
            "starts with no comment saying what it is for",
        );
    }
    for object in &objects {
        if object.kind() == "Secret" {
            let keys = secret_keys.entry(object.name()).or_default();
            for field in ["data", "stringData"] {
                if let Some(Value::Mapping(m)) = object.value.get(field) {
                    keys.extend(m.keys().filter_map(scalar));
                }
            }
        }
    }
    // Patch targets exist.
    for (origin, kind, name) in patch_targets {
        problems.check(
            objects
                .iter()
                .any(|o| Some(o.kind()) == kind && Some(o.name()) == name),
            &origin,
            format!("patch target {kind:?} {name:?} does not exist"),
        );
    }

    let workloads: Vec<&K8sObject> = objects
        .iter()
        .filter(|o| ["Deployment", "StatefulSet"].contains(&o.kind().as_str()))
        .collect();
    // (service name, port, target container port) for Services in front of `hevo serve`.
    let mut master_endpoints: Vec<(String, u16, u16)> = Vec::new();
    let mut worker_urls: Vec<(String, String)> = Vec::new();
    let mut serve_pod_labels: Vec<Value> = Vec::new();
    let mut worker_pod_labels: Vec<Value> = Vec::new();
    let mut container_ports: Vec<(Value, BTreeMap<String, u16>)> = Vec::new();
    let mut has_serve = false;
    let mut has_worker = false;
    // (origin, clients' token, workers' token) of the master, each as (Secret, key); (origin,
    // its token, every (Secret, key) it can read) of each worker.
    let mut master_tokens: Option<(String, Option<SecretKey>, Option<SecretKey>)> = None;
    let mut worker_tokens: Vec<(String, Option<SecretKey>, BTreeSet<SecretKey>)> = Vec::new();
    for workload in &workloads {
        let lines = Lines::new(files.get(&workload.origin));
        let object_line = lines
            .object(&workload.kind(), &workload.name())
            .unwrap_or(1);
        let origin = format!(
            "{}:{object_line}: {} {}",
            workload.origin,
            workload.kind(),
            workload.name()
        );
        let template = at(&workload.value, &["spec", "template"])
            .cloned()
            .unwrap_or(Value::Null);
        let labels = at(&template, &["metadata", "labels"]).cloned();
        problems.check(
            labels_match(
                at(&workload.value, &["spec", "selector", "matchLabels"]),
                labels.as_ref(),
            ),
            &origin,
            "spec.selector.matchLabels does not match the pod template's labels",
        );
        let pod = at(&template, &["spec"]).cloned().unwrap_or(Value::Null);
        let pod_security = pod.get("securityContext").cloned().unwrap_or(Value::Null);
        let mut volumes: BTreeMap<String, Value> = seq(pod.get("volumes"))
            .iter()
            .map(|v| (str_at(v, &["name"]).unwrap_or_default(), v.clone()))
            .collect();
        let claims: BTreeSet<String> = seq(at(&workload.value, &["spec", "volumeClaimTemplates"]))
            .iter()
            .filter_map(|c| str_at(c, &["metadata", "name"]))
            .collect();
        for claim in &claims {
            volumes.insert(claim.clone(), Value::String("persistentVolumeClaim".into()));
        }
        let grace = at(&pod, &["terminationGracePeriodSeconds"])
            .and_then(Value::as_i64)
            .unwrap_or(30);
        for container in seq(pod.get("containers")) {
            let container_name = str_at(container, &["name"]).unwrap_or_default();
            let container_line = lines
                .line(object_line, &format!("- name: {container_name}"))
                .unwrap_or(object_line);
            let origin = format!(
                "{}:{container_line}: {} {} container {container_name}",
                workload.origin,
                workload.kind(),
                workload.name()
            );
            let env_names: BTreeSet<String> = seq(container.get("env"))
                .iter()
                .filter_map(|e| str_at(e, &["name"]))
                .collect();
            let env_value = |name: &str| {
                seq(container.get("env"))
                    .iter()
                    .find(|e| str_at(e, &["name"]).as_deref() == Some(name))
                    .and_then(|e| str_at(e, &["value"]))
            };
            let mut argv = strings(container.get("command"));
            let args = strings(container.get("args"));
            if argv.is_empty() && args.is_empty() {
                argv = facts.dockerfile_cmd.clone();
            } else {
                argv.extend(args);
            }
            // $(VAR) in a command line is expanded by the kubelet only when VAR is in env.
            for arg in &argv {
                let mut rest = arg.as_str();
                while let Some(start) = rest.find("$(") {
                    let Some(len) = rest[start..].find(')') else {
                        break;
                    };
                    let var = &rest[start + 2..start + len];
                    problems.check(
                        env_names.contains(var),
                        &origin,
                        format!("$({var}) is not an env variable of the container"),
                    );
                    rest = &rest[start + len..];
                }
            }
            let mut env = env_names.clone();
            env.extend(facts.dockerfile_env.iter().cloned());
            let ports: BTreeMap<String, u16> = seq(container.get("ports"))
                .iter()
                .filter_map(|p| {
                    Some((
                        str_at(p, &["name"]).unwrap_or_default(),
                        at(p, &["containerPort"])?.as_u64()? as u16,
                    ))
                })
                .collect();
            container_ports.push((labels.clone().unwrap_or(Value::Null), ports.clone()));
            let mounts: Vec<(String, String)> = seq(container.get("volumeMounts"))
                .iter()
                .map(|m| {
                    (
                        str_at(m, &["name"]).unwrap_or_default(),
                        str_at(m, &["mountPath"]).unwrap_or_default(),
                    )
                })
                .collect();
            for (volume, _) in &mounts {
                problems.check(
                    volumes.contains_key(volume),
                    &origin,
                    format!("mounts the volume {volume}, which the pod does not have"),
                );
            }
            // Requests, so the scheduler can place it; a non-root identity matching the image.
            for resource in ["cpu", "memory"] {
                problems.check(
                    at(container, &["resources", "requests", resource]).is_some(),
                    &origin,
                    format!("no resources.requests.{resource}"),
                );
            }
            let security = container
                .get("securityContext")
                .cloned()
                .unwrap_or(Value::Null);
            let non_root = [&security, &pod_security]
                .iter()
                .any(|s| at(s, &["runAsNonRoot"]).and_then(Value::as_bool) == Some(true));
            problems.check(non_root, &origin, "runAsNonRoot is not set");
            match [&security, &pod_security]
                .iter()
                .find_map(|s| at(s, &["runAsUser"]).and_then(Value::as_i64))
            {
                Some(uid) => facts.run_as_users.push((origin.clone(), uid)),
                None => problems.add(&origin, "runAsUser is not set"),
            }
            let argv_lines = lines.items(container_line, &argv);
            let Some(invocation) = container_invocation(origin.clone(), &argv, &argv_lines, env)
            else {
                continue;
            };
            // The tokens: files of a mounted Secret, or variables from one.
            let files = secret_files(&mounts, &volumes, &secret_keys);
            let token = |file_flag: &str, var: &str, problems: &mut Scoped| {
                secret_token(container, &invocation, (file_flag, var), &files, problems)
            };
            if invocation.is_serve() {
                let client = token("--token-file", "HEVO_TOKEN", problems);
                let worker = token("--worker-token-file", "HEVO_WORKER_TOKEN", problems);
                master_tokens = Some((origin.clone(), client, worker));
            } else if invocation.program == Program::Worker {
                let own = token("--token-file", "HEVO_TOKEN", problems);
                let mut readable: BTreeSet<(String, String)> =
                    files.iter().map(|(_, key)| key.clone()).collect();
                readable.extend(secret_refs(container));
                worker_tokens.push((origin.clone(), own, readable));
            }
            if invocation.is_serve() {
                has_serve = true;
                record_serve(&invocation, problems, facts);
                facts.k8s_master_argv = Some(argv.clone());
                serve_pod_labels.extend(labels.clone());
                let grpc = invocation.flag("--listen").and_then(port_of).unwrap_or(0);
                let metrics = invocation.flag("--metrics-listen").and_then(port_of);
                problems.check(
                    ports.values().any(|p| *p == grpc),
                    &origin,
                    format!("no containerPort {grpc} (the --listen port)"),
                );
                if let Some(metrics) = metrics {
                    problems.check(
                        ports.values().any(|p| *p == metrics),
                        &origin,
                        format!("no containerPort {metrics} (the --metrics-listen port)"),
                    );
                    let annotations = at(&template, &["metadata", "annotations"]);
                    if let Some(port) = annotations
                        .and_then(|a| a.get("prometheus.io/port"))
                        .and_then(scalar)
                    {
                        problems.check(
                            port == metrics.to_string(),
                            &origin,
                            format!("prometheus.io/port {port} is not the metrics port {metrics}"),
                        );
                    }
                    if let Some(path) = annotations
                        .and_then(|a| a.get("prometheus.io/path"))
                        .and_then(scalar)
                    {
                        facts.metrics_paths.insert(path);
                    }
                }
                for probe in ["readinessProbe", "livenessProbe"] {
                    problems.check(
                        at(container, &[probe, "grpc"]).is_some(),
                        &origin,
                        format!("the master has no gRPC {probe}"),
                    );
                }
                for probe in ["startupProbe", "readinessProbe", "livenessProbe"] {
                    let Some(probe_value) = container.get(probe) else {
                        continue;
                    };
                    match probe_value.get("grpc") {
                        None => {
                            problems.add(&origin, format!("{probe} is not a gRPC health probe"))
                        }
                        Some(grpc_probe) => {
                            let port = at(grpc_probe, &["port"]).and_then(Value::as_u64);
                            problems.check(
                                port == Some(grpc as u64),
                                &origin,
                                format!(
                                    "{probe} probes port {port:?}, the master listens on {grpc}"
                                ),
                            );
                            facts
                                .probe_services
                                .insert(str_at(grpc_probe, &["service"]).unwrap_or_default());
                        }
                    }
                }
                problems.check(
                    invocation.flag("--tls-cert").is_none(),
                    &origin,
                    "the kubelet's gRPC probes are plaintext: with --tls-cert they would fail",
                );
                let state_dir = invocation.flag("--state-dir").unwrap_or_default();
                let persistent = mounts
                    .iter()
                    .any(|(volume, path)| path == state_dir && claims.contains(volume));
                problems.check(
                    persistent,
                    &origin,
                    format!("the state directory {state_dir} is not on a volumeClaimTemplate"),
                );
                problems.check(grace >= 30, &origin, format!("terminationGracePeriodSeconds {grace} leaves the master no time to save its state"));
            }
            if invocation.program == Program::Worker {
                has_worker = true;
                worker_pod_labels.extend(labels.clone());
                match invocation
                    .flag("--master")
                    .map(str::to_string)
                    .or_else(|| env_value("HEVO_MASTER"))
                {
                    Some(url) => worker_urls.push((origin.clone(), url)),
                    None => problems.add(
                        &origin,
                        "the worker is not told where the master is (--master or HEVO_MASTER)",
                    ),
                }
                problems.check(
                    grace >= 60,
                    &origin,
                    format!("terminationGracePeriodSeconds {grace} is less than the minute a worker needs to hand back its batch"),
                );
                problems.check(
                    workload.kind() == "Deployment",
                    &origin,
                    "workers should be a Deployment, scaled by its replica count",
                );
            }
            facts.invocations.push(invocation);
        }
    }
    problems.check(has_serve, base, "no container runs `hevo serve`");
    problems.check(has_worker, base, "no container runs `hevo-worker`");
    problems.check(
        workloads.iter().any(|w| {
            w.kind() == "StatefulSet"
                && serve_pod_labels.iter().any(|l| {
                    labels_match(at(&w.value, &["spec", "selector", "matchLabels"]), Some(l))
                })
        }),
        base,
        "the master is not a StatefulSet",
    );

    for object in &objects {
        let line = Lines::new(files.get(&object.origin))
            .object(&object.kind(), &object.name())
            .map_or_else(String::new, |l| format!(":{l}"));
        let origin = format!(
            "{}{line}: {} {}",
            object.origin,
            object.kind(),
            object.name()
        );
        match object.kind().as_str() {
            "Service" => {
                let selector = at(&object.value, &["spec", "selector"]);
                let selected: Vec<&BTreeMap<String, u16>> = container_ports
                    .iter()
                    .filter(|(labels, _)| labels_match(selector, Some(labels)))
                    .map(|(_, p)| p)
                    .collect();
                problems.check(
                    !selected.is_empty(),
                    &origin,
                    "its selector matches no pod template",
                );
                for port in seq(at(&object.value, &["spec", "ports"])) {
                    let service_port =
                        at(port, &["port"]).and_then(Value::as_u64).unwrap_or(0) as u16;
                    let target = at(port, &["targetPort"])
                        .and_then(scalar)
                        .unwrap_or_else(|| service_port.to_string());
                    let resolved = selected
                        .iter()
                        .find_map(|ports| match target.parse::<u16>() {
                            Ok(number) => ports.values().find(|p| **p == number).copied(),
                            Err(_) => ports.get(&target).copied(),
                        });
                    match resolved {
                        None => problems.add(
                            &origin,
                            format!(
                                "targetPort {target} is no container port of the selected pods"
                            ),
                        ),
                        Some(container_port) => {
                            if serve_pod_labels
                                .iter()
                                .any(|l| labels_match(selector, Some(l)))
                            {
                                master_endpoints.push((
                                    object.name(),
                                    service_port,
                                    container_port,
                                ));
                            }
                        }
                    }
                }
            }
            "PodDisruptionBudget" => {
                let selector = at(&object.value, &["spec", "selector", "matchLabels"]);
                problems.check(
                    container_ports
                        .iter()
                        .any(|(labels, _)| labels_match(selector, Some(labels))),
                    &origin,
                    "its selector matches no pod template",
                );
            }
            "HorizontalPodAutoscaler" => {
                let (kind, name) = (
                    str_at(&object.value, &["spec", "scaleTargetRef", "kind"]),
                    str_at(&object.value, &["spec", "scaleTargetRef", "name"]),
                );
                problems.check(
                    workloads
                        .iter()
                        .any(|w| Some(w.kind()) == kind && Some(w.name()) == name),
                    &origin,
                    format!("scaleTargetRef {kind:?} {name:?} does not exist"),
                );
            }
            _ => {}
        }
    }
    problems.check(
        objects.iter().any(|o| o.kind() == "PodDisruptionBudget"),
        base,
        "no PodDisruptionBudget",
    );
    problems.check(
        objects
            .iter()
            .any(|o| o.kind() == "HorizontalPodAutoscaler"),
        base,
        "no HorizontalPodAutoscaler example",
    );
    problems.check(!secret_keys.is_empty(), base, "the token is not a Secret");
    check_roles(master_tokens, &worker_tokens, problems);
    let grpc = facts
        .grpc_ports
        .iter()
        .find(|(o, _)| o.starts_with(base))
        .map(|(_, p)| *p);
    for (origin, url) in worker_urls {
        let ok = url_host_port(&url).is_some_and(|(host, port)| {
            let service = host.split('.').next().unwrap_or_default().to_string();
            master_endpoints.iter().any(|(name, service_port, target)| {
                *name == service && *service_port == port && Some(*target) == grpc
            })
        });
        problems.check(ok, &origin, format!("the worker dials {url}, which is no Service port in front of the master's gRPC port ({master_endpoints:?})"));
    }
}

/// A key of a Secret: (Secret name, key).
type SecretKey = (String, String);

/// The files that a container's mounted Secret volumes put in it: (path, (Secret, key)). A
/// volume with `items` holds only those keys, at their paths; one without holds every key.
fn secret_files(
    mounts: &[(String, String)],
    volumes: &BTreeMap<String, Value>,
    secret_keys: &BTreeMap<String, BTreeSet<String>>,
) -> Vec<(String, SecretKey)> {
    let mut files = Vec::new();
    for (volume, mount_path) in mounts {
        let Some(volume) = volumes.get(volume) else {
            continue;
        };
        let Some(secret) = str_at(volume, &["secret", "secretName"]) else {
            continue;
        };
        let dir = mount_path.trim_end_matches('/');
        let items = seq(at(volume, &["secret", "items"]));
        if items.is_empty() {
            for key in secret_keys.get(&secret).into_iter().flatten() {
                files.push((format!("{dir}/{key}"), (secret.clone(), key.clone())));
            }
        } else {
            for item in items {
                let key = str_at(item, &["key"]).unwrap_or_default();
                let path = str_at(item, &["path"]).unwrap_or_else(|| key.clone());
                files.push((format!("{dir}/{path}"), (secret.clone(), key)));
            }
        }
    }
    files
}

/// The (Secret, key) of every `secretKeyRef` in a container's env.
fn secret_refs(container: &Value) -> Vec<SecretKey> {
    seq(container.get("env"))
        .iter()
        .filter_map(|e| {
            Some((
                str_at(e, &["valueFrom", "secretKeyRef", "name"])?,
                str_at(e, &["valueFrom", "secretKeyRef", "key"])?,
            ))
        })
        .collect()
}

/// The (Secret, key) a command line's token of one role comes from: its file flag naming a
/// file of a mounted Secret, or its variable from a `secretKeyRef`. A file that is not there
/// is a problem; no token at all is the caller's.
fn secret_token(
    container: &Value,
    invocation: &super::invocation::Invocation,
    (file_flag, var): (&str, &str),
    files: &[(String, SecretKey)],
    problems: &mut Scoped,
) -> Option<SecretKey> {
    if let Some(file) = invocation.flag(file_flag) {
        let found = files
            .iter()
            .find(|(path, _)| path == file)
            .map(|(_, k)| k.clone());
        if found.is_none() {
            let (dir, key) = file.rsplit_once('/').unwrap_or(("", file));
            let secrets: BTreeSet<&String> = files
                .iter()
                .filter(|(path, _)| path.rsplit_once('/').map(|(d, _)| d) == Some(dir))
                .map(|(_, (secret, _))| secret)
                .collect();
            let origin = &invocation.origin;
            match secrets.first() {
                None => problems.add(origin, format!("{file_flag} {file} is not in a mounted Secret")),
                Some(secret) => problems.add(
                    origin,
                    format!("{file_flag} {file}: the Secret {secret} has no key {key} there (the volume holds {files:?})"),
                ),
            }
        }
        return found;
    }
    seq(container.get("env"))
        .iter()
        .find(|e| str_at(e, &["name"]).as_deref() == Some(var))
        .and_then(|e| {
            Some((
                str_at(e, &["valueFrom", "secretKeyRef", "name"])?,
                str_at(e, &["valueFrom", "secretKeyRef", "key"])?,
            ))
        })
}

/// The master gets two different keys, the clients' and the workers'; each worker gets the
/// master's workers' key and can read no other key (a worker never holds the clients' token).
fn check_roles(
    master: Option<(String, Option<SecretKey>, Option<SecretKey>)>,
    workers: &[(String, Option<SecretKey>, BTreeSet<SecretKey>)],
    problems: &mut Scoped,
) {
    let Some((origin, client, worker)) = master else {
        return;
    };
    let (Some(client), Some(worker)) = (client.clone(), worker.clone()) else {
        problems.check(
            client.is_some(),
            &origin,
            "the master gets no clients' token (--token-file from a Secret, or HEVO_TOKEN from one)",
        );
        problems.check(
            worker.is_some(),
            &origin,
            "the master gets no workers' token (--worker-token-file from a Secret, or HEVO_WORKER_TOKEN from one)",
        );
        return;
    };
    if client == worker {
        problems.add(
            &origin,
            format!("the master gets one key, {client:?}, for both roles"),
        );
        return;
    }
    for (origin, token, readable) in workers {
        match token {
            None => problems.add(
                origin,
                "no token: neither --token-file from a Secret nor HEVO_TOKEN from one",
            ),
            Some(token) => problems.check(
                *token == worker,
                origin,
                format!(
                    "the worker's token is {token:?}, not the master's workers' token {worker:?}"
                ),
            ),
        }
        for key in readable.iter().filter(|k| **k != worker) {
            problems.add(
                origin,
                format!(
                    "the worker can read {key:?}{}, not only the workers' token {worker:?}",
                    if *key == client {
                        " (the clients' token)"
                    } else {
                        ""
                    }
                ),
            );
        }
    }
}

/// `deploy/k8s/autoscale/../master.yaml` -> `deploy/k8s/master.yaml`.
pub fn normalize(path: &str) -> String {
    let mut parts: Vec<&str> = Vec::new();
    for part in path.split('/') {
        match part {
            "." => {}
            ".." => {
                parts.pop();
            }
            _ => parts.push(part),
        }
    }
    parts.join("/")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_are_normalized() {
        assert_eq!(
            normalize("deploy/k8s/autoscale/../master.yaml"),
            "deploy/k8s/master.yaml"
        );
        assert_eq!(normalize("deploy/k8s/./a/b/../c"), "deploy/k8s/a/c");
    }
}
