// trimorph editor page, part 5 of 5: loading, editing (drags as API calls), the commands
// and the keyboard. See core.js for the coordinates.
'use strict';

// ---- data ---------------------------------------------------------------------------
function applyGeo(r) {
  for (const k of ['points', 'mesh', 'model', 'model_outline', 'z0', 'z1', 'folding_outline']) if (r[k] !== undefined) T.geo[k] = r[k];
  T.geo.selection = r.selection;
  if (r.state) T.state = r.state;
}

async function loadImage(path) {
  const img = new Image();
  img.src = path + '?' + Date.now();
  await img.decode();
  return img;
}

async function reload(keepView) {
  T.state = await api('GET', '/api/state');
  const full = await api('GET', '/api/geometry?full=1');
  T.geo = full;
  T.stat = { net: full.net, quads: full.quads, model_triangles: full.model_triangles };
  if (T.state.frame && !T.img) T.img = await loadImage('/api/image.png');
  if (T.state.fixed && !T.fixedImg) T.fixedImg = await loadImage('/api/fixed.png');
  if (!T.state.fixed) T.fixedImg = null;
  $('mode').querySelector('[value=z0]').disabled = !T.state.z_modes;
  $('mode').querySelector('[value=z1]').disabled = !T.state.z_modes;
  layoutPanels();
  if (!keepView) fitView(); else draw();
  refreshJacobian();
  refreshWarp();
  await refreshPairs();
  status(summary());
}

async function refreshJacobian() {
  $('legend').hidden = !T.layers.jacobian;
  if (!T.layers.jacobian) return;
  const img = new Image();
  img.src = '/api/jacobian.png?v=' + (++T.jacVersion);
  try { await img.decode(); T.jac = img; draw(); } catch (e) { /* ignored: next change retries */ }
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
// (`d.ready`), and never after it failed. `t` is the pointer event's time.
function sendUpdate(d, body, t) {
  T.pending = { d, body, t };
  if (!T.busy) pump();
}

// A translate drag in xy mode with the live warp on asks its selection for the warp's
// basis (`POST /api/select?warp=8`): phi at the grid nodes is `map + v_x gx + v_y gy` for
// the drag `v` (exactly the engine's affine map of the selection), so the warped frame of
// each pointer position is drawn at once, without waiting for the exact update; the
// update's answer brings the mesh and the points, and the drag's end the exact map.
function wantsBasis(d) {
  return d.mode === 'xy' && d.op === 'translate' && T.layers.warp && T.state && T.state.frame;
}

// Draws the warped frame of drag `d` at translation `v` from its basis; `t` is the
// pointer event's time.
function predictWarp(d, v, t) {
  const b = d.basis;
  if (!b) return;
  const m = b.map, gx = b.gx, gy = b.gy, out = new Array(m.length);
  for (let k = 0; k < m.length; k++) out[k] = m[k] === null ? null : m[k] + v[0] * gx[k] + v[1] * gy[k];
  applyWarp({ ...b, map: out });
  draw();
  T.warpLatency.push(performance.now() - t);
}

// Each step's answer carries the forward map of the live warp (`?warp=8`, xy drags with a
// frame shown), so the warped frame of that step is drawn with its geometry, in the same
// redraw.
async function pump() {
  while (T.pending) {
    const { d, body, t } = T.pending;
    T.pending = null;
    T.busy = true;
    const t0 = performance.now();
    try {
      if (!(await d.ready)) continue;
      const live = T.layers.warp && T.state && T.state.frame && d.mode === 'xy' && !d.basis;
      const r = await api('POST', '/api/update' + (live ? '?warp=8' : ''), body);
      const t1 = performance.now();
      applyGeo(r);
      if (r.warp) applyWarp(r.warp);
      const tw = performance.now();
      draw();
      const t2 = performance.now();
      T.timings.push(t2 - t0);
      if (r.warp) T.warpLatency.push(t2 - t);
      // Where a step's time goes: request and parse, the warp, drawing, and the server's
      // exact update.
      T.phases.push({ request: t1 - t0, warp: tw - t1, draw: t2 - tw, update: r.state ? r.state.last_update_ms : null, server: r.server_ms });
      status(summary());
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
    // The ghost: where the anchors started (xy drags).
    ghost: mode() === 'xy' ? anchors.map((i) => T.geo.points[i].slice()) : null,
    ghostNow: () => anchors.map((i) => T.geo.points[i]),
  };
  T.drag = d;
  T.selecting = true;
  d.ready = updatesDone()
    .then(() => api('POST', '/api/select' + (wantsBasis(d) ? '?warp=8' : ''), { anchors, radius: radius(), mode: d.mode }))
    .then((r) => {
      applyGeo(r);
      if (r.warp && r.warp.gx) d.basis = r.warp;
      if (d.basis && d.lastV) predictWarp(d, d.lastV, performance.now()); else draw();
      return true;
    })
    .catch((err) => { message(String(err.message || err), true); if (T.drag === d) T.drag = null; return false; })
    .finally(() => { T.selecting = false; });
  draw();
});
mcanvas.addEventListener('mousedown', (e) => { message(''); movingDown(e); });
mcanvas.addEventListener('contextmenu', (e) => e.preventDefault());

function clearSelection() {
  T.anchors = [];
  T.geo.selection = null;
  draw();
  run(async () => { await updatesDone(); await api('POST', '/api/clear'); });
}

function endDrag(e) {
  const d = T.drag;
  T.drag = null;
  if (d && d.pair !== undefined) { endPairDrag(d, e); draw(); return; }
  if (!d || d.pan) return;
  if (d.moved && e) {
    // The last step is the release point itself.
    const [X, Y] = pointer(e);
    sendUpdate(d, opBody(d, X, Y), e.timeStamp);
  }
  draw();
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
  const [X, Y] = pointer(e, d.canvas || (d.panel === 'moving' ? mcanvas : canvas));
  if (d.pair !== undefined) {
    if (X === d.X0 && Y === d.Y0 && !d.moved) return;
    d.moved = true;
    pairDragTo(d, X, Y);
    draw();
    return;
  }
  if (d.pan) {
    const v = d.panel === 'moving' ? T.mview : T.view;
    v.tx = d.tx + X - d.X0; v.ty = d.ty + Y - d.Y0;
    draw();
    return;
  }
  if (X === d.X0 && Y === d.Y0 && !d.moved) return;
  d.moved = true;
  const body = opBody(d, X, Y);
  sendUpdate(d, body, e.timeStamp);
  if (d.op === 'translate' && d.mode === 'xy') {
    d.lastV = body.v;
    predictWarp(d, body.v, e.timeStamp);
  }
});

