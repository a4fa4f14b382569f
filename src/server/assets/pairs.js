// trimorph editor page, part 4 of 5: landmark pairs. A pair is a reference point `src`
// (in the moving image, the frame un-warped) and a target `dst` (in the fixed image, or
// with one image the current view); phi should send src to dst. The table lists them with
// their coordinates (editable), an active flag (only active pairs are fitted) and the
// residual |phi(src) - dst| under the current map.
'use strict';

// The pairs and their residuals under the current map, in the table and the views.
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
    if (p.active === false) tr.classList.add('off');
    const cell = (el) => { const td = document.createElement('td'); td.appendChild(el); tr.appendChild(td); return el; };
    const text = (t) => cell(document.createTextNode(t));
    text(String(i + 1));
    const on = cell(document.createElement('input'));
    on.type = 'checkbox'; on.checked = p.active !== false; on.title = 'active: fitted by re-fit';
    on.addEventListener('change', () => setActive(i, on.checked));
    text(p.name || '');
    // Moving x, y (the reference point), fixed x, y (the target): edited in place.
    [['src', 0], ['src', 1], ['dst', 0], ['dst', 1]].forEach(([which, k]) => {
      const inp = cell(document.createElement('input'));
      inp.type = 'number'; inp.step = 'any'; inp.className = 'coord';
      inp.value = String(Math.round(p[which][k] * 1000) / 1000);
      inp.dataset.which = which; inp.dataset.k = k;
      inp.addEventListener('change', () => editCoord(i, which, k, inp.value));
    });
    text(p.residual === null ? 'outside' : p.residual.toFixed(3));
    tr.addEventListener('click', (e) => {
      if (e.target.tagName === 'INPUT') return;
      lm.sel = i; applyPairs(v); draw();
    });
    body.appendChild(tr);
  });
  const active = lm.pairs.filter((p) => p.active !== false).length;
  $('lmsummary').textContent = lm.pairs.length
    ? `${lm.pairs.length} pairs (${active} active); rms ${lm.rms === null ? '-' : lm.rms.toFixed(3)} px, max ${lm.max === null ? '-' : lm.max.toFixed(3)} px`
    : (twoImages() ? 'no pairs (landmarks mode: click a point in the moving image, then its match in the fixed image)'
      : 'no pairs (landmarks mode: click the reference, then the target)');
  showPairsPanel();
}

function showPairsPanel() {
  const on = mode() === 'pairs';
  $('pairspanel').hidden = !on && !T.lm.pairs.length && !twoImages();
  let what;
  if (twoImages()) {
    what = T.lm.pendingSrc ? '(now click its match in the fixed image, right; Esc drops it)'
      : T.lm.pendingDst ? '(now click its match in the moving image, left; Esc drops it)'
        : '(click a point in either image, then its match in the other)';
  } else {
    what = T.lm.pendingSrc ? '(showing the target: click the target point; Esc drops the pair)'
      : T.lm.view === 'ref' ? '(showing the reference: click a reference point; v: the target)'
        : '(showing the target: drag a target; v: the reference)';
  }
  $('lmview').textContent = on ? what : '';
}

async function refreshPairs() { applyPairs(await api('GET', '/api/landmarks')); draw(); }
T.refreshPairs = refreshPairs;

function setActive(i, active) {
  run(async () => {
    const v = await api('POST', '/api/landmarks/active', { index: i, active });
    applyPairs(v); draw();
    message(`pair ${i + 1} ${active ? 'on' : 'off'}`);
  });
}

function editCoord(i, which, k, text) {
  const x = Number(text);
  const p = T.lm.pairs[i];
  if (!p || text.trim() === '' || !Number.isFinite(x)) { message(`pair ${i + 1}: "${text}" is not a number`, true); applyPairs(T.lm); return; }
  const q = p[which].slice();
  q[k] = x;
  run(async () => {
    const v = await api('POST', '/api/landmarks/move', { index: i, [which]: q });
    applyPairs(v); draw();
    message(`pair ${i + 1}: ${which === 'src' ? 'moving' : 'fixed'} point set to (${q[0]}, ${q[1]})`);
  });
}

// The pair whose point (`src` in the reference, `dst` in the target) is within 8 screen
// px of (X, Y), or -1.
function pairHit(X, Y, ref, toScr) {
  let hit = -1, bd = 8 * 8;
  T.lm.pairs.forEach((p, i) => {
    const q = ref ? p.src : p.dst;
    const [sx, sy] = toScr(q[0], q[1]);
    const d = (sx - X) ** 2 + (sy - Y) ** 2;
    if (d < bd) { bd = d; hit = i; }
  });
  return hit;
}

