//! deploy/k8s/: the manifests are wired together (see `hevo_tests::deploy::kubernetes` for the
//! list: kustomization resources, selectors, Services in front of the master's gRPC port,
//! probes, volumes, grace periods, non-root uids, and the Secret's two keys: the master gets the
//! clients' and the workers' token, the workers only the workers'); each manifest is valid
//! against the Kubernetes API schemas (kubernetes-validate, which bundles the official ones,
//! strict: unknown fields are errors); and the real kustomize (kubectl's) renders the base, with
//! and without the autoscale component, into valid objects in the namespace `hevo` that use the
//! generated Secret, with both keys, of which the workers mount only `worker-token`.

use hevo_tests::deploy::yaml::{at, parse_docs, seq, str_at};
use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected};
use hevo_tests::{Scratch, repo_root, tools};
use serde_norway::Value;
use std::path::{Path, PathBuf};

#[test]
fn the_manifests_are_wired_together() {
    Analysis::of(&DeployFiles::load())
        .problems
        .assert_none(Concern::Kubernetes, "deploy/k8s/");
}

#[test]
fn kubernetes_drift_is_reported() {
    assert_drift_detected(
        Concern::Kubernetes,
        None,
        &[
            Drift {
                path: "deploy/k8s/master.yaml",
                from: "              port: 50051\n              service: hevo.v1.WorkerService",
                to: "              port: 50052\n              service: hevo.v1.WorkerService",
                expected: "readinessProbe probes port Some(50052)",
            },
            Drift {
                path: "deploy/k8s/worker.yaml",
                from: "terminationGracePeriodSeconds: 90",
                to: "terminationGracePeriodSeconds: 10",
                expected: "terminationGracePeriodSeconds 10",
            },
            Drift {
                path: "deploy/k8s/worker.yaml",
                from: "value: http://hevo-master:50051",
                to: "value: http://hevo-masters:50051",
                expected: "the worker dials http://hevo-masters:50051",
            },
            Drift {
                path: "deploy/k8s/worker.yaml",
                from: "- $(POD_NAME)",
                to: "- $(POD)",
                expected: "$(POD) is not an env variable of the container",
            },
            Drift {
                path: "deploy/k8s/master.yaml",
                from: "- /etc/hevo/token/token",
                to: "- /etc/hevo/token/secret",
                expected: "the Secret hevo-token has no key secret",
            },
            Drift {
                path: "deploy/k8s/worker.yaml",
                from: "            items:\n              - key: worker-token\n                path: worker-token\n",
                to: "",
                expected: "the worker can read (\"hevo-token\", \"token\") (the clients' token)",
            },
            Drift {
                path: "deploy/k8s/worker.yaml",
                from: "- /etc/hevo/token/worker-token",
                to: "- /etc/hevo/token/token",
                expected: "--token-file /etc/hevo/token/token: the Secret hevo-token has no key token there",
            },
            Drift {
                path: "deploy/k8s/master.yaml",
                from: "            - --worker-token-file\n            - /etc/hevo/token/worker-token\n",
                to: "",
                expected: "container master: the master gets no workers' token",
            },
            Drift {
                path: "deploy/k8s/master.yaml",
                from: "- /etc/hevo/token/worker-token",
                to: "- /etc/hevo/token/token",
                expected: "container master: the master gets one key, (\"hevo-token\", \"token\"), for both roles",
            },
            Drift {
                path: "deploy/k8s/pdb.yaml",
                from: "      app.kubernetes.io/component: worker",
                to: "      app.kubernetes.io/component: workers",
                expected: "PodDisruptionBudget hevo-worker: its selector matches no pod template",
            },
            Drift {
                path: "deploy/k8s/kustomization.yaml",
                from: "  - pdb.yaml\n",
                to: "  - pdbs.yaml\n",
                expected: "resource pdbs.yaml does not exist",
            },
            Drift {
                path: "deploy/k8s/autoscale/kustomization.yaml",
                from: "name: hevo-worker",
                to: "name: hevo-workers",
                expected: "patch target Some(\"Deployment\") Some(\"hevo-workers\") does not exist",
            },
            Drift {
                path: "deploy/k8s/master.yaml",
                from: "            - name: state\n              mountPath: /var/lib/hevo",
                to: "            - name: tmp\n              mountPath: /var/lib/hevo",
                expected: "the state directory /var/lib/hevo is not on a volumeClaimTemplate",
            },
        ],
    );
}

