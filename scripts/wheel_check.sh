#!/usr/bin/env bash
# The wheel works anywhere: build it, install it in a fresh venv outside the repo (the core
# alone first: its size, and the one-line errors naming the extras; then the extras), and run
# the command line and the snippets of the README and the docs from another directory. CI runs
# this after `make test`.
# Usage: bash scripts/wheel_check.sh [PYTHON]   (default: python3)
set -euo pipefail
REPO="$(cd "$(dirname "$0")/.." && pwd)"
PYTHON="${1:-python3}"
WORK="$(mktemp -d /tmp/humanoid-wheel.XXXXXX)"
trap 'rm -rf "$WORK"' EXIT
echo "== wheel check in $WORK"
quiet() { sed '/neither a file nor a directory/d' >&2; }  # this machine's pip index warnings
"$PYTHON" -m pip wheel --quiet --no-deps "$REPO" -w "$WORK/dist" 2> >(quiet)
WHEEL="$(ls "$WORK"/dist/humanoid_toolkit-*.whl)"
echo "built $(basename "$WHEEL")"
"$PYTHON" -m venv "$WORK/venv"
"$WORK/venv/bin/pip" install --quiet "$WHEEL" 2> >(quiet)
mkdir "$WORK/elsewhere"
cd "$WORK/elsewhere"
BIN="$WORK/venv/bin"
where="$("$BIN/python" -c 'import humanoid; print(humanoid.__file__)')"
case "$where" in
    "$WORK"/venv/*) echo "imports $where" ;;
    *) echo "humanoid imported from $where, not from the installed wheel" >&2; exit 1 ;;
esac
"$BIN/humanoid" --version
# the compiled kernels came with the wheel (humanoid/kernels.c): the ground detects in C
"$BIN/python" -c 'from humanoid.constraints.ground import KERNELS; assert KERNELS is not None, "humanoid.kernels is not in the wheel"; print("compiled kernels:", KERNELS.__file__.rsplit("/", 1)[-1])'
"$BIN/humanoid" info adult_female | head -3
# the person's walk reads the default body's shipped gait cycle: no casadi needed
"$BIN/humanoid" walk --steps 2 --quiet -o walk.npz --html walk.html | tail -3
"$BIN/humanoid" walk --gait welded --steps 2 --quiet -o welded.npz | tail -1
for scene in $("$BIN/python" -c 'import humanoid.data as d; print(*d.scene_names())'); do
    "$BIN/humanoid" simulate "$scene" --duration 0.2 --quiet -o "$scene.npz" | head -1
done
"$BIN/humanoid" view push.npz --html push.html
"$BIN/humanoid" view talos --html talos.html
"$BIN/python" -c 'from humanoid.walking.norms import norms
n = norms()
print(f"norms: {len(n.units)} normative curves from the installed package data")'
"$BIN/python" -c 'import humanoid
from humanoid.motion.markers import default_markers, marker_positions, MarkerTrajectories
from humanoid.motion.bvh import write_bvh
h = humanoid.load("adult_male")
m = default_markers(h)
q = h.standing_configuration()[None].repeat(5, axis=0)
write_bvh("stand.bvh", h, [0.0, 0.1, 0.2, 0.3, 0.4], q)
print(f"markers: {len(m)} from the installed package data")'
# the core alone: a C3D or a study says which extra to install, in one line
"$BIN/humanoid" loads "$REPO/humanoid/data/trials/walking5.c3d" -o w.mot 2> c3d.txt \
    && { echo "humanoid loads read a C3D without ezc3d" >&2; exit 1; }
grep -q "pip install 'humanoid-toolkit\[c3d\]'" c3d.txt || { cat c3d.txt >&2; exit 1; }
echo "core only: $(tail -1 c3d.txt)"
"$BIN/humanoid" ik stand.bvh --model adult_male -o stand.mot --quiet > ik.txt
"$BIN/humanoid" id stand.mot --model adult_male --cutoff 0 -o stand_id.sto > id.txt
grep -q "root residual force" id.txt || { echo "humanoid id printed no residual" >&2; exit 1; }
echo "ik and id of a BVH: $(grep -c . stand_id.sto) lines of generalised forces"
"$BIN/humanoid" bench step --quick -o bench > bench.txt
rows=$(($(wc -l < bench/step.csv) - 1))
if [ "$rows" -lt 1 ]; then echo "bench step wrote no rows" >&2; exit 1; fi
echo "bench step --quick: $rows scenes timed"
printf '[study]\nname = "tiny"\nscene = "standing"\n[set]\n"scene.duration" = 0.2\n[grid]\n"scene.dt" = [0.001, 0.002]\n' > tiny.toml
"$BIN/humanoid" sweep tiny.toml --workers 2 --quiet 2> studies.txt \
    && { echo "humanoid sweep ran without dask" >&2; exit 1; }
grep -q "pip install 'humanoid-toolkit\[studies\]'" studies.txt || { cat studies.txt >&2; exit 1; }
echo "core only: $(tail -1 studies.txt)"
echo "core venv: $(du -sm "$WORK/venv" | cut -f1) MB installed"
"$BIN/pip" install --quiet "$WHEEL[c3d,studies]" 2> >(quiet)
"$BIN/humanoid" loads "$REPO/humanoid/data/trials/walking5.c3d" -o w.mot | tail -1
runs=$("$BIN/humanoid" sweep push_standing --list | wc -l)
if [ "$runs" -ne 750 ]; then echo "the shipped push_standing study lists $runs runs" >&2; exit 1; fi
"$BIN/humanoid" sweep tiny.toml --workers 2 --quiet > sweep.txt
grep -q "runs         2: 2 completed" sweep.txt || { cat sweep.txt >&2; exit 1; }
echo "sweep: a 2-run study on a 2-worker Dask cluster; the shipped study lists $runs runs"
# without the optimal extra, humanoid.optimal.gait says which pip install to run; with it, the
# Python snippets of the README and of the docs' guides (the optimal-control ones among them)
# run as a user following them would
"$BIN/python" -c 'import humanoid.optimal.gait' 2> optimal.txt && { echo "humanoid.optimal.gait imported without casadi" >&2; exit 1; }
grep -q "pip install 'humanoid-toolkit\[optimal\]'" optimal.txt || { cat optimal.txt >&2; exit 1; }
"$BIN/pip" install --quiet "$WHEEL[optimal]" 2> >(quiet)
"$BIN/python" "$REPO/scripts/readme_snippets.py" "$REPO/README.md" "$REPO"/docs/*.md
echo "== wheel check passed"
