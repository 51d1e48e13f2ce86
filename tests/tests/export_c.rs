//! `hevo export` end to end: the real binary writes the C library of a shipped controller;
//! `--check-closed-loop` drives the compiled C from the simulator and finds sim-core's
//! outcomes; `make check-qemu` runs the recorded vectors on an emulated Cortex-M4 (float,
//! bit-identical) and Cortex-M3 (fixed point), and the fixed rescue tree's state and stack fit
//! the e-puck1's 8 kB of RAM. The cross-compiler and QEMU come from
//! `scripts/install-export-tools.sh` (a step of the test tools' install); without them the
//! QEMU tests fail under CI and are skipped loudly elsewhere (`tools::require`).

use hevo_tests::{Proc, Scratch, hevo_ok, lines_of, repo_root, tools};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// `hevo export CONTROLLER --task TASK --out DIR EXTRA...`, which must succeed; its stdout.
fn export(controller: &str, task: &str, out: &Path, extra: &[&str]) -> String {
    let controller = repo_root().join("controllers").join(controller);
    let out_arg = out.to_string_lossy().into_owned();
    let mut args = vec![
        "export",
        controller.to_str().unwrap(),
        "--task",
        task,
        "--out",
        &out_arg,
    ];
    args.extend(extra);
    let output = hevo_ok(&args, None, Duration::from_secs(600));
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// `make -s -C DIR TARGET` with at most ten minutes; whether it succeeded, and its output.
fn make(dir: &Path, target: &str) -> (bool, String) {
    let mut command = Command::new("make");
    command
        .args(["-s", "-C"])
        .arg(dir)
        .arg(target)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut proc = Proc::spawn("make", &mut command);
    let stdout = lines_of(proc.child().stdout.take().expect("piped"));
    let stderr = lines_of(proc.child().stderr.take().expect("piped"));
    let status = proc
        .wait_timeout(Duration::from_secs(600))
        .unwrap_or_else(|| panic!("make {target} in {} did not finish", dir.display()));
    let text: String = stdout
        .iter()
        .chain(stderr.iter())
        .map(|l| l + "\n")
        .collect();
    (status.success(), text)
}

/// The number after `label` in `text`.
fn number_after(text: &str, label: &str) -> f64 {
    text.split(label)
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.trim_end_matches([';', ',']).parse().ok())
        .unwrap_or_else(|| panic!("no number after {label:?} in:\n{text}"))
}

#[test]
fn the_exported_c_in_the_loop_solves_what_sim_core_solves() {
    let test = "the_exported_c_in_the_loop_solves_what_sim_core_solves";
    let (Some(_), Some(_)) = (tools::require("make", test), tools::require("cc", test)) else {
        return;
    };
    let scratch = Scratch::new("export-loop");
    let stdout = export(
        "return_room.json",
        "return_room",
        &scratch.join("c"),
        &["--check-closed-loop", "--samples", "5", "--seed", "3"],
    );
    // "closed loop, 20 samples (seed 3): exported C solved S (..), sim-core S (..); 20 of 20
    // outcomes identical"
    let line = stdout
        .lines()
        .find(|l| l.starts_with("closed loop"))
        .unwrap_or_else(|| panic!("no closed-loop line in:\n{stdout}"));
    let n = number_after(line, "closed loop, ");
    assert!(n > 0.0, "{line}");
    assert_eq!(
        number_after(line, "exported C solved "),
        number_after(line, "sim-core "),
        "{line}"
    );
    assert!(
        line.ends_with(&format!("{n} of {n} outcomes identical")),
        "{line}"
    );
}

/// The shipped rescue exported with `export_args` into a scratch folder named `scratch_name`
/// and run by `make check-qemu`, which must pass: the folder (kept while it lives) and what
/// make printed. `None` where the cross-compiler or QEMU is missing (outside CI).
fn rescue_under_qemu(
    test: &str,
    scratch_name: &str,
    export_args: &[&str],
) -> Option<(Scratch, String)> {
    tools::require("make", test)?;
    tools::require("arm-none-eabi-gcc", test)?;
    tools::require("qemu-system-arm", test)?;
    let scratch = Scratch::new(scratch_name);
    let dir = scratch.join("c");
    export("rescue.json", "rescue", &dir, export_args);
    let (success, output) = make(&dir, "check-qemu");
    assert!(success, "make check-qemu:\n{output}");
    Some((scratch, output))
}

#[test]
fn the_float_export_runs_bit_identical_on_an_emulated_cortex_m4() {
    let test = "the_float_export_runs_bit_identical_on_an_emulated_cortex_m4";
    let Some((_scratch, output)) = rescue_under_qemu(test, "export-qemu-float", &[]) else {
        return;
    };
    assert!(output.contains("bit-identical to sim-core"), "{output}");
    assert!(number_after(&output, "hevo_step: ") > 100.0, "{output}");
}

#[test]
fn the_fixed_rescue_fits_the_e_puck1_ram_on_an_emulated_cortex_m3() {
    let test = "the_fixed_rescue_fits_the_e_puck1_ram_on_an_emulated_cortex_m3";
    let Some((scratch, output)) =
        rescue_under_qemu(test, "export-qemu-fixed", &["--target", "fixed"])
    else {
        return;
    };
    let dir = scratch.join("c");
    assert!(output.contains("Cortex-M3, no FPU"), "{output}");
    // No float instruction in the library: a core without FPU runs it.
    let objdump = Command::new("arm-none-eabi-objdump")
        .arg("-d")
        .arg(dir.join("hevo.arm.o"))
        .output()
        .expect("arm-none-eabi-objdump runs");
    let disassembly = String::from_utf8_lossy(&objdump.stdout);
    assert!(
        !disassembly.contains("\tv"),
        "a floating-point instruction:\n{disassembly}"
    );
    let state = number_after(&output, "sizeof(hevo_state) ");
    let stack = number_after(&output, "stack at most ");
    assert!(
        state + stack < 8192.0,
        "state {state} + stack {stack} bytes:\n{output}"
    );
}
