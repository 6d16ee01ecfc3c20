// origami_jax interactive view: panels with thickness, hinges, contacts, a time slider and a
// fold-angle plot linked to it. Loaded as a module by the page's loader, which replaces the two
// import specifiers below with blob URLs of the bundled three.js (no network).
import * as THREE from '__THREE__';
import { OrbitControls } from '__ORBIT__';

const root = document.getElementById('origami-app');
const data = JSON.parse(document.getElementById('origami-scene').textContent);

function floats(b64) {
  const bin = atob(b64);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  return new Float32Array(bytes.buffer);
}

const T = data.nFrames, P = data.nPanels, V = data.nVertices;
const H = data.hinges.length / 2;
const verts = floats(data.vertices);       // T * V * 3, world coordinates (centred)
const angles = floats(data.foldAngles);    // T * H, degrees (NaN: unknown)
const offsets = data.offsets;
const half = data.thickness / 2;
const times = data.times;

const COLORS = {
  front: new THREE.Color('#e8a33d'), back: new THREE.Color('#8fb3c9'), side: new THREE.Color('#6d6d6d'),
  fixed: new THREE.Color('#a9a9a9'), highlight: new THREE.Color('#e0457b'),
  valley: new THREE.Color('#1f5fd6'), mountain: new THREE.Color('#d62828'),
  flat: new THREE.Color('#444444'), hingeHighlight: new THREE.Color('#ff9900'),
};

// ---------------------------------------------------------------- geometry layout (static)
const panelOf = new Int32Array(V);
for (let p = 0; p < P; p++) for (let v = offsets[p]; v < offsets[p + 1]; v++) panelOf[v] = p;
const nextOf = new Int32Array(V);  // the corner after v in its panel
for (let p = 0; p < P; p++) {
  for (let v = offsets[p]; v < offsets[p + 1]; v++) nextOf[v] = v + 1 < offsets[p + 1] ? v + 1 : offsets[p];
}
const tri = data.triangles;  // top-face triangles, global vertex ids
const nTri = tri.length / 3;
const nOut = nTri * 6 + V * 6;
const src = new Int32Array(nOut), kind = new Uint8Array(nOut);  // kind 0 top, 1 bottom, 2 side
const edgeOf = new Int32Array(nOut);  // side: the corner that starts the edge
{
  let k = 0;
  for (let t = 0; t < nTri; t++) {
    const a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
    for (const s of [a, b, c]) { src[k] = s; kind[k++] = 0; }
    for (const s of [a, c, b]) { src[k] = s; kind[k++] = 1; }
  }
  // Quad A B C D = top i, top j, bottom j, bottom i, seen from outside: (A, D, C) and (A, C, B).
  for (let v = 0; v < V; v++) {
    const j = nextOf[v];
    for (const [s, bottom] of [[v, 0], [v, 1], [j, 1], [v, 0], [j, 1], [j, 0]]) {
      src[k] = s; kind[k] = bottom ? 4 : 2; edgeOf[k++] = v;
    }
  }
}
const highlightPanels = new Set(data.highlightPanels), fixedPanels = new Set(data.fixedPanels);
const highlightHinges = new Set(data.highlightHinges);

const positions = new Float32Array(nOut * 3), normals = new Float32Array(nOut * 3);
const colors = new Float32Array(nOut * 3), panelIds = new Float32Array(nOut);
for (let k = 0; k < nOut; k++) {
  const p = panelOf[src[k]];
  panelIds[k] = p;
  let c = kind[k] === 0 ? COLORS.front : kind[k] === 1 ? COLORS.back : COLORS.side;
  if (fixedPanels.has(p) && kind[k] < 2) c = COLORS.fixed;
  if (highlightPanels.has(p) && kind[k] < 2) c = COLORS.highlight;
  colors.set([c.r, c.g, c.b], 3 * k);
}

const panelNormal = new Float32Array(P * 3), sideNormal = new Float32Array(V * 3);
const outlinePos = new Float32Array(V * 4 * 3);
const hingePos = new Float32Array(H * 4 * 3), hingeCol = new Float32Array(H * 4 * 3);

