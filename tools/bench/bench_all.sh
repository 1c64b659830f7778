#!/usr/bin/env bash
# Runs, on the bundled scene and on every scene of ../shared/scenes that
# exists (skipping, with a note, those that do not):
#   rayfold bench   -> out/bench/<scene>.md/.json        (fold modes, Tables 1 and 2)
#   rayfold-peers   -> out/bench/<scene>-peers.md/.json  (speed against accuracy, Embree; and ray
#                      queries against Embree on $PEER_RAYS incoherent rays, default 1M, and the
#                      random views' pixel rays)
#   rayfold-peers   -> out/bench/<scene>-file-peers.md/.json (the same from the file's
#                      suggested camera alone: the one extra row)
#   bench_python.py -> out/bench/<scene>-python.md/.json (rayfold from Python against Mitsuba 3
#                      and Open3D on the peers report's random views; with $BENCH_PYTHON, a
#                      Python that has them and rayfold: make bench makes one)
#   bench_rays.py   -> out/bench/<scene>-rays.md/.json (scene.intersect against the same peers on
#                      1M incoherent rays and on the random views' rays as arrays; same Python)
#   bench_channels.py -> out/bench/<scene>-channels.md/.json (the G-buffer's resolved channel sets
#                      against the trace, on the same random views; same Python)
#   bench_dataset_loop.py -> out/bench/<scene>-dataset-loop.md/.json (cameras in, a G-buffer EXR out
#                      per view, against Mitsuba 3's aov integrator and Blender's Cycles passes on 4
#                      of the random views; same Python, Blender from Debian)
#   bench_batch.py  -> out/bench/batch.md/.json (one process against rayfold-batch with 1 and 2
#                      Ray workers, every scene, 640x480 and 1280x720; once, after the scenes)
#   bench_readback.py -> out/bench/readback.md/.json (the frame against the trace, host-layout and
#                      packed readback, every scene and channel set; once, after the scenes)
#   chart_peers.py  -> out/bench/<scene>-peers.png/.svg (speed against depth error and against
#                      other-triangle share, both against the double reference: rayfold's variants
#                      and Embree from rayfold-peers; with $BENCH_PYTHON, Mitsuba 3 and Open3D from
#                      bench_python.py beside rayfold from Python)
#   rayfold-stats   -> out/bench/<scene>-stats.txt  (traversal counters per pixel, both kernels, none and xy)
#   rayfold bench --align -> out/bench/<scene>-align.md/.json (views alone against aligned, the cost
#                      model's predictions; paths of $ALIGN_COUNTS views, default 2,4,8,16)
# and last out/bench/summary.md (bench_tables.py): the speed table with the
# ratios against Embree and the targets, printed too.
# Views: $RANDOM_VIEWS (default 16) random views per scene from seed $SEED
# (default 1; tools/fixtures/random_views.h), the kind told by its probe except
# where a scene's description says otherwise (Lost Empire: a Minecraft
# interior). The stats and the alignment paths start from the scenes'
# suggested views (../shared/scenes/README.md). rayfold-peers times the
# variants $PEER_VARIANTS (default tile,fast,exact-depth: on a CPU device the
# single-ray kernel is 3 to 20 times slower than the tile kernel,
# docs/results.md; exact-depth is the tile kernel with the exact depth, for
# its speed against its depth tail; the CPU reference validates every exact
# image whatever is timed). Extra
# arguments go to every tool (e.g. --frames 3 for a shorter run).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=${RAYFOLD_BIN:-build/rayfold}
peers=${RAYFOLD_PEERS:-build/rayfold-peers}
stats=${RAYFOLD_STATS:-build/rayfold-stats}
shared=${RAYFOLD_SCENES_DIR:-../shared/scenes}
out=${OUT_DIR:-out/bench}
random=(--random-views "${RANDOM_VIEWS:-16}" --seed "${SEED:-1}")
variants=${PEER_VARIANTS:-tile,fast,exact-depth}
python_peers=${BENCH_PYTHON:-}
mkdir -p "$out"
args=("$@")
# The options bench_python.py shares with the C++ tools.
py_args=()
while [ "$#" -gt 0 ]; do
  case $1 in --frames|--warmup|--size|--threads) py_args+=("$1" "$2"); shift 2 ;; *) shift ;; esac
done
set -- "${args[@]}"

