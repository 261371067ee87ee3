#!/usr/bin/env bash
# Builds the Debian package from already-built binaries, installs it on this machine, checks it
# and removes it again: `frontseat --version`, the units through `systemd-analyze verify`, the man
# page through `man -w`, the user in dialout, the conffiles, nothing enabled; `dpkg -r` removes the
# binaries and keeps an edited conffile; `dpkg -P` leaves nothing of the package behind.
#
#   deploy/debian/test-package.sh BIN_DIR      # e.g. target/release, or target/debug in CI
#
# Needs root, dpkg, cargo-deb (`cargo install cargo-deb --locked`), systemd-analyze and man-db.
# CI packages the dev-profile binaries its tests built (cargo-deb strips them) rather than pay a
# second, release build; `cargo deb` alone builds the release package users install.
set -euo pipefail
cd "$(dirname "$0")/../.."

bin_dir="${1:?usage: test-package.sh BIN_DIR}"
bin_dir="$(cd "$bin_dir" && pwd)"
[ "$(id -u)" = 0 ] || { echo "test-package.sh: needs root (dpkg -i)" >&2; exit 2; }
if dpkg-query -W -f='${Status}' frontseat 2>/dev/null | grep -qE 'installed|config-files'; then
  # Under CI, a run killed before its cleanup left it: the machine is CI's own. Elsewhere it may
  # be someone's installation: refuse.
  if [ "${CI:-}" = true ]; then
    echo "test-package.sh: purging a frontseat package left by an earlier run"
    dpkg -P frontseat
  else
    echo "test-package.sh: a frontseat package is installed here; remove it first (dpkg -P frontseat)" >&2
    exit 2
  fi
fi

