#!/usr/bin/env python3
"""FLINT baseline for the exact core (issue 24): dense fraction-free LU of R_ED.

Reads `trimorph solve` problems (dense or sparse "R"), builds R_ED (the relevant rows and the
derived columns of R; for a select-all edit, R without the anchor columns) as a FLINT
`fmpz_mat` and times `fmpz_mat.fflu()` (FLINT's dense fraction-free LU, python-flint from
PyPI). In the same run it times the whole `trimorph solve` process on the same file.

    python3 benches/flint_fflu.py TRIMORPH_BIN problem.json [problem2.json ...]
    python3 benches/flint_fflu.py --flint-only problem.json     (FLINT column only)

Each time is the best of REPEAT runs (environment variable, default 5; both sides alike), since
a shared machine's timings vary by tens of percent from run to run.

Prints CSV: file,rows,cols,flint_fflu_s,flint_rank,trimorph_s,trimorph_path,ratio.
Not run in CI (it needs python-flint and takes seconds).
"""
import json
import os
import subprocess
import sys
import tempfile
import time

import flint


def r_ed(doc):
    p = doc["P"]
    n = len(p)
    anchors = {int(k) for k in doc["anchors"]}
    derived = list(doc["derived"])
    moving = anchors | set(derived)
    R = doc["R"]
    if isinstance(R, dict):
        rows = [{int(c): int(v) for c, v in r} for r in R["rows"]]
    else:
        rows = [{j: int(v) for j, v in enumerate(r) if int(v) != 0} for r in R]
    relevant = [r for r in rows if any(c in moving for c in r)]
    pos = {s: k for k, s in enumerate(derived)}
    dense = [[0] * len(derived) for _ in relevant]
    for i, r in enumerate(relevant):
        for c, v in r.items():
            if c in pos:
                dense[i][pos[c]] = v
    return dense, n


def main():
    binary = sys.argv[1]
    print("file,rows,cols,flint_fflu_s,flint_rank,trimorph_s,trimorph_path,ratio")
    for f in sys.argv[2:]:
        doc = json.load(open(f))
        dense, _ = r_ed(doc)
        m = flint.fmpz_mat(dense)
        repeat = max(1, int(os.environ.get("REPEAT", "5")))
        t_flint = float("inf")
        for _ in range(repeat):
            t0 = time.perf_counter()
            lu = m.fflu()
            t_flint = min(t_flint, time.perf_counter() - t0)
            del lu
        rank = m.rank()
        if binary == "--flint-only":
            print(f"{f},{len(dense)},{len(dense[0]) if dense else 0},{t_flint:.3f},{rank},,,",
                  flush=True)
            continue
        with tempfile.NamedTemporaryFile(suffix=".json") as out:
            t_tri = float("inf")
            for _ in range(repeat):
                t0 = time.perf_counter()
                subprocess.run([binary, "solve", f, "-o", out.name], check=True)
                t_tri = min(t_tri, time.perf_counter() - t0)
            path = json.load(open(out.name)).get("path", "?")
        print(f"{f},{len(dense)},{len(dense[0]) if dense else 0},{t_flint:.3f},{rank},"
              f"{t_tri:.3f},{path},{t_tri / t_flint:.3f}", flush=True)


if __name__ == "__main__":
    main()
