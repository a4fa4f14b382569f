#!/usr/bin/env bash
# Scaling series of the exact core (issue 24): `trimorph solve` (whole process) on the
# select-all edit of a degree-5 C1 spline over random Delaunay meshes, modular path.
#   bash benches/exact_scaling.sh OUT.csv TRIANGLES...     (default 100 200 400 700 1000)
# Needs a release build: cargo build --release --bin trimorph --example c1_select_all
set -euo pipefail
out=${1:-docs/exact_scaling.csv}
shift || true
sizes=${*:-100 200 400 700 1000}
bin=target/release/trimorph
gen=target/release/examples/c1_select_all
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "triangles,rows,cols,seconds,path,rank" > "$out.tmp"
for t in $sizes; do
  "$gen" "$t" 7 "$tmp/p.json" sparse 2> "$tmp/gen.txt"
  dims=$(sed -E 's/.*R ([0-9]+) x ([0-9]+).*/\1,\2/' "$tmp/gen.txt")
  start=$(date +%s.%N)
  "$bin" solve "$tmp/p.json" -o "$tmp/o.json"
  end=$(date +%s.%N)
  secs=$(echo "$end - $start" | bc -l)
  info=$(python3 -c "import json; d=json.load(open('$tmp/o.json')); print(d['path'], d['rank'], sep=',')")
  printf '%s,%s,%.3f,%s\n' "$t" "$dims" "$secs" "$info" | tee -a "$out.tmp"
done
mv "$out.tmp" "$out"