fail() { echo "test-package.sh: FAILED: $*" >&2; exit 1; }
work="$(mktemp -d)"
cleanup() {
  # Never leave the package installed after a failed check.
  dpkg -P frontseat >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT

# cargo-deb takes the binaries from <target dir>/release: point it at the given ones.
mkdir -p "$work/target/release"
for b in frontseat frontseat-bench frontseat-chaos; do
  [ -x "$bin_dir/$b" ] || fail "$bin_dir/$b not built"
  ln -s "$bin_dir/$b" "$work/target/release/$b"
done
start=$(date +%s)
# --fast: lighter compression; this package is installed once and thrown away.
mkdir -p "$work/out"
CARGO_TARGET_DIR="$work/target" cargo deb --no-build --fast --output "$work/out/"
deb="$(ls "$work"/out/frontseat_*.deb)"
ddeb="$(ls "$work"/out/frontseat-dbgsym_*.ddeb)" || fail "no -dbgsym package"
echo "package: $(du -h "$deb" | cut -f1) ($(( $(date +%s) - start )) s to build)"
dpkg-deb --info "$deb" | grep -E '^ (Package|Version|Architecture|Depends|Installed-Size):'
dpkg-deb --contents "$deb" | awk '{print $6}' | sed 's#^\./#/#' > "$work/contents"
unstripped=$(stat -c %s "$bin_dir/frontseat")

dpkg -i "$deb"

# The binary, its version line, and that it was stripped.
[ "$(command -v frontseat)" = /usr/bin/frontseat ] || fail "frontseat is not /usr/bin/frontseat"
frontseat --version
frontseat --version | grep -qE '^frontseat [0-9]+\.[0-9]+\.[0-9]+' || fail "--version"
frontseat --version | grep -q '^commit: ' || fail "--version names no commit"
frontseat --version | grep -q '^build: ' || fail "--version names no build"
stripped=$(stat -c %s /usr/bin/frontseat)
echo "frontseat binary: $((unstripped / 1048576)) MiB built, $((stripped / 1048576)) MiB installed"
if file /usr/bin/frontseat 2>/dev/null | grep -q 'not stripped'; then fail "/usr/bin/frontseat is not stripped"; fi
[ "$stripped" -lt "$unstripped" ] || fail "/usr/bin/frontseat is no smaller than the built binary"
# The debug info is in the -dbgsym package, not in this one.
if grep -q '^/usr/lib/debug/' "$work/contents"; then fail "debug symbols inside the main package"; fi
dpkg-deb --contents "$ddeb" > "$work/ddeb-contents"
grep -q '/usr/lib/debug/.build-id/.*\.debug' "$work/ddeb-contents" || fail "no debug symbols in $ddeb"
echo "dbgsym package: $(du -h "$ddeb" | cut -f1)"

# The units, where Debian puts them, verified against the installed binary.
units=(frontseat-interface.service frontseat-sim.service frontseat-moos-gateway.service
  frontseat-topside.service frontseat-interface@.service)
for u in "${units[@]}"; do
  [ -f "/lib/systemd/system/$u" ] || fail "/lib/systemd/system/$u missing"
  grep -q '^ExecStart=/usr/bin/frontseat ' "/lib/systemd/system/$u" || fail "$u does not run /usr/bin/frontseat"
done
verify_out="$(SYSTEMD_LOG_COLOR=0 systemd-analyze verify frontseat-interface.service \
  frontseat-sim.service frontseat-moos-gateway.service frontseat-topside.service \
  frontseat-interface@auv1.service 2>&1)" || fail "systemd-analyze verify: $verify_out"
if grep -q 'frontseat' <<<"$verify_out"; then fail "systemd-analyze verify: $verify_out"; fi
echo "systemd-analyze verify: ${#units[@]} units clean"

# Nothing enabled or started by installing.
if ls /etc/systemd/system/*.wants/frontseat-* >/dev/null 2>&1; then fail "a unit was enabled"; fi

# Man pages and completions.
man -w frontseat || fail "man -w frontseat"
man -w frontseat-interface >/dev/null || fail "man -w frontseat-interface"
[ -s /usr/share/bash-completion/completions/frontseat ] || fail "bash completion"
[ -s /usr/share/zsh/vendor-completions/_frontseat ] || fail "zsh completion"
[ -s /usr/share/fish/vendor_completions.d/frontseat.fish ] || fail "fish completion"

# The user, in dialout; the configs, conffiles, readable by it.
id frontseat
id -nG frontseat | tr ' ' '\n' | grep -qx dialout || fail "frontseat is not in dialout"
conffiles="$(dpkg-query -W -f='${Conffiles}\n' frontseat)"
for c in interface sim moos-gateway topside; do
  grep -q "/etc/frontseat/$c.toml" <<<"$conffiles" || fail "/etc/frontseat/$c.toml is not a conffile"
done
[ "$(stat -c %G /etc/frontseat)" = frontseat ] || fail "/etc/frontseat not group frontseat"
for s in interface sim moos-gateway topside; do
  runuser -u frontseat -- frontseat "$s" --check -c "/etc/frontseat/$s.toml" \
    || fail "the packaged /etc/frontseat/$s.toml does not pass --check as the service user"
done

# Remove: binaries gone, an edited conffile kept.
echo "# edited by test-package.sh" >> /etc/frontseat/interface.toml
dpkg -r frontseat
[ ! -e /usr/bin/frontseat ] || fail "/usr/bin/frontseat left after dpkg -r"
[ ! -e /lib/systemd/system/frontseat-interface.service ] || fail "unit left after dpkg -r"
grep -q '^# edited by test-package.sh' /etc/frontseat/interface.toml || fail "edited conffile not kept by dpkg -r"

# Purge: nothing of the package left.
dpkg -P frontseat
[ ! -e /etc/frontseat ] || fail "/etc/frontseat left after dpkg -P"
left=()
while IFS= read -r f; do
  case "$f" in */) continue ;; esac
  [ -e "$f" ] && left+=("$f")
done < "$work/contents"
[ ${#left[@]} -eq 0 ] || fail "left after dpkg -P: ${left[*]}"
dpkg-query -W -f='${Status}' frontseat 2>/dev/null | grep -q installed && fail "still installed"
echo "test-package.sh: the package installs, checks and removes clean"
