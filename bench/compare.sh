#!/usr/bin/env bash
# Side-by-side primary-ray speed: Open3D's RaycastingScene (Embree 4) and omnisim on the same
# triangles, same equirectangular camera, same run. Prints one line per case with the ratio.
#
#   OMNISIM=target/release/omnisim bench/compare.sh [--runs 5]     (from the repository root)
#
# First run: makes a Python venv under ${BENCH_CACHE:-$HOME/.cache/omnisim-bench} with
# open3d-cpu and numpy (about 300 MB; needs Debian's libusb-1.0-0), unless BENCH_PYTHON names
# a Python that has them (tests/readers/requirements.txt has both), and writes the anchor
# scenes there: room (492 triangles) and clutter (240,492), with RON scenes wrapping them;
# `omnisim bench room` finds them there by name.
set -euo pipefail
case "${1:-}" in -h|--help) sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//'; exit 0 ;; esac
HERE=$(cd "$(dirname "$0")" && pwd)
CACHE=${BENCH_CACHE:-$HOME/.cache/omnisim-bench}
OMNISIM=${OMNISIM:-target/release/omnisim}
RUNS=5
[ "${1:-}" = "--runs" ] && RUNS=$2
[ -x "$OMNISIM" ] || { echo "no omnisim binary at $OMNISIM (cargo build --release -p omnisim-cli, or set OMNISIM)"; exit 1; }
mkdir -p "$CACHE"
PY=${BENCH_PYTHON:-$CACHE/venv/bin/python}
if ! "$PY" -c 'import open3d' 2>/dev/null; then
  [ -x "$PY" ] || python3 -m venv "$CACHE/venv"
  "$PY" -m pip install -q open3d-cpu numpy
  "$PY" -c 'import open3d' 2>/dev/null || { apt-get install -y -qq libusb-1.0-0 >/dev/null; }
fi
for s in room clutter; do
  if [ ! -f "$CACHE/scene_$s.ply" ]; then
    "$PY" -c "import sys; sys.path.insert(0, '$HERE'); import raycast_anchor as ra; v, t = ra.build_scene('$s'); ra.write_ply('$CACHE/scene_$s.ply', v, t)"
  fi
  cat > "$CACHE/$s.ron" <<RON
Scene(
    name: "$s",
    objects: [
        Mesh(name: "$s", path: "scene_$s.ply", colour: (200, 200, 200)),
    ],
)
RON
done
printf '%-8s %-16s %10s %10s %7s\n' scene pose open3d omnisim ratio
for s in room clutter; do
  for pose in 3,2,1.5 3.01,2.01,1.51 1.2,0.9,0.7; do
    o3d=$("$PY" "$HERE/open3d_rays.py" "$CACHE/scene_$s.ply" --pose "$pose" --runs "$RUNS" | "$PY" -c 'import json,sys; print(json.load(sys.stdin)["mrays_per_s"])')
    om=$("$OMNISIM" bench "$CACHE/$s.ron" --camera equirect --size 1024x1024 --pose "$pose" --backend cpu --runs "$RUNS" 2>/dev/null | "$PY" -c 'import json,sys; print(max(json.loads(l)["mrays_per_s"] for l in sys.stdin if l.strip()))')
    "$PY" -c "print(f'%-8s %-16s %10.2f %10.2f %6.2fx' % ('$s', '$pose', $o3d, $om, $om / $o3d))"
  done
done
