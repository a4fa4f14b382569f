// trimorph editor page. The engine (Rust, /api/...) computes all geometry; this page only
// draws what it is sent and turns mouse and keyboard input into API calls.
// World coordinates = mesh coordinates = reference image pixels (x right, y down).
'use strict';

const T = {
  state: null, geo: {}, stat: {}, img: null, jac: null, jacVersion: 0,
  view: { s: 1, tx: 0, ty: 0 }, anchors: [], center: null,
  drag: null, busy: false, pending: null, timings: [], phases: [], lastError: null,
  layers: {}, dragId: 0,
  // Landmark pairs (`GET /api/landmarks`), the selected pair, the reference point of a
  // half-placed pair, and which image the landmarks mode shows: 'ref' (the frame
  // un-warped, where reference points are clicked) or 'target' (the current view).
  lm: { pairs: [], rms: null, max: null, sel: -1, pendingSrc: null, view: 'ref', version: 0 },
  // The session token from the address `trimorph editor` printed (`/?token=...`); without
  // it the page relies on the cookie the server set when that address was loaded.
  token: new URLSearchParams(location.search).get('token'),
};
window.trimorph = T;

const $ = (id) => document.getElementById(id);
const canvas = $('view');
const ctx = canvas.getContext('2d');
const obl = $('oblique');
const octx = obl.getContext('2d');

async function api(method, path, body) {
  const opt = { method, headers: {} };
  if (T.token) opt.headers['X-Trimorph-Token'] = T.token;
  if (body !== undefined) {
    opt.headers['Content-Type'] = 'application/json';
    opt.body = JSON.stringify(body);
  }
  const r = await fetch(path, opt);
  const ct = r.headers.get('Content-Type') || '';
  const v = ct.startsWith('application/json') ? await r.json() : null;
  if (!r.ok) throw new Error((v && v.error) || ('HTTP ' + r.status));
  return v;
}
T.api = api;

// Two lines at the bottom: `#status`, the document's summary (refreshed after every
// change), and `#msg`, the outcome of the last action (success or error), which stays until
// the next action starts.
function status(text) { $('status').textContent = text; }
function message(msg, isError) {
  const f = $('msg');
  f.textContent = msg || '';
  f.className = isError ? 'error' : (msg ? 'ok' : '');
  if (isError) T.lastError = msg;
  T.lastMessage = msg || '';
}
T.message = message;

function mode() { return $('mode').value; }
function op() { return $('op').value; }
function radius() { return $('all').checked ? null : Math.max(0, parseInt($('radius').value || '0', 10)); }

// ---- view transform ----------------------------------------------------------------
function toScreen(x, y) { return [T.view.s * x + T.view.tx, T.view.s * y + T.view.ty]; }
function toWorld(X, Y) { return [(X - T.view.tx) / T.view.s, (Y - T.view.ty) / T.view.s]; }
T.toScreen = toScreen; T.toWorld = toWorld;

function bounds() {
  if (T.state && T.state.frame) return [-0.5, -0.5, T.state.frame.width - 0.5, T.state.frame.height - 0.5];
  let b = [Infinity, Infinity, -Infinity, -Infinity];
  for (const p of T.geo.points || []) {
    b = [Math.min(b[0], p[0]), Math.min(b[1], p[1]), Math.max(b[2], p[0]), Math.max(b[3], p[1])];
  }
  return b;
}

function fitView() {
  const [x0, y0, x1, y1] = bounds();
  const w = canvas.clientWidth, h = canvas.clientHeight;
  const s = 0.95 * Math.min(w / (x1 - x0 || 1), h / (y1 - y0 || 1));
  T.view = { s, tx: w / 2 - s * (x0 + x1) / 2, ty: h / 2 - s * (y0 + y1) / 2 };
  draw();
}

