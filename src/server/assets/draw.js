// trimorph editor page, part 2 of 5: drawing the main view (the target), the left panel
// (the moving image, two-image sessions), the landmark pairs, and the oblique 3D view.
'use strict';

function draw() {
  const dpr = sizeCanvas(canvas);
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = '#151617';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const v = T.view;
  ctx.setTransform(dpr * v.s, 0, 0, dpr * v.s, dpr * v.tx, dpr * v.ty);
  const px = 1 / v.s; // one screen pixel in world units
  const L = T.layers, g = T.geo, st = T.stat;
  ctx.imageSmoothingEnabled = v.s < 2;
  const two = twoImages();
  const back = two ? T.fixedImg : T.img;
  if (L.image && back) ctx.drawImage(back, -0.5, -0.5);
  if (!two && mode() === 'pairs' && T.lm.view === 'ref') {
    // The reference: the frame un-warped, with the pairs' reference points only.
    drawPairs(ctx, px, true);
    drawOblique();
    return;
  }
  if (L.warp && T.warpCanvas) {
    if (two && overlay() === 'colors') {
      // Two colours: the fixed image green, the warped moving image magenta (grey where
      // they agree), drawn opaque.
      ctx.drawImage(T.twoCanvas, -0.5, -0.5);
    } else {
      // The live warped frame over the background, mixed by the blend slider (1: warped
      // only).
      ctx.globalAlpha = +$('blend').value;
      ctx.drawImage(T.warpCanvas, -0.5, -0.5);
      ctx.globalAlpha = 1;
    }
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
    // One device pixel wide: Chromium strokes such hairlines on a fast path (a 1.5 px
    // stroke of the ~9,000 segments took 8-10 ms of every drag step).
    ctx.beginPath();
    for (const line of g.mesh) {
      if (!line.length) continue;
      ctx.moveTo(line[0][0], line[0][1]);
      for (let k = 1; k < line.length; k++) ctx.lineTo(line[k][0], line[k][1]);
    }
    ctx.lineWidth = px / dpr; ctx.strokeStyle = 'rgba(90, 200, 255, 0.9)'; ctx.stroke();
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
  drawGhost(px);
  if (sel) {
    ctx.fillStyle = '#fc3';
    for (const i of sel.derived) dot(pts[i], 2.2 * px);
    ctx.fillStyle = '#f33';
    for (const i of sel.anchors) dot(pts[i], 4.5 * px);
  } else {
    ctx.fillStyle = '#f33';
    for (const i of T.anchors) if (pts[i]) dot(pts[i], 4.5 * px);
  }
  drawPairs(ctx, px, false);
  if (T.center) {
    ctx.strokeStyle = '#fff'; ctx.lineWidth = 1.5 * px; ctx.beginPath();
    const [cx, cy] = T.center, k = 8 * px;
    ctx.moveTo(cx - k, cy); ctx.lineTo(cx + k, cy); ctx.moveTo(cx, cy - k); ctx.lineTo(cx, cy + k);
    ctx.stroke();
  }
  drawOblique();
  if (two) drawMoving();
}

// The ghost of a drag: where the dragged points started (hollow, dashed), with a line to
// where they are now, until the drag ends.
function drawGhost(px) {
  const d = T.drag;
  if (!d || !d.moved || !d.ghost) return;
  const now = d.ghostNow ? d.ghostNow() : [];
  ctx.save();
  ctx.setLineDash([4 * px, 3 * px]);
  ctx.lineWidth = 1.5 * px; ctx.strokeStyle = 'rgba(255, 255, 255, 0.85)';
  ctx.beginPath();
  d.ghost.forEach((p, k) => {
    ctx.moveTo(p[0] + 6 * px, p[1]); ctx.arc(p[0], p[1], 6 * px, 0, 2 * Math.PI);
    if (now[k]) { ctx.moveTo(p[0], p[1]); ctx.lineTo(now[k][0], now[k][1]); }
  });
  ctx.stroke();
  ctx.restore();
}

// The left panel: the moving image un-warped, with the pairs' reference points.
function drawMoving() {
  const dpr = sizeCanvas(mcanvas);
  const c = mctx, v = T.mview;
  c.setTransform(1, 0, 0, 1, 0, 0);
  c.fillStyle = '#151617';
  c.fillRect(0, 0, mcanvas.width, mcanvas.height);
  c.setTransform(dpr * v.s, 0, 0, dpr * v.s, dpr * v.tx, dpr * v.ty);
  c.imageSmoothingEnabled = v.s < 2;
  if (T.img) c.drawImage(T.img, -0.5, -0.5);
  drawPairs(c, 1 / v.s, true);
}

// Landmark pairs: in the reference, hollow circles at the reference points; in the target,
// filled circles at the targets and the residual line from phi(reference) to the target.
// Each is numbered (1-based, the table's order); the selected pair is yellow, inactive
// pairs grey.
function drawPairs(c, px, ref) {
  const lm = T.lm;
  const pending = ref ? lm.pendingSrc : lm.pendingDst;
  if (!lm.pairs.length && !pending) return;
  const r = 5 * px;
  c.font = `${12 * px}px system-ui, sans-serif`;
  lm.pairs.forEach((p, i) => {
    const col = i === lm.sel ? '#ffd21f' : p.active === false ? '#9a9a9a' : '#ff5cf0';
    c.strokeStyle = col; c.fillStyle = col; c.lineWidth = 1.5 * px;
    const at = ref ? p.src : p.dst;
    if (!ref && p.mapped && p.active !== false) {
      c.beginPath(); c.moveTo(p.mapped[0], p.mapped[1]); c.lineTo(p.dst[0], p.dst[1]);
      c.strokeStyle = 'rgba(255, 60, 60, 0.95)'; c.stroke();
      c.strokeStyle = col;
      const k = 3 * px;
      c.beginPath();
      c.moveTo(p.mapped[0] - k, p.mapped[1] - k); c.lineTo(p.mapped[0] + k, p.mapped[1] + k);
      c.moveTo(p.mapped[0] - k, p.mapped[1] + k); c.lineTo(p.mapped[0] + k, p.mapped[1] - k);
      c.stroke();
    }
    c.beginPath(); c.arc(at[0], at[1], r, 0, 2 * Math.PI);
    if (ref) c.stroke(); else c.fill();
    c.fillStyle = col;
    c.fillText(String(i + 1), at[0] + 1.4 * r, at[1] - 1.2 * r);
  });
  if (pending) {
    c.strokeStyle = '#fff'; c.lineWidth = 1.5 * px;
    c.beginPath(); c.arc(pending[0], pending[1], r, 0, 2 * Math.PI); c.stroke();
  }
  // A pair point being dragged: its start, dashed.
  const d = T.drag;
  if (d && d.pair !== undefined && d.moved && (d.which === 'src') === ref) {
    c.save();
    c.setLineDash([4 * px, 3 * px]); c.strokeStyle = 'rgba(255, 255, 255, 0.85)'; c.lineWidth = 1.5 * px;
    c.beginPath(); c.arc(d.start[0], d.start[1], r, 0, 2 * Math.PI);
    const q = lm.pairs[d.pair] && lm.pairs[d.pair][d.which];
    if (q) { c.moveTo(d.start[0], d.start[1]); c.lineTo(q[0], q[1]); }
    c.stroke();
    c.restore();
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

