// End-to-end test of the editor's two-image session (BigWarp's workflow) in headless
// Chromium, driven by playwright-core.
//
// usage: node bigwarp.mjs TRIMORPH_BINARY WORK_DIR SCREENSHOT.png
//
// WORK_DIR holds moving.png and fixed.png (512 x 512) and landmarks.csv (moving -> fixed).
// `trimorph fit` fits them (its deformation carries the landmarks), then `trimorph editor
// fit.json --moving moving.png --fixed fixed.png` opens the two panels with the fit's
// pairs. The test clicks three correction pairs (moving then fixed, and once fixed then
// moving), toggles the two-colour overlay, edits a coordinate in the table and switches a
// pair off, re-fits (the fit's own pairs kept), saves a scene and a deformation, checks the
// det J legend, the ghost of a drag, what undo says, and that the path field survives a
// reload, and measures the live warp: each drag step's time from the pointer event to the
// redraw with the warped frame. Prints one JSON line.
import { spawnSync } from 'node:child_process';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { apiClient, args, fail, launchBrowser, startEditor, stats } from './common.mjs';

const [bin, work, shot] = args('bigwarp.mjs');

const fitted = spawnSync(bin, ['fit', '--size', '512,512', '--landmarks', 'landmarks.csv', '-o', 'fit.json'], { cwd: work, encoding: 'utf8' });
if (fitted.status !== 0) fail('trimorph fit failed: ' + fitted.stderr);
const fitFile = JSON.parse(readFileSync(join(work, 'fit.json'), 'utf8'));
const nFit = (fitFile.landmarks || []).length;
if (nFit < 10) fail('the fit does not carry its landmarks: ' + JSON.stringify(Object.keys(fitFile)));

const { editor, addr, token } = await startEditor(bin, ['fit.json', '--moving', 'moving.png', '--fixed', 'fixed.png', '--port', '0'], work);

const api = apiClient(addr, token);

