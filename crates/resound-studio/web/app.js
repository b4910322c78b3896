// Resound Studio's page. It only shows what the API returns: every number and report text
// comes from the library; the page draws, plays and sends requests.
"use strict";

const $ = (id) => document.getElementById(id);
const state = { recording: null, object: null, surface: null, hit: null, estimate: null, renders: [] };

function say(msg, error = false) {
  const s = $("status");
  s.textContent = msg;
  s.className = error ? "error" : "";
}

// A finished step's line, with every warning the library raised (never silently dropped).
function sayDone(msg, ...lists) {
  const seen = new Set();
  for (const l of lists) for (const w of l || []) seen.add(w.message || String(w));
  if (!seen.size) { say(msg); return; }
  say(`${msg} · warning: ${[...seen].join("; ")}`);
  $("status").className = "warn";
}

// A picture and its PNG download link.
function showImage(id, url) {
  $(id).src = url;
  $(`${id}-png`).href = url;
}

async function api(path, opts = {}) {
  const res = await fetch(path, opts);
  const type = res.headers.get("content-type") || "";
  const body = type.includes("json") ? await res.json() : await res.text();
  if (!res.ok) {
    const text = typeof body === "string" && body.trim() ? body.trim() : null;
    const e = new Error((body && body.error) || text || `${res.status} ${res.statusText}`);
    e.status = res.status;
    throw e;
  }
  return body;
}

const post = (path, body) =>
  api(path, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(body) });

// A job: its progress by server-sent events, its result when done.
// A job that did not finish: cancelled by the user (said plainly, not as an error) or failed.
function jobError(s) {
  const e = new Error(s.state === "cancelled" ? `${s.kind} cancelled` : s.error || s.state);
  e.cancelled = s.state === "cancelled";
  e.report = s.report;
  return e;
}

function runJob(start, box) {
  const el = $(box);
  const bar = el.querySelector("progress");
  const msg = el.querySelector(".msg");
  const cancel = el.querySelector(".cancel");
  el.hidden = false;
  bar.removeAttribute("value");
  msg.textContent = "starting…";
  return new Promise((resolve, reject) => {
    const events = new EventSource(`/api/jobs/${start.id}/events`);
    cancel.onclick = () => api(`/api/jobs/${start.id}`, { method: "DELETE" }).catch(() => {});
    events.onmessage = (ev) => {
      const s = JSON.parse(ev.data);
      const p = s.progress;
      if (p && p.fraction !== undefined && p.fraction !== null) bar.value = p.fraction;
      else bar.removeAttribute("value");
      msg.textContent = `${s.message || s.kind} · ${s.elapsed_s.toFixed(1)} s`;
      if (s.state === "running") return;
      events.close();
      el.hidden = true;
      if (s.state === "done") resolve(s);
      else reject(jobError(s));
    };
    events.onerror = () => {
      // The stream ends after the last status; a real loss shows as a still-running job.
      api(`/api/jobs/${start.id}`).then((s) => {
        if (s.state === "running") return;
        events.close();
        el.hidden = true;
        if (s.state === "done") resolve(s);
        else reject(jobError(s));
      }).catch(reject);
    };
  });
}

// ---------------------------------------------------------------- audio (A/B without a gap)
const audio = { ctx: null, analyser: null, source: null, part: null, buffers: {}, startedAt: 0, offset: 0 };

function ctx() {
  if (!audio.ctx) {
    audio.ctx = new AudioContext();
    audio.analyser = audio.ctx.createAnalyser();
    audio.analyser.fftSize = 2048;
    audio.analyser.connect(audio.ctx.destination);
  }
  return audio.ctx;
}

async function decode(url) {
  const bytes = await (await fetch(url)).arrayBuffer();
  return await ctx().decodeAudioData(bytes);
}

function position() {
  return audio.source ? audio.offset + (audio.ctx.currentTime - audio.startedAt) : 0;
}

function play(buffer, name, at = 0) {
  const c = ctx();
  c.resume();
  stop();
  const src = c.createBufferSource();
  src.buffer = buffer;
  src.connect(audio.analyser);
  const offset = at < buffer.duration ? at : 0;
  src.start(0, offset);
  audio.source = src;
  audio.part = name;
  audio.startedAt = c.currentTime;
  audio.offset = offset;
  src.onended = () => {
    if (audio.source === src) {
      audio.source = null;
      audio.part = null;
      markParts();
    }
  };
  markParts();
  tick();
}

function stop() {
  if (audio.source) {
    const s = audio.source;
    audio.source = null;
    try { s.stop(); } catch (_) { /* already ended */ }
  }
  audio.part = null;
  markParts();
}

function markParts() {
  document.querySelectorAll("button.ab").forEach((b) => b.classList.toggle("on", b.dataset.part === audio.part));
}

function tick() {
  $("clock").textContent = `${position().toFixed(2)} s`;
  if (audio.source) requestAnimationFrame(tick);
}