/// The manifests (not the kustomizations) under deploy/k8s/.
fn manifests(files: &DeployFiles) -> Vec<String> {
    files
        .files
        .keys()
        .filter(|p| {
            p.starts_with("deploy/k8s/")
                && p.ends_with(".yaml")
                && !p.ends_with("kustomization.yaml")
        })
        .cloned()
        .collect()
}

#[test]
fn each_manifest_matches_the_kubernetes_schemas() {
    let test = "each_manifest_matches_the_kubernetes_schemas";
    let Some(validate) = tools::require("kubernetes-validate", test) else {
        return;
    };
    let files = DeployFiles::load();
    let mut args = vec!["--strict".to_string(), "--quiet".to_string()];
    args.extend(manifests(&files));
    let run = tools::run(&validate, &args, &repo_root());
    assert!(run.success, "kubernetes-validate --strict:\n{}", run.output);

    // The schemas are really applied: a misspelt field is rejected, naming the file.
    let scratch = Scratch::new("kubernetes-validate");
    let mut files = files;
    files.replace(
        "deploy/k8s/worker.yaml",
        "terminationGracePeriodSeconds: 90",
        "terminationGracePeriodSecond: 90",
    );
    files.write_to(scratch.path());
    let run = tools::run(&validate, &args, scratch.path());
    assert!(
        !run.success
            && run.output.contains("deploy/k8s/worker.yaml")
            && run.output.contains("terminationGracePeriodSecond"),
        "kubernetes-validate accepted a misspelt field:\n{}",
        run.output
    );
}

/// A kustomize: `kustomize build DIR`, or `kubectl kustomize DIR`.
fn kustomize(test: &str) -> Option<(PathBuf, &'static str)> {
    if let Some(kustomize) = tools::find("kustomize") {
        return Some((kustomize, "build"));
    }
    tools::require("kubectl", test).map(|kubectl| (kubectl, "kustomize"))
}

/// Renders a copy of deploy/k8s (with the two token files, which users create) with the autoscale
/// component on or off, validates the output, and returns its objects.
fn render(
    kustomize: &(PathBuf, &str),
    validate: &Path,
    scratch: &Scratch,
    autoscale: bool,
) -> Vec<Value> {
    let dir = scratch.join(if autoscale { "autoscale" } else { "base" });
    let mut files = DeployFiles::load();
    if autoscale {
        // What deploy/README.md tells users to do.
        files.replace(
            "deploy/k8s/kustomization.yaml",
            "# components:\n#   - autoscale\n",
            "components:\n  - autoscale\n",
        );
    }
    files.write_to(&dir);
    for (file, token) in [
        ("token", "client-test-token"),
        ("worker-token", "worker-test-token"),
    ] {
        std::fs::write(dir.join("deploy/k8s").join(file), token).expect("write a token file");
    }
    let run = tools::run(&kustomize.0, &[kustomize.1, "deploy/k8s"], &dir);
    assert!(
        run.success,
        "{} {} deploy/k8s (autoscale {autoscale}):\n{}",
        kustomize.0.display(),
        kustomize.1,
        run.output
    );
    let rendered = dir.join("rendered.yaml");
    std::fs::write(&rendered, &run.output).expect("write the rendered objects");
    let check = tools::run(validate, &["--strict", "--quiet", "rendered.yaml"], &dir);
    assert!(
        check.success,
        "the rendered objects (autoscale {autoscale}) fail kubernetes-validate:\n{}",
        check.output
    );
    let (objects, errors) = parse_docs(&run.output);
    assert!(errors.is_empty(), "{errors:?}");
    objects
}

