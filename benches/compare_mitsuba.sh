#!/usr/bin/env bash
# brdfit's Whitted renderer on the Mitsuba peer scene (data/scenes/mitsuba-front.toml, the
# scene of ../shared/peers/mitsuba/scene.xml), and Mitsuba 3 with the Blinn/Whitted plugins
# where it is installed, in one run.
#
#   PYTHON=/tmp/peers/bin/python benches/compare_mitsuba.sh
#
# brdfit: image error (RMSE on linear values against its own 16×16-supersampled reference)
# against time and rays per pixel, uniform and adaptive anti-aliasing (brdfit study render).
# Mitsuba (pip install mitsuba; llvm_ad_rgb needs LLVM ≥ 19, see ../shared/peers/README.md):
# benches/mitsuba_equal_error.py, the same scene in both programs, both timed at equal error
# against one shared high-spp reference, 2 threads, front and edge light.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
PEERS=${PEERS:-../shared/peers/mitsuba}
cargo build --release -q
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "== brdfit (2 threads), data/scenes/mitsuba-front.toml, 512×512"
target/release/brdfit study render --scene data/scenes/mitsuba-front.toml -o "$OUT"
if $PYTHON -c "import mitsuba" 2>/dev/null && [ -f "$PEERS/blinn_whitted.py" ]; then
  for light in front edge; do
    echo "== equal error against one shared reference, $light light (benches/mitsuba_equal_error.py)"
    PEERS="$PEERS" THREADS=2 $PYTHON benches/mitsuba_equal_error.py "$light" --ref-spp 4096 --runs 5
  done
else
  echo "== Mitsuba 3 is not installed for $PYTHON: only brdfit was measured."
fi
