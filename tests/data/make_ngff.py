"""Writes tests/data/ngff_tcyx_u16_v2_blosc.zarr: a tiny OME-Zarr 0.4 image (Zarr v2,
blosc-lz4 with byte shuffle, as ome-zarr-py writes by default) for tests/it/io/ngff.rs.

Axes (t, c, y, x) = (2, 2, 48, 64), uint16, chunks (1, 1, 32, 32), two levels (the second a
2x decimation, which trimorph does not read). Plane (t, c) is the crop x 200..264,
y 180..228 of data/microscopy/timelapse/frame_0{2t+c}.png, scaled by 257.

Run from the repository root with zarr-python 3 (PNGs decoded with zlib):
    /work/venv/bin/python tests/data/make_ngff.py
"""

import json
import shutil
import zlib
from pathlib import Path

import numpy as np
import zarr
from numcodecs import Blosc

def load(path):
    """An 8-bit gray, non-interlaced PNG as a numpy array (stdlib zlib only)."""
    b = Path(path).read_bytes()
    assert b[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, w, h = 8, b"", 0, 0
    while pos < len(b):
        n = int.from_bytes(b[pos : pos + 4], "big")
        kind, body = b[pos + 4 : pos + 8], b[pos + 8 : pos + 8 + n]
        if kind == b"IHDR":
            w, h = int.from_bytes(body[:4], "big"), int.from_bytes(body[4:8], "big")
            assert body[8] == 8 and body[9] == 0 and body[12] == 0, "8-bit gray, not interlaced"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    out = np.zeros((h, w), dtype=np.uint8)
    prev = np.zeros(w, dtype=np.int32)
    for y in range(h):
        f = raw[y * (w + 1)]
        line = np.frombuffer(raw[y * (w + 1) + 1 : (y + 1) * (w + 1)], np.uint8).astype(np.int32)
        if f == 0:
            cur = line
        elif f == 1:
            cur = np.cumsum(line) & 0xFF
        elif f == 2:
            cur = (line + prev) & 0xFF
        else:
            cur = np.zeros(w, dtype=np.int32)
            for x in range(w):
                a = int(cur[x - 1]) if x else 0
                b, c = int(prev[x]), int(prev[x - 1]) if x else 0
                if f == 3:
                    pr = (a + b) // 2
                else:
                    pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                    pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                cur[x] = (int(line[x]) + pr) & 0xFF
        out[y] = cur
        prev = cur
    return out


ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "tests/data/ngff_tcyx_u16_v2_blosc.zarr"


def planes():
    d = np.zeros((2, 2, 48, 64), dtype=np.uint16)
    for t in range(2):
        for c in range(2):
            f = load(ROOT / f"data/microscopy/timelapse/frame_0{2 * t + c}.png")
            d[t, c] = f[180:228, 200:264].astype(np.uint16) * 257
    return d


def main():
    if OUT.exists():
        shutil.rmtree(OUT)
    data = planes()
    g = zarr.open_group(str(OUT), mode="w", zarr_format=2)
    comp = Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE)
    a0 = g.create_array("0", shape=data.shape, chunks=(1, 1, 32, 32), dtype="<u2", compressors=comp)
    a0[:] = data
    a1 = g.create_array("1", shape=(2, 2, 24, 32), chunks=(1, 1, 24, 32), dtype="<u2", compressors=comp)
    a1[:] = data[:, :, ::2, ::2]
    g.attrs["multiscales"] = [
        {
            "version": "0.4",
            "name": "timelapse crop",
            "axes": [
                {"name": "t", "type": "time", "unit": "second"},
                {"name": "c", "type": "channel"},
                {"name": "y", "type": "space", "unit": "micrometer"},
                {"name": "x", "type": "space", "unit": "micrometer"},
            ],
            "datasets": [
                {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1.0, 1.0, 0.5, 0.5]}]},
                {"path": "1", "coordinateTransformations": [{"type": "scale", "scale": [1.0, 1.0, 1.0, 1.0]}]},
            ],
        }
    ]
    g.attrs["omero"] = {"channels": [{"label": "frame even"}, {"label": "frame odd"}]}
    print(json.dumps(dict(g.attrs))[:200], "...")


if __name__ == "__main__":
    main()
