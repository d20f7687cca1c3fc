#!/usr/bin/env bash
# omnisim against Open3D (Embree 4) on the same rays: omnisim's own ray map of each camera,
# moved to the pose, is what Open3D casts. Per-image time, rounds alternated, best round kept.
#
#   OMNISIM=target/release/omnisim bench/same_rays.sh [--rounds 3] [--scenes room,env1,env1-lit] [--extra "--hits-only"]
#
# env1-lit (not in the default scenes): lit colour images, Open3D given the primary rays plus one
# shadow ray per light per hit (same_rays.py --help).
#
# From the repository root (env1 is its scenes/env1.ron). Uses the venv of compare.sh
# (${BENCH_CACHE:-$HOME/.cache/omnisim-bench}) plus OpenEXR, or the Python BENCH_PYTHON names
# (tests/readers/requirements.txt has all three). Options: same_rays.py --help.
set -euo pipefail
case "${1:-}" in -h|--help) sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//'; exit 0 ;; esac
HERE=$(cd "$(dirname "$0")" && pwd)
CACHE=${BENCH_CACHE:-$HOME/.cache/omnisim-bench}
OMNISIM=${OMNISIM:-target/release/omnisim}
PY=${BENCH_PYTHON:-$CACHE/venv/bin/python}
[ -x "$OMNISIM" ] || { echo "no omnisim binary at $OMNISIM (cargo build --release -p omnisim-cli, or set OMNISIM)"; exit 1; }
if ! "$PY" -c 'import open3d, OpenEXR' 2>/dev/null; then
  [ -x "$PY" ] || python3 -m venv "$CACHE/venv"
  "$PY" -m pip install -q open3d-cpu numpy OpenEXR
  "$PY" -c 'import open3d' 2>/dev/null || { apt-get install -y -qq libusb-1.0-0 >/dev/null; }
fi
mkdir -p "$CACHE/same-rays"
exec "$PY" "$HERE/same_rays.py" --omnisim "$OMNISIM" --repo "$PWD" --work "$CACHE/same-rays" "$@"