// The loudest sample the analyser sees now (tests use it to hear that audio plays).
function level() {
  if (!audio.analyser) return 0;
  const a = new Float32Array(audio.analyser.fftSize);
  audio.analyser.getFloatTimeDomainData(a);
  return a.reduce((m, v) => Math.max(m, Math.abs(v)), 0);
}

// ---------------------------------------------------------------- 1. recording
async function openRecording(promise) {
  say("analysing…");
  try {
    const v = await promise;
    await showRecording(v);
    sayDone(`analysed ${v.name}: ${v.report.modes.length} modes`, v.report.warnings);
  } catch (e) {
    say(e.message, !e.cancelled);
  }
}

async function showRecording(v) {
  state.recording = v;
  stop();
  $("recording").hidden = false;
  const r = v.report;
  $("rec-title").textContent = `${v.name} · ${r.codec}, ${r.sample_rate} Hz · strike ${r.strike} of ${r.strikes_s.length} · ${r.modes.length} modes`;
  // The conditioning and onset lines; the whole text (with its mode table) below, folded.
  $("conditioning").textContent = v.text.split("\n").filter((l) => !/^\s*(#|\d+\s)/.test(l)).join("\n").trim();
  $("analysis-text").textContent = v.text;
  showImage("spectrogram", `/api/recordings/${v.id}/plot.png?strike=${r.strike}`);
  for (const part of ["recording", "modes", "residual"]) $(`dl-${part}`).href = `/api/recordings/${v.id}/part/${part}.wav`;
  const body = $("modes").querySelector("tbody");
  body.innerHTML = "";
  const top = Math.max(...r.modes.map((m) => m.amplitude));
  r.modes.forEach((m, i) => {
    const tr = document.createElement("tr");
    const db = 20 * Math.log10(m.amplitude / top);
    const sg = (r.sigma || [])[i];
    const pm = (x) => (x == null ? "–" : `±${x.toPrecision(2)}`);
    tr.innerHTML = `<td>${i + 1}</td><td>${m.freq_hz.toFixed(1)}</td><td class="sigma">${pm(sg && sg.freq_hz)}</td><td>${m.damping_per_s.toFixed(2)}</td><td class="sigma">${pm(sg && sg.damping_per_s)}</td><td>${db.toFixed(1)}</td>`;
    const td = document.createElement("td");
    const b = document.createElement("button");
    b.className = "small";
    b.textContent = "play";
    b.title = "hear this mode alone (normalized)";
    b.onclick = async () => play(await decode(`/api/recordings/${v.id}/mode/${i + 1}.wav`), `mode ${i + 1}`);
    td.appendChild(b);
    tr.appendChild(td);
    body.appendChild(tr);
  });
  audio.buffers = {};
  const [full, ...parts] = await Promise.all(
    ["audio", "part/recording.wav", "part/modes.wav", "part/residual.wav"].map((p) => decode(`/api/recordings/${v.id}/${p}`)),
  );
  audio.buffers = { recording: parts[0], modes: parts[1], residual: parts[2] };
  drawWave(full, r);
  updateButtons();
}

function drawWave(buf, r) {
  const c = $("wave");
  c.width = c.clientWidth * devicePixelRatio;
  const g = c.getContext("2d");
  const w = c.width, h = c.height;
  g.clearRect(0, 0, w, h);
  const x = buf.getChannelData(0);
  const per = Math.max(1, Math.floor(x.length / w));
  g.fillStyle = "#6b7a90";
  for (let i = 0; i < w; i++) {
    let lo = 0, hi = 0;
    for (let j = i * per; j < Math.min(x.length, (i + 1) * per); j++) { lo = Math.min(lo, x[j]); hi = Math.max(hi, x[j]); }
    g.fillRect(i, h / 2 - hi * h / 2, 1, Math.max(1, (hi - lo) * h / 2));
  }
  const dur = buf.duration;
  r.strikes_s.forEach((t, k) => {
    const px = (t / dur) * w;
    g.fillStyle = k + 1 === r.strike ? "#d6402f" : "#2f6fd6";
    g.fillRect(px - 1, 0, 3, h);
    g.fillText(String(k + 1), px + 4, 12);
  });
  c.onclick = async (ev) => {
    const t = (ev.offsetX / c.clientWidth) * dur;
    let best = 0;
    r.strikes_s.forEach((s, k) => { if (Math.abs(s - t) < Math.abs(r.strikes_s[best] - t)) best = k; });
    if (best + 1 === state.recording.report.strike) return;
    say(`analysing strike ${best + 1}…`);
    try {
      const v = await post(`/api/recordings/${state.recording.id}/analyze`, { strike: best + 1 });
      await showRecording(v);
      say(`strike ${best + 1}: ${v.report.modes.length} modes`);
    } catch (e) { say(e.message, !e.cancelled); }
  };
}

// ---------------------------------------------------------------- 2. object
const SHAPES = {
  bar: ["0.1,0.03,0.005", "length, width, height (m), centred on the origin"],
  box: ["0.1,0.08,0.06", "x, y, z (m), centred on the origin"],
  plate: ["0.2,0.15,0.004", "length, width, thickness (m), centred on the origin"],
  cylinder: ["0.03,0.1", "radius, height (m), centred on the origin"],
  sphere: ["0.03", "radius (m), centred on the origin"],
  bowl: ["0.06,0.004,0.04", "radius, wall thickness, depth (m); the rim is at z = 0"],
};

async function uploadMesh(file) {
  say(`checking ${file.name}…`);
  try {
    const v = await api(`/api/meshes?name=${encodeURIComponent(file.name)}&scale=${encodeURIComponent($("mesh-scale").value)}`, { method: "POST", body: file });
    state.mesh = v;
    $("mesh-check").hidden = false;
    $("mesh-check").textContent = v.text;
    say(`${v.name}: checked`);
  } catch (e) {
    state.mesh = null;
    say(e.message, !e.cancelled);
  }
}

async function solveObject() {
  const kind = $("kind").value;
  if (kind === "mesh" && !state.mesh) { say("choose a mesh file first", true); return; }
  const body = {
    kind,
    sizes_m: kind === "mesh" ? [] : $("sizes").value.split(",").map(Number),
    mesh: kind === "mesh" ? state.mesh.mesh : null,
    scale: Number($("mesh-scale").value),
    modes: Number($("nmodes").value),
    reference: $("reference").value,
  };
  $("solve").disabled = true;
  say("solving the modes…");
  try {
    const start = await post("/api/objects", body);
    const done = await runJob(start, "solve-job");
    const r = done.result;
    const what = kind === "mesh" ? state.mesh.name : `${kind} ${body.sizes_m.join(" × ")} m`;
    state.object = { id: r.object, report: r.report, kind, sizes: body.sizes_m, what };
    $("object").hidden = false;
    $("obj-title").textContent = `${what} · ${r.report.modes.length} modes from ${r.report.modes[0].freq_hz.toFixed(0)} Hz · ${r.report.surface_vertices} surface vertices`;
    $("obj-modes").textContent = r.text.split("\n").slice(0, 3).join(" · ");
    $("dl-model").href = `/api/objects/${r.object}/model.rmodal`;
    state.micFrom = null;
    const sel = $("shape-mode");
    sel.innerHTML = '<option value="">none</option>';
    r.report.modes.forEach((m, i) => sel.insertAdjacentHTML("beforeend", `<option value="${i + 1}">${i + 1}: ${m.freq_hz.toFixed(0)} Hz</option>`));
    await loadSurface();
    if (!state.hit) setHit(defaultHit());
    sayDone(`solved: ${r.report.modes.length} modes in ${done.elapsed_s.toFixed(1)} s`, done.warnings, r.report.warnings);
  } catch (e) {
    say(e.message, !e.cancelled);
  } finally {
    $("solve").disabled = false;
    updateButtons();
  }
}

function defaultHit() {
  // The top of the surface, off-centre: the highest vertex near a third of the length.
  const v = state.surface.vertices;
  let best = 0, score = -Infinity;
  for (let i = 0; i < v.length; i += 3) {
    const s = v[i + 2] - Math.abs(v[i] - state.surface.bbox_m[1][0] * 0.4) * 0.1;
    if (s > score) { score = s; best = i; }
  }
  return [v[best], v[best + 1], v[best + 2]];
}

async function hearMode() {
  const k = $("shape-mode").value;
  if (!k || !state.hit) return;
  const material = $("audition-material").value;
  try {
    const v = await post(`/api/objects/${state.object.id}/mode/${k}`, { material, hit_m: state.hit });
    const i = v.info;
    $("mode-info").textContent = `mode ${i.mode} in ${material}: ${i.freq_hz.toFixed(1)} Hz, d ${i.damping_per_s.toFixed(2)} 1/s, ${i.level_db.toFixed(1)} dB re the loudest mode at this hit (played normalized)`;
    play(await decode(`/api/renders/${v.render}.wav`), `object mode ${i.mode}`);
    sayDone(`object mode ${i.mode}: ${i.freq_hz.toFixed(1)} Hz`, i.note ? [i.note] : []);
  } catch (e) {
    say(e.message, !e.cancelled);
  }
}

async function loadSurface() {
  $("hear-mode").disabled = !$("shape-mode").value;
  const mode = $("shape-mode").value;
  state.surface = await api(`/api/objects/${state.object.id}/surface${mode ? `?mode=${mode}` : ""}`);
  drawObject();
}

const view = { yaw: -0.6, pitch: 0.5, drag: null, tris: [] };

function rotate(p) {
  const [x, y, z] = p;
  const cy = Math.cos(view.yaw), sy = Math.sin(view.yaw), cp = Math.cos(view.pitch), sp = Math.sin(view.pitch);
  const x1 = cy * x - sy * y, y1 = sy * x + cy * y;
  return [x1, cp * y1 - sp * z, sp * y1 + cp * z];
}

function drawObject() {
  const s = state.surface;
  if (!s) return;
  const c = $("view");
  const g = c.getContext("2d");
  const w = c.width, h = c.height;
  g.clearRect(0, 0, w, h);
  const [lo, hi] = s.bbox_m;
  const centre = [0, 1, 2].map((k) => (lo[k] + hi[k]) / 2);
  const size = Math.max(...[0, 1, 2].map((k) => hi[k] - lo[k])) || 1;
  const scale = 0.8 * Math.min(w, h) / size;
  const v = s.vertices;
  const n = v.length / 3;
  const screen = new Array(n);
  for (let i = 0; i < n; i++) {
    const r = rotate([v[3 * i] - centre[0], v[3 * i + 1] - centre[1], v[3 * i + 2] - centre[2]]);
    screen[i] = [w / 2 + r[0] * scale, h / 2 - r[2] * scale, r[1]];
  }
  const t = s.triangles;
  const tris = [];
  for (let k = 0; k < t.length; k += 3) {
    const a = screen[t[k]], b = screen[t[k + 1]], d = screen[t[k + 2]];
    const cross = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]);
    if (cross > 0) continue; // back face (screen y points down)
    tris.push({ k, depth: (a[2] + b[2] + d[2]) / 3, a, b, d, shade: Math.min(1, 0.35 + Math.abs(cross) / (scale * scale * 1e-4 + Math.abs(cross))) });
  }
  tris.sort((p, q) => q.depth - p.depth);
  for (const tr of tris) {
    let fill;
    if (s.displacement) {
      const u = (s.displacement[t[tr.k]] + s.displacement[t[tr.k + 1]] + s.displacement[t[tr.k + 2]]) / 3;
      fill = `hsl(${240 - 240 * u}, 75%, ${35 + 25 * tr.shade}%)`;
    } else {
      fill = `hsl(212, 18%, ${45 + 35 * tr.shade}%)`;
    }
    g.fillStyle = fill;
    g.strokeStyle = fill;
    g.beginPath();
    g.moveTo(tr.a[0], tr.a[1]); g.lineTo(tr.b[0], tr.b[1]); g.lineTo(tr.d[0], tr.d[1]);
    g.closePath(); g.fill(); g.stroke();
  }
  view.tris = tris;
  view.screen = { centre, scale, w, h };
  if (state.hit) {
    const r = rotate([state.hit[0] - centre[0], state.hit[1] - centre[1], state.hit[2] - centre[2]]);
    g.fillStyle = "#d6402f";
    g.beginPath();
    g.arc(w / 2 + r[0] * scale, h / 2 - r[2] * scale, 5, 0, 2 * Math.PI);
    g.fill();
  }
  if (state.mic && state.micFrom) {
    // The microphone is usually off the picture: a line from the clicked point towards it,
    // ending in a dot at the microphone or at the picture's edge.
    const at = (q) => { const r = rotate([q[0] - centre[0], q[1] - centre[1], q[2] - centre[2]]); return [w / 2 + r[0] * scale, h / 2 - r[2] * scale]; };
    const a = at(state.micFrom), b = at(state.mic);
    let t = 1;
    for (const [x0, dx, lim] of [[a[0], b[0] - a[0], w], [a[1], b[1] - a[1], h]]) {
      if (x0 + t * dx > lim - 8) t = Math.min(t, (lim - 8 - x0) / dx);
      if (x0 + t * dx < 8) t = Math.min(t, (8 - x0) / dx);
    }
    t = Math.max(0, t);
    const e = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
    g.strokeStyle = "#2f6fd6";
    g.lineWidth = 2;
    g.beginPath(); g.moveTo(a[0], a[1]); g.lineTo(e[0], e[1]); g.stroke();
    g.lineWidth = 1;
    g.fillStyle = "#2f6fd6";
    g.beginPath(); g.arc(e[0], e[1], 5, 0, 2 * Math.PI); g.fill();
    g.fillText(t < 1 ? "mic →" : "mic", e[0] + 8, e[1] - 6);
  }
}