// ---- drawing ------------------------------------------------------------------------
function draw() {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
    canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
  }
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = '#151617';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const v = T.view;
  ctx.setTransform(dpr * v.s, 0, 0, dpr * v.s, dpr * v.tx, dpr * v.ty);
  const px = 1 / v.s; // one screen pixel in world units
  const L = T.layers, g = T.geo, st = T.stat;
  ctx.imageSmoothingEnabled = v.s < 2;
  if (L.image && T.img) ctx.drawImage(T.img, -0.5, -0.5);
  if (mode() === 'pairs' && T.lm.view === 'ref') {
    // The reference: the frame un-warped, with the pairs' reference points only.
    drawPairs(px, true);
    drawOblique();
    return;
  }
  if (L.warp && T.warpCanvas) {
    // The live warped frame over the frame, mixed by the blend slider (1: warped only).
    ctx.globalAlpha = +$('blend').value;
    ctx.drawImage(T.warpCanvas, -0.5, -0.5);
    ctx.globalAlpha = 1;
  }
  if (L.jacobian && T.jac) ctx.drawImage(T.jac, -0.5, -0.5);
  if (L.model && g.model_outline) {
    const o = g.model_outline;
    ctx.beginPath();
    for (let k = 0; k < o.length; k += 4) { ctx.moveTo(o[k], o[k + 1]); ctx.lineTo(o[k + 2], o[k + 3]); }
    ctx.lineWidth = 2 * px; ctx.strokeStyle = 'rgba(90, 230, 140, 0.95)'; ctx.stroke();
  }
  const pts = g.points || [];
  if (L.quads && st.quads) {
    ctx.beginPath();
    for (const q of st.quads) polygon(q.map((i) => pts[i]));
    ctx.lineWidth = px; ctx.strokeStyle = 'rgba(180, 140, 255, 0.45)'; ctx.stroke();
  }
  if (L.net && st.net) {
    ctx.beginPath();
    for (const [a, b] of st.net) { ctx.moveTo(pts[a][0], pts[a][1]); ctx.lineTo(pts[b][0], pts[b][1]); }
    ctx.lineWidth = px; ctx.strokeStyle = 'rgba(160, 160, 160, 0.5)'; ctx.stroke();
  }
  if (L.mesh && g.mesh) {
    ctx.beginPath();
    for (const line of g.mesh) {
      if (!line.length) continue;
      ctx.moveTo(line[0][0], line[0][1]);
      for (let k = 1; k < line.length; k++) ctx.lineTo(line[k][0], line[k][1]);
    }
    ctx.lineWidth = 1.5 * px; ctx.strokeStyle = 'rgba(90, 200, 255, 0.9)'; ctx.stroke();
  }
  if (g.folding_outline && g.folding_outline.length) {
    // Triangles with a proven fold (det J certificate), outlined in red.
    const o = g.folding_outline;
    ctx.beginPath();
    for (let k = 0; k < o.length; k += 6) polygon([[o[k], o[k + 1]], [o[k + 2], o[k + 3]], [o[k + 4], o[k + 5]]]);
    ctx.lineWidth = 2.5 * px; ctx.strokeStyle = 'rgba(255, 40, 40, 0.95)'; ctx.stroke();
  }
  const sel = g.selection;
  if (L.constraints && sel && st.quads) {
    ctx.beginPath();
    for (const c of sel.constraints) if (st.quads[c]) polygon(st.quads[c].map((i) => pts[i]));
    ctx.lineWidth = 1.5 * px; ctx.strokeStyle = 'rgba(255, 160, 40, 0.9)'; ctx.stroke();
  }
  if (L.points) {
    const r = 2 * px;
    ctx.fillStyle = 'rgba(230, 230, 230, 0.8)';
    ctx.beginPath();
    for (const p of pts) ctx.rect(p[0] - r, p[1] - r, 2 * r, 2 * r);
    ctx.fill();
    const pinned = (T.state && T.state.pinned) || [];
    ctx.strokeStyle = '#3cf'; ctx.lineWidth = px; ctx.beginPath();
    for (const i of pinned) if (pts[i]) ctx.rect(pts[i][0] - 2 * r, pts[i][1] - 2 * r, 4 * r, 4 * r);
    ctx.stroke();
  }
  if (sel) {
    ctx.fillStyle = '#fc3';
    for (const i of sel.derived) dot(pts[i], 2.2 * px);
    ctx.fillStyle = '#f33';
    for (const i of sel.anchors) dot(pts[i], 4.5 * px);
  } else {
    ctx.fillStyle = '#f33';
    for (const i of T.anchors) if (pts[i]) dot(pts[i], 4.5 * px);
  }
  drawPairs(px, false);
  if (T.center) {
    ctx.strokeStyle = '#fff'; ctx.lineWidth = 1.5 * px; ctx.beginPath();
    const [cx, cy] = T.center, k = 8 * px;
    ctx.moveTo(cx - k, cy); ctx.lineTo(cx + k, cy); ctx.moveTo(cx, cy - k); ctx.lineTo(cx, cy + k);
    ctx.stroke();
  }
  drawOblique();
}

// Landmark pairs: in the reference, hollow circles at the reference points; in the target,
// filled circles at the targets and the residual line from phi(reference) to the target.
// Each is numbered (1-based, the table's order); the selected pair is yellow.
function drawPairs(px, ref) {
  const lm = T.lm;
  if (!lm.pairs.length && !lm.pendingSrc) return;
  const r = 5 * px;
  ctx.font = `${12 * px}px system-ui, sans-serif`;
  lm.pairs.forEach((p, i) => {
    const col = i === lm.sel ? '#ffd21f' : '#ff5cf0';
    ctx.strokeStyle = col; ctx.fillStyle = col; ctx.lineWidth = 1.5 * px;
    const at = ref ? p.src : p.dst;
    if (!ref && p.mapped) {
      ctx.beginPath(); ctx.moveTo(p.mapped[0], p.mapped[1]); ctx.lineTo(p.dst[0], p.dst[1]);
      ctx.strokeStyle = 'rgba(255, 60, 60, 0.95)'; ctx.stroke();
      ctx.strokeStyle = col;
      const k = 3 * px;
      ctx.beginPath();
      ctx.moveTo(p.mapped[0] - k, p.mapped[1] - k); ctx.lineTo(p.mapped[0] + k, p.mapped[1] + k);
      ctx.moveTo(p.mapped[0] - k, p.mapped[1] + k); ctx.lineTo(p.mapped[0] + k, p.mapped[1] - k);
      ctx.stroke();
    }
    ctx.beginPath(); ctx.arc(at[0], at[1], r, 0, 2 * Math.PI);
    if (ref) ctx.stroke(); else ctx.fill();
    ctx.fillStyle = col;
    ctx.fillText(String(i + 1), at[0] + 1.4 * r, at[1] - 1.2 * r);
  });
  if (ref && lm.pendingSrc) {
    ctx.strokeStyle = '#fff'; ctx.lineWidth = 1.5 * px;
    ctx.beginPath(); ctx.arc(lm.pendingSrc[0], lm.pendingSrc[1], r, 0, 2 * Math.PI); ctx.stroke();
  }
}

