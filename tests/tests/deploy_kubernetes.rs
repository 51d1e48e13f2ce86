//! deploy/k8s/: the manifests are wired together (see `hevo_tests::deploy::kubernetes` for the
//! list: kustomization resources, selectors, Services in front of the master's gRPC port,
//! probes, volumes, the token Secret, grace periods, non-root uids).

use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected};

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
