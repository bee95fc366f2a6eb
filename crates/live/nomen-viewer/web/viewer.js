// nomen live: draws the frames of /api/stream (server-sent events, one JSON frame each) with
// three.js. World frame: z up, metres (frames carry millimetres). The page's state for tests and
// tools is on <body> as data- attributes (docs/live.md) and on window.nomenViewer.
import * as THREE from '/vendor/three.module.js';

const MAX_PEOPLE = 256;
const NUM_JOINTS = 20;
const MAX_BONES = NUM_JOINTS - 1;
const MAX_TAGS = 256;
const ANONYMOUS = new THREE.Color(0x8a8f98);
const RAW_FIX = new THREE.Color(0x6c727c);
const FRAME_WINDOW = 120; // frames over which the frame time is averaged
const body = document.body;

// `?render=always` draws every animation frame, not only when something changed: the frame
// time then measures the drawing itself, whatever the rate of the data.
const params = new URLSearchParams(location.search);
const renderAlways = params.get('render') === 'always';
// The token travels as a cookie once the page is open: keep it out of the address bar.
if (params.has('token')) {
  params.delete('token');
  history.replaceState(null, '', location.pathname + (params.size ? `?${params}` : ''));
}

// --- scene ---------------------------------------------------------------------------------
const canvas = document.getElementById('canvas');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: false });
renderer.setPixelRatio(1);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1b1e23);
scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, -4, 8);
scene.add(sun);
const view = new THREE.PerspectiveCamera(50, 1, 0.05, 500);
view.up.set(0, 0, 1);

const room = new THREE.Group();
scene.add(room);

// Unlit, low-poly spheres: in software WebGL (headless Chromium, SwiftShader) lighting and
// triangles are what the frame time is made of.
const jointMesh = new THREE.InstancedMesh(
  new THREE.SphereGeometry(0.045, 6, 4),
  new THREE.MeshBasicMaterial(),
  MAX_PEOPLE * NUM_JOINTS,
);
jointMesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
jointMesh.setColorAt(0, ANONYMOUS);
jointMesh.count = 0;
jointMesh.frustumCulled = false;
scene.add(jointMesh);

// Estimated joints: a translucent sphere of radius 1 σ around each.
const sigmaMesh = new THREE.InstancedMesh(
  new THREE.SphereGeometry(1, 12, 8),
  new THREE.MeshBasicMaterial({ transparent: true, opacity: 0.22, depthWrite: false }),
  MAX_PEOPLE * NUM_JOINTS,
);
sigmaMesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
sigmaMesh.setColorAt(0, ANONYMOUS);
sigmaMesh.count = 0;
sigmaMesh.frustumCulled = false;
scene.add(sigmaMesh);

function lineBuffer(numSegments) {
  const geometry = new THREE.BufferGeometry();
  const position = new THREE.BufferAttribute(new Float32Array(numSegments * 6), 3);
  const color = new THREE.BufferAttribute(new Float32Array(numSegments * 6), 3);
  position.setUsage(THREE.DynamicDrawUsage);
  color.setUsage(THREE.DynamicDrawUsage);
  geometry.setAttribute('position', position);
  geometry.setAttribute('color', color);
  geometry.setDrawRange(0, 0);
  const lines = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ vertexColors: true }));
  lines.frustumCulled = false;
  scene.add(lines);
  return { geometry, position, color, n: 0 };
}
const bones = lineBuffer(MAX_PEOPLE * MAX_BONES);
// Per tag: a cross at the corrected position (3 segments), a small grey one at the raw fix (3)
// and the correction between them (1).
const tagLines = lineBuffer(MAX_TAGS * 7);

function pushSegment(buf, a, b, color) {
  const i = buf.n * 6;
  const p = buf.position.array;
  const c = buf.color.array;
  p[i] = a[0]; p[i + 1] = a[1]; p[i + 2] = a[2];
  p[i + 3] = b[0]; p[i + 4] = b[1]; p[i + 5] = b[2];
  c[i] = c[i + 3] = color.r; c[i + 1] = c[i + 4] = color.g; c[i + 2] = c[i + 5] = color.b;
  buf.n += 1;
}
function finishSegments(buf) {
  buf.geometry.setDrawRange(0, buf.n * 2);
  buf.position.needsUpdate = true;
  buf.color.needsUpdate = true;
}
function cross(buf, p, r, color) {
  pushSegment(buf, [p[0] - r, p[1], p[2]], [p[0] + r, p[1], p[2]], color);
  pushSegment(buf, [p[0], p[1] - r, p[2]], [p[0], p[1] + r, p[2]], color);
  pushSegment(buf, [p[0], p[1], p[2] - r], [p[0], p[1], p[2] + r], color);
}

