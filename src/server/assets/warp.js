// trimorph editor page, part 3 of 5: the live warp, O(q) = I(phi^-1(q)) as `trimorph warp`
// draws it, the moving frame I pulled through phi onto the target.
//
// The server sends phi at the nodes of a coarse grid over the moving frame (every 8 px;
// `forward_grid` in views.rs), on every drag step's answer (`POST /api/update?warp=8`) and
// on request (`GET /api/warp?forward=1`). Nothing is inverted: each grid cell is two
// triangles whose corners are phi(node), textured from the nodes, so inside a triangle
// phi^-1 is the affine interpolant of its corners; the frame is sampled bilinearly (pixel
// centres at integers). Rasterized here, only where the map changed (a local drag redraws
// a small rectangle). A translate drag draws its warped frame at the pointer event itself,
// from its selection's basis (`predictWarp` in app.js); other drags with each step's
// answer.
//
// Before (a second request per step, phi^-1 solved by Newton at every node on the server,
// then interpolated per pixel) the warped frame came 35-70 ms after the pointer.
'use strict';

function overlay() { return $('overlay').value; }

// The frame's RGBA pixels (once per image).
function pixelsOf(img, cacheKey) {
  if (T[cacheKey] && T[cacheKey].img === img) return T[cacheKey];
  const c = document.createElement('canvas');
  c.width = img.naturalWidth; c.height = img.naturalHeight;
  const cx = c.getContext('2d', { willReadFrequently: true });
  cx.drawImage(img, 0, 0);
  const data = cx.getImageData(0, 0, c.width, c.height).data;
  // A grey image (every pixel r = g = b, opaque) is sampled on one channel.
  let gray = new Uint8Array(c.width * c.height);
  for (let k = 0, p = 0; k < gray.length; k++, p += 4) {
    if (data[p] !== data[p + 1] || data[p] !== data[p + 2] || data[p + 3] !== 255) { gray = null; break; }
    gray[k] = data[p];
  }
  T[cacheKey] = { img, w: c.width, h: c.height, data, gray };
  return T[cacheKey];
}

// Asks for the forward map and draws the warp (after anything but a drag step, which
// brings its own map). One request in flight; a change while it runs asks for one more.
async function refreshWarp() {
  if (!T.layers.warp || !T.state || !T.state.frame) return;
  if (T.warpBusy) { T.warpAgain = true; return; }
  T.warpBusy = true;
  try {
    applyWarp(await api('GET', '/api/warp?forward=1'));
    draw();
  } catch (e) {
    message('live warp: ' + String(e.message || e), true);
  } finally {
    T.warpBusy = false;
    if (T.warpAgain) { T.warpAgain = false; refreshWarp(); }
  }
}
T.refreshWarp = refreshWarp;

// Builds the warped frame (and, with two images, the two-colour overlay) from a forward
// map; `T.warpMs` is the time it took.
function applyWarp(g) {
  if (!g || !T.img) return;
  const t0 = performance.now();
  const rect = rasterize(g);
  if (rect && twoImages() && T.fixedImg && overlay() === 'colors') twoColours(rect);
  T.warpMs = performance.now() - t0;
  T.warpVersion = (T.warpVersion || 0) + 1;
}
T.applyWarp = applyWarp;

function ensureCanvas(key, imgKey, W, H) {
  if (!T[key] || T[key].width !== W || T[key].height !== H) {
    T[key] = document.createElement('canvas');
    T[key].width = W; T[key].height = H;
    T[imgKey] = T[key].getContext('2d').createImageData(W, H);
  }
}

// Draws the warped frame from the forward map `g`. Only what changed is redrawn: the
// cells with a moved corner are found by comparing with the previous map, the rectangle
// covering where they were and where they are now is cleared, and every cell reaching into
// it is drawn again in the full pass's order, so the result is the full pass's exactly.
function rasterize(g) {
  const src = pixelsOf(T.img, 'srcPixels');
  const [W, H] = g.target, nx = g.nx, ny = g.ny, m = g.map;
  const prev = T.warpMap;
  const same = prev && prev.img === T.img && prev.nx === nx && prev.ny === ny && prev.step === g.step && prev.W === W && prev.H === H && T.warpCanvas && T.warpCanvas.width === W && T.warpCanvas.height === H;
  ensureCanvas('warpCanvas', 'warpImage', W, H);
  let rect = [0, 0, W - 1, H - 1];
  if (same) {
    rect = changedRect(prev.map, m, nx, ny);
    if (!rect) return null;
    rect = [Math.max(0, rect[0]), Math.max(0, rect[1]), Math.min(W - 1, rect[2]), Math.min(H - 1, rect[3])];
    if (rect[0] > rect[2] || rect[1] > rect[3]) { T.warpMap = { img: T.img, nx, ny, step: g.step, W, H, map: m }; return null; }
  }
  const out32 = new Uint32Array(T.warpImage.data.buffer);
  for (let y = rect[1]; y <= rect[3]; y++) out32.fill(0, y * W + rect[0], y * W + rect[2] + 1);
  drawCells(g, src, out32, W, rect);
  T.warpMap = { img: T.img, nx, ny, step: g.step, W, H, map: m };
  T.warpCanvas.getContext('2d').putImageData(T.warpImage, 0, 0, rect[0], rect[1], rect[2] - rect[0] + 1, rect[3] - rect[1] + 1);
  return rect;
}

