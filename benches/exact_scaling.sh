#!/usr/bin/env bash
# Scaling series of the exact core (issue 24): `trimorph solve` (whole process) on the
# select-all edit of a degree-5 C1 spline over random Delaunay meshes, modular path.
#   bash benches/exact_scaling.sh OUT.csv TRIANGLES...     (default 100 200 400 700 1000)
# Needs a release build: cargo build --release --bin trimorph --example c1_select_all
# FLINT_MAX=N also times FLINT's dense fflu of R_ED (benches/flint_fflu.py, python-flint) for
# meshes of at most N triangles, in the same run (column flint_s).
# Plot: python3 benches/plot_scaling.py OUT.csv docs/img/exact_scaling.svg [EDIT.csv]
#
#   bash benches/exact_scaling.sh --edit OUT.csv TRIANGLES...  (default 100 .. 5000)
# times instead `trimorph edit` (whole process) of the same select-all move in the default
# bounded mode (the determining-set path, `edit::global`) on the identity spline over that
# mesh (`c1_select_all ... spline`), and checks the result with `trimorph check`.
set -euo pipefail
bin=target/release/trimorph
gen=target/release/examples/c1_select_all
if [ "${1:-}" = "--edit" ]; then
  shift
  out=${1:-docs/edit_scaling.csv}
  shift || true
  sizes=${*:-100 200 500 1000 2000 5000}
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  echo '[{"op": "translate", "anchors": {"near": [[100, 100]]}, "neighborhood": "all", "by": [3, "-2"]}]' > "$tmp/all.json"
  echo "triangles,points,seconds,c1" > "$out.tmp"
  for t in $sizes; do
    "$gen" "$t" 7 "$tmp/m.json" spline 2> "$tmp/gen.txt"
    tri=$(sed -E 's/.*: ([0-9]+) triangles, ([0-9]+) control points.*/\1,\2/' "$tmp/gen.txt")
    start=$(date +%s.%N)
    "$bin" edit "$tmp/m.json" --script "$tmp/all.json" -o "$tmp/o.json" > "$tmp/edit.txt"
    end=$(date +%s.%N)
    grep -q "determining-set coordinates" "$tmp/edit.txt"
    c1=$("$bin" check "$tmp/o.json" > /dev/null 2>&1 && echo exact)
    printf '%s,%.3f,%s\n' "$tri" "$(echo "$end - $start" | bc -l)" "$c1" | tee -a "$out.tmp"
  done
  mv "$out.tmp" "$out"
  exit 0
fi
out=${1:-docs/exact_scaling.csv}
shift || true
sizes=${*:-100 200 400 700 1000}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "triangles,rows,cols,seconds,path,rank,flint_s" > "$out.tmp"
for t in $sizes; do
  "$gen" "$t" 7 "$tmp/p.json" sparse 2> "$tmp/gen.txt"
  dims=$(sed -E 's/.*R ([0-9]+) x ([0-9]+).*/\1,\2/' "$tmp/gen.txt")
  start=$(date +%s.%N)
  "$bin" solve "$tmp/p.json" -o "$tmp/o.json"
  end=$(date +%s.%N)
  secs=$(echo "$end - $start" | bc -l)
  info=$(python3 -c "import json; d=json.load(open('$tmp/o.json')); print(d['path'], d['rank'], sep=',')")
  flint=""
  if [ "$t" -le "${FLINT_MAX:-0}" ]; then
    flint=$(python3 "$(dirname "$0")/flint_fflu.py" --flint-only "$tmp/p.json" | tail -1 | cut -d, -f4)
  fi
  printf '%s,%s,%.3f,%s,%s\n' "$t" "$dims" "$secs" "$info" "$flint" | tee -a "$out.tmp"
done
mv "$out.tmp" "$out"
