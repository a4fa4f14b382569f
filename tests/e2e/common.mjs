// What the editor's browser tests (editor.mjs, bigwarp.mjs) share: their arguments, the
// failure report, starting `trimorph editor` and reading its address and session token,
// the token-carrying API client, Chromium's launch, and the timing statistics.
import { spawn } from 'node:child_process';
import { chromium } from 'playwright-core';

// The arguments `TRIMORPH_BINARY WORK_DIR SCREENSHOT.png` of script `name` (exit 2
// without them).
export function args(name) {
  const [bin, work, shot] = process.argv.slice(2);
  if (!bin || !work || !shot) {
    console.error(`usage: node ${name} TRIMORPH_BINARY WORK_DIR SCREENSHOT.png`);
    process.exit(2);
  }
  return [bin, work, shot];
}

// Fails the test: the message goes to stderr (the Rust harness shows it) and the exit
// code becomes 1.
export function fail(msg) {
  console.error('E2E FAILURE: ' + msg);
  process.exitCode = 1;
  throw new Error(msg);
}

// Starts `trimorph editor ARGS` in `cwd` and waits for the address it prints. Returns the
// process, the address (ending in `/`) and the session token.
export async function startEditor(bin, editorArgs, cwd) {
  const editor = spawn(bin, ['editor', ...editorArgs], { cwd, stdio: ['ignore', 'pipe', 'inherit'] });
  const [addr, token] = await new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => reject(new Error('the editor did not print its address')), 30000);
    editor.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/(http:\/\/127\.0\.0\.1:\d+\/)\?token=([0-9a-f]+)/);
      if (m) { clearTimeout(timer); resolve([m[1], m[2]]); }
    });
    editor.on('exit', (c) => reject(new Error('the editor exited with ' + c)));
  });
  return { editor, addr, token };
}

// The editor's JSON API with the session token: `api(method, path, body?)` answers the
// parsed body, and fails the test on an error status.
export function apiClient(addr, token) {
  return async (method, path, body) => {
    const r = await fetch(addr + path.replace(/^\//, ''), {
      method, headers: body ? { 'Content-Type': 'application/json', 'X-Trimorph-Token': token } : { 'X-Trimorph-Token': token },
      body: body ? JSON.stringify(body) : undefined,
    });
    const v = await r.json();
    if (!r.ok) fail(`${method} ${path}: ${r.status} ${v.error}`);
    return v;
  };
}

// Headless Chromium (CHROMIUM, or Debian's /usr/bin/chromium), with nothing that reaches
// the network.
export function launchBrowser() {
  return chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
}

// Count, median, 90th percentile and largest of a list of times.
export function stats(a) {
  const s = a.slice().sort((x, y) => x - y);
  return { n: s.length, median: s[Math.floor(s.length / 2)], p90: s[Math.floor(0.9 * (s.length - 1))], max: s[s.length - 1] };
}