window.addEventListener('mouseup', (e) => { if (e.button === 0 || e.button === 1) endDrag(e); });

function zoomAt(e, c, v) {
  e.preventDefault();
  const k = Math.exp(-e.deltaY / 500);
  const [X, Y] = pointer(e, c);
  const wx = (X - v.tx) / v.s, wy = (Y - v.ty) / v.s;
  v.s *= k;
  v.tx = X - v.s * wx; v.ty = Y - v.s * wy;
  draw();
}
canvas.addEventListener('wheel', (e) => zoomAt(e, canvas, T.view), { passive: false });
mcanvas.addEventListener('wheel', (e) => zoomAt(e, mcanvas, T.mview), { passive: false });

// ---- commands -----------------------------------------------------------------------
// Undo and redo say what they took back or did again.
async function undoRedo(which) {
  const r = await api('POST', '/api/' + which);
  applyGeo(r);
  T.anchors = [];
  draw();
  refreshJacobian();
  refreshWarp();
  await refreshPairs();
  message(which === 'undo' ? `undid: ${r.undid}` : `redid: ${r.redid}`);
}

// An export asks before it replaces a file (the server refuses the editor's own inputs).
async function exportAs(kind, path) {
  const st = await api('POST', '/api/stat', { path });
  if (st.exists && !confirm(`${path} exists. Overwrite it?`)) { message('not exported: ' + path + ' exists'); return; }
  const r = await api('POST', '/api/export', { kind, path });
  message('exported ' + r.saved);
}

