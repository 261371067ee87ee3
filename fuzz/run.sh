#!/usr/bin/env bash
# Runs the cargo-fuzz targets under libFuzzer (see fuzz/README.md and FUZZING.md).
#
#   fuzz/run.sh ci       [SECONDS]            every target, SECONDS each (default 15), FUZZ_JOBS (2) at
#                                             once: CI's smoke run
#   fuzz/run.sh campaign [SECONDS] [TARGET…]  every (or the named) target, one at a time, SECONDS
#                                             each (default 600), new inputs kept in the work dir
#   fuzz/run.sh merge    [TARGET…]            adds the campaign's new inputs (≤ 8 KiB) that reach new
#                                             edges to the checked-in corpus (set-cover merge, additive)
#   fuzz/run.sh bound                         checks every checked-in corpus against the size bound
#   fuzz/run.sh targets                       prints each target and its corpus directory
#
# Toolchain: the machine's stable Rust with RUSTC_BOOTSTRAP=1 (cargo-fuzz passes -Z flags); CI
# machines have no other toolchain. FUZZ_TOOLCHAIN=nightly uses `cargo +nightly` instead.
# Limits per run: -rss_limit_mb=512 (and malloc limit, the same), -timeout=10 s per input (30 in ci),
# -max_len=70000. The checked-in corpus is only read; new inputs, crash artifacts and logs go to
# FUZZ_WORK (default /tmp/frontseat-fuzz), outside the repository.
# Build dir: FUZZ_TARGET_DIR (default fuzz/target), separate from the workspace's target dir;
# FUZZ_NO_BUILD=1 runs the binaries already there.
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/.." && pwd)"
work="${FUZZ_WORK:-/tmp/frontseat-fuzz}"
target_dir="${FUZZ_TARGET_DIR:-$here/target}"
cargo_fuzz_version=0.13.2
# A single input running longer than this is a hang. CI raises it to 30 s: the crafted
# decompression-bomb seed (fuzz/corpus/mcap_reader/crafted_huge_definitions.mcap, 1.6 GiB of
# zstd output by design) takes about 8 s under ASan on a loaded 2-core machine.
timeout="${FUZZ_TIMEOUT:-10}"

# The size bound of each checked-in corpus (also checked by `cargo test --test fuzz_corpus`).
max_files=300
max_bytes=$((2 * 1024 * 1024))
# AddressSanitizer keeps freed memory in a quarantine (256 MB by default) to catch use after
# free; 64 MB leaves room under the 512 MB limit (mcap_reader peaked at 474 MB in 15 s with the
# default, 236 MB with this).
asan_options="detect_odr_violation=0:quarantine_size_mb=64"
# A campaign input larger than this is not merged into the checked-in corpus.
merge_max_bytes="${FUZZ_MERGE_MAX_BYTES:-8192}"

# target:corpus directory (relative to the repository root)
targets=(
  sim_codec:fuzz/corpus/sim_codec
  driver_line:vehicles/basic_simulator/fuzz/corpus
  moos_decode:fuzz/corpus/moos_decode
  config:fuzz/corpus/config
  sv2_frame:vehicles/waveglider_sv2/fuzz/corpus
  iver_sentence:vehicles/iver3/fuzz/corpus
  bluefin_codec:vehicles/bluefin/fuzz/corpus
  zmtp_guard:fuzz/corpus/zmtp_guard
  mavlink_frame:vehicles/ardupilot/fuzz/corpus
  mcap_reader:fuzz/corpus/mcap_reader
  goby_import:fuzz/corpus/goby_import
  imc_packet:vehicles/dune/fuzz/corpus
)

corpus_of() {
  local tc
  for tc in "${targets[@]}"; do
    if [ "${tc%%:*}" = "$1" ]; then
      echo "$root/${tc#*:}"
      return
    fi
  done
  echo "unknown target: $1" >&2
  exit 2
}

all_targets() {
  local tc
  for tc in "${targets[@]}"; do echo "${tc%%:*}"; done
}

cargo_fuzz() {
  if [ "${FUZZ_TOOLCHAIN:-}" != "" ]; then
    (cd "$here" && cargo "+$FUZZ_TOOLCHAIN" fuzz "$@")
  else
    (cd "$here" && RUSTC_BOOTSTRAP=1 cargo fuzz "$@")
  fi
}

ensure_cargo_fuzz() {
  export PATH="$HOME/.cargo/bin:$PATH"
  if [ "$(cargo fuzz --version 2>/dev/null)" != "cargo-fuzz $cargo_fuzz_version" ]; then
    cargo install cargo-fuzz --locked --version "$cargo_fuzz_version"
  fi
}