// The target rectangle [x0, y0, x1, y1] (whole pixels, grown by one) covering every cell
// with a corner that differs between the maps `a` and `b`, before and after; null if none.
function changedRect(a, b, nx, ny) {
  let r = null;
  const grow = (x, y) => {
    if (x === null || y === null) return;
    if (!r) r = [x, y, x, y];
    else { if (x < r[0]) r[0] = x; if (y < r[1]) r[1] = y; if (x > r[2]) r[2] = x; if (y > r[3]) r[3] = y; }
  };
  for (let j = 0; j < ny; j++) {
    for (let i = 0; i < nx; i++) {
      const k = 2 * (j * nx + i);
      if (a[k] === b[k] && a[k + 1] === b[k + 1]) continue;
      // Every cell around node (i, j): its corners, before and after.
      for (let jj = Math.max(0, j - 1); jj <= Math.min(ny - 1, j + 1); jj++) {
        for (let ii = Math.max(0, i - 1); ii <= Math.min(nx - 1, i + 1); ii++) {
          const q = 2 * (jj * nx + ii);
          grow(a[q], a[q + 1]); grow(b[q], b[q + 1]);
        }
      }
    }
  }
  return r && [Math.floor(r[0]) - 1, Math.floor(r[1]) - 1, Math.ceil(r[2]) + 1, Math.ceil(r[3]) + 1];
}