function polygon(ps) {
  if (ps.some((p) => !p)) return;
  ctx.moveTo(ps[0][0], ps[0][1]);
  for (let k = 1; k < ps.length; k++) ctx.lineTo(ps[k][0], ps[k][1]);
  ctx.closePath();
}
function dot(p, r) { if (!p) return; ctx.beginPath(); ctx.arc(p[0], p[1], r, 0, 2 * Math.PI); ctx.fill(); }

// Oblique 3D view of the deformed model (z modes): rotated 60 degrees about the x axis,
// back faces culled, front faces flat-shaded by their slope to the viewer. Rasterized here
// with a depth buffer (pixel centres, nearest face wins), so the model's own overlaps show
// right; 2D path fills of ~3000 triangles took Chromium 6 ms per redraw, this about 1 ms.
let oblImage = null, oblDepth = null;
function drawOblique() {
  const zmode = mode() === 'z0' || mode() === 'z1';
  obl.hidden = !zmode;
  const m = T.geo.model, tris = T.stat.model_triangles;
  if (!zmode || !m || !tris) return;
  const a = Math.PI / 3, ca = Math.cos(a), sa = Math.sin(a);
  const n = m.length / 3, P = new Float64Array(2 * n), D = new Float64Array(n);
  let b = [Infinity, Infinity, -Infinity, -Infinity];
  for (let i = 0; i < n; i++) {
    const x = m[3 * i], y = m[3 * i + 1] * ca - m[3 * i + 2] * sa;
    P[2 * i] = x; P[2 * i + 1] = y;
    // Towards the viewer, whose direction is (0, -sin a, cos a).
    D[i] = -m[3 * i + 1] * sa + m[3 * i + 2] * ca;
    if (x < b[0]) b[0] = x; if (y < b[1]) b[1] = y; if (x > b[2]) b[2] = x; if (y > b[3]) b[3] = y;
  }
  const W = obl.width, H = obl.height;
  const s = 0.9 * Math.min(W / (b[2] - b[0] || 1), H / (b[3] - b[1] || 1));
  const ox = W / 2 - s * (b[0] + b[2]) / 2, oy = H / 2 - s * (b[1] + b[3]) / 2;
  for (let i = 0; i < n; i++) { P[2 * i] = ox + s * P[2 * i]; P[2 * i + 1] = oy + s * P[2 * i + 1]; }
  if (!oblImage || oblImage.width !== W || oblImage.height !== H) {
    oblImage = octx.createImageData(W, H);
    oblDepth = new Float64Array(W * H);
  }
  const px = new Uint32Array(oblImage.data.buffer);
  px.fill(0);
  oblDepth.fill(-Infinity);
  const little = new Uint8Array(new Uint32Array([1]).buffer)[0] === 1;
  for (const t of tris) {
    const i0 = t[0], i1 = t[1], i2 = t[2];
    const ax = P[2 * i0], ay = P[2 * i0 + 1], bx = P[2 * i1], by = P[2 * i1 + 1], cx = P[2 * i2], cy = P[2 * i2 + 1];
    // Facing the viewer: positive orientation in the projected (y-down) plane.
    const area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    if (area <= 0) continue;
    const ux = m[3 * i1] - m[3 * i0], uy = m[3 * i1 + 1] - m[3 * i0 + 1], uz = m[3 * i1 + 2] - m[3 * i0 + 2];
    const vx = m[3 * i2] - m[3 * i0], vy = m[3 * i2 + 1] - m[3 * i0 + 1], vz = m[3 * i2 + 2] - m[3 * i0 + 2];
    const nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const light = Math.abs((ny * -sa + nz * ca) / (Math.hypot(nx, ny, nz) || 1));
    const c = 60 + 170 * light, r = Math.round(c * 0.5), g = Math.round(c), bl = Math.round(c * 0.7);
    const rgba = little ? ((255 << 24) | (bl << 16) | (g << 8) | r) >>> 0 : ((r << 24) | (g << 16) | (bl << 8) | 255) >>> 0;
    const x0 = Math.max(0, Math.ceil(Math.min(ax, bx, cx) - 0.5)), x1 = Math.min(W - 1, Math.floor(Math.max(ax, bx, cx) - 0.5));
    const y0 = Math.max(0, Math.ceil(Math.min(ay, by, cy) - 0.5)), y1 = Math.min(H - 1, Math.floor(Math.max(ay, by, cy) - 0.5));
    const d0 = D[i0] / area, d1 = D[i1] / area, d2 = D[i2] / area;
    for (let y = y0; y <= y1; y++) {
      const qy = y + 0.5;
      for (let x = x0; x <= x1; x++) {
        const qx = x + 0.5;
        // Edge functions: the weight of each vertex, times the area.
        const w0 = (cx - bx) * (qy - by) - (cy - by) * (qx - bx);
        const w1 = (ax - cx) * (qy - cy) - (ay - cy) * (qx - cx);
        const w2 = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax);
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const d = w0 * d0 + w1 * d1 + w2 * d2, k = y * W + x;
        if (d > oblDepth[k]) { oblDepth[k] = d; px[k] = rgba; }
      }
    }
  }
  octx.putImageData(oblImage, 0, 0);
}

