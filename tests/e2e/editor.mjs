// End-to-end test of `trimorph editor` in headless Chromium, driven by playwright-core.
//
// usage: node editor.mjs TRIMORPH_BINARY WORK_DIR SCREENSHOT.png
//
// Starts the editor on the bundled scene (port 0: any free port) in WORK_DIR, loads the
// page, selects an anchor by clicking it, drags it with the mouse, checks through the API
// that it moved by the drag, saves the deformation and runs `trimorph check` on it (exact
// C1), undoes with Ctrl+Z, and takes a screenshot. Prints one JSON line with the measured
// drag-step times (request + exact update + response + redraw, as seen by the page).
import { spawnSync } from 'node:child_process';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { apiClient, args, fail, launchBrowser, startEditor, stats } from './common.mjs';

const [bin, work, shot] = args('editor.mjs');

const { editor, addr, token } = await startEditor(bin, ['--port', '0'], work);

const api = apiClient(addr, token);

const browser = await launchBrowser();
let summary = {};
try {
  const page = await browser.newPage({ viewport: { width: 1100, height: 800 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  // Confirmation dialogs: accepted unless `dismissNext` is set; their texts are kept.
  const dialogs = [];
  let dismissNext = false;
  page.on('dialog', async (d) => {
    dialogs.push(d.message());
    if (dismissNext) { dismissNext = false; await d.dismiss(); } else await d.accept();
  });
  // Without the token the API refuses (the page alone gets no cookie).
  const bare = await fetch(addr + 'api/state');
  if (bare.status !== 401) fail('the API answered without the token: ' + bare.status);
  await page.goto(addr + '?token=' + token);
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
  // Whole CSS pixels (MouseEvent coordinates are whole numbers in Chromium).
  const X = Math.round(box.x + sx), Y = Math.round(box.y + sy);
  const DX = 40, DY = -25, STEPS = 20;
  await page.mouse.move(X, Y);
  await page.mouse.down();
  // The first steps go out at once, before the selection has answered.
  for (let k = 1; k <= STEPS; k++) {
    await page.mouse.move(X + Math.round((DX * k) / STEPS), Y + Math.round((DY * k) / STEPS));
    if (k > 3) await page.evaluate(() => window.trimorph.idle());
  }
  await page.mouse.up();
  await page.evaluate(() => window.trimorph.idle());

  const state = await api('GET', '/api/state');
  if (!state.selection || !state.selection.anchors.includes(idx)) fail('the clicked point is not the anchor: ' + JSON.stringify(state.selection));
  const after = await api('GET', '/api/geometry');
  const moved = [after.points[idx][0] - p0[0], after.points[idx][1] - p0[1]];
  const want = [DX / scale, DY / scale];
  // The drag ends under the pointer: the anchor moved exactly as the pointer did (up to the
  // 1/1000 px rounding of the answers).
  const dragErr = Math.hypot(moved[0] - want[0], moved[1] - want[1]);
  if (dragErr > 2e-3) fail(`anchor moved by ${moved}, the pointer by ${want}`);
  if (state.undo !== 1) fail('one drag should be one undo step, got ' + state.undo);

  // Save in the page: the message stays until the next action.
  await page.fill('#path', 'e2e.json');
  await page.click('#save');
  await page.waitForFunction(() => /^saved /.test(document.getElementById('msg').textContent), null, { timeout: 10000 });
  await page.waitForTimeout(600);
  await page.mouse.move(X + 200, Y + 100);
  const kept = await page.textContent('#msg');
  if (!/^saved /.test(kept)) fail('the save message did not stay: ' + kept);
  // This drag folds the map (3 triangles): the save asked for confirmation.
  if (state.fold_free !== false || !state.folding_triangles.length) fail('the drag was meant to fold: ' + JSON.stringify(state.folding_triangles));
  if (!dialogs.some((d) => /NOT certified fold-free/.test(d))) fail('saving a folding map did not ask: ' + JSON.stringify(dialogs));
  const outline = await page.evaluate(() => (window.trimorph.geo.folding_outline || []).length);
  if (outline !== 6 * state.folding_triangles.length) fail('the folding triangles are not outlined: ' + outline);
  // Saving again asks before overwriting; dismissed, nothing is written.
  const n0 = dialogs.length;
  dismissNext = true;
  await page.click('#save');
  await page.waitForFunction(() => /^not saved/.test(document.getElementById('msg').textContent), null, { timeout: 10000 });
  if (dialogs.length !== n0 + 1 || !/exists/.test(dialogs[n0])) fail('no overwrite confirmation: ' + dialogs.slice(n0));
  // The help panel.
  await page.keyboard.press('?');
  if (await page.locator('#helppanel').isHidden()) fail('? did not show the help panel');
  await page.keyboard.press('?');
  if (!(await page.locator('#helppanel').isHidden())) fail('? did not hide the help panel');
  // The live warp: the page's warped frame against `trimorph warp` of the same state.
  await page.waitForFunction(() => window.trimorph.warpVersion > 0 && !window.trimorph.warpBusy, null, { timeout: 20000 });
  await page.evaluate(() => window.trimorph.refreshWarp());
  await page.waitForFunction(() => !window.trimorph.warpBusy, null, { timeout: 20000 });
  await api('POST', '/api/save', { path: 'scene.json', scene: true });
  const warped = spawnSync(bin, ['warp', 'scene.json', '--image', 'scene.frame.png', '-o', 'cli_warp.png'], { cwd: work, encoding: 'utf8' });
  if (warped.status !== 0) fail('trimorph warp failed: ' + warped.stderr);
  const cliPng = readFileSync(join(work, 'cli_warp.png')).toString('base64');
  const cmp = await page.evaluate(async (b64) => {
    const img = new Image();
    img.src = 'data:image/png;base64,' + b64;
    await img.decode();
    const c = document.createElement('canvas');
    c.width = img.naturalWidth; c.height = img.naturalHeight;
    const cx = c.getContext('2d');
    cx.drawImage(img, 0, 0);
    const a = cx.getImageData(0, 0, c.width, c.height).data, b = window.trimorph.warpImage.data;
    let n = 0, sum = 0, big = 0, max = 0, missing = 0;
    for (let k = 0; k < a.length; k += 4) {
      if (b[k + 3] === 0) { if (a[k] !== 0) missing++; continue; }
      const d = Math.abs(a[k] - b[k]);
      n++; sum += d; if (d > 8) big++; if (d > max) max = d;
    }
    return { pixels: a.length / 4, compared: n, mean_abs: sum / n, over_8: big / n, max, missing, warp_ms: window.trimorph.warpMs };
  }, cliPng);
  // Tolerances: the page interpolates phi^-1 bilinearly between nodes 8 px apart, and
  // rounds to 8 bits; `trimorph warp` solves it to 0.01 px.
  if (!(cmp.mean_abs <= 1.0 && cmp.over_8 <= 0.005 && cmp.missing <= 0.01 * cmp.pixels)) fail('live warp differs from trimorph warp: ' + JSON.stringify(cmp));
  // Setting the slider's value fires no event: dispatch one so that the page redraws with
  // the warped frame only (the screenshot used to show the blend of 0.5 instead).
  const setBlend = (v) => page.evaluate((v) => {
    const b = document.getElementById('blend');
    b.value = v;
    b.dispatchEvent(new Event('input'));
  }, v);
  await setBlend(1);
  await page.evaluate(() => window.trimorph.idle());
  await page.screenshot({ path: shot.replace(/\.png$/, '_warp.png') });
  await setBlend(0.5);
  const check = spawnSync(bin, ['check', 'e2e.json'], { cwd: work, encoding: 'utf8' });
  if (check.status !== 0) fail('trimorph check failed: ' + check.stderr);
  const rep = JSON.parse(check.stdout);
  if (rep.c1_holds !== true || rep.c1_max_abs_residual !== '0') fail('not exactly C1: ' + check.stdout.slice(0, 300));

  await page.screenshot({ path: shot });

  // A fast tap on another point (press and release before the selection answers), then
  // pointer moves without a button: a selection, no edit.
  const far = before.points.reduce((b, p, i) => (Math.hypot(p[0] - 130, p[1] - 130) < Math.hypot(before.points[b][0] - 130, before.points[b][1] - 130) ? i : b), 0);
  const [tx, ty] = await page.evaluate(([x, y]) => window.trimorph.toScreen(x, y), before.points[far]);
  const TX = Math.round(box.x + tx), TY = Math.round(box.y + ty);
  const undoBefore = (await api('GET', '/api/state')).undo;
  await page.mouse.move(TX, TY);
  await page.mouse.down();
  await page.mouse.up();
  for (let k = 1; k <= 8; k++) await page.mouse.move(TX + 5 * k, TY + 3 * k);
  await page.evaluate(() => window.trimorph.idle());
  const tap = await api('GET', '/api/state');
  const tapGeo = await api('GET', '/api/geometry');
  if (tap.undo !== undoBefore) fail(`a tap made an edit: undo ${undoBefore} -> ${tap.undo}`);
  if (tapGeo.points[far][0] !== before.points[far][0] || tapGeo.points[far][1] !== before.points[far][1]) fail('a tap moved the point');
  if (!tap.selection || tap.selection.anchors[0] !== far) fail('the tap did not select the point: ' + JSON.stringify(tap.selection));
  // Back to the first anchor's selection for the undo below.
  await page.keyboard.press('Escape');
  await page.evaluate(() => window.trimorph.idle());

  // Ctrl+Z in the page undoes the drag.
  await page.keyboard.press('Control+z');
  await page.waitForFunction(() => window.trimorph.state && window.trimorph.state.undo === 0, null, { timeout: 10000 });

  const undone = await api('GET', '/api/geometry');
  if (undone.points[idx][0] !== p0[0] || undone.points[idx][1] !== p0[1]) fail('undo did not restore the anchor');

  // Live warp latency: the same point dragged again, step by step; each step waits until
  // the warped frame of that pointer position is drawn. The page measures from the
  // pointer event to the end of that redraw (`warpLatency`, ms).
  const nLat = await page.evaluate(() => window.trimorph.warpLatency.length);
  await page.mouse.move(X, Y);
  await page.mouse.down();
  for (let k = 1; k <= 30; k++) {
    const n = await page.evaluate(() => window.trimorph.warpLatency.length);
    await page.mouse.move(X + k, Y + Math.round(k / 2));
    await page.waitForFunction((n) => window.trimorph.warpLatency.length > n, n, { timeout: 20000 });
  }
  await page.mouse.up();
  await page.evaluate(() => window.trimorph.idle());
  const warpLatency = (await page.evaluate(() => window.trimorph.warpLatency)).slice(nLat + 3);
  await page.keyboard.press('Control+z');
  await page.waitForFunction(() => window.trimorph.state && window.trimorph.state.undo === 0, null, { timeout: 10000 });

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

  // Landmarks mode (key 5): three pairs clicked (reference, then target), one moved by a
  // drag, one deleted (click + Delete), exported as CSV and BigWarp CSV, then a re-fit to
  // the pairs whose residuals the table shows.
  await page.keyboard.press('5');
  await page.waitForFunction(() => document.getElementById('mode').value === 'pairs');
  const at = async (w) => {
    const [qx, qy] = await page.evaluate(([x, y]) => window.trimorph.toScreen(x, y), w);
    return [Math.round(box.x + qx), Math.round(box.y + qy)];
  };
  const lmVersion = () => page.evaluate(() => window.trimorph.lm.version);
  const placed = [[[200, 200], [206, 204]], [[300, 220], [305, 216]], [[260, 320], [263, 327]]];
  for (const [src, dst] of placed) {
    if ((await page.evaluate(() => window.trimorph.lm.view)) !== 'ref') fail('landmarks mode does not show the reference first');
    const v0 = await lmVersion();
    await page.mouse.click(...(await at(src)));
    await page.waitForFunction(() => window.trimorph.lm.view === 'target');
    await page.mouse.click(...(await at(dst)));
    await page.waitForFunction((v) => window.trimorph.lm.version > v, v0, { timeout: 10000 });
  }
  let lms = await api('GET', '/api/landmarks');
  if (lms.pairs.length !== 3) fail('three pairs were clicked, the server has ' + lms.pairs.length);
  lms.pairs.forEach((p, i) => {
    const [src, dst] = placed[i];
    const e = Math.max(Math.hypot(p.src[0] - src[0], p.src[1] - src[1]), Math.hypot(p.dst[0] - dst[0], p.dst[1] - dst[1]));
    if (e > 1 / scale) fail(`pair ${i + 1} is ${e} px from where it was clicked: ${JSON.stringify(p)}`);
  });
  // Move pair 2's target: show the target (v), drag it by (12, 8) screen px.
  await page.keyboard.press('v');
  const d0 = lms.pairs[1].dst;
  const [mx, my] = await at(d0);
  await page.mouse.move(mx, my);
  await page.mouse.down();
  for (let k = 1; k <= 4; k++) await page.mouse.move(mx + 3 * k, my + 2 * k);
  await page.mouse.up();
  await page.waitForFunction(() => /^moved pair 2/.test(document.getElementById('msg').textContent), null, { timeout: 10000 });
  lms = await api('GET', '/api/landmarks');
  const dm = [lms.pairs[1].dst[0] - d0[0], lms.pairs[1].dst[1] - d0[1]];
  if (Math.hypot(dm[0] - 12 / scale, dm[1] - 8 / scale) > 1e-6) fail(`pair 2's target moved by ${dm}, the pointer by ${[12 / scale, 8 / scale]}`);
  // Delete pair 1: click its target (selects it), Delete.
  await page.mouse.click(...(await at(lms.pairs[0].dst)));
  await page.keyboard.press('Delete');
  await page.waitForFunction(() => /^deleted pair 1/.test(document.getElementById('msg').textContent), null, { timeout: 10000 });
  lms = await api('GET', '/api/landmarks');
  if (JSON.stringify(lms.pairs.map((p) => p.name)) !== '["P2","P3"]') fail('delete left ' + JSON.stringify(lms.pairs.map((p) => p.name)));
  // Ctrl+Z takes the delete back (the table lists three pairs again), Ctrl+Y redoes it.
  for (const [key, want] of [['Control+z', '["P1","P2","P3"]'], ['Control+y', '["P2","P3"]']]) {
    const v0 = await lmVersion();
    await page.keyboard.press(key);
    await page.waitForFunction((v) => window.trimorph.lm.version > v, v0, { timeout: 10000 });
    lms = await api('GET', '/api/landmarks');
    const names = JSON.stringify(lms.pairs.map((p) => p.name));
    if (names !== want) fail(`${key} after the delete left ${names}`);
    const rows = await page.evaluate(() => document.querySelectorAll('#pairtable tbody tr').length);
    if (rows !== lms.pairs.length) fail(`${key}: the table lists ${rows} pairs, the server ${lms.pairs.length}`);
  }
  // Export both formats.
  for (const [file, format] of [['e2e_pairs.csv', 'csv'], ['e2e_bigwarp.csv', 'bigwarp']]) {
    await page.fill('#landmarks', file);
    await page.selectOption('#lmformat', format);
    await page.click('#lmexport');
    await page.waitForFunction(() => /^exported 2 pairs/.test(document.getElementById('msg').textContent), null, { timeout: 10000 });
    const text = readFileSync(join(work, file), 'utf8').trim().split('\n');
    const want = format === 'csv' ? 3 : 2;
    if (text.length !== want) fail(`${file}: ${JSON.stringify(text)}`);
    if (format === 'bigwarp' && !text[0].startsWith('"P2","true"')) fail(`${file} is not a BigWarp table: ${text[0]}`);
  }
  // One image: no re-register button (it registers the moving image to the fixed one).
  if (!(await page.locator('#reregister').isHidden())) fail('a re-register button without a fixed image');
  // Re-fit (soft) to the pairs: the residuals drop, the table shows the server's, one undo step.
  const rmsBefore = lms.rms;
  const undoFit = (await api('GET', '/api/state')).undo;
  await page.click('#refit');
  await page.waitForFunction(() => /^re-fit/.test(document.getElementById('msg').textContent), null, { timeout: 60000 });
  lms = await api('GET', '/api/landmarks');
  if (!(lms.rms < 0.5 * rmsBefore)) fail(`the re-fit left rms ${lms.rms} px (before ${rmsBefore})`);
  const shown = await page.evaluate(() => [...document.querySelectorAll('#pairtable tbody tr')].map((r) => r.cells[r.cells.length - 1].textContent));
  if (JSON.stringify(shown) !== JSON.stringify(lms.pairs.map((p) => p.residual.toFixed(3)))) fail(`the table shows ${shown}, the server ${JSON.stringify(lms.pairs.map((p) => p.residual))}`);
  if ((await api('GET', '/api/state')).undo !== undoFit + 1) fail('a re-fit is one undo step');
  await page.screenshot({ path: shot.replace(/\.png$/, '_landmarks.png') });

  // Scene round trip in the page: "save scene" keeps map, pairs, model and frame; a change,
  // then "load" brings the saved state back (over the same mesh: one undo step, which
  // Ctrl+Z takes back with the pairs it replaced).
  const savedGeo = JSON.stringify((await api('GET', '/api/geometry?full=1')).points);
  const savedPairs = JSON.stringify(lms.pairs.map((p) => [p.name, p.src, p.dst]));
  await page.fill('#path', 'e2e_scene.json');
  await page.click('#savescene');
  await page.waitForFunction(() => /^saved scene /.test(document.getElementById('msg').textContent), null, { timeout: 10000 });
  const sceneFile = JSON.parse(readFileSync(join(work, 'e2e_scene.json'), 'utf8'));
  if (!sceneFile.model || !sceneFile.image || (sceneFile.landmarks || []).length !== 2) fail('the scene lost a key: ' + JSON.stringify(Object.keys(sceneFile)));
  await api('POST', '/api/landmarks/delete', { index: 0 });
  await page.fill('#path', 'e2e_scene.json');
  await page.click('#load');
  await page.waitForFunction(() => /^loaded /.test(document.getElementById('msg').textContent), null, { timeout: 20000 });
  const back = await api('GET', '/api/landmarks');
  if (JSON.stringify(back.pairs.map((p) => [p.name, p.src, p.dst])) !== savedPairs) fail('the loaded scene has other pairs: ' + JSON.stringify(back.pairs));
  if (JSON.stringify((await api('GET', '/api/geometry?full=1')).points) !== savedGeo) fail('the loaded scene has another map');
  const loaded = await api('GET', '/api/state');
  if (!loaded.model || !loaded.frame) fail('the loaded scene lost the model or the frame: ' + JSON.stringify([loaded.model, loaded.frame]));
  const rowsLoaded = await page.evaluate(() => document.querySelectorAll('#pairtable tbody tr').length);
  if (rowsLoaded !== 2) fail(`after the load the table lists ${rowsLoaded} pairs`);
  const vLoad = await lmVersion();
  await page.keyboard.press('Control+z');
  await page.waitForFunction((v) => window.trimorph.lm.version > v, vLoad, { timeout: 10000 });
  if ((await api('GET', '/api/landmarks')).pairs.length !== 1) fail('Ctrl+Z after the load did not bring back the one-pair state');
  const landmarks = { rms_before: rmsBefore, rms_after: lms.rms, residuals_after: lms.pairs.map((p) => p.residual) };
  if (errors.length) fail('page errors: ' + errors.join('; '));

  const t = await page.evaluate(() => window.trimorph.timings);
  const ph = await page.evaluate(() => window.trimorph.phases);
  const part = (a, k) => stats(a.map((p) => p[k]).filter((v) => v !== null)).median;
  const parts = (a) => ({ request: part(a, 'request'), draw: part(a, 'draw'), update: part(a, 'update') });
  summary = {
    ok: true, anchor: idx, moved, drag_error_px: dragErr * scale, drag_steps: t.length, tap_anchor: far,
    live_warp_vs_cli: cmp, dialogs,
    xy_step_ms: stats(t.slice(0, nxy)), z1_step_ms: stats(t.slice(nxy)),
    xy_median_parts_ms: parts(ph.slice(0, nxy)), z1_median_parts_ms: parts(ph.slice(nxy)),
    exact_update_ms_last: state.last_update_ms, landmarks,
    live_warp_latency_ms: stats(warpLatency),
  };
  console.log(JSON.stringify(summary));
} finally {
  await browser.close();
  editor.kill();
}