# run NAME FILE KIND [--eye E --look-at L]: KIND auto, interior or object.
run() {
  local name=$1 file=$2 kind=$3; shift 3
  if [ ! -f "$file" ]; then echo "bench_all: $file absent; skipped"; return; fi
  echo "== $name"
  "$bin" bench "$file" "${random[@]}" --view-kind "$kind" "${args[@]}" --json "$out/$name.json" --md "$out/$name.md"
  "$peers" "$file" "${random[@]}" --view-kind "$kind" --variants "$variants" --rays "${PEER_RAYS:-1000000}" \
    "${args[@]}" --json "$out/$name-peers.json" --md "$out/$name-peers.md"
  "$peers" "$file" "$@" --views 1 --variants "$variants" "${args[@]}" \
    --json "$out/$name-file-peers.json" --md "$out/$name-file-peers.md"
  if [ -n "$python_peers" ]; then
    "$python_peers" tools/bench/bench_python.py "$file" --cameras "$out/$name-peers.json" "${py_args[@]}" \
      --json "$out/$name-python.json" --md "$out/$name-python.md"
    "$python_peers" tools/bench/bench_rays.py "$file" --cameras "$out/$name-peers.json" "${py_args[@]}" \
      --json "$out/$name-rays.json" > "$out/$name-rays.md"
    "$python_peers" tools/bench/bench_channels.py "$file" --cameras "$out/$name-peers.json" \
      --json "$out/$name-channels.json" > "$out/$name-channels.md"
    "$python_peers" tools/bench/bench_dataset_loop.py "$file" --cameras "$out/$name-peers.json" \
      --json "$out/$name-dataset-loop.json" > "$out/$name-dataset-loop.md"
  fi
  local py_chart=()
  if [ -n "$python_peers" ]; then py_chart=(--python "$out/$name-python.json"); fi
  /usr/bin/python3 tools/bench/chart_peers.py "$out/$name-peers.json" "$out/$name-peers" "${py_chart[@]}"
  : > "$out/$name-stats.txt"
  for fold in none xy; do "$stats" "$file" "$@" --size 1280x720 --fold "$fold" >> "$out/$name-stats.txt"; done
  "$bin" bench --align "$file" "$@" "${args[@]}" --counts "${ALIGN_COUNTS:-2,4,8,16}" \
    --json "$out/$name-align.json" --md "$out/$name-align.md"
}

run atrium scenes/atrium.glb auto
run conference "$shared/conference.glb" auto --eye 330,300,-300 --look-at 1000,200,0
run dabrovic_sponza "$shared/dabrovic_sponza.glb" auto --eye 0,3,0 --look-at 10,3,0
run sports_car "$shared/sports_car.glb" auto --eye 1.8,0.9,2.2 --look-at 0,0.45,0
run stanford_dragon "$shared/stanford_dragon.glb" auto --eye 0,0.13,0.22 --look-at 0,0.12,0
run lost_empire "$shared/lost_empire.glb" interior --eye -10,20,40 --look-at 10,10,0
run armadillo "$shared/armadillo.glb" auto --eye 0,20,170 --look-at 0,20,0

# Many views on Ray: one process against rayfold-batch (needs Ray in $BENCH_PYTHON).
if [ -n "$python_peers" ]; then
  "$python_peers" tools/bench/bench_batch.py --json "$out/batch.json" > "$out/batch.md" \
    || echo "bench_all: bench_batch.py failed; out/bench/batch.md holds what it printed"
  "$python_peers" tools/bench/bench_readback.py --json "$out/readback.json" > "$out/readback.md" \
    || echo "bench_all: bench_readback.py failed; out/bench/readback.md holds what it printed"
fi

align_reports=("$out"/*-align.json)
if [ -e "${align_reports[0]}" ]; then
  /usr/bin/python3 tools/bench/align_tables.py "${align_reports[@]}" > "$out/align-summary.md"
  echo; cat "$out/align-summary.md"
fi

peer_reports=("$out"/*-peers.json)  # the file-camera reports too: bench_tables.py tells them apart
if [ -e "${peer_reports[0]}" ]; then
  /usr/bin/python3 tools/bench/bench_tables.py --peers "${peer_reports[@]}" > "$out/summary.md"
  python_reports=("$out"/*-python.json)
  if [ -e "${python_reports[0]}" ]; then
    /usr/bin/python3 tools/bench/bench_tables.py --python "${python_reports[@]}" >> "$out/summary.md"
  fi
  ray_reports=("$out"/*-rays.json)
  if [ -e "${ray_reports[0]}" ]; then
    /usr/bin/python3 tools/bench/bench_tables.py --rays "${ray_reports[@]}" >> "$out/summary.md"
  fi
  echo; cat "$out/summary.md"
fi