// ---- data ---------------------------------------------------------------------------
function applyGeo(r) {
  for (const k of ['points', 'mesh', 'model', 'model_outline', 'z0', 'z1', 'folding_outline']) if (r[k] !== undefined) T.geo[k] = r[k];
  T.geo.selection = r.selection;
  if (r.state) T.state = r.state;
}

// The pairs and their residuals under the current map, in the table and the view.
function applyPairs(v) {
  const lm = T.lm;
  lm.pairs = v.pairs; lm.rms = v.rms; lm.max = v.max; lm.version++;
  // A pair change is one undo step: the status line counts it.
  if (T.state && v.undo !== undefined) { T.state.undo = v.undo; T.state.redo = v.redo; }
  if (lm.sel >= lm.pairs.length) lm.sel = -1;
  const body = $('pairtable').querySelector('tbody');
  body.textContent = '';
  lm.pairs.forEach((p, i) => {
    const tr = document.createElement('tr');
    if (i === lm.sel) tr.className = 'sel';
    for (const t of [String(i + 1), p.name || '', p.residual === null ? 'outside' : p.residual.toFixed(3)]) {
      const td = document.createElement('td'); td.textContent = t; tr.appendChild(td);
    }
    tr.addEventListener('click', () => { lm.sel = i; applyPairs(v); draw(); });
    body.appendChild(tr);
  });
  $('lmsummary').textContent = lm.pairs.length
    ? `${lm.pairs.length} pairs; rms ${lm.rms === null ? '-' : lm.rms.toFixed(3)} px, max ${lm.max === null ? '-' : lm.max.toFixed(3)} px`
    : 'no pairs (landmarks mode: click the reference, then the target)';
  showPairsPanel();
}

function showPairsPanel() {
  const on = mode() === 'pairs';
  $('pairspanel').hidden = !on && !T.lm.pairs.length;
  const what = T.lm.pendingSrc ? '(showing the target: click the target point; Esc drops the pair)'
    : T.lm.view === 'ref' ? '(showing the reference: click a reference point; v: the target)'
      : '(showing the target: drag a target; v: the reference)';
  $('lmview').textContent = on ? what : '';
}

async function refreshPairs() { applyPairs(await api('GET', '/api/landmarks')); draw(); }
T.refreshPairs = refreshPairs;

async function reload(keepView) {
  T.state = await api('GET', '/api/state');
  const full = await api('GET', '/api/geometry?full=1');
  T.geo = full;
  T.stat = { net: full.net, quads: full.quads, model_triangles: full.model_triangles };
  if (T.state.frame && !T.img) {
    const img = new Image();
    img.src = '/api/image.png?' + Date.now();
    await img.decode();
    T.img = img;
  }
  $('mode').querySelector('[value=z0]').disabled = !T.state.z_modes;
  $('mode').querySelector('[value=z1]').disabled = !T.state.z_modes;
  if (!keepView) fitView(); else draw();
  refreshJacobian();
  refreshWarp();
  await refreshPairs();
  status(summary());
}

function summary() {
  const s = T.state;
  if (!s) return '';
  const sel = s.selection ? `; ${s.selection.anchors.length} anchors, ${s.selection.derived.length} derived` : '';
  const t = T.timings.length ? `; last drag step ${T.timings[T.timings.length - 1].toFixed(1)} ms (exact update ${s.last_update_ms.toFixed(1)} ms)` : '';
  const folds = s.fold_free ? '; certified fold-free' : `; NOT certified fold-free (${s.folding_triangles.length} folding, ${s.undecided_triangles.length} undecided triangles)`;
  return `${s.name || 'untitled'}: degree ${s.degree}, ${s.points} control points, ${s.triangles} triangles; undo ${s.undo}, redo ${s.redo}; ${s.pinned.length} corrected${sel}${folds}${t}`;
}

// ---- live warp ----------------------------------------------------------------------
// The server sends phi^-1 at coarse nodes (`GET /api/warp`); the page pulls the frame
// through it: O(q) = I(phi^-1(q)), as `trimorph warp` does, with the map interpolated
// bilinearly in each cell and the frame sampled bilinearly (pixel centres at integers).
// One request in flight; a change while it runs asks for one more.
async function refreshWarp() {
  if (!T.layers.warp || !T.state || !T.state.frame) return;
  if (T.warpBusy) { T.warpAgain = true; return; }
  T.warpBusy = true;
  try {
    const g = await api('GET', '/api/warp');
    const t0 = performance.now();
    buildWarp(g);
    T.warpMs = performance.now() - t0;
    T.warpVersion = (T.warpVersion || 0) + 1;
    draw();
  } catch (e) {
    message('live warp: ' + String(e.message || e), true);
  } finally {
    T.warpBusy = false;
    if (T.warpAgain) { T.warpAgain = false; refreshWarp(); }
  }
}
T.refreshWarp = refreshWarp;

function sourcePixels() {
  if (T.src && T.src.img === T.img) return T.src;
  const c = document.createElement('canvas');
  c.width = T.img.naturalWidth; c.height = T.img.naturalHeight;
  const cx = c.getContext('2d', { willReadFrequently: true });
  cx.drawImage(T.img, 0, 0);
  T.src = { img: T.img, w: c.width, h: c.height, data: cx.getImageData(0, 0, c.width, c.height).data };
  return T.src;
}