// --- colours: subjects by their order in the registry, anonymous people grey ---------------
let subjectIndex = new Map();
const colorCache = new Map();
function subjectColor(subject) {
  if (subject == null) return ANONYMOUS;
  let c = colorCache.get(subject);
  if (!c) {
    let i = subjectIndex.get(subject);
    if (i === undefined) {
      i = 0;
      for (const ch of subject) i = (i * 31 + ch.charCodeAt(0)) >>> 0;
    }
    c = new THREE.Color().setHSL(((i * 137.508) % 360) / 360, 0.7, 0.58);
    colorCache.set(subject, c);
  }
  return c;
}
const cssColor = (c) => `#${c.getHexString()}`;

// --- camera control: drag turns, wheel zooms, double-click fits ---------------------------
const orbit = { target: new THREE.Vector3(0, 0, 1), distance: 12, azimuth: -0.9, elevation: 0.55 };
let userMoved = false;
function placeView() {
  const e = orbit.elevation, a = orbit.azimuth;
  view.position.set(
    orbit.target.x + orbit.distance * Math.cos(e) * Math.cos(a),
    orbit.target.y + orbit.distance * Math.cos(e) * Math.sin(a),
    orbit.target.z + orbit.distance * Math.sin(e),
  );
  view.lookAt(orbit.target);
  viewMoved = true;
}
let viewMoved = true;
let drag = null;
canvas.addEventListener('pointerdown', (ev) => { drag = { x: ev.clientX, y: ev.clientY }; canvas.setPointerCapture(ev.pointerId); });
canvas.addEventListener('pointerup', () => { drag = null; });
canvas.addEventListener('pointermove', (ev) => {
  if (!drag) return;
  orbit.azimuth -= (ev.clientX - drag.x) * 0.008;
  orbit.elevation = Math.min(1.5, Math.max(0.05, orbit.elevation + (ev.clientY - drag.y) * 0.008));
  drag = { x: ev.clientX, y: ev.clientY };
  userMoved = true;
  placeView();
});
canvas.addEventListener('wheel', (ev) => {
  ev.preventDefault();
  orbit.distance = Math.min(200, Math.max(1, orbit.distance * Math.exp(ev.deltaY * 0.001)));
  userMoved = true;
  placeView();
}, { passive: false });
canvas.addEventListener('dblclick', () => { userMoved = false; fitted = false; if (frame) growRoom(frame); });

// The room: a box around the anchors, the cameras and everyone seen so far in the session. The
// view is fitted to it whenever it grows, until the user turns or zooms (a double-click fits
// again).
const roomBox = new THREE.Box3();
let fitted = false;
function growRoom(frame) {
  const before = roomBox.clone();
  const add = (mm) => roomBox.expandByPoint(new THREE.Vector3(mm[0] / 1000, mm[1] / 1000, mm[2] / 1000));
  for (const a of frame.anchors) add(a.position_mm);
  for (const c of frame.cameras) add(c.position_mm);
  for (const p of frame.people) for (const j of p.joints) if (j) add(j);
  if (roomBox.isEmpty()) return;
  // Grown by more than 25 cm on a side: fit and redraw the floor.
  const grown = before.isEmpty()
    || before.min.distanceTo(roomBox.min) > 0.25 || before.max.distanceTo(roomBox.max) > 0.25;
  if (grown) {
    rebuildFloor(roomBox);
    fitted = false;
  }
  if (!fitted && !userMoved) {
    fit(roomBox);
    fitted = true;
  }
}
function fit(box) {
  const padded = box.clone().expandByScalar(0.5);
  padded.getCenter(orbit.target);
  orbit.target.z = Math.min(orbit.target.z, 1.0);
  const size = padded.getSize(new THREE.Vector3());
  orbit.distance = Math.max(4, 1.2 * Math.max(size.x, size.y, size.z * 2));
  placeView();
}

function rebuildFloor(box) {
  for (const old of room.children.filter((c) => c.userData.floor)) {
    room.remove(old);
    old.geometry.dispose();
  }
  const size = Math.ceil(Math.max(box.max.x - box.min.x, box.max.y - box.min.y, 4) + 1);
  const grid = new THREE.GridHelper(size, size, 0x4a515b, 0x30353d);
  grid.rotation.x = Math.PI / 2; // GridHelper lies in x-z; the floor is x-y
  grid.position.set((box.min.x + box.max.x) / 2, (box.min.y + box.max.y) / 2, 0);
  grid.userData.floor = true;
  room.add(grid);
}