# FUZZ_PROFILE=dev builds unoptimized (`cargo fuzz build --dev`): CI's choice, a cold build of
# 6 min on 2 cores instead of about 15-20 for the optimized one, for 15 s smoke runs where
# executions per second do not matter (campaigns keep the default, optimized).
profile="${FUZZ_PROFILE:-release}"
case "$profile" in
  release) profile_flag=() profile_dir=release ;;
  dev) profile_flag=(--dev) profile_dir=debug ;;
  *) echo "fuzz: FUZZ_PROFILE must be release or dev, not $profile" >&2; exit 2 ;;
esac

binary() {
  echo "$target_dir/$(rustc -vV | sed -n 's/^host: //p')/$profile_dir/$1"
}

build() {
  if [ -n "${FUZZ_NO_BUILD:-}" ]; then
    echo "fuzz: FUZZ_NO_BUILD set: running the binaries already in $target_dir"
    return
  fi
  local t0=$SECONDS
  cargo_fuzz build "${profile_flag[@]}" --target-dir "$target_dir"
  echo "fuzz: built every target in $((SECONDS - t0)) s"
}

# One libFuzzer run of target $1 for $2 seconds (further arguments go to libFuzzer); new inputs
# go to $work/$1/new, findings to $work/$1/artifacts.
run_one() {
  local t=$1 secs=$2 corpus
  shift 2
  corpus="$(corpus_of "$t")"
  mkdir -p "$work/$t/new" "$work/$t/artifacts"
  local log="$work/$t/run-$(date -u +%Y%m%dT%H%M%S).log"
  echo "fuzz: $t for $secs s (log $log)"
  local rc=0
  # The binary `build` made, run directly: `cargo fuzz run` would rebuild first whenever a source
  # changed since, in the middle of a campaign.
  # No Rust backtrace: symbolizing one in this binary took more than the 512 MB limit, so a
  # panic was reported as an OOM and its input not kept (FUZZ_RUST_BACKTRACE=1 to get one).
  RUST_BACKTRACE="${FUZZ_RUST_BACKTRACE:-0}" \
    ASAN_OPTIONS="${ASAN_OPTIONS:-$asan_options}" "$(binary "$t")" "$work/$t/new" "$corpus" \
    -max_total_time="$secs" -rss_limit_mb=512 -malloc_limit_mb=512 -timeout="$timeout" \
    -max_len=70000 -print_final_stats=1 -artifact_prefix="$work/$t/artifacts/" "$@" \
    >"$log" 2>&1 || rc=$?
  ln -sf "$log" "$work/$t/last.log"
  local found
  found=$(find "$work/$t/artifacts" -type f | wc -l)
  summary "$t" "$log" "$rc" "$found"
  [ "$rc" = 0 ] && [ "$found" = 0 ]
}

# One table row from a run's log: target, runs, exec/s, edges (cov), features (ft), corpus, peak
# RSS in MB (plain runs only),
# and the findings (files in the artifacts dir: crash-, oom-, timeout-, slow-unit-).
summary() {
  local t=$1 log=$2 rc=$3 found=$4
  local runs eps cov ft corp rss
  # Plain runs print stat:: lines at the end; fork mode (-fork=1, the campaign) only its
  # progress lines ("#N: cov: … exec/s: N …"), the last of which is the total.
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  [ -n "$runs" ] || runs=$(grep -oE '^#[0-9]+' "$log" | tail -1 | tr -d '#')
  eps=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  if [ -z "$eps" ]; then
    # fork mode's exec/s is the last job's: the average is runs over the run's time
    local secs_run
    secs_run=$(grep -oE 'time: [0-9]+s' "$log" | tail -1 | grep -oE '[0-9]+')
    [ -z "$secs_run" ] || [ "$secs_run" = 0 ] || eps=$((runs / secs_run))
  fi
  rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | tail -1)
  [ -n "$rss" ] || rss=$(grep -oE 'rss: [0-9]+' "$log" | tail -1 | grep -oE '[0-9]+$')
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  corp=$(grep -oE 'corp: [0-9]+(/[0-9]+[a-zA-Z]*)?' "$log" | tail -1 | cut -d' ' -f2)
  local verdict="ok, 0 findings"
  [ "$found" = 0 ] || verdict="$found findings in $work/$t/artifacts"
  [ "$rc" = 0 ] || verdict="FAILED (exit $rc): $(grep -m1 -E '^==[0-9]+==|panicked|ERROR: libFuzzer' "$log" || true)"
  printf '| `%s` | %s | %s | %s | %s | %s | %s | %s |\n' \
    "$t" "${runs:-?}" "${eps:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "${rss:-?}" "$verdict" \
    | tee -a "$work/summary.md"
}