function buildWarp(g) {
  const src = sourcePixels();
  const W = g.width, H = g.height, nx = g.nx, ny = g.ny, st = g.step, m = g.map;
  if (!T.warpCanvas || T.warpCanvas.width !== W || T.warpCanvas.height !== H) {
    T.warpCanvas = document.createElement('canvas');
    T.warpCanvas.width = W; T.warpCanvas.height = H;
    T.warpImage = T.warpCanvas.getContext('2d').createImageData(W, H);
  }
  const out = T.warpImage.data, sd = src.data, sw = src.w, sh = src.h;
  out.fill(0);
  const node = (i, n, N) => Math.min(i * st, N - 1);
  for (let y = 0; y < H; y++) {
    const j = Math.min(Math.floor(y / st), ny - 2);
    const y0 = node(j, ny, H), y1 = node(j + 1, ny, H);
    const ty = ny > 1 && y1 > y0 ? (y - y0) / (y1 - y0) : 0;
    for (let x = 0; x < W; x++) {
      const i = Math.min(Math.floor(x / st), nx - 2);
      const x0 = node(i, nx, W), x1 = node(i + 1, nx, W);
      const tx = nx > 1 && x1 > x0 ? (x - x0) / (x1 - x0) : 0;
      const k00 = 2 * (j * nx + i), k10 = k00 + 2, k01 = k00 + 2 * nx, k11 = k01 + 2;
      const a = m[k00], b = m[k10], c = m[k01], d = m[k11];
      if (a === null || b === null || c === null || d === null) continue;
      const w00 = (1 - tx) * (1 - ty), w10 = tx * (1 - ty), w01 = (1 - tx) * ty, w11 = tx * ty;
      let px = w00 * a + w10 * b + w01 * c + w11 * d;
      let py = w00 * m[k00 + 1] + w10 * m[k10 + 1] + w01 * m[k01 + 1] + w11 * m[k11 + 1];
      px = Math.min(Math.max(px, 0), sw - 1); py = Math.min(Math.max(py, 0), sh - 1);
      const ix = Math.min(Math.floor(px), sw - 2 < 0 ? 0 : sw - 2), iy = Math.min(Math.floor(py), sh - 2 < 0 ? 0 : sh - 2);
      const fx = px - ix, fy = py - iy;
      const s00 = 4 * (iy * sw + ix), s10 = s00 + 4, s01 = s00 + 4 * sw, s11 = s01 + 4;
      const o = 4 * (y * W + x);
      for (let ch = 0; ch < 3; ch++) {
        out[o + ch] = (1 - fy) * ((1 - fx) * sd[s00 + ch] + fx * sd[s10 + ch]) + fy * ((1 - fx) * sd[s01 + ch] + fx * sd[s11 + ch]);
      }
      out[o + 3] = 255;
    }
  }
  T.warpCanvas.getContext('2d').putImageData(T.warpImage, 0, 0);
}

async function refreshJacobian() {
  if (!T.layers.jacobian) return;
  const img = new Image();
  img.src = '/api/jacobian.png?v=' + (++T.jacVersion);
  try { await img.decode(); T.jac = img; draw(); } catch (e) { /* ignored: next change retries */ }
}

// One user action: clears the last action's message, runs, shows an error if it failed.
async function run(fn) {
  message('');
  try { await fn(); status(summary()); } catch (e) { message(String(e.message || e), true); status(summary()); }
}

// ---- editing ------------------------------------------------------------------------
function nearestOnScreen(X, Y, maxPx) {
  let best = -1, bd = maxPx * maxPx;
  const pts = T.geo.points || [];
  for (let i = 0; i < pts.length; i++) {
    const [sx, sy] = toScreen(pts[i][0], pts[i][1]);
    const d = (sx - X) ** 2 + (sy - Y) ** 2;
    if (d < bd) { bd = d; best = i; }
  }
  return best;
}

// Waits until no drag step is queued or in flight (a new selection or a clear must reach
// the server after the last step of the previous drag).
async function updatesDone() {
  while (T.busy || T.pending) await new Promise((r) => setTimeout(r, 2));
}

function anchorCentroid() {
  const pts = T.geo.points, a = T.anchors;
  let x = 0, y = 0;
  for (const i of a) { x += pts[i][0]; y += pts[i][1]; }
  return [x / a.length, y / a.length];
}

function opBody(d, X, Y) {
  const [wx, wy] = toWorld(X, Y);
  const zmode = d.mode !== 'xy';
  if (d.op === 'translate') {
    return zmode ? { op: 'translate', v: [-(Y - d.Y0) / T.view.s] } : { op: 'translate', v: [wx - d.wx0, wy - d.wy0] };
  }
  if (zmode) {
    const f = Math.exp(-(Y - d.Y0) / 150);
    const zs = T.geo[d.mode] || [];
    const c = d.anchors.reduce((s, i) => s + (zs[i] || 0), 0) / d.anchors.length;
    return { op: 'scale', center: [c], factor: f };
  }
  const c = d.center;
  if (d.op === 'rotate') {
    const a0 = Math.atan2(d.wy0 - c[1], d.wx0 - c[0]), a1 = Math.atan2(wy - c[1], wx - c[0]);
    return { op: 'rotate', center: c, angle: a1 - a0 };
  }
  const r0 = Math.hypot(d.wx0 - c[0], d.wy0 - c[1]) || 1;
  const f = Math.max(0.05, Math.hypot(wx - c[0], wy - c[1]) / r0);
  return { op: 'scale', center: c, factor: f };
}

