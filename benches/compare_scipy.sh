#!/usr/bin/env bash
# Side by side: brdfit fit and scipy (least_squares, MINPACK lm) on the same CSV files, same model,
# same loss (log) and same start, in one run, for every model brdfit fits. The peers:
# benches/scipy_models.py (every model; written from the papers) and, for Torrance–Sparrow D3,
# also the peer script PEER where it is given (then the reference of the ts-d3 ratios).
# brdfit runs twice: its default (global initialisation, then the local method; the start is one
# more candidate) and --local-only (the local method from the start, the same work as the peer).
# Every time is the median of $REPEAT fits in one process (file reading excluded), the way the
# peers time themselves. Data: for each model, samples simulated from a truth of that model
# (hemisphere grid, 1 % noise, seed 1) at each size; then MERL alumina-oxide, green ($REAL).
# benches/compare_scipy.py prints the rows:
#
#   solve s     brdfit: solve_seconds (set-up, global initialisation, local fits, polish);
#               peer: its own clock (least_squares only)
#   stats s     brdfit: statistics_seconds (checks, standard errors, ranges, the physical
#               check's albedo quadrature); peer: 0 (none)
#   geometry s  the parameter-free per-sample pass (the peer's, timed on its own)
#   total s     the three together (brdfit: its `seconds`)
#   own cost    ½ Σ r² as each program sums it
#   common cost ½ Σ r² at each program's parameters, one evaluator (scipy_models.py in long double)
#   ratio       reference peer / brdfit: solve against solve, total against total (brdfit's
#               statistics counted in its total, the peers have none)
#   vs ref      the row's common cost relative to the reference peer's (negative: lower)
#   own/common  own cost relative to common cost at the same parameters; `!` marks |x| > 1e-6
#
#   PYTHON=/tmp/peers/bin/python [MODELS="ts-d3 ggx-smith"] [REAL=FILE|""] [REPEAT=5] \
#     [BRDFIT=PATH] [PEER=/path/to/scipy_fit.py] benches/compare_scipy.sh [SIZES...]
#
# BRDFIT names another brdfit binary to time (say, a saved build of an earlier version, for a
# side by side in one run); without it the script builds this checkout and times that. PEER
# names an extra Torrance–Sparrow D3 peer script (it has no default; without it the ts-d3 rows
# are against benches/scipy_models.py alone).
#
# Needs numpy and scipy for PYTHON (python3 -m venv /tmp/peers && /tmp/peers/bin/pip install numpy scipy).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
PEER=${PEER:-}
if [ -n "$PEER" ] && [ ! -f "$PEER" ]; then
  echo "PEER=$PEER is not a file; fix: give the path of a scipy peer script, or leave PEER unset" >&2
  exit 2
fi
SIZES=${*:-10000 1000000}
MODELS=${MODELS:-lambert phong blinn-phong ts-d1 ts-d2 ts-d3 ts-abc ggx-smith ggx-smith-2}
REAL=${REAL-data/merl-alumina-oxide.csv}
REPEAT=${REPEAT:-5}
if [ -n "${BRDFIT:-}" ]; then
  BIN=$BRDFIT
  [ -x "$BIN" ] || { echo "BRDFIT=$BIN is not an executable; fix: give the path of a built brdfit binary" >&2; exit 2; }
else
  cargo build --release -q
  BIN=target/release/brdfit
fi
if ! $PYTHON -c "import scipy" 2>/dev/null; then
  echo "needs scipy for $PYTHON; fix: python3 -m venv /tmp/peers && /tmp/peers/bin/pip install numpy scipy, then PYTHON=/tmp/peers/bin/python" >&2
  exit 2
fi