function pick(px, py) {
  // The nearest front triangle under the cursor, and the point on it.
  let found = null;
  for (let i = view.tris.length - 1; i >= 0; i--) {
    const { a, b, d, k } = view.tris[i];
    const det = (b[1] - d[1]) * (a[0] - d[0]) + (d[0] - b[0]) * (a[1] - d[1]);
    const l1 = ((b[1] - d[1]) * (px - d[0]) + (d[0] - b[0]) * (py - d[1])) / det;
    const l2 = ((d[1] - a[1]) * (px - d[0]) + (a[0] - d[0]) * (py - d[1])) / det;
    const l3 = 1 - l1 - l2;
    if (l1 >= 0 && l2 >= 0 && l3 >= 0) { found = { k, l: [l1, l2, l3] }; break; }
  }
  if (!found) return null;
  const s = state.surface;
  const p = [0, 0, 0];
  const corner = [];
  for (let j = 0; j < 3; j++) {
    const vi = s.triangles[found.k + j];
    corner.push([0, 1, 2].map((c) => s.vertices[3 * vi + c]));
    for (let c = 0; c < 3; c++) p[c] += found.l[j] * s.vertices[3 * vi + c];
  }
  // The face's normal, turned towards the viewer (the side that was clicked).
  const e1 = [0, 1, 2].map((c) => corner[1][c] - corner[0][c]);
  const e2 = [0, 1, 2].map((c) => corner[2][c] - corner[0][c]);
  let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
  const len = Math.hypot(...n) || 1;
  n = n.map((x) => x / len);
  if (rotate(n)[1] > 0) n = n.map((x) => -x);
  return { p, n };
}