const browser = await launchBrowser();
let summary = {};
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 800 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('dialog', (d) => d.accept());
  await page.goto(addr + '?token=' + token);
  await page.waitForFunction(() => window.trimorph && window.trimorph.ready, null, { timeout: 30000 });
  const msgIs = (re) => page.waitForFunction((s) => new RegExp(s).test(document.getElementById('msg').textContent), re.source, { timeout: 60000 });

  // Two panels: the moving image on the left, the fixed image on the right.
  if (await page.locator('#moving').isHidden()) fail('the moving panel is hidden');
  const state = await api('GET', '/api/state');
  if (!state.fixed || state.fixed.width !== 512 || state.frame.width !== 512) fail('the two images: ' + JSON.stringify([state.frame, state.fixed]));
  let lms = await api('GET', '/api/landmarks');
  if (lms.pairs.length !== nFit) fail(`the fit's ${nFit} landmarks came in as ${lms.pairs.length} pairs`);
  const fitMapped = lms.pairs.map((p) => p.mapped);
  const mbox = await page.locator('#moving').boundingBox();
  const vbox = await page.locator('#view').boundingBox();
  if (!(mbox.x + mbox.width <= vbox.x + 4)) fail('the panels overlap: ' + JSON.stringify([mbox, vbox]));
  const atM = async (w) => {
    const [x, y] = await page.evaluate(([x, y]) => window.trimorph.toScreenM(x, y), w);
    return [Math.round(mbox.x + x), Math.round(mbox.y + y)];
  };
  const atV = async (w) => {
    const [x, y] = await page.evaluate(([x, y]) => window.trimorph.toScreen(x, y), w);
    return [Math.round(vbox.x + x), Math.round(vbox.y + y)];
  };
  const scaleM = await page.evaluate(() => window.trimorph.mview.s);
  const scaleV = await page.evaluate(() => window.trimorph.view.s);
  const lmVersion = () => page.evaluate(() => window.trimorph.lm.version);

  // Landmarks mode: three corrections in the upper left, 5 px right of where the fit sends
  // them; the third placed fixed point first.
  await page.keyboard.press('5');
  const corr = [[64, 72], [104, 64], [72, 112]];
  const placed = [];
  for (let k = 0; k < corr.length; k++) {
    const src = corr[k];
    const v0 = await lmVersion();
    // phi(src) under the fit: a throwaway pair's `mapped` would add a step; the map's
    // value comes from a GET-only helper instead: the nearest carried pair is not enough,
    // so ask the server through the forward grid (nodes every 8 px, src on a node).
    const g = await api('GET', '/api/warp?forward=1');
    const node = 2 * ((src[1] / g.step) * g.nx + src[0] / g.step);
    const dst = [g.map[node] + 5, g.map[node + 1]];
    placed.push([src, dst]);
    const order = k === 2 ? [[atV, dst], [atM, src]] : [[atM, src], [atV, dst]];
    for (const [at, w] of order) await page.mouse.click(...(await at(w)));
    await page.waitForFunction((v) => window.trimorph.lm.version > v, v0, { timeout: 10000 });
  }
  lms = await api('GET', '/api/landmarks');
  if (lms.pairs.length !== nFit + 3) fail(`${nFit} + 3 pairs expected, the server has ${lms.pairs.length}`);
  placed.forEach(([src, dst], k) => {
    const p = lms.pairs[nFit + k];
    const e = Math.max(Math.hypot(p.src[0] - src[0], p.src[1] - src[1]) * scaleM, Math.hypot(p.dst[0] - dst[0], p.dst[1] - dst[1]) * scaleV);
    if (e > 1) fail(`correction ${k + 1} is ${e} screen px from where it was clicked: ${JSON.stringify(p)}`);
  });

  // The overlay: two colours (o), the fixed image green and the warped moving image
  // magenta; then back to the blend.
  await page.keyboard.press('o');
  const colours = await page.evaluate(() => {
    const d = window.trimorph.twoImage.data;
    let green = 0, magenta = 0;
    for (let k = 0; k < d.length; k += 4) {
      if (d[k + 1] > d[k] + 40) green++;
      if (d[k] > d[k + 1] + 40 && d[k + 2] === d[k]) magenta++;
    }
    return { overlay: document.getElementById('overlay').value, green, magenta, pixels: d.length / 4 };
  });
  if (colours.overlay !== 'colors' || !colours.green || !colours.magenta) fail('two-colour overlay: ' + JSON.stringify(colours));
  await page.screenshot({ path: shot.replace(/\.png$/, '_colors.png') });
  await page.keyboard.press('o');

  // The table: edit the first correction's fixed x, switch the last carried pair off.
  const row = nFit; // 0-based row of the first correction
  const newX = Math.round((lms.pairs[row].dst[0] + 1) * 1000) / 1000;
  let v0 = await lmVersion();
  const input = page.locator(`#pairtable tbody tr:nth-child(${row + 1}) input.coord[data-which=dst][data-k="0"]`);
  await input.fill(String(newX));
  await input.press('Enter');
  await page.waitForFunction((v) => window.trimorph.lm.version > v, v0, { timeout: 10000 });
  lms = await api('GET', '/api/landmarks');
  if (lms.pairs[row].dst[0] !== newX) fail(`the table edit set fixed x to ${lms.pairs[row].dst[0]}, not ${newX}`);
  const off = nFit - 1;
  v0 = await lmVersion();
  await page.locator(`#pairtable tbody tr:nth-child(${off + 1}) input[type=checkbox]`).click();
  await page.waitForFunction((v) => window.trimorph.lm.version > v, v0, { timeout: 10000 });
  lms = await api('GET', '/api/landmarks');
  if (lms.pairs[off].active !== false) fail('the checkbox did not switch the pair off');

  // Re-fit: the fit's own (active) pairs and the corrections. Far from the corrections the
  // map stays where the fit put it.
  const rmsBefore = lms.rms;
  await page.click('#refit');
  await msgIs(/^re-fit/);
  lms = await api('GET', '/api/landmarks');
  if (lms.pairs.length !== nFit + 3) fail('the re-fit changed the pairs');
  const far = [];
  for (let i = 0; i < nFit; i++) {
    const p = lms.pairs[i];
    if (Math.min(...corr.map((c) => Math.hypot(p.src[0] - c[0], p.src[1] - c[1]))) < 150) continue;
    far.push(Math.hypot(p.mapped[0] - fitMapped[i][0], p.mapped[1] - fitMapped[i][1]));
  }
  const farMax = Math.max(...far);
  if (!far.length || farMax > 3) fail(`the re-fit moved the fit's far landmarks by up to ${farMax} px (${far.length} far)`);
  const corrRes = lms.pairs.slice(nFit).map((p) => p.residual);
  await page.screenshot({ path: shot });

  // Re-register from the pixels (a button of two-image sessions): the corrected points stay
  // pinned, the active pairs join the image term; one undo step, named.
  if (await page.locator('#reregister').isHidden()) fail('no re-register button in a two-image session');
  await page.click('#reregister');
  await msgIs(/^re-registered \(ncc\)/);
  const regMsg = await page.textContent('#msg');
  if (!/certified fold-free/.test(regMsg)) fail('re-register: ' + regMsg);
  const regState = await api('GET', '/api/state');
  if (regState.undo_next !== 're-register (ncc)') fail('re-register is not one undo step: ' + regState.undo_next);

  // Save: a scene (images, all pairs with the flag) and a deformation, checked by trimorph.
  await page.fill('#path', 'two_scene.json');
  await page.click('#savescene');
  await msgIs(/^saved scene /);
  const scene = JSON.parse(readFileSync(join(work, 'two_scene.json'), 'utf8'));
  if (scene.image !== 'moving.png' || scene.fixed !== 'fixed.png') fail('the scene lost an image: ' + JSON.stringify([scene.image, scene.fixed]));
  if (scene.landmarks.length !== nFit + 3 || scene.landmarks[off].active !== false) fail('the scene lost a pair or its flag');
  await page.fill('#path', 'corrected.json');
  await page.click('#save');
  await msgIs(/^saved /);
  const check = spawnSync(bin, ['check', 'corrected.json'], { cwd: work, encoding: 'utf8' });
  if (check.status !== 0) fail('trimorph check failed: ' + check.stderr);

  // det J legend (j), shown with the overlay.
  await page.keyboard.press('2');
  await page.keyboard.press('j');
  await page.waitForFunction(() => !document.getElementById('legend').hidden);
  await page.keyboard.press('j');

  // Live warp latency on the 512 x 512 frames, and the ghost of the drag: a control point
  // near the centre dragged step by step; each step waits for its warped frame.
  const geo = await api('GET', '/api/geometry');
  let idx = -1, best = Infinity;
  geo.points.forEach((p, i) => { const d = (p[0] - 300) ** 2 + (p[1] - 300) ** 2; if (d < best) { best = d; idx = i; } });
  const [X, Y] = await atV(geo.points[idx]);
  const nLat = await page.evaluate(() => window.trimorph.warpLatency.length);
  await page.mouse.move(X, Y);
  await page.mouse.down();
  let ghost = null;
  for (let k = 1; k <= 40; k++) {
    const n = await page.evaluate(() => window.trimorph.warpLatency.length);
    await page.mouse.move(X + k, Y + Math.round(k / 2));
    await page.waitForFunction((n) => window.trimorph.warpLatency.length > n, n, { timeout: 20000 });
    if (k === 20) ghost = await page.evaluate(() => window.trimorph.drag && window.trimorph.drag.ghost);
  }
  await page.screenshot({ path: shot.replace(/\.png$/, '_drag.png') });
  await page.mouse.up();
  await page.evaluate(() => window.trimorph.idle());
  if (!ghost || ghost.length !== 1 || Math.hypot(ghost[0][0] - geo.points[idx][0], ghost[0][1] - geo.points[idx][1]) > 1e-9) fail('no ghost at the drag start: ' + JSON.stringify(ghost));
  const lat = (await page.evaluate(() => window.trimorph.warpLatency)).slice(nLat + 3);
  const phases = (await page.evaluate(() => window.trimorph.phases)).slice(-lat.length);

  // Undo says what it undid.
  await page.keyboard.press('Control+z');
  await msgIs(/^undid: translate of point \d+ \(xy\)/);
  const undoMsg = await page.textContent('#msg');

  // The path field survives a reload.
  await page.fill('#path', 'kept_name.json');
  await page.reload();
  await page.waitForFunction(() => window.trimorph && window.trimorph.ready, null, { timeout: 30000 });
  const kept = await page.inputValue('#path');
  if (kept !== 'kept_name.json') fail('the path field after a reload: ' + kept);
  if (errors.length) fail('page errors: ' + errors.join('; '));

  const part = (k) => stats(phases.map((p) => p[k])).median;
  summary = {
    ok: true, fit_pairs: nFit, corrections: placed.length, overlay_colours: colours,
    rms_before_refit: rmsBefore, corrections_residual_after: corrRes, far_landmarks: far.length,
    far_moved_max_px: farMax, undo_message: undoMsg, reregister_message: regMsg,
    live_warp_latency_ms: stats(lat),
    live_warp_median_parts_ms: { request: part('request'), warp: part('warp'), draw: part('draw'), update: part('update') },
  };
  console.log(JSON.stringify(summary));
} finally {
  await browser.close();
  editor.kill();
}