// Saving asks before overwriting a file and before saving a map that is not certified
// fold-free; `scene` also keeps the model, the images and the pairs (images written
// beside it when they have no file in the folder).
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
    T.img = null; T.fixedImg = null; T.anchors = [];
    await reload(false);
    message('loaded ' + path + (st.same_layout === false ? ' (new document: the undo history was cleared)' : ' (undo restores the previous state)'));
  }),
  exportobj: () => run(() => exportAs('obj', $('path').value.replace(/\.[^.]*$/, '') + '.obj')),
  exportimg: () => run(() => exportAs('warped', $('path').value.replace(/\.[^.]*$/, '') + '.png')),
  // The re-fit uses the active pairs (with a fit's own landmarks, when the deformation
  // carried them); the residuals after it are in the table.
  refit: () => run(async () => {
    await updatesDone();
    const r = await api('POST', '/api/refit', { hard: $('hard').checked });
    applyGeo(r); applyPairs(r.landmarks); draw(); refreshJacobian(); refreshWarp();
    const l = r.landmarks;
    const n = l.pairs.filter((p) => p.active !== false).length;
    message(`re-fit (${r.method}${$('hard').checked ? ', hard' : ''}) to ${n} pairs: rms ${l.rms.toFixed(3)} px, max ${l.max.toFixed(3)} px; ${r.pinned} corrected points held exactly (undo takes it back)`);
  }),
  // Two images: the moving image registered to the fixed one again from the pixels,
  // starting from the current deformation; corrected points stay pinned, and the active
  // pairs join the image term (exactly with "hard").
  reregister: () => run(async () => {
    await updatesDone();
    const pairs = T.lm.pairs.some((p) => p.active !== false);
    const hard = pairs && $('hard').checked;
    message('registering from the pixels...');
    const r = await api('POST', '/api/register', { pairs, hard });
    applyGeo(r); draw(); refreshJacobian(); refreshWarp();
    if (pairs) applyPairs((await api('GET', '/api/landmarks')));
    draw();
    message(`re-registered (${r.metric}): ${r.metric_before.toFixed(4)} -> ${r.metric_after.toFixed(4)}, ${r.iterations} iterations, ${Math.round(r.time_ms)} ms; ${r.fold_free ? 'certified fold-free' : 'NOT certified fold-free'} (det J >= ${r.det_j_lower_bound.toFixed(3)}); ${r.pinned} corrected points held exactly${pairs ? `, ${r.pairs} pairs${hard ? ' (exact)' : ''}` : ''} (undo takes it back)`);
  }),
  ...pairCommands,
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
  T.lm.view = 'ref'; T.lm.pendingSrc = null; T.lm.pendingDst = null; showPairsPanel();
  T.anchors = []; await api('POST', '/api/clear'); T.geo.selection = null; draw();
}));
$('overlay').addEventListener('change', () => { if (T.warpImage && twoImages()) twoColours(); draw(); });

window.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'INPUT' && e.target.type !== 'checkbox') return;
  const k = e.key, ctrl = e.ctrlKey || e.metaKey;
  if (k === '?') { toggleHelp(); return; }
  if (k === 'Escape' && !$('helppanel').hidden) { $('helppanel').hidden = true; return; }
  const setSel = (id, v) => { const el = $(id); if (!el.querySelector(`[value=${v}]`).disabled) { el.value = v; el.dispatchEvent(new Event('change')); } };
  const toggle = (sel) => { const b = document.querySelector(sel); b.checked = !b.checked; b.dispatchEvent(new Event('change')); };
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
  else if (mode() === 'pairs' && k === 'v' && !twoImages()) { T.lm.view = T.lm.view === 'ref' ? 'target' : 'ref'; showPairsPanel(); draw(); }
  else if (mode() === 'pairs' && k === 'Escape' && dropHalfPair()) { /* dropped */ }
  else if (k === 't') $('op').value = 'translate';
  else if (k === 'r') $('op').value = 'rotate';
  else if (k === 's') $('op').value = 'scale';
  else if (k === 'a') $('all').checked = !$('all').checked;
  else if (k === '+' || k === '=') $('radius').value = Math.min(50, +$('radius').value + 1);
  else if (k === '-') $('radius').value = Math.max(0, +$('radius').value - 1);
  else if (k === 'j') toggle('[data-layer=jacobian]');
  else if (k === 'f') fitView();
  else if (k === 'w') toggle('[data-layer=warp]');
  else if (k === 'b') { const b = $('blend'); b.value = +b.value > 0.5 ? 0 : 1; draw(); }
  else if (k === 'o' && twoImages()) { const o = $('overlay'); o.value = o.value === 'blend' ? 'colors' : 'blend'; o.dispatchEvent(new Event('change')); }
  else if (k === 'c') { T.center = null; draw(); }
  else if (k === 'Escape') run(async () => { T.anchors = []; await api('POST', '/api/clear'); T.geo.selection = null; draw(); });
});

window.addEventListener('resize', draw);
$('blend').addEventListener('input', draw);
run(() => reload(false)).then(() => { T.ready = true; });
