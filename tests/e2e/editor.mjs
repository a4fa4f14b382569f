// End-to-end test of `trimorph editor` in headless Chromium, driven by playwright-core.
//
// usage: node editor.mjs TRIMORPH_BINARY WORK_DIR SCREENSHOT.png
//
// Starts the editor on the bundled scene (port 0: any free port) in WORK_DIR, loads the
// page, selects an anchor by clicking it, drags it with the mouse, checks through the API
// that it moved by the drag, saves the deformation and runs `trimorph check` on it (exact
// C1), undoes with Ctrl+Z, and takes a screenshot. Prints one JSON line with the measured
// drag-step times (request + exact update + response + redraw, as seen by the page).
import { spawn, spawnSync } from 'node:child_process';
import { chromium } from 'playwright-core';

const [bin, work, shot] = process.argv.slice(2);
if (!bin || !work || !shot) {
  console.error('usage: node editor.mjs TRIMORPH_BINARY WORK_DIR SCREENSHOT.png');
  process.exit(2);
}
const exe = process.env.CHROMIUM || '/usr/bin/chromium';

function fail(msg) {
  console.error('E2E FAILURE: ' + msg);
  process.exitCode = 1;
  throw new Error(msg);
}

const editor = spawn(bin, ['editor', '--port', '0'], { cwd: work, stdio: ['ignore', 'pipe', 'inherit'] });
const addr = await new Promise((resolve, reject) => {
  let out = '';
  const timer = setTimeout(() => reject(new Error('the editor did not print its address')), 30000);
  editor.stdout.on('data', (d) => {
    out += d;
    const m = out.match(/http:\/\/127\.0\.0\.1:\d+\//);
    if (m) { clearTimeout(timer); resolve(m[0]); }
  });
  editor.on('exit', (c) => reject(new Error('the editor exited with ' + c)));
});

const api = async (method, path, body) => {
  const r = await fetch(addr + path.replace(/^\//, ''), {
    method, headers: body ? { 'Content-Type': 'application/json' } : {},
    body: body ? JSON.stringify(body) : undefined,
  });
  const v = await r.json();
  if (!r.ok) fail(`${method} ${path}: ${r.status} ${v.error}`);
  return v;
};

const browser = await chromium.launch({
  executablePath: exe,
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync'],
});
let summary = {};
try {
  const page = await browser.newPage({ viewport: { width: 1100, height: 800 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(addr);
  await page.waitForFunction(() => window.trimorph && window.trimorph.ready, null, { timeout: 30000 });

  // The anchor: the control point nearest the frame centre.
  const before = await api('GET', '/api/geometry');
  let idx = -1, best = Infinity;
  before.points.forEach((p, i) => {
    const d = (p[0] - 255.5) ** 2 + (p[1] - 255.5) ** 2;
    if (d < best) { best = d; idx = i; }
  });
  const p0 = before.points[idx];
  const box = await page.locator('#view').boundingBox();
  const [sx, sy] = await page.evaluate(([x, y]) => window.trimorph.toScreen(x, y), p0);
  const scale = await page.evaluate(() => window.trimorph.view.s);
  const X = box.x + sx, Y = box.y + sy;
  const DX = 40, DY = -25, STEPS = 20;
  await page.mouse.move(X, Y);
  await page.mouse.down();
  for (let k = 1; k <= STEPS; k++) {
    await page.mouse.move(X + (DX * k) / STEPS, Y + (DY * k) / STEPS);
    await page.evaluate(() => window.trimorph.idle());
  }
  await page.mouse.up();
  await page.evaluate(() => window.trimorph.idle());

  const state = await api('GET', '/api/state');
  if (!state.selection || !state.selection.anchors.includes(idx)) fail('the clicked point is not the anchor: ' + JSON.stringify(state.selection));
  const after = await api('GET', '/api/geometry');
  const moved = [after.points[idx][0] - p0[0], after.points[idx][1] - p0[1]];
  const want = [DX / scale, DY / scale];
  if (Math.hypot(moved[0] - want[0], moved[1] - want[1]) > 1.5 / scale + 1e-3) {
    fail(`anchor moved by ${moved}, the drag was ${want}`);
  }
  if (state.undo !== 1) fail('one drag should be one undo step, got ' + state.undo);

  await api('POST', '/api/save', { path: 'e2e.json' });
  const check = spawnSync(bin, ['check', 'e2e.json'], { cwd: work, encoding: 'utf8' });
  if (check.status !== 0) fail('trimorph check failed: ' + check.stderr);
  const rep = JSON.parse(check.stdout);
  if (rep.c1_holds !== true || rep.c1_max_abs_residual !== '0') fail('not exactly C1: ' + check.stdout.slice(0, 300));

  await page.screenshot({ path: shot });

  // Ctrl+Z in the page undoes the drag.
  await page.keyboard.press('Control+z');
  await page.waitForFunction(() => window.trimorph.state && window.trimorph.state.undo === 0, null, { timeout: 10000 });
  const undone = await api('GET', '/api/geometry');
  if (undone.points[idx][0] !== p0[0] || undone.points[idx][1] !== p0[1]) fail('undo did not restore the anchor');

  // z1 mode: key 4, click the same point, drag up: the top surface sigma1 rises there and
  // the oblique 3D view is shown.
  const nxy = await page.evaluate(() => window.trimorph.timings.length);
  const z0 = (await api('GET', '/api/geometry?full=1')).z1[idx];
  await page.keyboard.press('4');
  await page.mouse.move(X, Y);
  await page.mouse.down();
  for (let k = 1; k <= 10; k++) {
    await page.mouse.move(X, Y - 3 * k);
    await page.evaluate(() => window.trimorph.idle());
  }
  await page.mouse.up();
  await page.evaluate(() => window.trimorph.idle());
  const zs = await api('GET', '/api/state');
  if (!zs.selection || zs.selection.mode !== 'z1') fail('z1 mode did not select: ' + JSON.stringify(zs.selection));
  const z1 = (await api('GET', '/api/geometry?full=1')).z1[idx];
  if (!(Math.abs(z1 - z0 - 30 / scale) < 1.5 / scale + 1e-3)) fail(`z1 moved from ${z0} to ${z1}, the drag was ${30 / scale}`);
  if (await page.locator('#oblique').isHidden()) fail('the oblique view is hidden in z1 mode');
  await page.screenshot({ path: shot.replace(/\.png$/, '_z1.png') });
  if (errors.length) fail('page errors: ' + errors.join('; '));

  const t = await page.evaluate(() => window.trimorph.timings);
  const stats = (a) => {
    const s = a.slice().sort((x, y) => x - y);
    return { n: s.length, median: s[Math.floor(s.length / 2)], p90: s[Math.floor(0.9 * (s.length - 1))], max: s[s.length - 1] };
  };
  const ph = await page.evaluate(() => window.trimorph.phases);
  const part = (a, k) => stats(a.map((p) => p[k]).filter((v) => v !== null)).median;
  const parts = (a) => ({ request: part(a, 'request'), draw: part(a, 'draw'), update: part(a, 'update') });
  summary = {
    ok: true, anchor: idx, moved, drag_steps: t.length,
    xy_step_ms: stats(t.slice(0, nxy)), z1_step_ms: stats(t.slice(nxy)),
    xy_median_parts_ms: parts(ph.slice(0, nxy)), z1_median_parts_ms: parts(ph.slice(nxy)),
    exact_update_ms_last: state.last_update_ms,
  };
  console.log(JSON.stringify(summary));
} finally {
  await browser.close();
  editor.kill();
}