# brdfit's flags, the truth simulated and the start both programs take (every model's declared
# start, src/model/*.rs).
args() {
  case $1 in
    ts-*) echo "--model torrance-sparrow --distribution ${1#ts-}" ;;
    *) echo "--model $1" ;;
  esac
}
truth() {
  case $1 in
    lambert) echo "pd=0.5" ;;
    phong) echo "c1=30,ps=0.4,pd=0.3" ;;
    blinn-phong) echo "c1=50,ps=0.4,pd=0.3" ;;
    ts-d1) echo "n=1.8,c1=23,ps=0.667,pd=0.333" ;;
    ts-d2) echo "n=1.8,c2=3.4,ps=0.667,pd=0.333" ;;
    ts-d3) echo "n=1.8,c3=0.35,ps=0.667,pd=0.333" ;;
    ts-abc) echo "n=1.8,b=25,c=1.2,ps=0.667,pd=0.333" ;;
    ggx-smith) echo "alpha=0.35,n=1.8,ps=0.667,pd=0.333" ;;
    ggx-smith-2) echo "alpha1=0.08,ps1=0.3,alpha2=0.4,ps2=0.5,n=1.8,pd=0.3" ;;
    *) echo "unknown model $1; fix: MODELS from lambert phong blinn-phong ts-d1 ts-d2 ts-d3 ts-abc ggx-smith ggx-smith-2" >&2; exit 2 ;;
  esac
}
start() {
  case $1 in
    lambert) echo "pd=0.5" ;;
    phong | blinn-phong) echo "c1=10,ps=0.5,pd=0.5" ;;
    ts-d1) echo "n=1.5,c1=10,ps=0.5,pd=0.5" ;;
    ts-d2) echo "n=1.5,c2=3,ps=0.5,pd=0.5" ;;
    ts-d3) echo "n=1.5,c3=0.5,ps=0.5,pd=0.5" ;;
    ts-abc) echo "n=1.5,b=100,c=1.5,ps=0.5,pd=0.5" ;;
    ggx-smith) echo "alpha=0.3,n=1.5,ps=0.5,pd=0.5" ;;
    ggx-smith-2) echo "alpha1=0.1,ps1=0.5,alpha2=0.4,ps2=0.5,n=1.5,pd=0.5" ;;
  esac
}
for m in $MODELS; do truth "$m" > /dev/null; done

TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
# One model on one file: the peers, brdfit twice, then the rows.
# compare FILE MODEL PEER_CHANNEL BRDFIT_CHANNEL_FLAGS...
compare() {
  local csv=$1 m=$2 ch=$3
  shift 3
  local s peers=()
  s=$(start "$m")
  if [ "$m" = ts-d3 ] && [ -n "$PEER" ]; then
    # (its numpy warnings on far-out trial points are dropped)
    $PYTHON "$PEER" "$csv" --loss log --start "$s" --repeat "$REPEAT" --channel "$ch" > "$TMP/shared.json" 2> /dev/null
    peers+=(--peer "$(basename "$PEER")=$TMP/shared.json")
  fi
  # The peer's analytic Jacobian against central differences at the start (on files up to
  # 100k rows: the check costs two residual passes per parameter).
  if [ "$(wc -l < "$csv")" -le 100010 ]; then
    $PYTHON benches/scipy_models.py "$csv" --model "$m" --start "$s" --channel "$ch" --check-jac > "$TMP/jac.txt" ||
      { echo "$m: the peer's Jacobian disagrees with central differences on $csv:" >&2; cat "$TMP/jac.txt" >&2; exit 1; }
  fi
  $PYTHON benches/scipy_models.py "$csv" --model "$m" --start "$s" --repeat "$REPEAT" --channel "$ch" > "$TMP/peer.json"
  peers+=(--peer "scipy_models.py=$TMP/peer.json")
  # shellcheck disable=SC2046
  $BIN fit "$csv" $(args "$m") "$@" --max-input-mb 256 --start "$s" --repeat "$REPEAT" -q \
    --json "$TMP/default.json" > /dev/null
  # shellcheck disable=SC2046
  $BIN fit "$csv" $(args "$m") "$@" --max-input-mb 256 --start "$s" --local-only --repeat "$REPEAT" -q \
    --json "$TMP/local.json" > /dev/null
  local shared=()
  [ -n "$PEER" ] && shared=(--shared-peer "$PEER")
  $PYTHON benches/compare_scipy.py "$csv" --model "$m" --channel "$ch" "${shared[@]}" \
    "${peers[@]}" --brdfit "default=$TMP/default.json" --brdfit "local-only=$TMP/local.json"
}

echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
printf "%-9s %-18s %-24s %9s %9s %9s %9s %18s %18s %17s %8s %10s\n" samples model program "solve s" \
  "stats s" "geometry" "total s" "own cost" "common cost" "solve  total" "vs ref" "own/common"
for n in $SIZES; do
  for m in $MODELS; do
    csv="$TMP/$m-$n.csv"
    # shellcheck disable=SC2046
    $BIN simulate $(args "$m") --set "$(truth "$m")" --grid "hemisphere:$n" --noise 0.01 --seed 1 \
      -q -o "$csv"
    compare "$csv" "$m" brdf
    rm -f "$csv"
  done
done
if [ -n "$REAL" ]; then
  for m in $MODELS; do
    compare "$REAL" "$m" brdf_g --channel g
  done
fi
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