// A click with "the microphone" chosen: the point that far out along the clicked face's normal.
function setMic(p, n) {
  const d = Number($("mic-distance").value);
  if (!(d > 0)) { say("the microphone's distance is a positive number of metres", true); return; }
  state.mic = p.map((x, c) => x + d * n[c]);
  state.micFrom = p;
  $("mic").value = state.mic.map((x) => x.toFixed(4)).join(",");
  drawObject();
  say(`microphone at ${$("mic").value} m, ${d} m out from the surface`);
}

function setHit(p) {
  state.hit = p;
  $("hit").value = p.map((x) => x.toFixed(4)).join(",");
  drawObject();
  updateButtons();
}

// ---------------------------------------------------------------- 3. material
async function estimate() {
  $("estimate").disabled = true;
  say("estimating the material…");
  $("estimate-refused").hidden = true;
  // An earlier estimate (of another object, hit or recording) is not shown beside this one's
  // outcome, nor saved in its place.
  $("estimated").hidden = true;
  state.estimate = null;
  try {
    const start = await post("/api/estimate", {
      recording: state.recording.id,
      object: state.object.id,
      hit_m: state.hit,
      allow_implausible: $("keep-implausible").checked,
    });
    const done = await runJob(start, "estimate-job");
    const r = done.result;
    state.estimate = r;
    $("estimated").hidden = false;
    $("estimate-report").textContent = [r.text, ...r.notes.map((n) => `note: ${n}`)].join("\n");
    showImage("estimate-plot", `/api/estimates/${r.estimate}/plot.png`);
    $("save-name").value = r.material.name;
    $("material-download").href = `/api/estimates/${r.estimate}/material.json`;
    sayDone(`estimated in ${done.elapsed_s.toFixed(1)} s`, done.warnings, r.info.warnings);
  } catch (e) {
    say(e.message, !e.cancelled);
    // A refused fit still shows its report (what was paired, how much of the loudness).
    if (e.report) {
      $("estimate-refused").textContent = `not kept:\n${e.report}`;
      $("estimate-refused").hidden = false;
    }
  } finally {
    updateButtons();
  }
}