function computeFrame(f) {
  const base = f * V * 3;
  for (let p = 0; p < P; p++) {  // Newell normal of each panel
    let nx = 0, ny = 0, nz = 0;
    for (let v = offsets[p]; v < offsets[p + 1]; v++) {
      const a = base + 3 * v, b = base + 3 * nextOf[v];
      nx += (verts[a + 1] - verts[b + 1]) * (verts[a + 2] + verts[b + 2]);
      ny += (verts[a + 2] - verts[b + 2]) * (verts[a] + verts[b]);
      nz += (verts[a] - verts[b]) * (verts[a + 1] + verts[b + 1]);
    }
    const l = Math.hypot(nx, ny, nz) || 1;
    panelNormal[3 * p] = nx / l; panelNormal[3 * p + 1] = ny / l; panelNormal[3 * p + 2] = nz / l;
  }
  for (let v = 0; v < V; v++) {  // outward side normals: edge × panel normal
    const a = base + 3 * v, b = base + 3 * nextOf[v], n = 3 * panelOf[v];
    const ex = verts[b] - verts[a], ey = verts[b + 1] - verts[a + 1], ez = verts[b + 2] - verts[a + 2];
    const ox = ey * panelNormal[n + 2] - ez * panelNormal[n + 1];
    const oy = ez * panelNormal[n] - ex * panelNormal[n + 2];
    const oz = ex * panelNormal[n + 1] - ey * panelNormal[n];
    const l = Math.hypot(ox, oy, oz) || 1;
    sideNormal[3 * v] = ox / l; sideNormal[3 * v + 1] = oy / l; sideNormal[3 * v + 2] = oz / l;
  }
  for (let k = 0; k < nOut; k++) {
    const s = src[k], a = base + 3 * s, n = 3 * panelOf[s], q = 3 * k, kk = kind[k];
    const sign = kk === 1 || kk === 4 ? -half : half;
    positions[q] = verts[a] + sign * panelNormal[n];
    positions[q + 1] = verts[a + 1] + sign * panelNormal[n + 1];
    positions[q + 2] = verts[a + 2] + sign * panelNormal[n + 2];
    if (kk === 0) { normals[q] = panelNormal[n]; normals[q + 1] = panelNormal[n + 1]; normals[q + 2] = panelNormal[n + 2]; }
    else if (kk === 1) { normals[q] = -panelNormal[n]; normals[q + 1] = -panelNormal[n + 1]; normals[q + 2] = -panelNormal[n + 2]; }
    else { const e = 3 * edgeOf[k]; normals[q] = sideNormal[e]; normals[q + 1] = sideNormal[e + 1]; normals[q + 2] = sideNormal[e + 2]; }
  }
  // Panel outlines on both faces; hinges on both faces of their panel, coloured by fold sign.
  // Plain loops over typed arrays: no allocation per frame.
  let o = 0;
  for (let v = 0; v < V; v++) {
    const n = 3 * panelOf[v], a = base + 3 * v, b = base + 3 * nextOf[v];
    for (let side = 0; side < 2; side++) {
      const sign = side ? -half : half;
      const dx = sign * panelNormal[n], dy = sign * panelNormal[n + 1], dz = sign * panelNormal[n + 2];
      outlinePos[o] = verts[a] + dx; outlinePos[o + 1] = verts[a + 1] + dy; outlinePos[o + 2] = verts[a + 2] + dz;
      outlinePos[o + 3] = verts[b] + dx; outlinePos[o + 4] = verts[b + 1] + dy; outlinePos[o + 5] = verts[b + 2] + dz;
      o += 6;
    }
  }
  o = 0;
  for (let h = 0; h < H; h++) {
    const angle = angles[f * H + h];
    const c = highlightHinges.has(h) ? COLORS.hingeHighlight
      : !(Math.abs(angle) > 0.05) ? COLORS.flat : angle > 0 ? COLORS.valley : COLORS.mountain;
    const p0 = data.hinges[2 * h], p1 = data.hinges[2 * h + 1];
    const n = 3 * panelOf[p0], a = base + 3 * p0, b = base + 3 * p1;
    for (let side = 0; side < 2; side++) {
      const sign = (side ? -half : half) * 1.02;
      const dx = sign * panelNormal[n], dy = sign * panelNormal[n + 1], dz = sign * panelNormal[n + 2];
      hingePos[o] = verts[a] + dx; hingePos[o + 1] = verts[a + 1] + dy; hingePos[o + 2] = verts[a + 2] + dz;
      hingePos[o + 3] = verts[b] + dx; hingePos[o + 4] = verts[b + 1] + dy; hingePos[o + 5] = verts[b + 2] + dz;
      for (let k = 0; k < 6; k += 3) { hingeCol[o + k] = c.r; hingeCol[o + k + 1] = c.g; hingeCol[o + k + 2] = c.b; }
      o += 6;
    }
  }
}

