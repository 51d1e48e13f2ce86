#!/usr/bin/env bash
# Installs what `make check-qemu` in a `hevo export` directory needs, from Debian's packages:
# the Arm cross-compiler (gcc-arm-none-eabi), its C library with semihosting
# (libnewlib-arm-none-eabi) and the emulator (qemu-system-arm, whose netduinoplus2 machine is
# an STM32F405, close to the e-puck2's STM32F407). Idempotent: installed packages are left as
# they are. As root (CI runs it as root through scripts/install-test-tools.sh); otherwise it
# says what to install and fails.
#
#   scripts/install-export-tools.sh
set -euo pipefail

packages=(gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm)

log() {
    echo "install-export-tools: $*" >&2
}

missing=()
for package in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q 'install ok installed' ||
        missing+=("$package")
done

if ((${#missing[@]} > 0)); then
    if ! command -v apt-get >/dev/null; then
        log "no apt-get: install ${missing[*]} (or your system's Arm GCC, newlib and QEMU) yourself"
        exit 1
    fi
    if ((EUID != 0)); then
        log "needs the Debian packages ${missing[*]}: apt-get install ${missing[*]} (as root)"
        exit 1
    fi
    log "apt-get install ${missing[*]}"
    if ! apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null; then
        apt-get update -q >/dev/null
        apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
    fi
fi

for tool in arm-none-eabi-gcc arm-none-eabi-size qemu-system-arm; do
    command -v "$tool" >/dev/null || {
        log "no $tool after installing ${packages[*]}"
        exit 1
    }
done
log "$(arm-none-eabi-gcc --version | head -n 1); $(qemu-system-arm --version | head -n 1)"
