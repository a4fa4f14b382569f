#!/usr/bin/env bash
# Makes the pictures of README.md from the bundled data, with the commands the README shows.
#
#   docs/pictures.sh OUT_DIR            writes them into OUT_DIR (docs/img's file names)
#   docs/pictures.sh --update           writes them into docs/img
#
# Run from the top of a checkout, with `trimorph` on PATH (`cargo build --release`, then
# PATH="$PWD/target/release:$PATH") and a Python with numpy, Pillow, scipy and tifffile
# (the register pair and the montages). python/tests/test_readme_pictures.py runs it and
# checks that every picture in docs/img is what it makes now.
#
# Not made here (each has its own command):
# - morph_real_contact.png, morph_delaunay_contact.png: the morph of the real pair and the
#   classic Delaunay baseline, by `TRIMORPH_DOC_IMAGES=1 cargo test --test it morph::real`
#   (the test also checks that they are current);
# - editor*.png: browser screenshots of the editor, by `TRIMORPH_E2E=1 cargo test --test it
#   server::editor_e2e` (written to target/e2e/; Chromium's rendering is not byte-stable, so
#   they are copied by hand).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" = "--update" ]; then OUT=docs/img; else OUT=${1:?usage: docs/pictures.sh OUT_DIR | --update}; fi
mkdir -p "$OUT"
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
PY=${PYTHON:-python3}

# The demo: the 2D edit (before / after / warped / warped as a colour mesh), the 2.5D worm
# (top and oblique views) and the fit of the worm to the time-lapse.
trimorph demo -o "$W/demo" > /dev/null
cp "$W/demo/before.png" "$OUT/demo_before.png"
cp "$W/demo/after.png" "$OUT/demo_after.png"
cp "$W/demo/warped.png" "$OUT/demo_warped.png"
cp "$W/demo/warped_mesh.png" "$OUT/demo_warped_mesh.png"
cp "$W/demo/models/view_top.png" "$OUT/model_top.png"
cp "$W/demo/models/view_oblique.png" "$OUT/model_oblique.png"
cp data/microscopy/timelapse/frame_00.png "$OUT/fit_frame_00.png"
cp "$W/demo/fit/out/frame_09.overlay.png" "$OUT/fit_overlay_09.png"
cp "$W/demo/fit/out/frame_09.registered.png" "$OUT/fit_registered_09.png"
# Every layer of the demo's edit, and its Jacobian determinant.
trimorph render "$W/demo/edited.json" --show all --size 900,1080 \
    -o "$OUT/demo_after_layers.png" > /dev/null
trimorph field "$W/demo/edited.json" -o "$W/field.npy" --jacobian "$OUT/demo_jacobian.png" > /dev/null

# The edge modes: a 0.75x zoom out by 10 degrees (README "Edges"), warped three ways,
# side by side at a third of their size.
"$PY" - "$W/zoom.csv" <<'EOF'
import math, sys
c, s = 0.75 * math.cos(math.radians(10)), 0.75 * math.sin(math.radians(10))
rows = ["name,src_x,src_y,dst_x,dst_y"]
for i, (x, y) in enumerate([(x, y) for x in (50, 275, 500) for y in (60, 330, 600)]):
    u, v = x - 275, y - 330
    rows.append(f"p{i},{x},{y},{275 + c * u - s * v:.3f},{330 + s * u + c * v:.3f}")
open(sys.argv[1], "w").write("\n".join(rows) + "\n")
EOF
trimorph fit --size 550,660 --landmarks "$W/zoom.csv" --bend 1e-3 -o "$W/zoom.json" > /dev/null
for mode in constant edge reflect; do
  trimorph warp "$W/zoom.json" --image data/microscopy/cell.png --mode $mode -o "$W/$mode.png" > /dev/null
done
"$PY" - "$W" "$OUT/warp_modes.png" <<'EOF'
import sys
from PIL import Image
w = sys.argv[1]
tiles = [Image.open(f"{w}/{m}.png").convert("L").resize((220, 264), Image.BILINEAR)
         for m in ("constant", "edge", "reflect")]
sheet = Image.new("L", (3 * 220 + 2 * 10, 264), 255)
for k, t in enumerate(tiles):
    sheet.paste(t, (k * 230, 0))
sheet.save(sys.argv[2], optimize=False)
EOF

# The fit of the 14 nucleus tracks with bend 1e-6, its mesh and landmark residuals.
T=data/microscopy/timelapse
trimorph fit --size 511,511 --landmarks $T/tracks_0_9.csv -o "$W/fit6.json" --bend 1e-6 > /dev/null
trimorph render "$W/fit6.json" --background $T/frame_09.png --show mesh,points \
    -o "$OUT/fit_adapted_nuclei.png" > /dev/null

# Registration of the immunohistochemistry pair with a known answer.
"$PY" benches/register_compare.py "$(command -v trimorph)" --pairs ihc --write-pair "$W/register" > /dev/null
trimorph register "$W/register/fixed.tif" "$W/register/moving.tif" -o "$W/register/def.json" \
    --overlay "$OUT/register_overlay.png" > /dev/null
# Every frame of the time-lapse registered to the first; frame 5's overlay.
trimorph register --frames data/microscopy/timelapse --reference frame_00 -o "$W/drift" > /dev/null
cp "$W/drift/frame_05.overlay.png" "$OUT/register_frames_overlay.png"

# The faces morph, default (top) and with --pin-frame (bottom).
F=data/faces
trimorph morph $F/takeo.png $F/einstein.jpg --landmarks-src $F/takeo.pts \
    --landmarks-dst $F/einstein.pts --frames 6 -o "$W/faces" > /dev/null 2>&1
trimorph morph $F/takeo.png $F/einstein.jpg --landmarks-src $F/takeo.pts \
    --landmarks-dst $F/einstein.pts --frames 6 --pin-frame -o "$W/faces_pinned" > /dev/null 2>&1
"$PY" - "$W" "$OUT/morph_faces_contact.png" <<'EOF'
import sys
from PIL import Image
w = sys.argv[1]
top = Image.open(f"{w}/faces/contact-sheet.png").convert("RGB")
bottom = Image.open(f"{w}/faces_pinned/contact-sheet.png").convert("RGB")
sheet = Image.new("RGB", (max(top.width, bottom.width), top.height + bottom.height), "white")
sheet.paste(top, (0, 0))
sheet.paste(bottom, (0, top.height))
sheet.save(sys.argv[2], optimize=False)
EOF

# Thesis figures 7.1, 7.3, 7.6 and 7.8 (bit sizes of the fraction-free factoring).
trimorph bench bitgrowth --trials 20 -o "$W/bitgrowth" > /dev/null 2>&1
for k in 1 3 6 8; do cp "$W/bitgrowth/fig7_$k.png" "$OUT/fig7_$k.png"; done

# The exact-solve scaling plot, from the measured series in docs/*.csv.
"$PY" benches/plot_scaling.py docs/exact_scaling.csv "$OUT/exact_scaling.svg" docs/edit_scaling.csv > /dev/null
echo "pictures written to $OUT"
