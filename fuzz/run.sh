#!/usr/bin/env bash
# Runs every fuzz target for SECONDS (default 600) each, JOBS at a time (default 2), from the
# committed seeds; corpora go to fuzz/corpus/ (not committed), crashes to fuzz/artifacts/.
# Needs nightly and cargo-fuzz: `cargo install cargo-fuzz`. Prints execs and crashes per target.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_EACH=${1:-600}
JOBS=${JOBS:-2}
# shellcheck disable=SC2206
TARGETS=(${TARGETS:-audio mesh scene_toml material_json rmodal grains npy})
cargo +nightly fuzz build >/dev/null
export RESOUND_FUZZ_TMP=${RESOUND_FUZZ_TMP:-/dev/shm}
run() {
    local t=$1
    mkdir -p "fuzz/corpus/$t" "fuzz/logs"
    cp -n fuzz/seeds/"$t"/* "fuzz/corpus/$t/" 2>/dev/null || true
    cargo +nightly fuzz run "$t" "fuzz/corpus/$t" -- \
        -max_total_time="$SECONDS_EACH" -max_len=65536 -rss_limit_mb=2048 -timeout=10 \
        -print_final_stats=1 >"fuzz/logs/$t.log" 2>&1 || true
    local execs crashes secs
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "fuzz/logs/$t.log" | grep -o '[0-9]*$' || echo "?")
    secs=$(grep -o 'Done [0-9]* runs in [0-9]* second' "fuzz/logs/$t.log" | grep -o '[0-9]* second' | grep -o '[0-9]*' || echo "<$SECONDS_EACH (stopped early)")
    crashes=$(ls "fuzz/artifacts/$t" 2>/dev/null | wc -l)
    echo "$t: ${execs} execs in ${secs} s, ${crashes} crash/timeout/oom artifacts"
}
export -f run
export SECONDS_EACH
printf '%s\n' "${TARGETS[@]}" | xargs -P "$JOBS" -I{} bash -c 'run {}'
