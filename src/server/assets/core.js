// trimorph editor page, part 1 of 5 (core.js, draw.js, warp.js, pairs.js, app.js: classic
// scripts loaded in that order, sharing one global scope). The engine (Rust, /api/...)
// computes all geometry; the page only draws what it is sent and turns mouse and keyboard
// input into API calls.
//
// Coordinates: the main view (`#view`) shows the target: world coordinates are the fixed
// image's pixels (or, with one image, the frame's), where phi sends the reference. The
// left panel (`#moving`, two-image sessions only) shows the moving image un-warped: its
// world coordinates are the reference's (mesh coordinates = moving pixels). Pixel centres
// at integers, x right, y down, everywhere.
'use strict';

const T = {
  state: null, geo: {}, stat: {}, img: null, fixedImg: null, jac: null, jacVersion: 0,
  view: { s: 1, tx: 0, ty: 0 }, mview: { s: 1, tx: 0, ty: 0 }, anchors: [], center: null,
  drag: null, busy: false, pending: null, timings: [], phases: [], lastError: null,
  layers: {}, dragId: 0,
  // Live warp: milliseconds from a drag step's pointer event to the end of the redraw that
  // shows the warped frame of that step (one entry per step drawn).
  warpLatency: [],
  // Landmark pairs (`GET /api/landmarks`), the selected pair, the half-placed pair's
  // point (`pendingSrc` in the reference, `pendingDst` in the target), and which image
  // the one-image landmarks mode shows: 'ref' (the frame un-warped, where reference
  // points are clicked) or 'target' (the current view).
  lm: { pairs: [], rms: null, max: null, sel: -1, pendingSrc: null, pendingDst: null, view: 'ref', version: 0 },
  // The session token from the address `trimorph editor` printed (`/?token=...`); without
  // it the page relies on the cookie the server set when that address was loaded.
  token: new URLSearchParams(location.search).get('token'),
};
window.trimorph = T;

const $ = (id) => document.getElementById(id);
const canvas = $('view');
const ctx = canvas.getContext('2d');
const mcanvas = $('moving');
const mctx = mcanvas.getContext('2d');
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

// One user action: clears the last action's message, runs, shows an error if it failed.
async function run(fn) {
  message('');
  try { await fn(); status(summary()); } catch (e) { message(String(e.message || e), true); status(summary()); }
}

function mode() { return $('mode').value; }
function op() { return $('op').value; }
function radius() { return $('all').checked ? null : Math.max(0, parseInt($('radius').value || '0', 10)); }
// A two-image session (`--moving M --fixed F`): two panels.
function twoImages() { return !!(T.state && T.state.fixed); }
T.twoImages = twoImages;

// ---- view transforms ----------------------------------------------------------------
function toScreen(x, y) { return [T.view.s * x + T.view.tx, T.view.s * y + T.view.ty]; }
function toWorld(X, Y) { return [(X - T.view.tx) / T.view.s, (Y - T.view.ty) / T.view.s]; }
// The left panel's (moving image, reference coordinates).
function toScreenM(x, y) { return [T.mview.s * x + T.mview.tx, T.mview.s * y + T.mview.ty]; }
function toWorldM(X, Y) { return [(X - T.mview.tx) / T.mview.s, (Y - T.mview.ty) / T.mview.s]; }
T.toScreen = toScreen; T.toWorld = toWorld; T.toScreenM = toScreenM; T.toWorldM = toWorldM;

// One coordinate convention for every pointer event: CSS pixels from the canvas's top
// left corner (`clientX - rect.left`, unrounded), so that a drag ends under the pointer.
function pointer(e, c) {
  const r = (c || canvas).getBoundingClientRect();
  return [e.clientX - r.left, e.clientY - r.top];
}
T.pointer = pointer;

function frameBounds(f) { return [-0.5, -0.5, f.width - 0.5, f.height - 0.5]; }

function bounds() {
  if (T.state && T.state.fixed) return frameBounds(T.state.fixed);
  if (T.state && T.state.frame) return frameBounds(T.state.frame);
  let b = [Infinity, Infinity, -Infinity, -Infinity];
  for (const p of T.geo.points || []) {
    b = [Math.min(b[0], p[0]), Math.min(b[1], p[1]), Math.max(b[2], p[0]), Math.max(b[3], p[1])];
  }
  return b;
}

function fitTo(c, b) {
  const [x0, y0, x1, y1] = b;
  const w = c.clientWidth, h = c.clientHeight;
  const s = 0.95 * Math.min(w / (x1 - x0 || 1), h / (y1 - y0 || 1));
  return { s, tx: w / 2 - s * (x0 + x1) / 2, ty: h / 2 - s * (y0 + y1) / 2 };
}

function fitView() {
  layoutPanels();
  T.view = fitTo(canvas, bounds());
  if (twoImages() && T.state.frame) T.mview = fitTo(mcanvas, frameBounds(T.state.frame));
  draw();
}

// One panel, or the moving image on the left and the target on the right.
function layoutPanels() {
  const two = twoImages();
  document.body.classList.toggle('two', two);
  mcanvas.hidden = !two;
  $('overlaylabel').hidden = !two;
  $('reregister').hidden = !two;
}

// Sizes a canvas's backing store to its CSS size; returns the device pixel ratio.
function sizeCanvas(c) {
  const dpr = window.devicePixelRatio || 1;
  const w = c.clientWidth, h = c.clientHeight;
  if (c.width !== Math.round(w * dpr) || c.height !== Math.round(h * dpr)) {
    c.width = Math.round(w * dpr); c.height = Math.round(h * dpr);
  }
  return dpr;
}

function summary() {
  const s = T.state;
  if (!s) return '';
  const sel = s.selection ? `; ${s.selection.anchors.length} anchors, ${s.selection.derived.length} derived` : '';
  const t = T.timings.length ? `; last drag step ${T.timings[T.timings.length - 1].toFixed(1)} ms (exact update ${s.last_update_ms.toFixed(1)} ms)` : '';
  const folds = s.fold_free ? '; certified fold-free' : `; NOT certified fold-free (${s.folding_triangles.length} folding, ${s.undecided_triangles.length} undecided triangles)`;
  // The buttons say what they would take back or do again.
  $('undo').title = 'Ctrl+Z' + (s.undo_next ? ': undo ' + s.undo_next : ': nothing to undo');
  $('redo').title = 'Ctrl+Y' + (s.redo_next ? ': redo ' + s.redo_next : ': nothing to redo');
  return `${s.name || 'untitled'}: degree ${s.degree}, ${s.points} control points, ${s.triangles} triangles; undo ${s.undo}, redo ${s.redo}; ${s.pinned.length} corrected${sel}${folds}${t}`;
}

// The file-name fields survive a reload of the page (kept in this origin's storage: one
// editor port, one set of names).
const KEPT_FIELDS = ['path', 'landmarks'];
function restoreFields() {
  for (const id of KEPT_FIELDS) {
    let v = null;
    try { v = localStorage.getItem('trimorph.' + id); } catch (e) { /* storage disabled */ }
    if (v) $(id).value = v;
    $(id).addEventListener('input', () => {
      try { localStorage.setItem('trimorph.' + id, $(id).value); } catch (e) { /* storage disabled */ }
    });
  }
}
restoreFields();
