#!/usr/bin/env bash
# Run every fuzz target for SECONDS (default 600), two at a time; crashes land in
# fuzz/artifacts/<target>/. Needs cargo-fuzz (cargo install cargo-fuzz); on a stable
# toolchain RUSTC_BOOTSTRAP=1 lets cargo-fuzz pass its sanitizer flags.
set -u
cd "$(dirname "$0")"
SECONDS_EACH=${1:-600}
export RUSTC_BOOTSTRAP=1
mkdir -p logs
cargo fuzz build -O
run() { mkdir -p "corpus/$1"; cargo fuzz run -O "$1" "corpus/$1" -- -max_total_time="$SECONDS_EACH" -timeout=10 -rss_limit_mb=2048 > "logs/$1.log" 2>&1; echo "$1: exit $?" >> logs/summary.txt; }
: > logs/summary.txt
run csv & run astm & wait
run cornell & run scene & wait
run merl & run fit_json & wait
cat logs/summary.txt