// Drag steps: at most one request in flight; the newest position waits in `pending` (older
// ones are dropped). A step of a drag is sent only once the drag's selection answered
// (`d.ready`), and never after it failed.
function sendUpdate(d, body) {
  T.pending = { d, body };
  if (!T.busy) pump();
}

async function pump() {
  while (T.pending) {
    const { d, body } = T.pending;
    T.pending = null;
    T.busy = true;
    const t0 = performance.now();
    try {
      if (!(await d.ready)) continue;
      const r = await api('POST', '/api/update', body);
      const t1 = performance.now();
      applyGeo(r);
      draw();
      const t2 = performance.now();
      T.timings.push(t2 - t0);
      // Where a step's time goes: request and parse, drawing, and the server's exact update.
      T.phases.push({ request: t1 - t0, draw: t2 - t1, update: r.state ? r.state.last_update_ms : null });
      status(summary());
      refreshWarp();
    } catch (e) {
      message(String(e.message || e), true);
    } finally {
      T.busy = false;
    }
  }
}

async function idle() {
  while (T.busy || T.pending || T.selecting) await new Promise((r) => setTimeout(r, 5));
}
T.idle = idle;

// One coordinate convention for every pointer event: CSS pixels from the canvas's top
// left corner (`clientX - rect.left`, unrounded), so that a drag ends under the pointer.
function pointer(e) {
  const r = canvas.getBoundingClientRect();
  return [e.clientX - r.left, e.clientY - r.top];
}
T.pointer = pointer;

canvas.addEventListener('contextmenu', (e) => {
  e.preventDefault();
  const [X, Y] = pointer(e);
  T.center = toWorld(X, Y);
  draw();
});

// The press starts the drag at once (the selection request runs in the background; the
// drag's steps wait for it), and the release ends it whatever the server has answered:
// a fast tap selects and never edits.
canvas.addEventListener('mousedown', (e) => {
  message('');
  const [X, Y] = pointer(e);
  if (e.button === 0 && mode() === 'pairs') { pairsDown(X, Y); return; }
  if (e.button === 1 || (e.button === 0 && mode() === 'view')) {
    T.drag = { pan: true, X0: X, Y0: Y, tx: T.view.tx, ty: T.view.ty };
    return;
  }
  if (e.button !== 0) return;
  const hit = nearestOnScreen(X, Y, 10);
  if (hit < 0) {
    if (!e.shiftKey) {
      T.drag = { pan: true, X0: X, Y0: Y, tx: T.view.tx, ty: T.view.ty };
      clearSelection();
    }
    return;
  }
  let anchors = T.anchors.slice();
  if (e.shiftKey) {
    anchors = anchors.includes(hit) ? anchors.filter((i) => i !== hit) : anchors.concat([hit]);
  } else if (!anchors.includes(hit)) {
    anchors = [hit];
  }
  if (!anchors.length) { clearSelection(); return; }
  T.anchors = anchors;
  const [wx0, wy0] = toWorld(X, Y);
  const d = {
    id: ++T.dragId, X0: X, Y0: Y, wx0, wy0, op: op(), mode: mode(), anchors,
    center: T.center || anchorCentroid(), moved: false,
  };
  T.drag = d;
  T.selecting = true;
  d.ready = updatesDone()
    .then(() => api('POST', '/api/select', { anchors, radius: radius(), mode: d.mode }))
    .then((r) => { applyGeo(r); draw(); return true; })
    .catch((err) => { message(String(err.message || err), true); if (T.drag === d) T.drag = null; return false; })
    .finally(() => { T.selecting = false; });
  draw();
});

// Landmarks mode: a press on a shown point (a reference point in the reference, a target
// in the target) selects its pair and drags that point (sent once, at the release);
// elsewhere the first click gives a reference point and shows the target, the second the
// target point, which adds the pair.
function pairsDown(X, Y) {
  const lm = T.lm, ref = lm.view === 'ref';
  let hit = -1, bd = 8 * 8;
  lm.pairs.forEach((p, i) => {
    const q = ref ? p.src : p.dst;
    const [sx, sy] = toScreen(q[0], q[1]);
    const d = (sx - X) ** 2 + (sy - Y) ** 2;
    if (d < bd) { bd = d; hit = i; }
  });
  if (hit >= 0 && !lm.pendingSrc) {
    lm.sel = hit;
    const q = ref ? lm.pairs[hit].src : lm.pairs[hit].dst;
    T.drag = { pair: hit, which: ref ? 'src' : 'dst', X0: X, Y0: Y, start: q.slice(), moved: false };
    applyPairs(lm); draw();
    return;
  }
  const w = toWorld(X, Y);
  if (!lm.pendingSrc) {
    lm.pendingSrc = w;
    lm.view = 'target';
    showPairsPanel(); draw();
    message('reference point set: now click its target point');
    return;
  }
  const src = lm.pendingSrc;
  lm.pendingSrc = null;
  lm.view = 'ref';
  run(async () => {
    const v = await api('POST', '/api/landmarks/add', { src, dst: w });
    lm.sel = v.index;
    applyPairs(v); draw();
    message(`added pair ${v.index + 1}`);
  });
}

function pairDragTo(d, X, Y) {
  const p = T.lm.pairs[d.pair];
  if (!p) return null;
  const q = [d.start[0] + (X - d.X0) / T.view.s, d.start[1] + (Y - d.Y0) / T.view.s];
  p[d.which] = q;
  return q;
}