fn kind_name(object: &Value) -> (String, String) {
    (
        str_at(object, &["kind"]).unwrap_or_default(),
        str_at(object, &["metadata", "name"]).unwrap_or_default(),
    )
}

#[test]
fn kustomize_renders_the_base_and_the_autoscale_component() {
    let test = "kustomize_renders_the_base_and_the_autoscale_component";
    let Some(kustomize) = kustomize(test) else {
        return;
    };
    let Some(validate) = tools::require("kubernetes-validate", test) else {
        return;
    };
    let scratch = Scratch::new("kustomize");
    for autoscale in [false, true] {
        let objects = render(&kustomize, &validate, &scratch, autoscale);
        let what = format!("rendered with autoscale {autoscale}");
        let kinds: Vec<(String, String)> = objects.iter().map(kind_name).collect();
        for expected in [
            "Namespace",
            "Secret",
            "Service",
            "StatefulSet",
            "Deployment",
            "PodDisruptionBudget",
        ] {
            assert!(
                kinds.iter().any(|(k, _)| k == expected),
                "{what}: no {expected} in {kinds:?}"
            );
        }
        assert_eq!(
            kinds.iter().any(|(k, _)| k == "HorizontalPodAutoscaler"),
            autoscale,
            "{what}: {kinds:?}"
        );
        // The generated Secret, with its hashed name, is the one the pods mount.
        let secret = objects
            .iter()
            .find(|o| kind_name(o).0 == "Secret")
            .expect("a Secret");
        let secret_name = kind_name(secret).1;
        assert!(
            secret_name.starts_with("hevo-token-")
                && at(secret, &["data", "token"]).is_some()
                && at(secret, &["data", "worker-token"]).is_some(),
            "{what}: the Secret is {secret:?}"
        );
        for object in &objects {
            let (kind, name) = kind_name(object);
            let origin = format!("{what}: {kind} {name}");
            if kind != "Namespace" {
                assert_eq!(
                    str_at(object, &["metadata", "namespace"]).as_deref(),
                    Some("hevo"),
                    "{origin}: not in the namespace hevo"
                );
            }
            assert_eq!(
                str_at(object, &["metadata", "labels", "app.kubernetes.io/part-of"]).as_deref(),
                Some("hevo"),
                "{origin}: no part-of label"
            );
            let pod = at(object, &["spec", "template", "spec"]);
            for volume in pod.map(|p| seq(p.get("volumes"))).unwrap_or_default() {
                if let Some(secret) = str_at(volume, &["secret", "secretName"]) {
                    assert_eq!(
                        secret, secret_name,
                        "{origin}: mounts a Secret kustomize did not generate"
                    );
                    // The workers' pods get the workers' key alone.
                    if kind == "Deployment" {
                        let keys: Vec<String> = seq(at(volume, &["secret", "items"]))
                            .iter()
                            .filter_map(|item| str_at(item, &["key"]))
                            .collect();
                        assert_eq!(keys, ["worker-token"], "{origin}: mounts {volume:?}");
                    }
                }
            }
            for container in pod.map(|p| seq(p.get("containers"))).unwrap_or_default() {
                assert_eq!(
                    str_at(container, &["image"]).as_deref(),
                    Some("hevo:local"),
                    "{origin}: the image is not kustomization.yaml's"
                );
            }
            if kind == "Deployment" {
                assert_eq!(
                    at(object, &["spec", "replicas"]).is_some(),
                    !autoscale,
                    "{origin}: with the autoscaler, the Deployment must leave its replica count to it"
                );
            }
            if kind == "HorizontalPodAutoscaler" {
                assert_eq!(
                    (
                        str_at(object, &["spec", "scaleTargetRef", "kind"]),
                        str_at(object, &["spec", "scaleTargetRef", "name"])
                    ),
                    (Some("Deployment".into()), Some("hevo-worker".into())),
                    "{origin}"
                );
            }
        }
    }
}