// Landmarks mode, a press in the main view. With one image: on a shown point (a
// reference point in the reference, a target in the target) it selects its pair and drags
// that point (sent once, at the release); elsewhere the first click gives a reference
// point and shows the target, the second the target point, which adds the pair. With two
// images the main view is the target: a click gives the target point (the pair is added
// once its moving point is clicked too, before or after).
function pairsDown(X, Y) {
  const lm = T.lm, two = twoImages(), ref = !two && lm.view === 'ref';
  const hit = pairHit(X, Y, ref, toScreen);
  if (hit >= 0 && !lm.pendingSrc && !lm.pendingDst) {
    startPairDrag(hit, ref ? 'src' : 'dst', X, Y, T.view);
    return;
  }
  const w = toWorld(X, Y);
  if (two) { placeHalf('dst', w); return; }
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
  addPair(src, w);
}

// A press in the left panel (the moving image): pan, or in landmarks mode a pair's
// moving point (drag it, or place one).
function movingDown(e) {
  const [X, Y] = pointer(e, mcanvas);
  const lm = T.lm;
  if (e.button === 0 && mode() === 'pairs') {
    const hit = pairHit(X, Y, true, toScreenM);
    if (hit >= 0 && !lm.pendingSrc && !lm.pendingDst) { startPairDrag(hit, 'src', X, Y, T.mview, mcanvas); return; }
    placeHalf('src', toWorldM(X, Y));
    return;
  }
  if (e.button === 0 || e.button === 1) T.drag = { pan: true, panel: 'moving', X0: X, Y0: Y, tx: T.mview.tx, ty: T.mview.ty };
}

// Two images: one point of a pair; the pair is added when both are placed.
function placeHalf(which, w) {
  const lm = T.lm;
  if (which === 'src') lm.pendingSrc = w; else lm.pendingDst = w;
  if (lm.pendingSrc && lm.pendingDst) {
    const src = lm.pendingSrc, dst = lm.pendingDst;
    lm.pendingSrc = null; lm.pendingDst = null;
    addPair(src, dst);
    return;
  }
  showPairsPanel(); draw();
  message(which === 'src' ? 'moving point set: now click its match in the fixed image' : 'fixed point set: now click its match in the moving image');
}

function addPair(src, dst) {
  run(async () => {
    const v = await api('POST', '/api/landmarks/add', { src, dst });
    T.lm.sel = v.index;
    applyPairs(v); draw();
    message(`added pair ${v.index + 1}`);
  });
}

function startPairDrag(i, which, X, Y, view, c) {
  const lm = T.lm;
  lm.sel = i;
  T.drag = { pair: i, which, X0: X, Y0: Y, start: lm.pairs[i][which].slice(), moved: false, view, canvas: c };
  applyPairs(lm); draw();
}

function pairDragTo(d, X, Y) {
  const p = T.lm.pairs[d.pair];
  if (!p) return null;
  const q = [d.start[0] + (X - d.X0) / d.view.s, d.start[1] + (Y - d.Y0) / d.view.s];
  p[d.which] = q;
  return q;
}

function endPairDrag(d, e) {
  if (!d.moved) return;
  const q = e ? pairDragTo(d, ...pointer(e, d.canvas)) : T.lm.pairs[d.pair][d.which];
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

function dropHalfPair() {
  const lm = T.lm;
  if (!lm.pendingSrc && !lm.pendingDst) return false;
  lm.pendingSrc = null; lm.pendingDst = null; lm.view = 'ref';
  showPairsPanel(); draw(); message('half-placed pair dropped');
  return true;
}

const pairCommands = {
  lmimport: () => run(async () => {
    const path = $('landmarks').value;
    if (T.lm.pairs.length && !confirm(`Replace the ${T.lm.pairs.length} pairs with those of ${path}?`)) { message('not imported'); return; }
    const v = await api('POST', '/api/landmarks/import', { path });
    T.lm.sel = -1; T.lm.pendingSrc = null; T.lm.pendingDst = null;
    applyPairs(v); draw();
    message(`imported ${v.pairs.length} pairs from ${path}`);
  }),
  lmexport: () => run(async () => {
    const path = $('landmarks').value, format = $('lmformat').value;
    const st = await api('POST', '/api/stat', { path });
    if (st.exists && !confirm(`${path} exists. Overwrite it?`)) { message('not exported: ' + path + ' exists'); return; }
    const r = await api('POST', '/api/landmarks/export', { path, format });
    const n = T.lm.pairs.length, on = T.lm.pairs.filter((p) => p.active !== false).length;
    const what = format === 'bigwarp' || on === n ? `${n} pairs` : `${on} active pairs of ${n}`;
    message(`exported ${what} (${format}) to ${r.saved}`);
  }),
};