async function save() {
  const name = $("save-name").value.trim();
  try {
    await post("/api/materials", { estimate: state.estimate.estimate, name, replace: $("replace").checked });
    say(`saved ${name} to the library`);
    await loadLibrary(name);
  } catch (e) {
    say(e.status === 409 ? `${e.message}: tick “replace” to overwrite it, or choose another name` : e.message, true);
  }
}

// ---------------------------------------------------------------- 4. audition
async function render() {
  $("render").disabled = true;
  const material = $("audition-material").value;
  say(`rendering ${material}…`);
  try {
    const micText = $("mic").value.trim();
    const mic = micText ? micText.split(",").map(Number) : null;
    if (mic && !(mic.length === 3 && mic.every(Number.isFinite))) throw new Error("the microphone is x,y,z in metres (or empty)");
    const start = await post("/api/render", {
      material, object: state.object.id, hit_m: state.hit, mic_m: mic,
      impactor: $("impactor").value, impactor_radius_m: Number($("impactor-radius").value) / 1000,
      speed_m_s: Number($("speed").value), duration_s: Number($("duration").value),
    });
    const done = await runJob(start, "render-job");
    const r = done.result;
    const item = { id: r.render, material, object: state.object.what, hit: state.hit.slice(), info: r.info };
    state.renders.push(item);
    addRenderRow(item);
    play(await decode(`/api/renders/${r.render}.wav`), `render ${r.render}`);
    sayDone(`rendered ${material}${r.notes.length ? ` (${r.notes.join("; ")})` : ""}`, done.warnings, r.info.warnings);
  } catch (e) {
    say(e.message, !e.cancelled);
  } finally {
    updateButtons();
  }
}