// Cameras as small pyramids at their poses, anchors as boxes: rebuilt when the registry changes.
let roomKey = '';
function rebuildRoom(frame) {
  const key = JSON.stringify([frame.session, frame.cameras, frame.anchors]);
  if (key === roomKey) return;
  roomKey = key;
  for (const old of room.children.filter((c) => !c.userData.floor)) room.remove(old);
  const camGeometry = new THREE.ConeGeometry(0.15, 0.3, 4);
  const camMaterial = new THREE.MeshLambertMaterial({ color: 0x5a86c8 });
  for (const c of frame.cameras) {
    const m = new THREE.Mesh(camGeometry, camMaterial);
    const q = c.rotation_wxyz;
    m.quaternion.set(q[1], q[2], q[3], q[0]);
    // The cone points along its local y; turn it to the camera's optical axis (+z).
    m.quaternion.multiply(new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(1, 0, 0), -Math.PI / 2));
    m.position.set(c.position_mm[0] / 1000, c.position_mm[1] / 1000, c.position_mm[2] / 1000);
    room.add(m);
  }
  const anchorGeometry = new THREE.BoxGeometry(0.12, 0.12, 0.12);
  const anchorMaterial = new THREE.MeshLambertMaterial({ color: 0xc8a25a });
  for (const a of frame.anchors) {
    const m = new THREE.Mesh(anchorGeometry, anchorMaterial);
    m.position.set(a.position_mm[0] / 1000, a.position_mm[1] / 1000, a.position_mm[2] / 1000);
    room.add(m);
  }
  roomBox.makeEmpty();
  subjectIndex = new Map(frame.subjects.map((s, i) => [s, i]));
  colorCache.clear();
}

// --- a frame from the server into the scene ------------------------------------------------
const matrix = new THREE.Matrix4();
const labelPool = [];
const labelsEl = document.getElementById('labels');
let labelAnchors = []; // [x, y, z] in metres, per label shown
let frame = null;
let dirty = false;

function applyFrame() {
  dirty = false;
  rebuildRoom(frame);
  growRoom(frame);
  let nj = 0, ns = 0;
  bones.n = 0;
  labelAnchors = [];
  const people = frame.people.slice(0, MAX_PEOPLE);
  for (const p of people) {
    const color = subjectColor(p.subject);
    const js = p.joints;
    for (const j of js) {
      if (!j) continue;
      const x = j[0] / 1000, y = j[1] / 1000, z = j[2] / 1000;
      matrix.makeTranslation(x, y, z);
      jointMesh.setMatrixAt(nj, matrix);
      jointMesh.setColorAt(nj, color);
      nj += 1;
      if (j.length > 3) {
        const s = Math.max(j[3] / 1000, 0.01);
        matrix.makeScale(s, s, s).setPosition(x, y, z);
        sigmaMesh.setMatrixAt(ns, matrix);
        sigmaMesh.setColorAt(ns, color);
        ns += 1;
      }
    }
    for (const [a, b] of frame.bones) {
      const ja = js[a], jb = js[b];
      if (!ja || !jb) continue;
      pushSegment(bones, [ja[0] / 1000, ja[1] / 1000, ja[2] / 1000], [jb[0] / 1000, jb[1] / 1000, jb[2] / 1000], color);
    }
    // The label floats above the highest joint.
    let top = null;
    for (const j of js) if (j && (!top || j[2] > top[2])) top = j;
    if (top) labelAnchors.push([top[0] / 1000, top[1] / 1000, top[2] / 1000 + 0.25, p]);
  }
  jointMesh.count = nj;
  jointMesh.instanceMatrix.needsUpdate = true;
  if (jointMesh.instanceColor) jointMesh.instanceColor.needsUpdate = true;
  sigmaMesh.count = ns;
  sigmaMesh.instanceMatrix.needsUpdate = true;
  if (sigmaMesh.instanceColor) sigmaMesh.instanceColor.needsUpdate = true;
  finishSegments(bones);

  tagLines.n = 0;
  for (const t of frame.tags.slice(0, MAX_TAGS)) {
    const raw = t.raw_mm.map((v) => v / 1000);
    const fixed = t.corrected_mm.map((v) => v / 1000);
    const color = new THREE.Color(0xf2f2f2);
    cross(tagLines, fixed, 0.15, color);
    cross(tagLines, raw, 0.07, RAW_FIX);
    pushSegment(tagLines, raw, fixed, RAW_FIX);
  }
  finishSegments(tagLines);

  for (let i = 0; i < labelAnchors.length; i += 1) {
    let el = labelPool[i];
    if (!el) {
      el = document.createElement('div');
      el.className = 'label';
      labelsEl.appendChild(el);
      labelPool.push(el);
    }
    const p = labelAnchors[i][3];
    const text = p.subject == null
      ? `anonymous ${Math.round(p.confidence * 100)}%`
      : `${p.subject} ${Math.round(p.confidence * 100)}%`;
    if (el.textContent !== text) el.textContent = text;
    el.classList.toggle('anonymous', p.subject == null);
    el.style.borderLeftColor = cssColor(subjectColor(p.subject));
    el.style.display = '';
  }
  for (let i = labelAnchors.length; i < labelPool.length; i += 1) labelPool[i].style.display = 'none';
  viewMoved = true;

  updatePanels();
  const named = [...new Set(people.filter((p) => p.subject != null).map((p) => p.subject))].sort();
  body.dataset.seq = String(frame.seq);
  body.dataset.session = String(frame.session);
  body.dataset.named = named.join(',');
  body.dataset.numPeople = String(people.length);
  body.dataset.numAnonymous = String(people.filter((p) => p.subject == null).length);
  body.dataset.numTags = String(frame.tags.length);
  body.dataset.tNs = frame.t_ns == null ? '' : String(frame.t_ns);
}

