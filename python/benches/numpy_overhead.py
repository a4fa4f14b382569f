"""What numpy in and out adds to the Rust warp, on 4096 x 4096 images (issue 20: < 5 %).

`Deformation.warp_profiled` returns the seconds spent in what the Rust API `warp_pages`
also does (allocating the output, the library call); the rest of the Python call (argument
checks, borrowing the numpy buffer, wrapping the output as an array) is the overhead. Each
result is freed outside the timed call, as a Rust caller frees its output too. Run: `python python/benches/numpy_overhead.py [--size 4096] [--reps 5]`.
"""

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import trimorph

DATA = Path(__file__).resolve().parents[2] / "data" / "morph"


def fitted(size: int) -> trimorph.Deformation:
    rows = [l.split(",") for l in (DATA / "nuclei_landmarks.csv").read_text().splitlines()[1:]]
    k = size / 184.0
    src = np.array([[float(r[1]), float(r[2])] for r in rows]) * k
    dst = np.array([[float(r[3]), float(r[4])] for r in rows]) * k
    return trimorph.fit(src, dst, size=(size, size))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    d = fitted(a.size)
    rng = np.random.default_rng(0)
    n = a.size
    cases = {
        "gray8": (rng.random((n, n)) * 255).astype(np.uint8),
        "rgb8": (rng.random((n, n, 3)) * 255).astype(np.uint8),
        "gray16": (rng.random((n, n)) * 65535).astype(np.uint16),
        "gray32f": rng.random((n, n), dtype=np.float32),
    }
    print(f"{n}x{n}, {a.reps} runs each (median): total Python call vs library call alone")
    for name, img in cases.items():
        d.warp_profiled(img)  # warm up
        totals, inners = [], []
        for _ in range(a.reps):
            t0 = time.perf_counter()
            out, _, inner = d.warp_profiled(img)
            totals.append(time.perf_counter() - t0)
            inners.append(inner)
            # Freed outside the timed call (a Rust caller frees its output too).
            del out
        t, i = statistics.median(totals), statistics.median(inners)
        print(f"  {name:8s} total {t * 1e3:8.1f} ms  library {i * 1e3:8.1f} ms  "
              f"numpy in/out {100.0 * (t - i) / i:5.2f} %")


if __name__ == "__main__":
    main()
