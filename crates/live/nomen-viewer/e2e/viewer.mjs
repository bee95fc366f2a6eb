// Opens nomen serve's viewer in Debian's Chromium, headless, waits until it shows people, reads
// the page's state from its data- attributes, measures its frame time and saves a screenshot.
// Prints one JSON object on stdout. crates/app/nomen-cli/tests/viewer.rs runs it.
//
//   node viewer.mjs URL --screenshot FILE [--min-people N] [--measure-s S] [--timeout-s S]
//                       [--width PX] [--height PX] [--chromium PATH]
import { chromium } from 'playwright-core';

function parse(argv) {
  const options = {
    url: null, screenshot: null, minPeople: 1, measureS: 3, timeoutS: 60,
    width: 1280, height: 720, chromium: process.env.CHROMIUM ?? '/usr/bin/chromium',
  };
  const names = {
    '--screenshot': 'screenshot', '--min-people': 'minPeople', '--measure-s': 'measureS',
    '--timeout-s': 'timeoutS', '--width': 'width', '--height': 'height', '--chromium': 'chromium',
  };
  for (let i = 0; i < argv.length; i += 1) {
    const name = names[argv[i]];
    if (name) {
      const value = argv[i + 1];
      if (value === undefined) throw new Error(`${argv[i]} needs a value`);
      options[name] = typeof options[name] === 'number' ? Number(value) : value;
      i += 1;
    } else if (options.url === null) {
      options.url = argv[i];
    } else {
      throw new Error(`unexpected argument ${argv[i]}`);
    }
  }
  if (!options.url || !options.screenshot) throw new Error('usage: node viewer.mjs URL --screenshot FILE [...]');
  return options;
}

const options = parse(process.argv.slice(2));
const browser = await chromium.launch({
  executablePath: options.chromium,
  headless: true,
  // As root, without the sandbox; no background traffic to hosts a closed network refuses.
  args: [
    '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync',
  ],
});
const errors = [];
try {
  const page = await browser.newPage({ viewport: { width: options.width, height: options.height } });
  page.on('pageerror', (e) => errors.push(`page error: ${e.message}`));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(`console: ${m.text()}`); });
  // Nothing but the viewer's own address may be asked for.
  const origin = new URL(options.url).origin;
  const foreign = [];
  page.on('request', (r) => { if (!r.url().startsWith(origin)) foreign.push(r.url()); });
  await page.goto(options.url, { waitUntil: 'load', timeout: options.timeoutS * 1000 });
  await page.waitForFunction(
    (minPeople) => document.body.dataset.status === 'live'
      && Number(document.body.dataset.numPeople) >= minPeople
      && Number(document.body.dataset.numFrames ?? 0) >= 30,
    options.minPeople,
    { timeout: options.timeoutS * 1000, polling: 100 },
  );
  // The frame intervals of requestAnimationFrame over the measurement, as the page sees them,
  // and how many of those frames the page drew.
  const before = await page.evaluate(() => window.nomenViewer.counts());
  const intervals = await page.evaluate((ms) => new Promise((resolve) => {
    const d = [];
    let previous = null;
    const t0 = performance.now();
    function step(now) {
      if (previous !== null) d.push(now - previous);
      previous = now;
      if (now - t0 < ms) requestAnimationFrame(step); else resolve(d);
    }
    requestAnimationFrame(step);
  }), options.measureS * 1000);
  const after = await page.evaluate(() => window.nomenViewer.counts());
  const state = await page.evaluate(() => {
    const b = document.body.dataset;
    const gl = document.createElement('canvas').getContext('webgl2');
    const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
    return {
      status: b.status,
      seq: Number(b.seq),
      session: Number(b.session),
      named: b.named ? b.named.split(',') : [],
      num_people: Number(b.numPeople),
      num_anonymous: Number(b.numAnonymous),
      num_tags: Number(b.numTags),
      page_frame_ms: Number(b.frameMs),
      page_frame_ms_p95: Number(b.frameMsP95),
      page_work_ms: Number(b.workMs),
      num_labels: document.querySelectorAll('.label:not([style*="display: none"])').length,
      num_events: document.querySelectorAll('#events li').length,
      num_sources: document.querySelectorAll('#health tbody tr').length,
      webgl: info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : null,
    };
  });
  await page.screenshot({ path: options.screenshot });
  const sorted = [...intervals].sort((a, b) => a - b);
  const mean = intervals.reduce((s, x) => s + x, 0) / Math.max(intervals.length, 1);
  const at = (q) => sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))] ?? null;
  process.stdout.write(`${JSON.stringify({
    ...state,
    measured: {
      seconds: options.measureS,
      num_frames: intervals.length,
      num_rendered: after.numRendered - before.numRendered,
      mean_ms: mean,
      p50_ms: at(0.5),
      p95_ms: at(0.95),
      max_ms: sorted[sorted.length - 1] ?? null,
      fps: intervals.length ? 1000 / mean : null,
    },
    foreign_requests: foreign,
    errors,
  })}\n`);
} finally {
  await browser.close();
}