// ---------------------------------------------------------------- three.js scene
const viewport = root.querySelector('.viewport');
// Multisampling costs a software renderer (SwiftShader, llvmpipe: VMs, remote desktops, CI) about
// 2.5x per frame; GPUs do it for free.
function softwareRenderer() {
  try {
    const gl = document.createElement('canvas').getContext('webgl2');
    const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
    const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : '';
    const lose = gl && gl.getExtension('WEBGL_lose_context');
    if (lose) lose.loseContext();
    return /swiftshader|llvmpipe|software/i.test(name);
  } catch (error) { return false; }
}
const software = softwareRenderer();
const renderer = new THREE.WebGLRenderer({ antialias: !software, preserveDrawingBuffer: true });
renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
renderer.setClearColor(0xf7f7f5);
viewport.appendChild(renderer.domElement);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(35, 1, 1e-3, 1e3);
camera.up.set(0, 0, 1);
scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8a80, 1.6));
const headlight = new THREE.DirectionalLight(0xffffff, 1.4);
camera.add(headlight);
headlight.position.set(0.3, 0.6, 1);
scene.add(camera);

const geometry = new THREE.BufferGeometry();
const positionAttr = new THREE.BufferAttribute(positions, 3).setUsage(THREE.DynamicDrawUsage);
const normalAttr = new THREE.BufferAttribute(normals, 3).setUsage(THREE.DynamicDrawUsage);
geometry.setAttribute('position', positionAttr);
geometry.setAttribute('normal', normalAttr);
geometry.setAttribute('color', new THREE.BufferAttribute(colors, 3));
geometry.setAttribute('panelId', new THREE.BufferAttribute(panelIds, 1));
const material = new THREE.MeshLambertMaterial({
  vertexColors: true, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
});
const mesh = new THREE.Mesh(geometry, material);
mesh.userData.role = 'panels';
mesh.frustumCulled = false;
scene.add(mesh);

const outlineGeometry = new THREE.BufferGeometry();
const outlineAttr = new THREE.BufferAttribute(outlinePos, 3).setUsage(THREE.DynamicDrawUsage);
outlineGeometry.setAttribute('position', outlineAttr);
const outlines = new THREE.LineSegments(outlineGeometry, new THREE.LineBasicMaterial({ color: 0x333333, transparent: true, opacity: 0.55 }));
outlines.frustumCulled = false;
outlines.userData.role = 'outlines';
scene.add(outlines);

const hingeGeometry = new THREE.BufferGeometry();
const hingeAttr = new THREE.BufferAttribute(hingePos, 3).setUsage(THREE.DynamicDrawUsage);
const hingeColAttr = new THREE.BufferAttribute(hingeCol, 3).setUsage(THREE.DynamicDrawUsage);
hingeGeometry.setAttribute('position', hingeAttr);
hingeGeometry.setAttribute('color', hingeColAttr);
const hinges = new THREE.LineSegments(hingeGeometry, new THREE.LineBasicMaterial({ vertexColors: true }));
hinges.frustumCulled = false;
hinges.userData.role = 'hinges';
scene.add(hinges);

// Contacts: red spheres, grouped by frame.
const contactsByFrame = Array.from({ length: T }, () => []);
for (let i = 0; i < data.contacts.frames.length; i++) {
  contactsByFrame[data.contacts.frames[i]].push(data.contacts.points.slice(3 * i, 3 * i + 3));
}
const maxContacts = Math.max(1, ...contactsByFrame.map((c) => c.length));
const extent = data.extent;
const contactMesh = new THREE.InstancedMesh(
  new THREE.SphereGeometry(0.012 * extent, 12, 8),
  new THREE.MeshLambertMaterial({ color: 0xe01010, emissive: 0x550000 }),
  maxContacts,
);
contactMesh.count = 0;
contactMesh.frustumCulled = false;
contactMesh.userData.role = 'contacts';
scene.add(contactMesh);
const tmp = new THREE.Matrix4();