function addRenderRow(item) {
  const tr = document.createElement("tr");
  tr.dataset.render = item.id;
  const peak = 20 * Math.log10(item.info.peak);
  cells(tr, [String(state.renders.length), item.material, item.object, item.hit.map((x) => x.toFixed(3)).join(", "), `${peak.toFixed(1)} dBFS`, "–"]);
  tr.lastChild.className = "distance";
  const td = document.createElement("td");
  const b = document.createElement("button");
  b.className = "small";
  b.textContent = "play";
  b.onclick = async () => play(await decode(`/api/renders/${item.id}.wav`), `render ${item.id}`);
  const cmp = document.createElement("button");
  cmp.className = "small";
  cmp.textContent = "compare";
  cmp.title = "log-mel distance to the recording (resound compare)";
  cmp.onclick = async () => {
    try {
      const d = await api(`/api/compare?recording=${state.recording.id}&render=${item.id}`);
      tr.querySelector(".distance").textContent = d.distance.toFixed(3);
      $("comparison").hidden = false;
      showImage("cmp-recording", `/api/recordings/${state.recording.id}/plot.png?strike=${state.recording.report.strike}`);
      showImage("cmp-render", `/api/renders/${item.id}/plot.png`);
      $("cmp-render-caption").textContent = `render ${item.id}: ${item.material} on ${item.object} (log-mel distance ${d.distance.toFixed(3)})`;
    } catch (e) { say(e.message, !e.cancelled); }
  };
  const a = document.createElement("a");
  a.href = `/api/renders/${item.id}.wav`;
  a.textContent = "WAV";
  a.download = `render-${item.id}.wav`;
  td.append(b, " ", cmp, " ", a);
  tr.appendChild(td);
  $("renders").querySelector("tbody").appendChild(tr);
}

// ---------------------------------------------------------------- 5. scene preview
// The page writes a scene file's document (the same fields as a scene TOML) and the library
// checks and renders it.
function dropScene() {
  const n = Math.max(1, Math.min(12, Number($("drop-count").value)));
  const h = Number($("drop-height").value);
  const listener = $("drop-listener").value.split(",").map(Number);
  const shapes = { sphere: { sphere: 0.02 }, box: { box: [0.04, 0.03, 0.02] }, plate: { plate: [0.08, 0.05, 0.004] } };
  const shape = shapes[$("drop-shape").value];
  const bodies = [{
    name: "table", fixed: true, shape: { box: [1.0, 0.04, 0.7] }, material: $("drop-table").value,
    density: 700, position: [0, -0.02, 0], modes: 30,
  }];
  for (let i = 0; i < n; i++) {
    const x = (i - (n - 1) / 2) * 0.09;
    bodies.push({
      name: `object ${i + 1}`, shape, material: $("drop-material").value, density: 2700,
      position: [x, h + 0.03 * i, 0.05 * ((i % 3) - 1)], rotation: [17 * i, 29 * i, 0],
      restitution: 0.4, modes: 20,
    });
  }
  return { duration: 2.5, sample_rate: 48000, seed: 1, stereo: true, listener: { position: listener }, body: bodies };
}

async function renderScene() {
  $("drop").disabled = true;
  say("rendering the drop…");
  try {
    const start = await api("/api/scene", { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(dropScene()) });
    const done = await runJob(start, "scene-job");
    const r = done.result;
    $("scene-result").hidden = false;
    $("scene-text").textContent = r.text;
    $("scene-wav").href = `/api/renders/${r.render}.wav`;
    drawTimeline(r.events, r.summary);
    state.scene = r;
    play(await decode(`/api/renders/${r.render}.wav`), `scene ${r.render}`);
    sayDone(`rendered the drop: ${r.events.length} events in ${done.elapsed_s.toFixed(1)} s`, done.warnings, r.summary.warnings);
  } catch (e) {
    say(e.message, !e.cancelled);
  } finally {
    $("drop").disabled = false;
  }
}

function drawTimeline(events, summary) {
  const c = $("timeline");
  c.width = c.clientWidth * devicePixelRatio;
  const g = c.getContext("2d");
  const w = c.width, h = c.height;
  g.clearRect(0, 0, w, h);
  const pairs = [...new Set(events.map((e) => e.bodies.join(" · ")))];
  const dur = Math.max(0.1, ...events.map((e) => e.time_s), summary.duration_s || 0);
  const row = (h - 20) / Math.max(1, pairs.length);
  const top = Math.max(1e-12, ...events.filter((e) => e.kind === "impact").map((e) => e.force));
  g.font = "11px system-ui";
  pairs.forEach((p, i) => { g.fillStyle = "#5b6573"; g.fillText(p, 4, 12 + i * row); });
  for (const e of events) {
    const x = 4 + (e.time_s / dur) * (w - 8);
    const y0 = (pairs.indexOf(e.bodies.join(" · ")) + 1) * row;
    if (e.kind === "impact") {
      g.fillStyle = "#d6402f";
      const hh = Math.max(2, (row - 14) * Math.sqrt(e.force / top));
      g.fillRect(x - 1, y0 - hh, 2, hh);
    } else {
      g.fillStyle = e.kind === "rolling" ? "#2f6fd6" : "#1c9a5b";
      g.fillRect(x, y0 - 4, 1.5, 3);
    }
  }
  g.fillStyle = "#5b6573";
  g.fillText(`${dur.toFixed(2)} s`, w - 40, h - 4);
  g.fillText("0 s", 4, h - 4);
}

