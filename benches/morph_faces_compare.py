#!/usr/bin/env python3
"""The faces morph (issue 52): `trimorph morph` against the classic OpenCV Delaunay morph,
timed in the same run on the bundled portraits (`data/faces/`: Takeo Kanade 150 x 225 RGB,
Albert Einstein 817 x 1024 grey, 68 iBUG landmarks each).

* trimorph: the whole command, `trimorph morph A B --landmarks-src A.pts --landmarks-dst B.pts
  --frames 11 -o DIR --quiet` (reading, both certified fits, 11 frames, PNGs, GIF, APNG and
  contact sheet), wall time of the process.
* OpenCV: the usual Delaunay morph (as in LearnOpenCV's face morphing): B brought into A's
  frame by the landmarks' least-squares similarity (`cv2.estimateAffinePartial2D`, then
  `cv2.warpAffine`), the 68 landmarks plus 8 frame points (corners and side midpoints) in both,
  for each frame t the intermediate points, their Delaunay triangulation (`cv2.Subdiv2D`), each
  triangle of A and of B warped affinely onto it (`cv2.getAffineTransform`,
  `cv2.warpAffine` on the triangle's bounding box, a filled-triangle mask), cross-dissolved,
  and written as PNG: reading, alignment, 11 frames and their PNGs.

Also printed: each method's largest landmark miss at t = 1 is not compared (the Delaunay
morph interpolates its points by construction; trimorph's fits report theirs).

Usage: morph_faces_compare.py TRIMORPH_BIN [--runs 3]   (needs numpy, opencv-python-headless)
Prints one JSON line per run and method.
"""
import argparse
import json
import os
import subprocess
import tempfile
import time

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
FACES = os.path.join(HERE, "..", "data", "faces")


def pts(path):
    """iBUG .pts points, 1-based as stored, shifted to pixel centres at integers."""
    text = open(path).read()
    body = text[text.index("{") + 1 : text.index("}")]
    v = np.array(body.split(), dtype=np.float64).reshape(-1, 2)
    return v - 1.0


def frame_points(w, h):
    return np.array(
        [[0, 0], [(w - 1) / 2, 0], [w - 1, 0], [w - 1, (h - 1) / 2], [w - 1, h - 1],
         [(w - 1) / 2, h - 1], [0, h - 1], [0, (h - 1) / 2]],
        dtype=np.float64,
    )


def warp_triangle(src, dst, t_src, t_dst):
    """Warps triangle t_src of src onto triangle t_dst of dst (float images), in place."""
    r = cv2.boundingRect(np.float32([t_dst]))
    x, y, w, h = r
    if w <= 0 or h <= 0:
        return
    t_dst_local = np.float32([[p[0] - x, p[1] - y] for p in t_dst])
    m = cv2.getAffineTransform(np.float32(t_src), t_dst_local)
    patch = cv2.warpAffine(src, m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
    mask = np.zeros((h, w), dtype=np.float32)
    cv2.fillConvexPoly(mask, np.int32(np.round(t_dst_local)), 1.0, cv2.LINE_AA)
    if src.ndim == 3:
        mask = mask[..., None]
    roi = dst[y : y + h, x : x + w]
    hh, ww = roi.shape[:2]
    roi[...] = roi * (1 - mask[:hh, :ww]) + patch[:hh, :ww] * mask[:hh, :ww]


def opencv_morph(a_path, b_path, la, lb, frames, out_dir):
    a = cv2.imread(a_path, cv2.IMREAD_COLOR).astype(np.float32)
    b = cv2.imread(b_path, cv2.IMREAD_COLOR).astype(np.float32)
    h, w = a.shape[:2]
    s, _ = cv2.estimateAffinePartial2D(lb.astype(np.float32), la.astype(np.float32))
    b_in_a = cv2.warpAffine(b, s, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
    lb_a = lb @ s[:, :2].T + s[:, 2]
    ring = frame_points(w, h)
    pa = np.vstack([la, ring])
    pb = np.vstack([lb_a, ring])
    for k in range(frames):
        t = k / (frames - 1)
        pt = (1 - t) * pa + t * pb
        sub = cv2.Subdiv2D((-1, -1, w + 2, h + 2))
        clipped = np.stack([np.clip(pt[:, 0], 0, w - 1), np.clip(pt[:, 1], 0, h - 1)], axis=1)
        for q in clipped:
            sub.insert((float(q[0]), float(q[1])))
        wa = np.zeros_like(a)
        wb = np.zeros_like(a)
        for tri in sub.getTriangleList():
            v = np.asarray(tri, dtype=np.float64).reshape(3, 2)
            d = np.linalg.norm(clipped[None, :, :] - v[:, None, :], axis=2)
            ids = d.argmin(axis=1)
            if (d[np.arange(3), ids] > 0.01).any():
                continue  # a triangle of Subdiv2D's outer virtual vertices
            warp_triangle(a, wa, pa[ids], pt[ids])
            warp_triangle(b_in_a, wb, pb[ids], pt[ids])
        frame = (1 - t) * wa + t * wb
        cv2.imwrite(os.path.join(out_dir, f"frame_{k:03}.png"), np.clip(frame + 0.5, 0, 255).astype(np.uint8))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("trimorph")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--frames", type=int, default=11)
    args = ap.parse_args()
    a, b = os.path.join(FACES, "takeo.png"), os.path.join(FACES, "einstein.jpg")
    pa, pb = os.path.join(FACES, "takeo.pts"), os.path.join(FACES, "einstein.pts")
    la, lb = pts(pa), pts(pb)
    for run in range(args.runs):
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            subprocess.run(
                [args.trimorph, "morph", a, b, "--landmarks-src", pa, "--landmarks-dst", pb,
                 "--frames", str(args.frames), "-o", os.path.join(d, "t"), "--quiet"],
                check=True,
            )
            tt = time.perf_counter() - t0
            os.makedirs(os.path.join(d, "o"))
            t0 = time.perf_counter()
            opencv_morph(a, b, la, lb, args.frames, os.path.join(d, "o"))
            to = time.perf_counter() - t0
        print(json.dumps({"run": run, "method": "trimorph", "seconds": round(tt, 3)}))
        print(json.dumps({"run": run, "method": "opencv_delaunay", "seconds": round(to, 3)}))
        print(json.dumps({"run": run, "ratio": round(tt / to, 2)}))


if __name__ == "__main__":
    main()