// ---------------------------------------------------------------- camera presets
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
const fitDistance = () => (0.5 * extent) / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2));
const PRESETS = {
  front: [0, -1, 0.0001], side: [1, 0, 0.0001], top: [0, -0.0001, 1], iso: [1, -1.2, 0.9],
};
function setView(name) {
  let dir;
  if (name === 'fit') dir = camera.position.clone().sub(controls.target).normalize();
  else dir = new THREE.Vector3(...PRESETS[name]).normalize();
  const d = fitDistance();
  controls.target.set(0, 0, 0);
  camera.position.copy(dir.multiplyScalar(d));
  camera.near = d / 1000; camera.far = d * 100;
  camera.updateProjectionMatrix();
  controls.update();
  requestRender();
}

// ---------------------------------------------------------------- UI
const $ = (sel) => root.querySelector(sel);
const slider = $('.slider'), playButton = $('.play'), speedSelect = $('.speed'), readout = $('.readout');
slider.max = String(T - 1);
$('.title').textContent = data.title;
const verdict = $('.verdict');
if (data.verdict) { verdict.textContent = data.verdict; verdict.className = `verdict ${data.verdictLevel}`; }
else verdict.remove();
for (const name of ['front', 'side', 'top', 'iso', 'fit']) {
  const button = document.createElement('button');
  button.textContent = name; button.title = `camera: ${name}`;
  button.addEventListener('click', () => setView(name));
  $('.cameras').appendChild(button);
}
const unitText = data.lengthUnit ? `lengths in ${data.lengthUnit}; ` : '';
$('.units').textContent = `${unitText}fold angles in degrees, valley +, mountain −. ${data.thicknessNote}`;
const noteList = $('.notes');
for (const note of data.notes) { const li = document.createElement('li'); li.textContent = note; noteList.appendChild(li); }
if (!H) $('.plot-box').style.display = 'none';

let current = 0;
function unitSuffix(unit) { return !unit ? '' : unit === '°' ? '°' : ` ${unit}`; }
function fmt(x) { if (Number.isInteger(x) && Math.abs(x) < 1e6) return String(x); return Math.abs(x) >= 1e4 || (Math.abs(x) < 1e-3 && x !== 0) ? x.toExponential(3) : x.toPrecision(4); }
function setFrame(f) {
  current = Math.max(0, Math.min(T - 1, f | 0));
  computeFrame(current);
  positionAttr.needsUpdate = true; normalAttr.needsUpdate = true;
  outlineAttr.needsUpdate = true; hingeAttr.needsUpdate = true; hingeColAttr.needsUpdate = true;
  const list = contactsByFrame[current];
  for (let i = 0; i < list.length; i++) { tmp.makeTranslation(list[i][0], list[i][1], list[i][2]); contactMesh.setMatrixAt(i, tmp); }
  contactMesh.count = list.length;
  contactMesh.instanceMatrix.needsUpdate = true;
  if (String(current) !== slider.value) slider.value = String(current);
  readout.textContent = `${data.timeLabel} ${fmt(times[current])}${unitSuffix(data.timeUnit)}` +
    `  (frame ${current + 1}/${T})${list.length ? `  · ${list.length} contact(s)` : ''}`;
  drawCursor();
  requestRender();
}
slider.addEventListener('input', () => { pause(); setFrame(Number(slider.value)); });

let playing = false, position = 0, last = 0;
const FRAMES_PER_SECOND = 30;
function play() {
  if (current >= T - 1) current = 0;
  playing = true; position = current; last = performance.now(); playButton.textContent = '❚❚ pause';
}
function pause() { playing = false; playButton.textContent = '▶ play'; }
playButton.addEventListener('click', () => (playing ? pause() : play()));
root.addEventListener('keydown', (event) => {
  if (event.target.tagName === 'SELECT') return;
  if (event.key === ' ') { event.preventDefault(); playing ? pause() : play(); }
  else if (event.key === 'ArrowRight') { pause(); setFrame(current + 1); }
  else if (event.key === 'ArrowLeft') { pause(); setFrame(current - 1); }
});

