# shellcheck shell=bash
# Sourced by package.sh and arm64-ci.sh: the arm64 build root and how to run things in it.
#
# Why a chroot of Debian unstable: rustup reaches no other target's standard library here, but
# Debian ships one per architecture (`libstd-rust-dev:arm64`, the same version as its `rustc`).
# Unstable's rustc is new enough for the workspace (rust-version in Cargo.toml); bookworm's is not.
# So the build root is a Debian unstable chroot for the host (amd64) made by mmdebstrap, with
# multiarch arm64 enabled: Debian's rustc and cargo run natively (no emulation while compiling),
# link with gcc-aarch64-linux-gnu against libc6-dev:arm64, and strip with its binutils. Nothing of
# unstable enters the host. arm64 programs (the tests, the demo, dpkg in an arm64 root) run under
# qemu-user through binfmt_misc, registered with the F flag so they run inside chroots too.
#
# The binaries are linked against an older glibc than unstable's (see ARM64_SYSROOT_SUITE).
#
# Everything lives under one cache directory, out of the tracked tree (target/ is ignored):
#   $ARM64_CACHE/chroot       the build root (remade when the package list below changes)
#   $ARM64_CACHE/target       its cargo target dir (never the host's target/debug)
#   $ARM64_CACHE/cargo-home   its cargo registry
#   $ARM64_CACHE/root-arm64   an arm64 Debian 12 root the package is installed into (CI)

ARM64_REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
ARM64_CACHE="${FRONTSEAT_ARM64_CACHE:-$ARM64_REPO/target/arm64}"
ARM64_TRIPLE=aarch64-unknown-linux-gnu
ARM64_MIRROR="${FRONTSEAT_DEBIAN_MIRROR:-http://deb.debian.org/debian}"
# The build root's packages; a change here remakes the chroot.
ARM64_PACKAGES="rustc,cargo,libstd-rust-dev:arm64,gcc-aarch64-linux-gnu,libc6-dev:arm64,gcc,libc6-dev,dpkg-dev,ca-certificates,file,qemu-user"
# The registry may serve a snapshot whose Release file is past its Valid-Until date.
ARM64_APTOPT='Acquire::Check-Valid-Until "false"'

arm64_log() { echo "arm64: $*" >&2; }

# Installs a Debian (host) package if its command is missing.
arm64_need() { # COMMAND PACKAGE
  command -v "$1" >/dev/null 2>&1 && return 0
  arm64_log "installing $2 (for $1)"
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$2" >/dev/null
}

# qemu-aarch64 through binfmt_misc, registered with the F flag (the interpreter is opened at
# registration, so arm64 programs run inside chroots that have no qemu of their own). The
# interpreter is the build root's qemu-user (Debian unstable's, 11.x; it is in ARM64_PACKAGES):
# bookworm's qemu-user-static (7.2) lacks the TCGETS2 ioctl the serial crate sets a tty up with,
# so the pseudo-terminal tests fail under it with ENOSYS. Registered anew each time (the build
# root may have been remade); the entry is the machine's, named qemu-aarch64 as Debian's is.
arm64_binfmt() {
  local dir=/proc/sys/fs/binfmt_misc
  local qemu="$ARM64_CACHE/chroot/usr/bin/qemu-aarch64"
  [ -x "$qemu" ] || { arm64_log "no $qemu: make the build root first (arm64_chroot)"; return 1; }
  if [ ! -e "$dir/register" ]; then
    mount -t binfmt_misc binfmt_misc "$dir" \
      || { arm64_log "cannot mount binfmt_misc (needs root, or a privileged container)"; return 1; }
  fi
  if [ -e "$dir/qemu-aarch64" ]; then echo -1 > "$dir/qemu-aarch64"; fi
  # The ELF header of an aarch64 executable (e_machine 0xb7), as Debian's qemu-user-binfmt has it.
  printf '%s' ':qemu-aarch64:M::\x7f\x45\x4c\x46\x02\x01\x01\x00\x00\x00\x00\x00\x00\x00\x00\x00\x02\x00\xb7\x00:\xff\xff\xff\xff\xff\xff\xff\x00\xff\xff\xff\xff\xff\xff\xff\xff\xfe\xff\xff\xff:'"$qemu"':F' \
    > "$dir/register"
  grep -q '^enabled' "$dir/qemu-aarch64" \
    || { arm64_log "qemu-aarch64 is not enabled in binfmt_misc"; return 1; }
}

# The glibc the binaries are linked against: Debian 12's (2.36), extracted (not installed) into
# the build root as a sysroot. Linked against unstable's own glibc they would need 2.39 (Rust's
# std refers to pidfd_spawnp with that version) and run on no Debian 12, Raspberry Pi OS 12 or
# Ubuntu 22.04 (a Jetson's JetPack 6); against this one they need 2.35 (hypot's version).
ARM64_SYSROOT_SUITE=bookworm
# What the build root is made of; a change here remakes it.
ARM64_STAMP="$ARM64_PACKAGES sysroot=$ARM64_SYSROOT_SUITE v2"

# The build root, made once (about 2 minutes, 1.6 GB) and reused while ARM64_STAMP holds.
arm64_chroot() {
  local root="$ARM64_CACHE/chroot"
  if [ -f "$root/.frontseat-stamp" ] && [ "$(cat "$root/.frontseat-stamp")" = "$ARM64_STAMP" ]; then
    return 0
  fi
  arm64_need mmdebstrap mmdebstrap
  mkdir -p "$ARM64_CACHE"
  rm -rf "$root" "$root.new"
  arm64_log "making the build root (Debian unstable, mmdebstrap) in $root"
  mmdebstrap --quiet --variant=apt --architectures=amd64,arm64 --aptopt="$ARM64_APTOPT" \
    --include="$ARM64_PACKAGES" unstable "$root.new" "$ARM64_MIRROR"
  arm64_setup_root "$root.new"
  mv "$root.new" "$root"
  arm64_log "build root: $(chroot "$root" rustc --version)"
}