# The checked-in corpora stay small: at most $max_files files and $max_bytes bytes each.
bound() {
  local bad=0 t dir n bytes
  for t in $(all_targets); do
    dir="$(corpus_of "$t")"
    n=$(find "$dir" -maxdepth 1 -type f | wc -l)
    bytes=$(find "$dir" -maxdepth 1 -type f -printf '%s\n' | awk '{s+=$1} END {print s+0}')
    printf '%-14s %4d files %8d bytes\n' "$t" "$n" "$bytes"
    if [ "$n" -gt "$max_files" ] || [ "$bytes" -gt "$max_bytes" ]; then
      echo "fuzz: $dir is over the bound ($max_files files, $max_bytes bytes)" >&2
      bad=1
    fi
  done
  return "$bad"
}

merge() {
  local t corpus small
  for t in "$@"; do
    corpus="$(corpus_of "$t")"
    [ -d "$work/$t/new" ] || { echo "fuzz: no campaign inputs for $t in $work/$t/new" >&2; continue; }
    local before
    before=$(find "$corpus" -maxdepth 1 -type f | wc -l)
    # Only inputs of at most $merge_max_bytes are candidates (the bound is in bytes too), and
    # only plain edge coverage counts (no hit counts, no compared values): a set-cover merge into
    # the checked-in corpus keeps every file there and adds the fewest inputs that reach an edge
    # it does not. The named regression seeds are never removed.
    small="$work/$t/merge-candidates"
    rm -rf "$small"
    mkdir -p "$small"
    find "$work/$t/new" -maxdepth 1 -type f -size -"$((merge_max_bytes + 1))"c -exec cp {} "$small/" \;
    ASAN_OPTIONS="${ASAN_OPTIONS:-$asan_options}" "$(binary "$t")" "$corpus" "$small" \
      -set_cover_merge=1 -use_counters=0 -use_cmp=0 -rss_limit_mb=512 -malloc_limit_mb=512 \
      -timeout="$timeout" -max_len=70000 >"$work/$t/merge.log" 2>&1
    echo "fuzz: $t: $before → $(find "$corpus" -maxdepth 1 -type f | wc -l) files"
  done
  bound
}

mode="${1:-}"
shift || true
case "$mode" in
  ci)
    secs="${1:-15}"
    timeout="${FUZZ_TIMEOUT:-30}"
    ensure_cargo_fuzz
    build
    failed=()
    work="$(mktemp -d)"
    # FUZZ_JOBS targets at once (default 2, one per core of a CI machine): each libFuzzer run is
    # one process on one core, so two halve the step's time and leave each its own core.
    jobs="${FUZZ_JOBS:-2}"
    pids=() names=()
    for t in $(all_targets); do
      run_one "$t" "$secs" &
      pids+=("$!") names+=("$t")
      if [ "${#pids[@]}" -ge "$jobs" ]; then
        wait "${pids[0]}" || failed+=("${names[0]}")
        pids=("${pids[@]:1}") names=("${names[@]:1}")
      fi
    done
    for i in "${!pids[@]}"; do
      wait "${pids[$i]}" || failed+=("${names[$i]}")
    done
    bound || failed+=(corpus-bound)
    if [ "${#failed[@]}" -gt 0 ]; then
      for t in "${failed[@]}"; do
        [ -f "$work/$t/last.log" ] && tail -n 40 "$work/$t/last.log"
      done
      echo "fuzz: FAILED: ${failed[*]} (inputs in $work/<target>/artifacts/)" >&2
      exit 1
    fi
    rm -rf "$work"
    echo "fuzz: every target ran $secs s with no crash, hang or OOM"
    ;;
  campaign)
    secs="${1:-600}"
    shift || true
    [ "$#" -gt 0 ] || set -- $(all_targets)
    ensure_cargo_fuzz
    build
    failed=()
    for t in "$@"; do
      # Fork mode: a crash, timeout or OOM is saved and the run goes on for its whole budget.
      run_one "$t" "$secs" -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
        || failed+=("$t")
    done
    [ "${#failed[@]}" = 0 ] || { echo "fuzz: findings in: ${failed[*]} (see $work/<target>/artifacts/)" >&2; exit 1; }
    ;;
  merge)
    [ "$#" -gt 0 ] || set -- $(all_targets)
    ensure_cargo_fuzz
    merge "$@"
    ;;
  bound) bound ;;
  targets)
    for tc in "${targets[@]}"; do echo "${tc%%:*} ${tc#*:}"; done
    ;;
  *)
    sed -n '2,17p' "$0" >&2
    exit 2
    ;;
esac
