#!/usr/bin/env bash
# Bounded fuzzing for CI: builds the cargo-fuzz targets of fuzz/ once (one `cargo fuzz build`;
# the runs execute the built binaries, so nothing is built again per target), runs each for
# SECONDS, prints per target the executions run and the crashes found, and fails if any target
# crashed (or hung past the per-input timeout, or ran out of memory). See docs/fuzzing.md.
#
#   tools/fuzz-ci.sh [SECONDS] [TARGET...]      (default: 30 s each, every target)
#
# FUZZ_QUICK_BUILD=1 (what .ci/run sets): 16 codegen units and no debug info instead of
# cargo-fuzz's one codegen unit with line tables — a shorter build for short runs; the fuzzing
# itself is the same (release, debug assertions, coverage instrumentation).
#
# Each target starts from its seeds in the repository (fuzz/seeds/TARGET/, read only) and
# writes what it finds to fuzz/corpus/TARGET/ (not in the repository). A crashing input is
# kept in fuzz/artifacts/TARGET/; reproduce it with `cargo +nightly fuzz run TARGET FILE`.
#
# libFuzzer needs nightly (sanitizer and coverage flags). Without a nightly toolchain this
# script says so and exits 0: the seeds are still replayed on stable by `cargo test`
# (tests/fuzz_corpus.rs of each owning crate).
set -uo pipefail
cd "$(dirname "$0")/.."

SECONDS_PER_TARGET="${1:-30}"
shift || true
if [ "$#" -gt 0 ]; then
  TARGETS=("$@")
else
  TARGETS=(library protocol trajectory hfm journal urdf stl obj dae model linkfile program edit)
fi
# Per-input limits: an input slower than this many seconds is a hang; more memory than this
# is a leak or an unbounded allocation. Both fail the run like a crash.
TIMEOUT_S="${FUZZ_TIMEOUT_S:-20}"
RSS_MB="${FUZZ_RSS_MB:-2048}"

# Exit status: 0 clean (or skipped: no nightly), 1 a target crashed, hung or ran out of memory,
# 3 the fuzzing itself could not run (cargo-fuzz not installable, the targets did not build).
#
# FUZZ_SANITIZER: address (default) or none (faster build and runs; everything fuzzed here is
# safe Rust). FUZZ_STABLE=1: without nightly, fuzz on stable with -s none instead of skipping.
SANITIZER="${FUZZ_SANITIZER:-address}"
TOOLCHAIN=nightly
if ! rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
  if [ "${FUZZ_STABLE:-0}" = 1 ]; then
    echo "fuzz-ci: no nightly toolchain; fuzzing on stable without a sanitizer (FUZZ_STABLE=1)"
    TOOLCHAIN=stable
    SANITIZER=none
  else
    echo "fuzz-ci: no nightly toolchain (rustup toolchain install nightly); fuzzing skipped."
    echo "fuzz-ci: the seed corpora are still replayed on stable by cargo test (fuzz_corpus tests)."
    exit 0
  fi
fi
if ! cargo +"$TOOLCHAIN" fuzz --version >/dev/null 2>&1; then
  echo "fuzz-ci: installing cargo-fuzz"
  cargo install cargo-fuzz --locked || { echo "fuzz-ci: cannot install cargo-fuzz"; exit 3; }
fi

BUILD_ARGS=(-s "$SANITIZER")
BUILD_KIND=""
if [ "${FUZZ_QUICK_BUILD:-0}" = 1 ]; then
  BUILD_ARGS+=(--codegen-units 16)
  export CARGO_PROFILE_RELEASE_DEBUG=0
  BUILD_KIND=", quick build"
fi
# As `cargo fuzz run` does for AddressSanitizer builds.
if [ "$SANITIZER" = address ]; then
  export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_odr_violation=0"
fi
# Where `cargo fuzz build` puts the binaries: fuzz/target/HOST/release/TARGET.
HOST=$(rustc +"$TOOLCHAIN" -vV | sed -n 's/^host: //p')
BIN_DIR="fuzz/target/$HOST/release"

start=$(date +%s)
echo "fuzz-ci: building every target of fuzz/ ($TOOLCHAIN, release with debug assertions, sanitizer $SANITIZER$BUILD_KIND)"
if ! (cd fuzz && cargo +"$TOOLCHAIN" fuzz build "${BUILD_ARGS[@]}") >"${TMPDIR:-/tmp}/fuzz-ci-build.log" 2>&1; then
  tail -n 40 "${TMPDIR:-/tmp}/fuzz-ci-build.log"
  echo "fuzz-ci: build failed"
  exit 3
fi
built=$(date +%s)
echo "fuzz-ci: built in $((built - start)) s"

logs=$(mktemp -d)
failed=()
for t in "${TARGETS[@]}"; do
  mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
  before=$(ls "fuzz/artifacts/$t" | wc -l)
  log="$logs/$t.log"
  if [ ! -x "$BIN_DIR/$t" ]; then
    echo "fuzz-ci: $t: no binary $BIN_DIR/$t after the build"
    exit 3
  fi
  # What `cargo fuzz run TARGET corpus/TARGET seeds/TARGET -- ARGS` runs, without its rebuild check.
  (cd fuzz && "../$BIN_DIR/$t" -artifact_prefix="artifacts/$t/" \
      -max_total_time="$SECONDS_PER_TARGET" -timeout="$TIMEOUT_S" -rss_limit_mb="$RSS_MB" \
      -print_final_stats=1 "corpus/$t" "seeds/$t") >"$log" 2>&1
  status=$?
  after=$(ls "fuzz/artifacts/$t" | wc -l)
  crashes=$((after - before))
  # -print_final_stats=1 prints "stat::number_of_executed_units: N", also after a crash; the
  # "Done N runs in S second(s)" line only on a clean finish; "#N" status lines as a fallback
  runs=$(grep -Eo 'stat::number_of_executed_units: *[0-9]+' "$log" | tail -n 1 | grep -Eo '[0-9]+$')
  if [ -z "$runs" ]; then
    runs=$(grep -Eo 'Done [0-9]+ runs' "$log" | tail -n 1 | awk '{print $2}')
  fi
  if [ -z "$runs" ]; then
    runs=$(grep -Eo '^#[0-9]+' "$log" | tail -n 1 | tr -d '#')
  fi
  echo "fuzz-ci: $t: ${runs:-0} executions in ${SECONDS_PER_TARGET} s, $crashes crash(es), exit $status"
  if [ "$status" -ne 0 ] || [ "$crashes" -gt 0 ]; then
    failed+=("$t")
    echo "---- $t: end of the libFuzzer log ----"
    grep -E 'ERROR|panicked|SUMMARY|Test unit written|artifact_prefix|timeout|out-of-memory' "$log" | tail -n 20
    tail -n 30 "$log"
    echo "----"
  fi
done
echo "fuzz-ci: total $(( $(date +%s) - start )) s (build $((built - start)) s, runs $(( $(date +%s) - built )) s)"
rm -rf "$logs"
if [ "${#failed[@]}" -gt 0 ]; then
  echo "fuzz-ci: FAILED: ${failed[*]} (inputs in fuzz/artifacts/; replay: cargo +nightly fuzz run TARGET FILE)"
  exit 1
fi
echo "fuzz-ci: no crash"