# The sysroot, the compiler wrapper and cargo's cross settings in a fresh build root.
arm64_setup_root() { # ROOT
  local root="$1"
  mkdir -p "$root/src" "$root/build/target" "$root/build/cargo-home" "$root/out" "$root/opt"
  rm -rf "$root/opt/sysroot"
  mmdebstrap --quiet --variant=extract --architectures=arm64 --aptopt="$ARM64_APTOPT" \
    --include=libc6-dev,libgcc-s1 "$ARM64_SYSROOT_SUITE" "$root/opt/sysroot" "$ARM64_MIRROR"
  # Cargo links with, and the cc crate compiles C (ring, zstd, lz4) with, aarch64-linux-gnu-gcc
  # from PATH: in the build root that is this wrapper, so both see the sysroot's glibc.
  printf '%s\n' '#!/bin/sh' \
    '# frontseat arm64 build root (deploy/debian/arm64-env.sh): Debian cross gcc against the glibc' \
    '# of the sysroot in /opt/sysroot, so that the binaries run on that release and later.' \
    'exec /usr/bin/aarch64-linux-gnu-gcc --sysroot=/opt/sysroot "$@"' \
    > "$root/usr/local/bin/aarch64-linux-gnu-gcc"
  chmod 755 "$root/usr/local/bin/aarch64-linux-gnu-gcc"
  # Cargo's cross settings (cargo-deb reads strip and objcopy from here too).
  printf '%s\n' "[target.$ARM64_TRIPLE]" 'linker = "aarch64-linux-gnu-gcc"' \
    'strip = { path = "aarch64-linux-gnu-strip" }' 'objcopy = { path = "aarch64-linux-gnu-objcopy" }' \
    > "$root/build/cargo-config.toml"
  echo "$ARM64_STAMP" > "$root/.frontseat-stamp"
}

# The crates the build needs, fetched by the host's cargo into the build root's cargo home (the
# host's network set-up, certificates included, is the one that works; the build root then builds
# offline).
arm64_fetch() {
  mkdir -p "$ARM64_CACHE/cargo-home"
  CARGO_HOME="$ARM64_CACHE/cargo-home" cargo fetch --locked --manifest-path "$ARM64_REPO/Cargo.toml"
}

# Runs a command in the build root, in a private mount namespace (nothing stays mounted): the
# work tree (or ARM64_SRC, another tree of the same project) read-only at /src (the working directory), the cache's target and cargo-home at
# /build, ARM64_OUT (if set) at /out. EXTRA_BIND="host:inside" binds one more path (read-only).
arm64_run() {
  local root="$ARM64_CACHE/chroot"
  mkdir -p "$ARM64_CACHE/target" "$ARM64_CACHE/cargo-home"
  local commit
  commit="$(git -C "$ARM64_REPO" rev-parse --short=10 HEAD 2>/dev/null || echo unknown)"
  FRONTSEAT_GIT_COMMIT="$commit" ARM64_OUT="${ARM64_OUT:-}" EXTRA_BIND="${EXTRA_BIND:-}" ARM64_SRC="${ARM64_SRC:-}" \
    ARM64_ENV="${ARM64_ENV:-}" unshare -m --propagation private -- bash -euo pipefail -c '
    root="$1"; shift
    mount --bind "${ARM64_SRC:-$ARM64_REPO}" "$root/src"; mount -o remount,bind,ro "$root/src"
    mount --bind "$ARM64_CACHE/target" "$root/build/target"
    mount --bind "$ARM64_CACHE/cargo-home" "$root/build/cargo-home"
    cp "$root/build/cargo-config.toml" "$ARM64_CACHE/cargo-home/config.toml"
    if [ -n "$ARM64_OUT" ]; then mount --bind "$ARM64_OUT" "$root/out"; fi
    if [ -n "$EXTRA_BIND" ]; then
      if [ -d "${EXTRA_BIND%%:*}" ]; then mkdir -p "$root${EXTRA_BIND#*:}"; else touch "$root${EXTRA_BIND#*:}"; fi
      mount --bind "${EXTRA_BIND%%:*}" "$root${EXTRA_BIND#*:}"
      mount -o remount,bind,ro "$root${EXTRA_BIND#*:}"
    fi
    mount -t proc proc "$root/proc"
    mount --rbind /dev "$root/dev"
    mount -t tmpfs tmpfs "$root/tmp"
    cp /etc/resolv.conf "$root/etc/resolv.conf" 2>/dev/null || true
    exec chroot "$root" /usr/bin/env -i PATH=/usr/local/bin:/usr/bin:/bin HOME=/root \
      CARGO_HOME=/build/cargo-home CARGO_TARGET_DIR=/build/target CARGO_TERM_COLOR=never \
      CARGO_INCREMENTAL=0 CARGO_NET_OFFLINE=true FRONTSEAT_GIT_COMMIT="$FRONTSEAT_GIT_COMMIT" \
      RUST_BACKTRACE=1 $ARM64_ENV \
      bash -c "cd /src && exec \"\$@\"" bash "$@"
  ' bash "$root" "$@"
}
export ARM64_REPO ARM64_CACHE
