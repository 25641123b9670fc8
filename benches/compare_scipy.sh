#!/usr/bin/env bash
# Side by side: brdfit fit and the scipy peer (../shared/peers/scipy_fit.py) on the same CSV
# files, same loss (log) and same start, in one run. Prints both fit times (median of 5, fit
# only: geometry + solve, no file reading), both costs and the ratio.
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
    for i in 1 2 3 4 5; do
      $BIN fit "$csv" --start "$START" $extra --json "$TMP/fit-$i.json" --force > /dev/null
    done
    $PYTHON - "$TMP" "$n" "$mode" "$peer" <<'PY'
import json, statistics, sys
tmp, n, mode, peer = sys.argv[1:5]
fits = [json.load(open(f"{tmp}/fit-{i}.json")) for i in range(1, 6)]
t = statistics.median(f["seconds"] for f in fits)
cost = fits[0]["cost"]
line = f"{n:<9} {'brdfit ' + mode:<24} {t:11.4f} {cost:14.8e}"
if peer != "n/a":
    p = json.loads(peer)
    line += f" {p['seconds'] / t:8.1f}x  (scipy cost {'higher' if p['cost'] > cost * (1 + 1e-9) else 'not lower' if p['cost'] >= cost * (1 - 1e-9) else 'LOWER'})"
print(line)
PY
  done
  if [ "$peer" != "n/a" ]; then
    $PYTHON -c "import json,sys; p=json.loads(sys.argv[1]); print(f\"{sys.argv[2]:<9} {'scipy least_squares lm':<24} {p['seconds']:11.4f} {p['cost']:14.8e}\")" "$peer" "$n"
  fi
done
