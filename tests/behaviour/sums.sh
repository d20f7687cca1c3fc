#!/usr/bin/env bash
# Behaviour, byte for byte: runs a fixed list of omnisim commands on the CPU (render with every
# camera and output, the shipped data-set specs made small, preview, describe, project) and
# prints the SHA-256 of every file they write, one `sum  path` line per file, sorted by path.
#
#   tests/behaviour/sums.sh [OMNISIM_BINARY] > now.sha256
#   diff tests/behaviour/expected.sha256 now.sha256
#   tests/behaviour/sums.sh --check [OMNISIM_BINARY]   # the same, exit 1 on any difference
#
# A refactoring keeps every sum. What a run records of its own circumstances is taken out
# before hashing, and only that: seconds and rates (describe's sidecars, the manifest's
# timing), the omnisim version, the host, and absolute paths (the work folder is a temporary).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"

check=false
if [ "${1:-}" = "--check" ]; then check=true; shift; fi
bin="${1:-$root/target/debug/omnisim}"
[ -x "$bin" ] || { echo "no omnisim binary at $bin (cargo build -p omnisim-cli, or pass its path)" >&2; exit 2; }
bin="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cp -r "$root/scenes" "$work/scenes"
out="$work/out"
mkdir -p "$out"
cd "$work"

run() { "$bin" "$@" >/dev/null 2>"$work/stderr" || { cat "$work/stderr" >&2; echo "failed: omnisim $*" >&2; exit 1; }; }

# Every camera on the CPU, every optional output.
all=(--backend cpu --segmentation --normals --linear)
run render scenes/env1.ron --camera pinhole --size 64x48 --pose 1.2,0.9,0.7,0,10,200 "${all[@]}" --out out/pinhole
run render scenes/env1-lit.ron --camera stereo --size 64x48 --baseline 0.2 --pose 0,0,0.6,0,0,30 "${all[@]}" --out out/stereo
run render scenes/env2.ron --camera equirect --size 96x48 --pose 0,0,0.4 "${all[@]}" --out out/equirect
run render scenes/env2-lit.ron --camera cylindrical --size 96x32 --vfov 80 --pose 0.5,0.2,0.4,0,0,45 "${all[@]}" --out out/cylindrical
run render scenes/env1.ron --camera omni --size 64x64 --poses-file scenes/paper-omni-poses.txt "${all[@]}" --out out/omni
run render scenes/env1-lit.ron --camera omni --size 64x64 --mirror parabolic --mirror-b 0.05 --pose 1.5,0,0.4,0,0,60 "${all[@]}" --out out/parabolic
run render scenes/env1.ron --camera omni --size 64x64 --mirror spherical --mount down --pose 0.5,0.5,1.2 "${all[@]}" --out out/spherical
run render scenes/env2.ron --camera omni --size 64x64 --misalign-offset 0.002,0,0.001 --misalign-tilt 1,0,2 --hidden-centre 5 --pose 1.5,0,0.4,0,0,60 "${all[@]}" --out out/misaligned
run render scenes/env1.ron --camera omni --size 64x64 --mirror-rays shortcut --edge-samples 4 --pose 1.5,0,0.4,0,0,60 --backend cpu --out out/shortcut
run render scenes/env1.ron --camera omni --size 64x64 --tracer reference --exr-compression rle --pose 1.5,0,0.4,0,50,60 --backend cpu --out out/reference

# Textured faces (image and procedural textures filtered to each pixel's ray cone).
run render scenes/env1-textured.ron --camera omni --size 64x64 --pose 1.5,0,0.4,0,0,60 "${all[@]}" --out out/textured-omni
run render scenes/env1-textured-lit.ron --camera pinhole --size 64x48 --edge-samples 4 --pose 1.2,0.9,0.7,0,10,200 --backend cpu --out out/textured-pinhole
for format in gltf obj ply; do
    run render scenes/textured-$format.ron --camera equirect --size 96x48 --pose -0.5,0,0.8 --backend cpu --out out/textured-$format
done

# The shipped data-set specs, small: fewer and smaller frames, the same features.
for spec in scenes/env1-dataset.ron scenes/env1-speed-dataset.ron; do
    sed -i -e 's/size: (250, 250)/size: (48, 48)/' -e 's/spacing: 0.1/spacing: 1.0/' \
        -e 's/count: 50,/count: 3,/' -e 's/count: 100)/count: 4)/' "$spec"
done
run dataset scenes/env1-dataset.ron --backend cpu --out out/dataset
run dataset scenes/env1-speed-dataset.ron --backend cpu --out out/speed-dataset
run preview scenes/env1-dataset.ron --out out/preview/

# Vision on a data set and on a render folder.
run describe out/dataset -d fourier -d hog -d gist:blocks=4 -d radon:angles=36 -d sift --out out/describe
run describe out/omni -d fourier:k=8 -d vertical-hog --out out/describe-render
run project out/dataset --view panorama:width=128,height=32 --view birds-eye:width=40,height=40 --out out/project
run project out/omni --view perspective:width=32,height=24,yaw=30 --view equirect:width=64,height=32 --out out/project-render

# What a run records of its circumstances, taken out of text files before hashing: in JSON any
# key that holds "seconds" or "elapsed" (timings), in every text file the omnisim
# version, the host name and the temporary work folder (also as the digest of the scene file's
# full path in omnisim-run.txt).
normalise() {
    case "$1" in
        *.json) python3 -c '
import json, re, sys
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if not re.search(r"seconds|elapsed", k)}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
json.dump(strip(json.load(open(sys.argv[1]))), sys.stdout, sort_keys=True)' "$1" ;;
        *) cat "$1" ;;
    esac | sed -E -e 's/(omnisim[ -]?(version)?"?[:=]? *"?)[0-9]+\.[0-9]+\.[0-9]+/\1_/g' \
        -e "s/$(hostname | sed 's/[.[\*^$/]/\\&/g')/_host_/g" \
        -e "s#$work#_work_#g" -e "s#$bin#_omnisim_#g" -E -e 's/(scene=[^ :]*):[0-9a-f]{16}/\1:_/g'
}
sums="$work/sums"
find out -type f | LC_ALL=C sort | while read -r file; do
    case "$file" in
        *.json | *.txt | *.yaml | *.csv | *.svg) sum="$(normalise "$file" | sha256sum)" ;;
        *) sum="$(sha256sum <"$file")" ;;
    esac
    echo "${sum%% *}  $file"
done >"$sums"

if $check; then
    diff -u "$here/expected.sha256" "$sums" && echo "behaviour unchanged: $(wc -l <"$sums") files"
else
    cat "$sums"
fi
