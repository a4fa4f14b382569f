#!/bin/sh
# Runs fuzz targets one after another (a single process each, so one core), each for
# SECONDS, at low priority. A crash stops that target's run early (see artifacts/TARGET).
# Usage: cargo +nightly fuzz build -O && fuzz/run.sh SECONDS [TARGET ...]   (default: all)
# A unit that runs longer than TIMEOUT seconds (default 20; 60 for editor_api, whose
# units run re-fits) is reported as a timeout.
# Appends one line per run to fuzz/runs.log: date, target, seconds, execs, crashes.
set -u
cd "$(dirname "$0")"
secs=$1
shift
targets=${*:-"deformation_json solve_json model_obj model_ply landmarks_csv landmarks_bigwarp edit_script ldu_rebuild image_decode_warp editor_api landmarks_points ngff_metadata"}
for t in $targets; do
    mkdir -p "corpus/$t" "artifacts/$t"
    cp -n seeds/"$t"/* "corpus/$t/" 2>/dev/null
    case $t in
        *json|edit_script) dict=json.dict ;;
        landmarks*) dict=csv.dict ;;
        ngff_metadata) dict=json.dict ;;
        model_obj) dict=obj.dict ;;
        model_ply) dict=ply.dict ;;
        editor_api) dict=editor.dict ;;
        image_decode_warp) dict=image.dict ;;
        *) dict= ;;
    esac
    case $t in
        editor_api) timeout=${TIMEOUT:-60} ;;
        *) timeout=${TIMEOUT:-20} ;;
    esac
    before=$(ls "artifacts/$t" | wc -l)
    start=$(date -u +%FT%TZ)
    t0=$(date +%s)
    # The binaries from `cargo +nightly fuzz build -O`, run directly so that edits to the
    # main crate during a run do not trigger a rebuild.
    nice -n 19 "target/x86_64-unknown-linux-gnu/release/$t" "corpus/$t" \
        -max_total_time="$secs" -timeout="$timeout" -rss_limit_mb=3072 -max_len=65536 \
        -print_final_stats=1 -artifact_prefix="artifacts/$t/" \
        ${dict:+-dict=$dict} > "logs-$t.txt" 2>&1
    rc=$?
    took=$(( $(date +%s) - t0 ))
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "logs-$t.txt" | tail -1 | grep -o '[0-9]*$')
    after=$(ls "artifacts/$t" | wc -l)
    echo "$start $t ${took}s execs=${execs:-?} new_artifacts=$((after - before)) rc=$rc" >> runs.log
done
