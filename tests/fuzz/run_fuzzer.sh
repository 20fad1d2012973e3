#!/usr/bin/env bash
# Runs one fuzz target for a bounded time: first over its seeds (the shipped files and the
# regression inputs of earlier findings), then on inputs libFuzzer derives from them. Fails
# (non-zero) on a crash, a sanitizer report, a hang (-timeout) or an unexpected exception.
# Usage: run_fuzzer.sh FUZZER WORK_DIR SEED...   (a SEED is a file or a folder)
# The time is $THERMOVIS_FUZZ_SECONDS (default 8 s; longer runs find more).
# New inputs go to WORK_DIR/corpus (never into the source tree); a failing input is written to
# WORK_DIR/crash-* and is the regression case to add under tests/fuzz/regressions/<target>/.
set -euo pipefail
fuzzer=$1 work=$2 seconds=${THERMOVIS_FUZZ_SECONDS:-8}
shift 2
rm -rf "$work"
mkdir -p "$work/corpus" "$work/seeds"
for seed in "$@"; do
  if [ -d "$seed" ]; then
    find "$seed" -maxdepth 1 -type f -exec cp {} "$work/seeds/" \;
  elif [ -f "$seed" ]; then
    cp "$seed" "$work/seeds/"
  else
    echo "run_fuzzer.sh: seed $seed does not exist" >&2
    exit 2
  fi
done
# -timeout=10: an input taking longer than 10 s is a hang (files of a few kB parse in
# milliseconds); -rss_limit_mb: a parser allocating without bound is a failure too.
exec "$fuzzer" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=8192 \
  -print_final_stats=1 -artifact_prefix="$work/" "$work/corpus" "$work/seeds"
