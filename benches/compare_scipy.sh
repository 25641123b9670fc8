#!/usr/bin/env bash
# Side by side: brdfit fit and the scipy peer (../shared/peers/scipy_fit.py) on the same CSV
# files, same loss (log) and same start, in one run. brdfit runs twice: its default (global
# initialisation, then the local method) and --local-only (the local method from the start,
# the same work as the peer). Every time is the median of 5 fits in one process (file reading
# excluded), the way the peer times itself. benches/compare_scipy.py prints the table:
#
#   solve s     brdfit: seconds − geometry_seconds; peer: its own clock (least_squares only)
#   geometry s  the parameter-free per-sample pass (peer: its geometry(), timed by the script)
#   total s     the two together
#   own cost    ½ Σ r² as each program sums it
#   common cost ½ Σ r² at each program's parameters, one evaluator (long double)
#   ratio       peer / brdfit: solve against solve, total against total; then brdfit's common
#               cost relative to the peer's (negative or zero: no higher)
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
if [ ! -f "$PEER" ] || ! $PYTHON -c "import scipy" 2>/dev/null; then
  echo "needs $PEER and scipy for $PYTHON" >&2
  exit 2
fi
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
printf "%-9s %-24s %9s %9s %9s %18s %18s %s\n" samples program "solve s" "geometry" "total s" \
  "own cost" "common cost" "  solve   total   cost vs scipy"
for n in $SIZES; do
  csv="$TMP/mgo-$n.csv"
  $BIN simulate --model torrance-sparrow --set n=1.8,c3=0.35,ps=0.667,pd=0.333 \
      --grid hemisphere:$n --noise 0.01 --seed 1 -o "$csv"
  peer=$($PYTHON "$PEER" "$csv" --loss log --start "$START" --repeat 5)
  $BIN fit "$csv" --max-input-mb 256 --start "$START" --repeat 5 --json "$TMP/default.json" > /dev/null
  $BIN fit "$csv" --max-input-mb 256 --start "$START" --local-only --repeat 5 --json "$TMP/local.json" > /dev/null
  $PYTHON benches/compare_scipy.py "$csv" "$PEER" "$peer" \
      "default=$TMP/default.json" "local-only=$TMP/local.json"
done
