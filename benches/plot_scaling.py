#!/usr/bin/env python3
"""SVG plot of the exact-core scaling series (no dependencies).

    python3 benches/plot_scaling.py docs/exact_scaling.csv docs/img/exact_scaling.svg \
        [docs/edit_scaling.csv]

Reads the CSV of benches/exact_scaling.sh (triangles,rows,cols,seconds,path,rank[,flint_s])
and draws seconds against triangles on log-log axes: trimorph's whole `solve` process and,
where the column is present, FLINT's dense fflu of the same matrix. A third argument, the
CSV of `benches/exact_scaling.sh --edit` (triangles,points,seconds,c1), adds the bounded
select-all `trimorph edit` series.
"""
import csv
import math
import sys


def main():
    src, dst = sys.argv[1], sys.argv[2]
    rows = list(csv.DictReader(open(src)))
    series = [("trimorph solve, exact (modular)", "seconds", "#1f77b4", rows)]
    if any(r.get("flint_s") for r in rows):
        series.append(("FLINT fmpz_mat fflu", "flint_s", "#d62728", rows))
    if len(sys.argv) > 3:
        edits = list(csv.DictReader(open(sys.argv[3])))
        series.append(("trimorph edit, bounded (determining set)", "seconds", "#2ca02c", edits))
    pts = {}
    for name, key, _, rs in series:
        pts[name] = [(float(r["triangles"]), float(r[key])) for r in rs if r.get(key)]
    xs = [x for v in pts.values() for x, _ in v]
    ys = [y for v in pts.values() for _, y in v]
    x0, x1 = math.floor(math.log10(min(xs))), math.ceil(math.log10(max(xs)))
    y0, y1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))
    w, h, ml, mr, mt, mb = 560, 360, 60, 20, 20, 50

    def px(x):
        return ml + (math.log10(x) - x0) / (x1 - x0) * (w - ml - mr)

    def py(y):
        return h - mb - (math.log10(y) - y0) / (y1 - y0) * (h - mt - mb)

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" '
           f'font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>']
    for e in range(x0, x1 + 1):
        for m in (1, 2, 5):
            v = m * 10 ** e
            if 10 ** x0 <= v <= 10 ** x1:
                x = px(v)
                out.append(f'<line x1="{x:.1f}" y1="{mt}" x2="{x:.1f}" y2="{h - mb}" stroke="#ddd"/>')
                out.append(f'<text x="{x:.1f}" y="{h - mb + 16}" text-anchor="middle">{v:g}</text>')
    for e in range(y0, y1 + 1):
        y = py(10 ** e)
        out.append(f'<line x1="{ml}" y1="{y:.1f}" x2="{w - mr}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{ml - 6}" y="{y + 4:.1f}" text-anchor="end">{10 ** e:g}</text>')
    out.append(f'<text x="{(w + ml) / 2}" y="{h - 12}" text-anchor="middle">triangles</text>')
    out.append(f'<text x="14" y="{(h - mb) / 2}" text-anchor="middle" '
               f'transform="rotate(-90 14 {(h - mb) / 2})">seconds (whole process)</text>')
    for k, (name, _, color, _) in enumerate(series):
        p = pts[name]
        d = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in p)
        out.append(f'<polyline points="{d}" fill="none" stroke="{color}" stroke-width="2"/>')
        for x, y in p:
            out.append(f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="3" fill="{color}"/>')
        out.append(f'<text x="{ml + 10}" y="{mt + 16 + 16 * k}" fill="{color}">{name}</text>')
    out.append("</svg>")
    open(dst, "w").write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
