#!/usr/bin/env bash
# Scaling series of the exact core (issue 24): `trimorph solve` (whole process) on the
# select-all edit of a degree-5 C1 spline over random Delaunay meshes, modular path.
#   bash benches/exact_scaling.sh OUT.csv TRIANGLES...     (default 100 200 400 700 1000)
# Needs a release build: cargo build --release --bin trimorph --example c1_select_all
# FLINT_MAX=N also times FLINT's dense fflu of R_ED (benches/flint_fflu.py, python-flint) for
# meshes of at most N triangles, in the same run (column flint_s).
# Plot: python3 benches/plot_scaling.py OUT.csv docs/img/exact_scaling.svg
set -euo pipefail
out=${1:-docs/exact_scaling.csv}
shift || true
sizes=${*:-100 200 400 700 1000}
bin=target/release/trimorph
gen=target/release/examples/c1_select_all
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
