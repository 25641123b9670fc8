#!/usr/bin/env bash
# brdfit's Whitted renderer on the Mitsuba peer scene (data/scenes/mitsuba-front.toml), and
# Mitsuba 3 with Blinn/Whitted plugins where they are given, in one run.
#
#   PYTHON=/tmp/peers/bin/python [PEERS=/path/to/mitsuba-plugins] benches/compare_mitsuba.sh
#
# PEERS is a folder holding blinn_whitted.py (Blinn's Torrance–Sparrow plugin and a Whitted
# integrator for Mitsuba 3); it has no default. Without it only brdfit is measured.
#
# brdfit: image error (RMSE on linear values against its own 16×16-supersampled reference)
# against time and rays per pixel, uniform and adaptive anti-aliasing (brdfit study render).
# Mitsuba (pip install mitsuba; llvm_ad_rgb needs LLVM ≥ 19, DRJIT_LIBLLVM_PATH):
# benches/mitsuba_equal_error.py, the same scene in both programs, both timed at equal error
# against one shared high-spp reference, 2 threads, front and edge light.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
PEERS=${PEERS:-}
if [ -n "$PEERS" ] && [ ! -f "$PEERS/blinn_whitted.py" ]; then
  echo "PEERS=$PEERS holds no blinn_whitted.py; fix: give the folder of the Mitsuba Blinn/Whitted plugins" >&2
  exit 2
fi
cargo build --release -q
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "== brdfit (2 threads), data/scenes/mitsuba-front.toml, 512×512"
target/release/brdfit study render --scene data/scenes/mitsuba-front.toml -o "$OUT"
if [ -z "$PEERS" ]; then
  echo "== PEERS is not set (the folder of blinn_whitted.py): only brdfit was measured."
elif $PYTHON -c "import mitsuba" 2>/dev/null; then
  for light in front edge; do
    echo "== equal error against one shared reference, $light light (benches/mitsuba_equal_error.py)"
    PEERS="$PEERS" THREADS=2 $PYTHON benches/mitsuba_equal_error.py "$light" --ref-spp 4096 --runs 5
  done
else
  echo "== Mitsuba 3 is not installed for $PYTHON: only brdfit was measured."
fi
