#!/usr/bin/env bash
# Runs, on the bundled scene and on every scene of ../shared/scenes that
# exists (skipping, with a note, those that do not):
#   rayfold bench   -> out/bench/<scene>.md/.json        (fold modes, Tables 1 and 2)
#   rayfold-peers   -> out/bench/<scene>-peers.md/.json  (speed against accuracy, Embree)
#   chart_peers.py  -> out/bench/<scene>-peers.png/.svg
#   rayfold-stats   -> out/bench/<scene>-stats.txt  (traversal counters per pixel, both kernels, none and xy)
#   rayfold bench --align -> out/bench/<scene>-align.md/.json (views alone against aligned, the cost
#                      model's predictions; paths of $ALIGN_COUNTS views, default 2,4,8,16)
# and last out/bench/summary.md (bench_tables.py): the speed table with the
# ratios against Embree and the targets, printed too.
# Views start from the scenes' suggested starting points
# (../shared/scenes/README.md). Extra arguments go to both tools
# (e.g. --views 3 --frames 3 for a shorter run).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${RAYFOLD_BIN:-build/rayfold}
peers=${RAYFOLD_PEERS:-build/rayfold-peers}
stats=${RAYFOLD_STATS:-build/rayfold-stats}
shared=${RAYFOLD_SCENES_DIR:-../shared/scenes}
out=${OUT_DIR:-out/bench}
mkdir -p "$out"
args=("$@")

run() {
  local name=$1 file=$2; shift 2
  if [ ! -f "$file" ]; then echo "bench_all: $file absent; skipped"; return; fi
  echo "== $name"
  "$bin" bench "$file" "$@" "${args[@]}" --json "$out/$name.json" --md "$out/$name.md"
  "$peers" "$file" "$@" "${args[@]}" --json "$out/$name-peers.json" --md "$out/$name-peers.md"
  /usr/bin/python3 tools/chart_peers.py "$out/$name-peers.json" "$out/$name-peers"
  : > "$out/$name-stats.txt"
  for fold in none xy; do "$stats" "$file" "$@" --size 1280x720 --fold "$fold" >> "$out/$name-stats.txt"; done
  "$bin" bench --align "$file" "$@" "${args[@]}" --counts "${ALIGN_COUNTS:-2,4,8,16}" \
    --json "$out/$name-align.json" --md "$out/$name-align.md"
}

run atrium scenes/atrium.glb
run conference "$shared/conference.glb" --eye 330,300,-300 --look-at 1000,200,0
run dabrovic_sponza "$shared/dabrovic_sponza.glb" --eye 0,3,0 --look-at 10,3,0
run sports_car "$shared/sports_car.glb" --eye 1.8,0.9,2.2 --look-at 0,0.45,0
run stanford_dragon "$shared/stanford_dragon.glb" --eye 0,0.13,0.22 --look-at 0,0.12,0
run lost_empire "$shared/lost_empire.glb" --eye -10,20,40 --look-at 10,10,0
run armadillo "$shared/armadillo.glb" --eye 0,20,170 --look-at 0,20,0

align_reports=("$out"/*-align.json)
if [ -e "${align_reports[0]}" ]; then
  /usr/bin/python3 tools/align_tables.py "${align_reports[@]}" > "$out/align-summary.md"
  echo; cat "$out/align-summary.md"
fi

peer_reports=("$out"/*-peers.json)
if [ -e "${peer_reports[0]}" ]; then
  /usr/bin/python3 tools/bench_tables.py --peers "${peer_reports[@]}" > "$out/summary.md"
  echo; cat "$out/summary.md"
fi