// ---------------------------------------------------------------- 6. library
async function loadLibrary(select) {
  const l = await api("/api/materials");
  const body = $("library").querySelector("tbody");
  body.innerHTML = "";
  const sel = $("audition-material");
  const keep = select || sel.value;
  const dropKeep = $("drop-material").value || "metal";
  sel.innerHTML = "";
  $("drop-material").innerHTML = "";
  for (const [m, origin] of l.materials) {
    const tr = document.createElement("tr");
    cells(tr, [m.name, m.alpha.toExponential(3), m.beta.toExponential(3), m.gamma.toExponential(3), m.sigma.toExponential(3), origin]);
    const td = document.createElement("td");
    const a = document.createElement("a");
    a.href = `/api/materials/${encodeURIComponent(m.name)}`;
    a.textContent = "JSON";
    a.download = `${m.name}.json`;
    td.appendChild(a);
    if (origin !== "builtin" && origin !== "preset") {
      const ren = document.createElement("button");
      ren.className = "small";
      ren.textContent = "rename";
      ren.onclick = async () => {
        const to = prompt(`New name for ${m.name}`, m.name);
        if (!to || to === m.name) return;
        try {
          await post(`/api/materials/${encodeURIComponent(m.name)}/rename`, { to, replace: false });
          say(`renamed ${m.name} to ${to}`);
          await loadLibrary(to);
        } catch (e) { say(e.status === 409 ? `${e.message}: delete it first or choose another name` : e.message, true); }
      };
      td.append(" ", ren);
      const del = document.createElement("button");
      del.className = "small";
      del.textContent = "delete";
      del.onclick = async () => {
        if (!confirm(`Delete ${m.name} from the library?`)) return;
        try {
          await api(`/api/materials/${encodeURIComponent(m.name)}`, { method: "DELETE" });
          say(`deleted ${m.name}`);
          await loadLibrary();
        } catch (e) { say(e.message, !e.cancelled); }
      };
      td.append(" ", del);
    }
    tr.appendChild(td);
    body.appendChild(tr);
    sel.add(new Option(m.name));
    $("drop-material").add(new Option(m.name));
  }
  if ([...sel.options].some((o) => o.value === keep)) sel.value = keep;
  if ([...$("drop-material").options].some((o) => o.value === dropKeep)) $("drop-material").value = dropKeep;
  showKept(l.files || []);
}

// Table cells from text (names come from the library: never parsed as HTML).
function cells(tr, texts) {
  for (const t of texts) {
    const td = document.createElement("td");
    td.textContent = t;
    tr.appendChild(td);
  }
}

// The statistics and grain files kept in the library: download or delete each.
function showKept(files) {
  const body = $("kept").querySelector("tbody");
  body.innerHTML = "";
  $("kept-empty").hidden = files.length > 0;
  for (const f of files) {
    const tr = document.createElement("tr");
    cells(tr, [f.name, f.kind, f.summary, String(f.bytes), f.updated]);
    const td = document.createElement("td");
    const url = `/api/library/files/${f.kind}/${encodeURIComponent(f.name)}`;
    const a = document.createElement("a");
    a.href = url;
    a.textContent = "download";
    td.appendChild(a);
    const del = document.createElement("button");
    del.className = "small";
    del.textContent = "delete";
    del.onclick = async () => {
      if (!confirm(`Delete the ${f.kind} file ${f.name} from the library?`)) return;
      try {
        await api(url, { method: "DELETE" });
        say(`deleted ${f.kind} ${f.name}`);
        await loadLibrary();
      } catch (e) { say(e.message, true); }
    };
    td.append(" ", del);
    tr.appendChild(td);
    body.appendChild(tr);
  }
}

function updateButtons() {
  $("estimate").disabled = !(state.recording && state.object && state.hit);
  $("render").disabled = !(state.object && state.hit);
}

// ---------------------------------------------------------------- wiring
// A picture that fails to load says why (the API's message) instead of showing a broken image.
function explainImages() {
  document.querySelectorAll("img").forEach((img) => {
    img.addEventListener("error", async () => {
      if (!img.src) return;
      try { await api(img.src); } catch (e) { say(`${img.alt}: ${e.message}`, true); }
    });
  });
}