function endPairDrag(d, e) {
  if (!d.moved) return;
  const q = e ? pairDragTo(d, ...pointer(e)) : T.lm.pairs[d.pair][d.which];
  run(async () => {
    const v = await api('POST', '/api/landmarks/move', { index: d.pair, [d.which]: q });
    applyPairs(v); draw();
    message(`moved pair ${d.pair + 1}`);
  });
}

function deletePair() {
  const i = T.lm.sel;
  if (i < 0) return;
  run(async () => {
    const v = await api('POST', '/api/landmarks/delete', { index: i });
    T.lm.sel = -1;
    applyPairs(v); draw();
    message(`deleted pair ${i + 1}`);
  });
}

function clearSelection() {
  T.anchors = [];
  T.geo.selection = null;
  draw();
  run(async () => { await updatesDone(); await api('POST', '/api/clear'); });
}

function endDrag(e) {
  const d = T.drag;
  T.drag = null;
  if (d && d.pair !== undefined) { endPairDrag(d, e); return; }
  if (!d || d.pan) return;
  if (d.moved && e) {
    // The last step is the release point itself.
    const [X, Y] = pointer(e);
    sendUpdate(d, opBody(d, X, Y));
  }
  run(async () => {
    await idle();
    T.state = await api('GET', '/api/state');
    refreshJacobian();
    refreshWarp();
    await refreshPairs();
  });
}

window.addEventListener('mousemove', (e) => {
  const d = T.drag;
  if (!d) return;
  // The release happened where no event reached us (outside the window): the drag is over.
  if (e.buttons === 0) { endDrag(null); return; }
  const [X, Y] = pointer(e);
  if (d.pair !== undefined) {
    if (X === d.X0 && Y === d.Y0 && !d.moved) return;
    d.moved = true;
    pairDragTo(d, X, Y);
    draw();
    return;
  }
  if (d.pan) {
    T.view.tx = d.tx + X - d.X0; T.view.ty = d.ty + Y - d.Y0;
    draw();
    return;
  }
  if (X === d.X0 && Y === d.Y0 && !d.moved) return;
  d.moved = true;
  sendUpdate(d, opBody(d, X, Y));
});

window.addEventListener('mouseup', (e) => { if (e.button === 0 || e.button === 1) endDrag(e); });

canvas.addEventListener('wheel', (e) => {
  e.preventDefault();
  const k = Math.exp(-e.deltaY / 500);
  const [X, Y] = pointer(e);
  const [wx, wy] = toWorld(X, Y);
  T.view.s *= k;
  T.view.tx = X - T.view.s * wx; T.view.ty = Y - T.view.s * wy;
  draw();
}, { passive: false });

// ---- commands -----------------------------------------------------------------------
async function undoRedo(which) {
  const r = await api('POST', '/api/' + which);
  applyGeo(r);
  T.anchors = [];
  draw();
  refreshJacobian();
  refreshWarp();
  await refreshPairs();
}

// An export asks before it replaces a file (the server refuses the editor's own inputs).
async function exportAs(kind, path) {
  const st = await api('POST', '/api/stat', { path });
  if (st.exists && !confirm(`${path} exists. Overwrite it?`)) { message('not exported: ' + path + ' exists'); return; }
  const r = await api('POST', '/api/export', { kind, path });
  message('exported ' + r.saved);
}

// Saving asks before overwriting a file and before saving a map that is not certified
// fold-free; `scene` also keeps the model and the frame (written beside it when they have
// no file in the folder).
async function save(scene) {
  const path = $('path').value;
  await updatesDone();
  const st = await api('POST', '/api/stat', { path });
  if (st.exists && !confirm(`${path} exists. Overwrite it?`)) { message('not saved: ' + path + ' exists'); return; }
  const s = T.state;
  if (s && !s.fold_free && !confirm(`The map folds: it is NOT certified fold-free (${s.folding_triangles.length} folding, ${s.undecided_triangles.length} undecided triangles, outlined in red). Save anyway?`)) {
    message('not saved: the map folds');
    return;
  }
  const r = await api('POST', '/api/save', { path, scene });
  const also = (r.written || []).length ? ' (also wrote ' + r.written.join(', ') + ')' : '';
  message((scene ? 'saved scene ' : 'saved ') + r.saved + also);
}

function toggleHelp() { $('helppanel').hidden = !$('helppanel').hidden; }

