#!/usr/bin/env bash
# Runs every fuzz target (or those named after SECONDS) for SECONDS each (default 60) and prints
# the executions and findings of each. Installs cargo-fuzz when it is missing.
#
#   fuzz/run.sh [SECONDS] [TARGET...]
#
# The targets are built with the stable toolchain and without AddressSanitizer
# (FUZZ_SANITIZER=address adds it, with a nightly toolchain or RUSTC_BOOTSTRAP=1; see
# docs/fuzzing.md): nomen's
# crates forbid unsafe code, and what fuzzing finds in them is panics, hangs and memory growth,
# which libFuzzer catches without it. Each run starts from the committed seeds in
# fuzz/corpus/TARGET and keeps what it learns in fuzz/corpus-work/TARGET (not committed); a
# crash leaves its input in fuzz/artifacts/TARGET/. Exit status: 0 when every target ran
# clean, 1 when one found a crash, a hang or memory growth, 2 when fuzzing is not possible here
# (cargo-fuzz cannot be installed, or the targets do not build with this toolchain).
#
# Environment: FUZZ_JOBS (1: targets run at a time), FUZZ_SANITIZER (none), FUZZ_RSS_LIMIT_MB (2048: more is an out-of-memory
# finding), FUZZ_TIMEOUT_S (10: one input taking longer is a hang finding), CARGO_TARGET_DIR
# (the build goes to $CARGO_TARGET_DIR/fuzz, else fuzz/target).
set -uo pipefail
cd "$(dirname "$0")"

seconds="${1:-60}"
shift || true
sanitizer="${FUZZ_SANITIZER:-none}"
rss_limit_mb="${FUZZ_RSS_LIMIT_MB:-2048}"
timeout_s="${FUZZ_TIMEOUT_S:-10}"
target_dir="${CARGO_TARGET_DIR:+$CARGO_TARGET_DIR/fuzz}"
target_dir="${target_dir:-target}"

if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "installing cargo-fuzz"
  cargo install cargo-fuzz --locked || { echo "fuzz: cargo-fuzz could not be installed: not fuzzing"; exit 2; }
fi

# Without a sanitizer the stable compiler builds the targets (cargo-fuzz passes it no unstable
# flag then); AddressSanitizer needs `-Zsanitizer`: a nightly toolchain if there is one, else
# stable allowed its unstable flags.
toolchain=()
if [ "$sanitizer" = none ]; then
  echo "fuzz: toolchain $(rustc --version), no sanitizer"
elif rustup run nightly rustc --version >/dev/null 2>&1; then
  toolchain=(+nightly)
  echo "fuzz: toolchain $(rustup run nightly rustc --version), sanitizer $sanitizer"
else
  export RUSTC_BOOTSTRAP=1
  echo "fuzz: toolchain $(rustc --version) with RUSTC_BOOTSTRAP=1, sanitizer $sanitizer"
fi

if [ "$#" -gt 0 ]; then
  targets=("$@")
else
  mapfile -t targets < <(cargo fuzz list)
fi

build=(cargo "${toolchain[@]}" fuzz build -s "$sanitizer" --codegen-units 16 --target-dir "$target_dir")
echo "fuzz: ${build[*]}"
start=$(date +%s)
if ! "${build[@]}" >build.log 2>&1; then
  tail -n 30 build.log
  echo "fuzz: the targets do not build with this toolchain (see fuzz/build.log): not fuzzing"
  exit 2
fi
echo "fuzz: built ${#targets[@]} targets in $(( $(date +%s) - start )) s; ${seconds} s each"

# One target: runs it and prints its line of the table; its exit status is the run's.
fuzz_one() {
  local t="$1" log rc runs rate corpus result kind crash
  mkdir -p "corpus-work/$t" "artifacts/$t" "corpus/$t"
  log="artifacts/$t/last-run.log"
  cargo "${toolchain[@]}" fuzz run -s "$sanitizer" --codegen-units 16 --target-dir "$target_dir" \
    "$t" "corpus-work/$t" "corpus/$t" -- \
    -max_total_time="$seconds" -rss_limit_mb="$rss_limit_mb" -timeout="$timeout_s" \
    -print_final_stats=1 >"$log" 2>&1
  rc=$?
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  corpus=$(find "corpus-work/$t" -type f | wc -l)
  if [ "$rc" -eq 0 ]; then
    result=ok
  else
    kind=$(grep -m1 -o -E 'panicked at [^ ]*|ERROR: libFuzzer: [a-z-]+|out-of-memory|timeout' "$log" || true)
    crash=$(ls -t "artifacts/$t" 2>/dev/null | grep -v last-run.log | head -n 1)
    result="FAILED (${kind:-exit $rc}) ${crash:+artifacts/$t/$crash} log fuzz/$log"
  fi
  printf '%-16s %12s %9s %8s  %s\n' "$t" "${runs:-?}" "${rate:-?}" "$corpus" "$result"
  echo "$rc" >"artifacts/$t/last-run.rc"
}

# FUZZ_JOBS targets at a time (default 1).
jobs_max="${FUZZ_JOBS:-1}"
printf '%-16s %12s %9s %8s  %s\n' target executions exec/s corpus result
for t in "${targets[@]}"; do
  rm -f "artifacts/$t/last-run.rc"
  fuzz_one "$t" &
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do
    sleep 1
  done
done
wait
status=0
for t in "${targets[@]}"; do
  [ "$(cat "artifacts/$t/last-run.rc" 2>/dev/null)" = 0 ] || status=1
done
echo "fuzz: ${#targets[@]} targets, ${seconds} s each, in $(( $(date +%s) - start )) s with the build"
exit "$status"
