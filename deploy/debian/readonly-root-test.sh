#!/usr/bin/env bash
# The packaged service on a read-only root (issue 46): in a root where the frontseat package is
# installed (an arm64 one under qemu in CI, or any other), everything is mounted read-only but the
# units' ReadWritePaths= (/var/lib/frontseat, /var/log/frontseat), as on an image that overlays
# its root; /tmp is private (PrivateTmp=). The sim and interface units' ExecStart then run there as
# the units say (User=, WorkingDirectory=, Environment=), the interface configured to record,
# until the interface reaches running:command and has written a recording; SIGTERM ends both,
# which must exit 0 with no write refused. What is not systemd here: no PID 1, so the directories
# StateDirectory=/LogsDirectory= would make are made by this script, and the rest of the sandbox
# (DevicePolicy=, SystemCallFilter=, ...) is checked by `systemd-analyze verify`/`security` only.
#
#   deploy/debian/readonly-root-test.sh ROOT      # as root; ROOT has the package installed
set -euo pipefail
root="$(cd "${1:?usage: readonly-root-test.sh ROOT}" && pwd)"
[ "$(id -u)" = 0 ] || { echo "readonly-root-test.sh: needs root" >&2; exit 2; }
fail() { echo "readonly-root-test.sh: FAILED: $*" >&2; exit 1; }
units="$root/lib/systemd/system"
[ -f "$units/frontseat-interface.service" ] || fail "no frontseat package installed in $root"

key() { sed -n "s/^$2=//p" "$units/$1" | tail -1; }
for u in frontseat-sim.service frontseat-interface.service; do
  [ "$(key "$u" ProtectSystem)" = strict ] || fail "$u: ProtectSystem is not strict"
done
rw="$(key frontseat-interface.service ReadWritePaths)"
[ "$rw" = "/var/lib/frontseat /var/log/frontseat" ] || fail "interface ReadWritePaths=$rw"
user="$(key frontseat-interface.service User)"

work="$(mktemp -d)"
cfg="$root/etc/frontseat/interface.toml"
cp -p "$cfg" "$work/interface.toml.orig"
cleanup() {
  cp -p "$work/interface.toml.orig" "$cfg"
  rm -rf "$work"
}
trap cleanup EXIT
# The packaged config, set to record where the unit may write, and to command without a helm.
sed -i 's/^require_helm = true/require_helm = false/' "$cfg"
cat >> "$cfg" <<'EOF'

# added by readonly-root-test.sh
[record]
enabled = true
dir = "/var/log/frontseat"
flush_s = 0.5
EOF
# What StateDirectory= and LogsDirectory= make before the service starts.
for d in $rw; do
  rm -rf "${root:?}$d"
  install -d -m 0750 "$root$d"
  chroot "$root" chown "$user:$user" "$d"
done

# Each unit's ExecStart, as the unit's user in its working directory with its environment.
cmd_of() { # UNIT -> a shell command run inside the root
  local u="$units/$1"
  printf 'cd %q && exec setpriv --reuid=%q --regid=%q --init-groups --inh-caps=-all -- env -i %s %s' \
    "$(key "$1" WorkingDirectory)" "$(key "$1" User)" "$(key "$1" Group)" \
    "$(sed -n 's/^Environment=//p' "$u" | tr '\n' ' ')" "$(key "$1" ExecStart)"
}
sim_cmd="$(cmd_of frontseat-sim.service)"
iface_cmd="$(cmd_of frontseat-interface.service)"
echo "sim:       $sim_cmd"
echo "interface: $iface_cmd"

unshare -m --propagation private -- bash -euo pipefail -c '
  r="$1" work="$2" rw="$3" sim_cmd="$4" iface_cmd="$5"
  fail() { echo "readonly-root-test.sh: FAILED: $*" >&2; exit 1; }
  # The root read-only, then its writable paths bound over it (their own mounts stay writable).
  mount --bind "$r" "$r"
  for d in $rw; do mount --bind "$r$d" "$r$d"; done
  mount -o remount,bind,ro "$r"
  mount -t proc proc "$r/proc"
  mount --rbind /dev "$r/dev"
  mount -t tmpfs tmpfs "$r/tmp"
  # The check can fail: a write outside them is refused, for root too.
  if chroot "$r" touch /etc/frontseat/probe 2>/dev/null || chroot "$r" touch /usr/probe 2>/dev/null; then
    fail "the root is not read-only"
  fi
  chroot "$r" sh -c "$sim_cmd" >"$work/sim.log" 2>&1 &
  sim=$!
  chroot "$r" sh -c "$iface_cmd" >"$work/interface.log" 2>&1 &
  iface=$!
  stop() { kill -TERM "$iface" "$sim" 2>/dev/null || true; wait "$iface" "$sim" 2>/dev/null || true; }
  # Under qemu a start takes seconds: up to 120 s for running:command, then 60 s for a recording.
  ok=
  for _ in $(seq 1200); do
    if grep -q "to=\"running:command\"" "$work/interface.log"; then ok=1; break; fi
    kill -0 "$iface" 2>/dev/null || break
    sleep 0.1
  done
  [ -n "$ok" ] || { stop; cat "$work/sim.log" "$work/interface.log" >&2; fail "the interface never reached running:command"; }
  rec=
  for _ in $(seq 600); do
    rec="$(find "$r/var/log/frontseat" -name "*.mcap" -size +4k | head -1)"
    [ -n "$rec" ] && break
    sleep 0.1
  done
  [ -n "$rec" ] || { stop; cat "$work/interface.log" >&2; fail "no recording under /var/log/frontseat"; }
  kill -TERM "$iface"
  iface_rc=0; wait "$iface" || iface_rc=$?
  kill -TERM "$sim"
  sim_rc=0; wait "$sim" || sim_rc=$?
  [ "$iface_rc" = 0 ] || { cat "$work/interface.log" >&2; fail "the interface exited $iface_rc after SIGTERM"; }
  [ "$sim_rc" = 0 ] || { cat "$work/sim.log" >&2; fail "the sim exited $sim_rc after SIGTERM"; }
' bash "$root" "$work" "$rw" "$sim_cmd" "$iface_cmd"

if grep -iE 'read-only file system|os error 30' "$work/sim.log" "$work/interface.log"; then
  fail "a write was refused"
fi
echo "written, all under $rw:"
for d in $rw; do (cd "$root$d" && find . -type f -printf "  $d/%P %s bytes\n"); done
echo "readonly-root-test.sh: the sim and interface ran, commanded and recorded on a read-only root"