// ---------------------------------------------------------------- fold-angle plot
const plot = $('.plot'), plotContext = plot.getContext('2d');
const palette = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f', '#bcbd22', '#17becf'];
let plotImage = null, plotBox = null;
function drawPlot() {
  if (!H) return;
  const ratio = window.devicePixelRatio || 1;
  const width = plot.clientWidth || 280, height = plot.clientHeight || 180;
  plot.width = width * ratio; plot.height = height * ratio;
  const g = plotContext;
  g.setTransform(ratio, 0, 0, ratio, 0, 0);
  g.clearRect(0, 0, width, height);
  let lo = Infinity, hi = -Infinity;
  for (let i = 0; i < angles.length; i++) { const a = angles[i]; if (a < lo) lo = a; if (a > hi) hi = a; }
  if (!(hi >= lo)) { lo = -1; hi = 1; }
  if (hi - lo < 1) { lo -= 0.5; hi += 0.5; }
  const pad = 0.06 * (hi - lo); lo -= pad; hi += pad;
  const box = { left: 42, right: width - 8, top: 8, bottom: height - 24, lo, hi };
  const t0 = times[0], t1 = times[T - 1] > t0 ? times[T - 1] : t0 + 1;
  box.x = (t) => box.left + ((t - t0) / (t1 - t0)) * (box.right - box.left);
  box.y = (a) => box.bottom - ((a - lo) / (hi - lo)) * (box.bottom - box.top);
  box.t0 = t0; box.t1 = t1;
  g.strokeStyle = '#bbb'; g.lineWidth = 1; g.strokeRect(box.left, box.top, box.right - box.left, box.bottom - box.top);
  g.fillStyle = '#444'; g.font = '11px system-ui, sans-serif';
  const ticks = niceTicks(lo, hi, 5);
  g.textAlign = 'right'; g.textBaseline = 'middle';
  for (const tick of ticks) {
    const y = box.y(tick);
    g.fillText(`${+tick.toPrecision(6)}°`, box.left - 4, y);
    g.strokeStyle = tick === 0 ? '#999' : '#eee';
    g.beginPath(); g.moveTo(box.left, y); g.lineTo(box.right, y); g.stroke();
  }
  g.textAlign = 'center'; g.textBaseline = 'top';
  g.fillText(`${data.timeLabel}${data.timeUnit ? ' [' + data.timeUnit + ']' : ''}: ${fmt(t0)} … ${fmt(times[T - 1])}`, (box.left + box.right) / 2, box.bottom + 6);
  // Frames with contacts: red ticks along the time axis.
  g.strokeStyle = '#e01010'; g.lineWidth = 2;
  for (let f = 0; f < T; f++) {
    if (!contactsByFrame[f].length) continue;
    const x = box.x(times[f]);
    g.beginPath(); g.moveTo(x, box.bottom - 5); g.lineTo(x, box.bottom); g.stroke();
  }
  const alpha = H > 40 ? 0.35 : 1;
  const order = [...Array(H).keys()].sort((a, b) => highlightHinges.has(a) - highlightHinges.has(b));
  for (const h of order) {
    g.strokeStyle = palette[h % palette.length];
    g.globalAlpha = highlightHinges.has(h) ? 1 : alpha;
    g.lineWidth = highlightHinges.has(h) ? 2.6 : 1.3;
    g.beginPath();
    let pen = false;
    for (let f = 0; f < T; f++) {
      const a = angles[f * H + h];
      if (!Number.isFinite(a)) { pen = false; continue; }
      const x = box.x(times[f]), y = box.y(a);
      if (pen) g.lineTo(x, y); else { g.moveTo(x, y); pen = true; }
    }
    g.stroke();
  }
  g.globalAlpha = 1;
  plotImage = g.getImageData(0, 0, plot.width, plot.height);
  plotBox = box;
  drawCursor();
}
function niceTicks(lo, hi, n) {
  const step0 = (hi - lo) / n, mag = 10 ** Math.floor(Math.log10(step0));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= step0);
  const out = [];
  for (let t = Math.ceil(lo / step) * step; t <= hi; t += step) out.push(Math.abs(t) < 1e-9 * step ? 0 : t);
  return out;
}
function drawCursor() {
  if (!plotImage || !plotBox) return;
  plotContext.putImageData(plotImage, 0, 0);
  const x = plotBox.x(times[current]);
  plotContext.strokeStyle = '#000'; plotContext.lineWidth = 1;
  plotContext.beginPath(); plotContext.moveTo(x, plotBox.top); plotContext.lineTo(x, plotBox.bottom); plotContext.stroke();
  if (H <= 10) {
    const rows = [];
    for (let h = 0; h < H; h++) {
      const a = angles[current * H + h];
      const mark = highlightHinges.has(h) ? ' <b style="color:#ff9900">(highlighted)</b>' : '';
      rows.push(`<span style="color:${palette[h % palette.length]}">■</span> ${escapeHtml(data.hingeNames[h])}: ${Number.isFinite(a) ? a.toFixed(1) + '°' : '–'}${mark}`);
    }
    $('.plot-legend').innerHTML = rows.join('<br>');
  } else {
    $('.plot-legend').textContent = `${H} hinges${highlightHinges.size ? `; ${highlightHinges.size} highlighted` : ''}`;
  }
}
function escapeHtml(text) { return String(text).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' })[c]); }
function seekFromPlot(event) {
  if (!plotBox) return;
  const rect = plot.getBoundingClientRect();
  const t = plotBox.t0 + ((event.clientX - rect.left - plotBox.left) / (plotBox.right - plotBox.left)) * (plotBox.t1 - plotBox.t0);
  let best = 0;
  for (let f = 1; f < T; f++) if (Math.abs(times[f] - t) < Math.abs(times[best] - t)) best = f;
  pause(); setFrame(best);
}
let dragging = false;
plot.addEventListener('pointerdown', (e) => { dragging = true; seekFromPlot(e); });
plot.addEventListener('pointermove', (e) => { if (dragging) seekFromPlot(e); });
window.addEventListener('pointerup', () => { dragging = false; });

// ---------------------------------------------------------------- render loop
let dirty = true, renders = 0;
function requestRender() { dirty = true; }
function renderNow() { renderer.render(scene, camera); renders++; dirty = false; }
function resize() {
  const w = viewport.clientWidth || 300, h = viewport.clientHeight || 200;
  renderer.setSize(w, h, false);
  camera.aspect = w / h; camera.updateProjectionMatrix();
  requestRender();
}
new ResizeObserver(() => { resize(); drawPlot(); }).observe(viewport);
controls.addEventListener('change', requestRender);
function loop(now) {
  if (playing) {
    const speed = Number(speedSelect.value);
    position += ((now - last) / 1000) * FRAMES_PER_SECOND * speed;
    if (position >= T - 1) {
      if ($('.loop').checked) position = position % Math.max(T - 1, 1); else { position = T - 1; pause(); }
    }
    if ((position | 0) !== current) setFrame(position | 0);
  }
  last = now;
  if (dirty) renderNow();
  requestAnimationFrame(loop);
}

resize();
setView('iso');
setFrame(0);
drawPlot();
renderNow();
requestAnimationFrame(loop);

// ---------------------------------------------------------------- test and scripting hook
window.__origami = {
  ready: true,
  nPanels: P, nFrames: T, nHinges: H,
  get frame() { return current; },
  get renders() { return renders; },
  setFrame(f) { slider.value = String(f); slider.dispatchEvent(new Event('input')); renderNow(); return current; },
  setView(name) { setView(name); renderNow(); },
  countPanels() {
    let n = 0;
    scene.traverse((o) => { if (o.userData.role === 'panels') n += new Set(o.geometry.getAttribute('panelId').array).size; });
    return n;
  },
  vertexSample(n = 24) { return Array.from(positionAttr.array.slice(0, n)); },
  contactsShown() { return contactMesh.count; },
  timeUpdates(n = 200, synced = 40) {
    // Mean ms per frame change: `submitMs` what the page does (geometry, buffer upload, draw calls)
    // over `n` changes; `meanMs` the same plus a 1-pixel read that waits for the rasterizer, over
    // `synced` changes; `geometryMs` the geometry alone.
    const gl = renderer.getContext(), pixel = new Uint8Array(4);
    let s = performance.now();
    for (let i = 0; i < n; i++) { setFrame(i % T); renderNow(); }
    const submit = (performance.now() - s) / n;
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    s = performance.now();
    for (let i = 0; i < synced; i++) { setFrame(i % T); renderNow(); gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel); }
    const mean = (performance.now() - s) / synced;
    s = performance.now();
    for (let i = 0; i < n; i++) computeFrame(i % T);
    return { submitMs: submit, meanMs: mean, geometryMs: (performance.now() - s) / n, software };
  },
};
root.dispatchEvent(new CustomEvent('origami-ready'));