const commands = {
  help: toggleHelp,
  undo: () => run(() => undoRedo('undo')),
  redo: () => run(() => undoRedo('redo')),
  save: () => run(() => save(false)),
  savescene: () => run(() => save(true)),
  load: () => run(async () => {
    const path = $('path').value;
    await updatesDone();
    const st = await api('POST', '/api/stat', { path });
    const steps = T.state ? T.state.undo + T.state.redo : 0;
    if (st.exists && st.same_layout === false && steps > 0
        && !confirm(`${path} is over another mesh: loading it starts a new document and clears the undo history (${steps} steps). Load it?`)) {
      message('not loaded: the undo history is kept');
      return;
    }
    await api('POST', '/api/load', { path });
    T.img = null; T.anchors = [];
    await reload(false);
    message('loaded ' + path + (st.same_layout === false ? ' (new document: the undo history was cleared)' : ' (undo restores the previous state)'));
  }),
  exportobj: () => run(() => exportAs('obj', $('path').value.replace(/\.[^.]*$/, '') + '.obj')),
  exportimg: () => run(() => exportAs('warped', $('path').value.replace(/\.[^.]*$/, '') + '.png')),
  // The re-fit uses the pairs in the page; the residuals after it are in the table.
  refit: () => run(async () => {
    await updatesDone();
    const r = await api('POST', '/api/refit', { hard: $('hard').checked });
    applyGeo(r); applyPairs(r.landmarks); draw(); refreshJacobian(); refreshWarp();
    const l = r.landmarks;
    message(`re-fit (${r.method}${$('hard').checked ? ', hard' : ''}) to ${l.pairs.length} pairs: rms ${l.rms.toFixed(3)} px, max ${l.max.toFixed(3)} px; ${r.pinned} corrected points held exactly (undo takes it back)`);
  }),
  lmimport: () => run(async () => {
    const path = $('landmarks').value;
    if (T.lm.pairs.length && !confirm(`Replace the ${T.lm.pairs.length} pairs with those of ${path}?`)) { message('not imported'); return; }
    const v = await api('POST', '/api/landmarks/import', { path });
    T.lm.sel = -1; T.lm.pendingSrc = null;
    applyPairs(v); draw();
    message(`imported ${v.pairs.length} pairs from ${path}`);
  }),
  lmexport: () => run(async () => {
    const path = $('landmarks').value, format = $('lmformat').value;
    const st = await api('POST', '/api/stat', { path });
    if (st.exists && !confirm(`${path} exists. Overwrite it?`)) { message('not exported: ' + path + ' exists'); return; }
    const r = await api('POST', '/api/landmarks/export', { path, format });
    message(`exported ${T.lm.pairs.length} pairs (${format}) to ${r.saved}`);
  }),
};
for (const [id, fn] of Object.entries(commands)) $(id).addEventListener('click', fn);

for (const box of document.querySelectorAll('[data-layer]')) {
  T.layers[box.dataset.layer] = box.checked;
  box.addEventListener('change', () => {
    T.layers[box.dataset.layer] = box.checked;
    if (box.dataset.layer === 'jacobian') refreshJacobian();
    if (box.dataset.layer === 'warp') refreshWarp();
    draw();
  });
}
$('mode').addEventListener('change', () => run(async () => {
  T.lm.view = 'ref'; T.lm.pendingSrc = null; showPairsPanel();
  T.anchors = []; await api('POST', '/api/clear'); T.geo.selection = null; draw();
}));

window.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'INPUT' && e.target.type !== 'checkbox') return;
  const k = e.key, ctrl = e.ctrlKey || e.metaKey;
  if (k === '?') { toggleHelp(); return; }
  if (k === 'Escape' && !$('helppanel').hidden) { $('helppanel').hidden = true; return; }
  const setSel = (id, v) => { const el = $(id); if (!el.querySelector(`[value=${v}]`).disabled) { el.value = v; el.dispatchEvent(new Event('change')); } };
  if (ctrl && (k === 'z' || k === 'Z')) { e.preventDefault(); (e.shiftKey ? commands.redo : commands.undo)(); }
  else if (ctrl && k === 'y') { e.preventDefault(); commands.redo(); }
  else if (ctrl && k === 's') { e.preventDefault(); commands.save(); }
  else if (ctrl) return;
  else if (k === '1') setSel('mode', 'view');
  else if (k === '2') setSel('mode', 'xy');
  else if (k === '3') setSel('mode', 'z0');
  else if (k === '4') setSel('mode', 'z1');
  else if (k === '5') setSel('mode', 'pairs');
  else if (mode() === 'pairs' && (k === 'Delete' || k === 'Backspace')) { e.preventDefault(); deletePair(); }
  else if (mode() === 'pairs' && k === 'v') { T.lm.view = T.lm.view === 'ref' ? 'target' : 'ref'; showPairsPanel(); draw(); }
  else if (mode() === 'pairs' && k === 'Escape' && T.lm.pendingSrc) { T.lm.pendingSrc = null; T.lm.view = 'ref'; showPairsPanel(); draw(); message('half-placed pair dropped'); }
  else if (k === 't') $('op').value = 'translate';
  else if (k === 'r') $('op').value = 'rotate';
  else if (k === 's') $('op').value = 'scale';
  else if (k === 'a') $('all').checked = !$('all').checked;
  else if (k === '+' || k === '=') $('radius').value = Math.min(50, +$('radius').value + 1);
  else if (k === '-') $('radius').value = Math.max(0, +$('radius').value - 1);
  else if (k === 'j') { const b = document.querySelector('[data-layer=jacobian]'); b.checked = !b.checked; b.dispatchEvent(new Event('change')); }
  else if (k === 'f') fitView();
  else if (k === 'w') { const b = document.querySelector('[data-layer=warp]'); b.checked = !b.checked; b.dispatchEvent(new Event('change')); }
  else if (k === 'b') { const b = $('blend'); b.value = +b.value > 0.5 ? 0 : 1; draw(); }
  else if (k === 'c') { T.center = null; draw(); }
  else if (k === 'Escape') run(async () => { T.anchors = []; await api('POST', '/api/clear'); T.geo.selection = null; draw(); });
});

window.addEventListener('resize', draw);
$('blend').addEventListener('input', draw);
run(() => reload(false)).then(() => { T.ready = true; });