// Draws every cell of `g` that reaches into `rect`, clipped to it: two triangles a cell,
// corners phi(node) in the target, textured from the nodes in the frame.
function drawCells(g, src, out32, W, rect) {
  const st = g.step, nx = g.nx, ny = g.ny, m = g.map;
  const sw = src.w, sh = src.h, sd = src.data;
  const gray = src.gray;
  const node = (i, N) => Math.min(i * st, N - 1);
  const ix1 = Math.max(sw - 2, 0), iy1 = Math.max(sh - 2, 0);
  const [rx0, ry0, rx1, ry1] = rect;
  const tri = (ax, ay, bx, by, cx, cy, au, av, bu, bv, cu, cv) => {
    const area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    if (Math.abs(area) < 1e-12) return;
    const x0 = Math.max(rx0, Math.ceil(Math.min(ax, bx, cx))), x1 = Math.min(rx1, Math.floor(Math.max(ax, bx, cx)));
    const y0 = Math.max(ry0, Math.ceil(Math.min(ay, by, cy))), y1 = Math.min(ry1, Math.floor(Math.max(ay, by, cy)));
    if (x0 > x1 || y0 > y1) return;
    const inv = 1 / area, eps = -1e-9;
    // Barycentric weights of b and c as affine functions of (x, y); a's is 1 - wb - wc;
    // and the frame position (u, v) likewise.
    const bX = (cy - ay) * inv, bY = -(cx - ax) * inv, bC = -(bX * ax + bY * ay);
    const cX = -(by - ay) * inv, cY = (bx - ax) * inv, cC = -(cX * ax + cY * ay);
    const uX = bX * (bu - au) + cX * (cu - au), uY = bY * (bu - au) + cY * (cu - au), uC = au + bC * (bu - au) + cC * (cu - au);
    const vX = bX * (bv - av) + cX * (cv - av), vY = bY * (bv - av) + cY * (cv - av), vC = av + bC * (bv - av) + cC * (cv - av);
    for (let y = y0; y <= y1; y++) {
      let wb = bX * x0 + bY * y + bC, wc = cX * x0 + cY * y + cC;
      let u = uX * x0 + uY * y + uC, v = vX * x0 + vY * y + vC;
      let o = y * W + x0;
      for (let x = x0; x <= x1; x++, wb += bX, wc += cX, u += uX, v += vX, o++) {
        if (wb < eps || wc < eps || 1 - wb - wc < eps) continue;
        const uu = u < 0 ? 0 : u > sw - 1 ? sw - 1 : u;
        const vv = v < 0 ? 0 : v > sh - 1 ? sh - 1 : v;
        const iu = Math.min(uu | 0, ix1), iv = Math.min(vv | 0, iy1);
        const fu = uu - iu, fv = vv - iv;
        const s00 = iv * sw + iu, s01 = s00 + sw;
        const w00 = (1 - fu) * (1 - fv), w10 = fu * (1 - fv), w01 = (1 - fu) * fv, w11 = fu * fv;
        if (gray) {
          const k = (w00 * gray[s00] + w10 * gray[s00 + 1] + w01 * gray[s01] + w11 * gray[s01 + 1] + 0.5) | 0;
          out32[o] = 0xff000000 | (k << 16) | (k << 8) | k;
        } else {
          const p00 = 4 * s00, p10 = p00 + 4, p01 = 4 * s01, p11 = p01 + 4;
          const r = (w00 * sd[p00] + w10 * sd[p10] + w01 * sd[p01] + w11 * sd[p11] + 0.5) | 0;
          const gg = (w00 * sd[p00 + 1] + w10 * sd[p10 + 1] + w01 * sd[p01 + 1] + w11 * sd[p11 + 1] + 0.5) | 0;
          const b = (w00 * sd[p00 + 2] + w10 * sd[p10 + 2] + w01 * sd[p01 + 2] + w11 * sd[p11 + 2] + 0.5) | 0;
          out32[o] = LITTLE ? (0xff000000 | (b << 16) | (gg << 8) | r) >>> 0 : ((r << 24) | (gg << 16) | (b << 8) | 0xff) >>> 0;
        }
      }
    }
  };
  for (let j = 0; j + 1 < ny; j++) {
    const v0 = node(j, sh), v1 = node(j + 1, sh);
    for (let i = 0; i + 1 < nx; i++) {
      const k00 = 2 * (j * nx + i), k10 = k00 + 2, k01 = k00 + 2 * nx, k11 = k01 + 2;
      const a = m[k00], b = m[k10], c = m[k01], d = m[k11];
      if (a === null || b === null || c === null || d === null) continue;
      // Skip cells wholly outside the rectangle.
      const ay = m[k00 + 1], by = m[k10 + 1], cy = m[k01 + 1], dy = m[k11 + 1];
      if (Math.max(a, b, c, d) < rx0 || Math.min(a, b, c, d) > rx1 || Math.max(ay, by, cy, dy) < ry0 || Math.min(ay, by, cy, dy) > ry1) continue;
      const u0 = node(i, sw), u1 = node(i + 1, sw);
      tri(a, ay, b, by, d, dy, u0, v0, u1, v0, u1, v1);
      tri(a, ay, d, dy, c, cy, u0, v0, u1, v1, u0, v1);
    }
  }
}

const LITTLE = new Uint8Array(new Uint32Array([1]).buffer)[0] === 1;

// The two-colour overlay: the fixed image in green, the warped moving image in magenta
// (where both are bright the pixel is grey-white; a misfit shows as green and magenta
// fringes).
function twoColours(rect) {
  const f = pixelsOf(T.fixedImg, 'fixedPixels');
  const W = T.warpCanvas.width, H = T.warpCanvas.height;
  const fresh = !T.twoCanvas || T.twoCanvas.width !== W || T.twoCanvas.height !== H;
  ensureCanvas('twoCanvas', 'twoImage', W, H);
  const [x0, y0, x1, y1] = rect && !fresh ? rect : [0, 0, W - 1, H - 1];
  const a = T.warpImage.data, fd = f.data, out = T.twoImage.data;
  for (let y = y0; y <= y1; y++) {
    for (let x = x0; x <= x1; x++) {
      const o = 4 * (y * W + x);
      const fo = x < f.w && y < f.h ? 4 * (y * f.w + x) : -1;
      const fg = fo < 0 ? 0 : 0.299 * fd[fo] + 0.587 * fd[fo + 1] + 0.114 * fd[fo + 2];
      const mg = a[o + 3] ? 0.299 * a[o] + 0.587 * a[o + 1] + 0.114 * a[o + 2] : 0;
      out[o] = mg; out[o + 1] = fg; out[o + 2] = mg; out[o + 3] = 255;
    }
  }
  T.twoCanvas.getContext('2d').putImageData(T.twoImage, 0, 0, x0, y0, x1 - x0 + 1, y1 - y0 + 1);
}
