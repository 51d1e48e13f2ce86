#!/usr/bin/env bash
# Builds a stand-in for the Dockerfile's runtime base (distroless cc-debian12: glibc, libgcc,
# no shell, no package manager, a `nonroot` user) from this machine's Debian packages, for
# machines that reach Debian's package mirrors but no container registry. The live container
# tests use it; anyone can:
#
#   deploy/debian-base.sh localhost/hevo-base:debian
#   podman build -f deploy/Dockerfile --build-arg RUNTIME_IMAGE=localhost/hevo-base:debian \
#       --build-context build=DIR -t hevo:local .
#
# (DIR holds out/bin/{hevo,hevo-worker}, built on this machine, and an empty out/var/lib/hevo:
# see deploy/README.md.) The packages come from apt's configured mirrors (`apt-get download`,
# no root needed), are unpacked with dpkg-deb into a directory and imported with
# `podman import` (or the engine in $CONTAINER_ENGINE, e.g. docker). The release is this
# machine's, so binaries linked here find the glibc they were linked with.
set -euo pipefail

usage() {
    cat <<'EOF'
usage: debian-base.sh IMAGE

Assembles glibc, libgcc and a nonroot user from this machine's Debian packages and imports
them as IMAGE with podman (or $CONTAINER_ENGINE).
EOF
}

die() {
    echo "debian-base.sh: $*" >&2
    exit 2
}

case "${1:-}" in
    -h | --help)
        usage
        exit 0
        ;;
    "" | -*)
        usage >&2
        exit 2
        ;;
esac
image=$1
engine=${CONTAINER_ENGINE:-podman}
command -v apt-get >/dev/null || die "needs apt-get (a Debian or Ubuntu machine)"
command -v dpkg-deb >/dev/null || die "needs dpkg-deb"
command -v "$engine" >/dev/null || die "no $engine (set CONTAINER_ENGINE to docker or podman)"

# What distroless/cc holds that the binaries need: the C library, libgcc's unwinder, and the
# files that name the system, its services and its users.
packages=(base-files netbase libc6 libgcc-s1)

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/debs" "$work/root"
(cd "$work/debs" && apt-get download -q "${packages[@]}" >/dev/null 2>&1) ||
    die "apt-get download ${packages[*]} failed: update apt's lists (apt-get update, as root)"
for deb in "$work"/debs/*.deb; do
    dpkg-deb --extract "$deb" "$work/root"
done

root=$work/root
# Distroless's users: root, nobody and nonroot (65532), each without a login shell.
mkdir -p "$root/etc" "$root/tmp" "$root/root" "$root/home/nonroot"
cat >"$root/etc/passwd" <<'EOF'
root:x:0:0:root:/root:/sbin/nologin
nobody:x:65534:65534:nobody:/nonexistent:/sbin/nologin
nonroot:x:65532:65532:nonroot:/home/nonroot:/sbin/nologin
EOF
cat >"$root/etc/group" <<'EOF'
root:x:0:
nobody:x:65534:
nonroot:x:65532:
EOF
chmod 1777 "$root/tmp"
chmod 700 "$root/root"
# No shell, as in distroless: nothing that could run a script in the image.
rm -rf "$root/bin/sh" "$root/usr/share/doc" "$root/usr/share/man" "$root/usr/share/lintian"

# Everything root's, but nonroot's home (unpacked as another user, everything becomes root's).
owner=(--owner=0 --group=0)
if ((EUID == 0)); then
    chown 65532:65532 "$root/home/nonroot"
    owner=()
fi
tar --numeric-owner ${owner[@]+"${owner[@]}"} -C "$root" -c . |
    "$engine" import \
        --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
        --change 'USER 65532:65532' \
        --change 'WORKDIR /home/nonroot' \
        - "$image" >/dev/null
echo "debian-base.sh: imported $image ($(cat "$root/etc/debian_version" 2>/dev/null || echo Debian): ${packages[*]})" >&2
