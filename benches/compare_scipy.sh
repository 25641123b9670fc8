#!/usr/bin/env bash
# Side by side: brdfit fit and the scipy peer (../shared/peers/scipy_fit.py) on the same CSV
# files, same loss (log) and same start, in one run. Prints both fit times (median of 5 fits in
# one process each, fit only: geometry + solve + statistics, no file reading), both costs and
# the ratio.
#
#   PYTHON=/tmp/peers/bin/python benches/compare_scipy.sh [SIZES...]
#
# Needs numpy and scipy for PYTHON (python3 -m venv /tmp/peers && /tmp/peers/bin/pip install numpy scipy).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
PEER=${PEER:-../shared/peers/scipy_fit.py}
SIZES=${*:-10000 1000000}
START="n=1.5,c3=0.5,ps=0.5,pd=0.5"
cargo build --release -q
BIN=target/release/brdfit
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
printf "%-9s %-24s %11s %14s %9s\n" samples program seconds cost ratio
for n in $SIZES; do
  csv="$TMP/mgo-$n.csv"
  $BIN simulate --model torrance-sparrow --set n=1.8,c3=0.35,ps=0.667,pd=0.333 \
      --grid hemisphere:$n --noise 0.01 --seed 1 -o "$csv"
  peer="n/a"
  if [ -f "$PEER" ] && $PYTHON -c "import scipy" 2>/dev/null; then
    peer=$($PYTHON "$PEER" "$csv" --loss log --start "$START" --repeat 5)
  fi
  for mode in "default" "local-only"; do
    extra=""
    [ "$mode" = "local-only" ] && extra="--local-only"
    # Five fits in one process, median time: the way the peer times itself.
    $BIN fit "$csv" --start "$START" $extra --repeat 5 --json "$TMP/fit.json" --force > /dev/null
    $PYTHON - "$TMP" "$n" "$mode" "$peer" <<'PY'
import json, sys
tmp, n, mode, peer = sys.argv[1:5]
f = json.load(open(f"{tmp}/fit.json"))
t, cost = f["seconds"], f["cost"]
line = f"{n:<9} {'brdfit ' + mode:<24} {t:11.4f} {cost:14.8e}"
if peer != "n/a":
    p = json.loads(peer)
    rel = (cost - p["cost"]) / p["cost"]
    line += f" {p['seconds'] / t:8.1f}x  (cost vs scipy {rel:+.1e} relative)"
print(line)
PY
  done
  if [ "$peer" != "n/a" ]; then
    $PYTHON -c "import json,sys; p=json.loads(sys.argv[1]); print(f\"{sys.argv[2]:<9} {'scipy least_squares lm':<24} {p['seconds']:11.4f} {p['cost']:14.8e}\")" "$peer" "$n"
  fi
done