const projected = new THREE.Vector3();
function placeLabels() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  for (let i = 0; i < labelAnchors.length; i += 1) {
    const [x, y, z] = labelAnchors[i];
    projected.set(x, y, z).project(view);
    const el = labelPool[i];
    if (projected.z > 1) { if (el.style.display !== 'none') el.style.display = 'none'; continue; }
    if (el.style.display !== '') el.style.display = '';
    const sx = (projected.x * 0.5 + 0.5) * w, sy = (-projected.y * 0.5 + 0.5) * h;
    const transform = `translate(${Math.round(sx)}px, ${Math.round(sy)}px) translate(-50%, -100%)`;
    // Written only when it moved: each write costs the browser a style pass.
    if (el.dataset.at !== transform) {
      el.dataset.at = transform;
      el.style.transform = transform;
    }
  }
}

// --- side panels ---------------------------------------------------------------------------
const $ = (id) => document.getElementById(id);
let healthKey = null, eventsKey = null, legendKey = null;
function seconds(ns) { return ns == null ? '–' : (ns / 1e9).toFixed(1); }
function escapeText(s) { const d = document.createElement('span'); d.textContent = s; return d; }

function updatePanels() {
  $('session').textContent = String(frame.session);
  $('clock').textContent = `${seconds(frame.t_ns)} s`;
  const people = frame.people;
  const numNamed = people.filter((p) => p.subject != null).length;
  $('people-summary').textContent = people.length === 0
    ? 'nobody on screen'
    : `${people.length} on screen: ${numNamed} named, ${people.length - numNamed} anonymous; ` +
      `${frame.tags.length} tag fix(es); ${frame.num_decisions} decisions`;
  const legend = JSON.stringify(frame.subjects);
  if (legend !== legendKey) {
    legendKey = legend;
    const ul = $('legend');
    ul.replaceChildren();
    for (const s of [...frame.subjects, null]) {
      const li = document.createElement('li');
      const sw = document.createElement('span');
      sw.className = 'swatch';
      sw.style.background = cssColor(subjectColor(s));
      li.append(sw, escapeText(s ?? 'anonymous'));
      ul.append(li);
    }
  }
  const h = frame.health;
  const hKey = h ? `${h.uptime_s}` : null;
  if (hKey !== healthKey) {
    healthKey = hKey;
    if (h) {
      $('health-summary').textContent =
        `${h.num_received} received, ${h.num_malformed} malformed, ${h.num_dropped} dropped, ` +
        `${h.num_rejected} refused; queue ${h.queue_len}/${h.queue_capacity}; ` +
        `${h.num_published} published; up ${h.uptime_s.toFixed(0)} s` +
        (h.last_connection_error ? `; broker: ${h.last_connection_error}` : '');
      const tbody = $('health').tBodies[0];
      tbody.replaceChildren();
      for (const s of h.sources) {
        const tr = document.createElement('tr');
        if (s.num_dropped > 0 || s.num_rejected > 0 || s.rate_hz === 0) tr.className = 'bad';
        if (s.last_rejection) tr.title = s.last_rejection;
        for (const v of [s.source, s.rate_hz.toFixed(1), s.num_received, s.num_dropped, s.num_rejected]) {
          const td = document.createElement('td');
          td.textContent = String(v);
          tr.append(td);
        }
        tbody.append(tr);
      }
      const ul = $('malformed');
      ul.replaceChildren();
      for (const m of h.malformed) {
        const li = document.createElement('li');
        li.textContent = `${m.count} malformed on ${m.topic}: ${m.reason}`;
        ul.append(li);
      }
    }
  }
  const last = frame.events[frame.events.length - 1];
  const eKey = `${frame.events.length}:${last ? last.t_ns + last.message : ''}`;
  if (eKey !== eventsKey) {
    eventsKey = eKey;
    const ol = $('events');
    ol.replaceChildren();
    for (const e of [...frame.events].reverse()) {
      const li = document.createElement('li');
      const t = document.createElement('span');
      t.className = 't';
      t.textContent = `${seconds(e.t_ns)} s`;
      const k = document.createElement('span');
      k.className = `kind ${e.kind}`;
      k.textContent = e.kind.replace('_', '-');
      li.append(t, k, escapeText(e.message));
      ol.append(li);
    }
  }
  $('perf').textContent =
    `pages ${frame.server.num_clients}, frames skipped ${frame.server.num_frames_skipped}, ` +
    `frame ${body.dataset.frameMs ?? '–'} ms (work ${body.dataset.workMs ?? '–'} ms)`;
}

