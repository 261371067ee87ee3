#!/usr/bin/env bash
# Builds the Debian package, target/debian/frontseat_<version>_<arch>.deb, and its debug symbols,
# frontseat-dbgsym_<version>_<arch>.ddeb, from one command:
#
#   deploy/debian/package.sh                # amd64 (this machine): `cargo deb`, a release build
#   deploy/debian/package.sh --arch arm64   # arm64, cross-built here in a Debian chroot
#
# Options:
#   --arch amd64|arm64   the package's architecture (default amd64)
#   --bin-dir DIR        package these already-built binaries instead of a release build (CI
#                        packages its dev binaries; for arm64, DIR is inside the arm64 cache,
#                        e.g. target/arm64/target/aarch64-unknown-linux-gnu/debug)
#   --out DIR            where the .deb goes (default target/debian)
#   --fast               lighter compression (a package installed once and thrown away)
#
# Both use cargo-deb and the one [package.metadata.deb] in Cargo.toml, so the arm64 package has the
# amd64 one's contents: binaries, units, man pages, completions, conffiles, maintainer scripts.
# arm64: Debian unstable's rustc, cargo and libstd-rust-dev:arm64 in a chroot under target/arm64
# (deploy/debian/arm64-env.sh says why and how); the first run makes it (about 2 minutes and
# 1.6 GB), the release build takes as long as the amd64 one. Needs root (mmdebstrap, chroot, mount
# namespaces), apt (it installs mmdebstrap and qemu-user-static if missing) and cargo-deb on this
# machine (`cargo install cargo-deb --locked --version 3.8.0`), which runs inside the chroot.
set -euo pipefail
cd "$(dirname "$0")/../.."

arch=amd64
bin_dir=
out="$PWD/target/debian"
fast=()
while [ $# -gt 0 ]; do
  case "$1" in
    --arch) arch="${2:?--arch needs amd64 or arm64}"; shift 2 ;;
    --bin-dir) bin_dir="${2:?--bin-dir needs a directory}"; shift 2 ;;
    --out) out="${2:?--out needs a directory}"; shift 2 ;;
    --fast) fast=(--fast); shift ;;
    -h | --help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "package.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
mkdir -p "$out"
out="$(cd "$out" && pwd)"
command -v cargo-deb >/dev/null 2>&1 \
  || { echo "package.sh: needs cargo-deb (cargo install cargo-deb --locked --version 3.8.0)" >&2; exit 2; }

case "$arch" in
  amd64)
    [ "$(dpkg --print-architecture)" = amd64 ] || { echo "package.sh: this machine is not amd64" >&2; exit 2; }
    if [ -z "$bin_dir" ]; then
      exec cargo deb --locked "${fast[@]}" --output "$out/"
    fi
    bin_dir="$(cd "$bin_dir" && pwd)"
    work="$(mktemp -d)"
    trap 'rm -rf "$work"' EXIT
    # cargo-deb takes the binaries from <target dir>/release: point it at the given ones.
    mkdir -p "$work/release"
    for b in frontseat frontseat-bench frontseat-chaos; do
      [ -x "$bin_dir/$b" ] || { echo "package.sh: $bin_dir/$b not built" >&2; exit 1; }
      ln -s "$bin_dir/$b" "$work/release/$b"
    done
    CARGO_TARGET_DIR="$work" cargo deb --no-build "${fast[@]}" --output "$out/"
    ;;
  arm64)
    [ "$(id -u)" = 0 ] || { echo "package.sh: --arch arm64 needs root (chroot, mount namespace)" >&2; exit 2; }
    # shellcheck source=deploy/debian/arm64-env.sh
    . deploy/debian/arm64-env.sh
    arm64_chroot
    arm64_fetch
    in_dir=/build/target/$ARM64_TRIPLE/release
    if [ -z "$bin_dir" ]; then
      arm64_run cargo build --locked --release --target "$ARM64_TRIPLE" -p frontseat --bins
    else
      bin_dir="$(cd "$bin_dir" && pwd)"
      case "$bin_dir" in
        "$ARM64_CACHE/target/"*) in_dir="/build/target/${bin_dir#"$ARM64_CACHE/target/"}" ;;
        *) echo "package.sh: --bin-dir for arm64 must be under $ARM64_CACHE/target" >&2; exit 2 ;;
      esac
    fi
    # cargo-deb (this machine's binary, bound into the chroot) with --target finds the binaries in
    # <target dir>/aarch64-unknown-linux-gnu/release: a scratch target dir points there, so a dev
    # build can be packaged as CI does. Its strip and objcopy are the arm64 binutils (the chroot's
    # cargo config); $auto's Depends come from the chroot's dpkg-shlibdeps and libc6:arm64.
    EXTRA_BIND="$(command -v cargo-deb):/usr/local/bin/cargo-deb" ARM64_OUT="$out" \
      arm64_run bash -euo pipefail -c '
        t=/tmp/pkg-target/'"$ARM64_TRIPLE"'/release
        mkdir -p "$t"
        for b in frontseat frontseat-bench frontseat-chaos; do
          [ -x "$1/$b" ] || { echo "package.sh: $1/$b not built" >&2; exit 1; }
          ln -s "$1/$b" "$t/$b"
        done
        shift
        CARGO_TARGET_DIR=/tmp/pkg-target cargo-deb --no-build --target '"$ARM64_TRIPLE"' "$@" --output /out/
      ' bash "$in_dir" "${fast[@]}"
    ;;
  *) echo "package.sh: --arch must be amd64 or arm64" >&2; exit 2 ;;
esac
ls -1 "$out"/frontseat*_"$arch".*deb