async function start() {
  explainImages();
  const info = await api("/api/info");
  $("version").textContent = `v${info.version}`;
  for (const s of info.samples) $("sample").insertAdjacentHTML("beforeend", `<option>${s}</option>`);
  for (const k of info.primitives) $("kind").insertAdjacentHTML("beforeend", `<option>${k}</option>`);
  $("kind").value = "bar";
  $("shape-hint").textContent = SHAPES.bar[1];
  $("kind").insertAdjacentHTML("beforeend", '<option value="mesh">mesh (upload)</option>');
  $("kind").onchange = () => {
    const mesh = $("kind").value === "mesh";
    document.querySelectorAll(".for-mesh").forEach((e) => { e.hidden = !mesh; });
    document.querySelectorAll(".for-primitive").forEach((e) => { e.hidden = mesh; });
    $("mesh-check").hidden = !mesh || !state.mesh;
    const [sizes, hint] = SHAPES[$("kind").value] || ["", "a closed surface; its coordinates times the unit scale are metres"];
    if (!mesh) $("sizes").value = sizes;
    $("shape-hint").textContent = hint;
  };
  $("mesh-file").onchange = (e) => e.target.files[0] && uploadMesh(e.target.files[0]);
  $("import").onchange = async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    try {
      const r = await api(`/api/materials/import?replace=${$("import-replace").checked}`, { method: "POST", body: f });
      say(`imported ${r.imported}`);
      await loadLibrary(r.imported);
    } catch (err) { say(err.status === 409 ? `${err.message}: tick “replace” to overwrite it` : err.message, true); }
    e.target.value = "";
  };
  $("keep-file").onchange = async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    const name = $("keep-name").value.trim() || f.name.replace(/(\.stats)?\.json$|\.grains$/i, "");
    try {
      const r = await api(`/api/library/files?name=${encodeURIComponent(name)}&replace=${$("keep-replace").checked}`, { method: "POST", body: f });
      say(`kept ${r.kind} ${r.name}: ${r.summary}`);
      await loadLibrary();
    } catch (err) { say(err.status === 409 ? `${err.message}: tick “replace” to overwrite it` : err.message, true); }
    e.target.value = "";
  };
  $("open-sample").onclick = () => openRecording(post(`/api/samples/${encodeURIComponent($("sample").value)}`, {}));
  const upload = (file) => {
    if (file.size > info.max_upload_bytes) {
      say(`${file.name} is ${(file.size / 1e6).toFixed(1)} MB; the studio takes at most ${(info.max_upload_bytes / 1e6).toFixed(0)} MB`, true);
      return;
    }
    openRecording(api(`/api/recordings?name=${encodeURIComponent(file.name)}`, { method: "POST", body: file }));
  };
  $("file").onchange = (e) => e.target.files[0] && upload(e.target.files[0]);
  const drop = $("drop");
  drop.ondragover = (e) => { e.preventDefault(); drop.classList.add("over"); };
  drop.ondragleave = () => drop.classList.remove("over");
  drop.ondrop = (e) => { e.preventDefault(); drop.classList.remove("over"); e.dataTransfer.files[0] && upload(e.dataTransfer.files[0]); };
  document.querySelectorAll("button.ab").forEach((b) => {
    b.onclick = () => {
      const buf = audio.buffers[b.dataset.part];
      if (buf) play(buf, b.dataset.part, audio.source ? position() : 0);
    };
  });
  $("stop").onclick = stop;
  $("solve").onclick = solveObject;
  $("shape-mode").onchange = loadSurface;
  $("hear-mode").onclick = hearMode;
  const v = $("view");
  v.onmousedown = (e) => { view.drag = { x: e.offsetX, y: e.offsetY, yaw: view.yaw, pitch: view.pitch, moved: false }; };
  v.onmousemove = (e) => {
    if (!view.drag) return;
    const dx = e.offsetX - view.drag.x, dy = e.offsetY - view.drag.y;
    if (Math.abs(dx) + Math.abs(dy) > 3) view.drag.moved = true;
    view.yaw = view.drag.yaw + dx * 0.01;
    view.pitch = Math.max(-1.5, Math.min(1.5, view.drag.pitch + dy * 0.01));
    drawObject();
  };
  v.onmouseup = (e) => {
    const moved = view.drag && view.drag.moved;
    view.drag = null;
    if (moved) return;
    const sx = v.width / v.clientWidth;
    const hit = pick(e.offsetX * sx, e.offsetY * sx);
    if (!hit) return;
    if (document.querySelector('input[name="click-sets"]:checked').value === "mic") setMic(hit.p, hit.n);
    else setHit(hit.p);
  };
  $("mic").onchange = () => { state.micFrom = null; drawObject(); };
  $("hit").onchange = () => {
    const p = $("hit").value.split(",").map(Number);
    if (p.length === 3 && p.every(Number.isFinite)) setHit(p);
    else say("the hit point is x,y,z in metres", true);
  };
  $("estimate").onclick = estimate;
  $("save").onclick = save;
  $("render").onclick = render;
  $("drop").onclick = renderScene;
  await loadLibrary();
  say("ready");
}

window.studio = { state, level, position, playing: () => audio.part, pick, view };
start().catch((e) => say(e.message, !e.cancelled));