// --- live stream ---------------------------------------------------------------------------
const stream = new EventSource('/api/stream');
stream.onopen = () => { body.dataset.status = 'live'; $('status').textContent = 'live'; };
stream.onerror = () => { body.dataset.status = 'reconnecting'; $('status').textContent = 'reconnecting'; };
stream.onmessage = (ev) => {
  try {
    const f = JSON.parse(ev.data);
    if (Array.isArray(f.people)) { frame = f; dirty = true; }
  } catch (e) {
    body.dataset.lastError = String(e);
  }
};

// --- render loop, measuring its own frame time ---------------------------------------------
const intervals = new Float64Array(FRAME_WINDOW);
const works = new Float64Array(FRAME_WINDOW);
let numFrames = 0;
let numRendered = 0;
let previous = null;
function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== w || canvas.height !== h) {
    renderer.setSize(w, h, false);
    view.aspect = w / Math.max(h, 1);
    view.updateProjectionMatrix();
    viewMoved = true;
  }
}
function loop(now) {
  requestAnimationFrame(loop);
  const start = performance.now();
  resize();
  // Drawn when something changed: a new frame from the server, or the view.
  if (dirty && frame) applyFrame();
  if (viewMoved || renderAlways) {
    placeLabels();
    viewMoved = false;
    renderer.render(scene, view);
    numRendered += 1;
  }
  const work = performance.now() - start;
  if (previous !== null) {
    intervals[numFrames % FRAME_WINDOW] = now - previous;
    works[numFrames % FRAME_WINDOW] = work;
    numFrames += 1;
    if (numFrames % 30 === 0) publishFrameTimes();
  }
  previous = now;
}
function stats(values, n) {
  const v = Array.from(values.subarray(0, n)).sort((a, b) => a - b);
  const mean = v.reduce((s, x) => s + x, 0) / Math.max(n, 1);
  return { mean, p95: v[Math.min(n - 1, Math.floor(0.95 * n))] ?? 0 };
}
function publishFrameTimes() {
  const n = Math.min(numFrames, FRAME_WINDOW);
  const interval = stats(intervals, n), work = stats(works, n);
  body.dataset.frameMs = interval.mean.toFixed(2);
  body.dataset.frameMsP95 = interval.p95.toFixed(2);
  body.dataset.workMs = work.mean.toFixed(2);
  body.dataset.numFrames = String(numFrames);
  body.dataset.numRendered = String(numRendered);
}
placeView();
requestAnimationFrame(loop);

// A hook for tests and tools: the newest frame and the last frame intervals and work times, ms.
window.nomenViewer = {
  frame: () => frame,
  counts: () => ({ numFrames, numRendered }),
  frameTimes: () => {
    const n = Math.min(numFrames, FRAME_WINDOW);
    return { intervals: Array.from(intervals.subarray(0, n)), work: Array.from(works.subarray(0, n)) };
  },
};
