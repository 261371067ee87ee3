#!/usr/bin/env bash
# The memory footprint of `frontseat sim` + `frontseat interface` at 10 Hz (the sim's default
# rate), as BENCHMARKS.md's "arm64 footprint" section reports it: both started from BIN, the
# interface with no helm needed (require_helm = false) so it reaches running:command; after it
# does, SETTLE seconds, then RSS from /proc/<pid>/status and, per mapping, /proc/<pid>/smaps.
#
#   deploy/debian/footprint.sh BIN [SETTLE]   # prints one line per process
#
# Under qemu-user (an arm64 BIN through binfmt_misc) the process is qemu: its RSS holds the
# guest's pages (qemu maps guest memory 1:1 into its own) plus qemu's own — its binary, its heap
# and the translated-code buffer (the only read-write-execute mappings), counted apart. What qemu
# allocates by mmap (its page tables for the guest, translation metadata) cannot be told from the
# guest's anonymous memory and stays in "the rest": under qemu that figure is an upper bound.
set -euo pipefail
bin="${1:?usage: footprint.sh BIN [SETTLE]}"
settle="${2:-10}"
work="$(mktemp -d)"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
port=$((20000 + RANDOM % 20000))
"$bin" sim --port "$port" >"$work/sim.log" 2>&1 &
pids+=($!)
sim=$!
cat >"$work/iface.toml" <<EOF
name = "footprint-auv"
require_helm = false
[driver]
name = "basic_simulator"
[driver.basic_simulator]
tcp_port = $port
EOF
for _ in $(seq 600); do grep -q "simulator listening" "$work/sim.log" && break; sleep 0.1; done
"$bin" interface -c "$work/iface.toml" >"$work/iface.log" 2>&1 &
pids+=($!)
iface=$!
ok=
for _ in $(seq 1200); do
  if grep -q 'to="running:command"' "$work/iface.log"; then ok=1; break; fi
  sleep 0.1
done
[ -n "$ok" ] || { cat "$work/sim.log" "$work/iface.log" >&2; echo "footprint.sh: no running:command" >&2; exit 1; }
sleep "$settle"
report() { # NAME PID
  local qemu=0
  case "$(readlink "/proc/$2/exe")" in *qemu*) qemu=1 ;; esac
  awk -v name="$1" -v qemu="$qemu" -v bin="$(basename "$bin")" '
    /^[0-9a-f]+-[0-9a-f]+ / {
      perms = $2; path = $6
      own = qemu && (path ~ /qemu/ || path == "[heap]" || perms == "rwxp")
      file = !own && path ~ ("/" bin "$")
    }
    /^Rss:/ { total += $2; if (own) mine += $2; else if (file) exe += $2; else rest += $2 }
    END {
      printf "%s: RSS %.1f MiB = the program file %.1f + the rest (heap, stacks, libraries) %.1f", name, total / 1024, exe / 1024, rest / 1024
      if (qemu) printf " + qemu itself (its binary, heap, code buffer) %.1f", mine / 1024
      printf " MiB\n"
    }
  ' "/proc/$2/smaps"
}
report sim "$sim"
report interface "$iface"
