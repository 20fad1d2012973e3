// The viewer's page: one HTML document with its style and script inline (no CDN, no files to
// install), served from the binary.
//
// The script polls /targets.json and /status.json four times a second, draws the latency plot
// on a canvas, and measures the display latency: on every animation frame it reads the stamp
// in the top-left corner of the stream image (display/frame_stamp.hpp: 64 cells of 8x8 px,
// capture time in 100 us units, seq, checksum); when the stamp changes, the new image is on
// the page, and now minus its capture time is the capture-to-pixels latency. The samples go to
// POST /display-latency once a second and are kept in window.thermovis for tests.
#include "web_server.hpp"

namespace thermovis::view {

const char* const kPageHtml = R"PAGE(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>thermovis: live fusion ranging</title>
<style>
  body { background: #111; color: #ddd; font: 14px/1.4 sans-serif; margin: 12px; }
  h1 { font-size: 16px; margin: 0 0 8px 0; font-weight: normal; }
  #layout { display: flex; gap: 16px; align-items: flex-start; flex-wrap: wrap; }
  #left { flex: 3 1 640px; }
  #right { flex: 1 1 340px; }
  #stream { width: 100%; background: #000; display: block; image-rendering: auto; }
  .views button { background: #333; color: #ddd; border: 1px solid #555; padding: 4px 10px;
    margin-right: 4px; cursor: pointer; }
  .views button.active { background: #2a6; color: #fff; }
  table { border-collapse: collapse; width: 100%; margin-bottom: 12px; }
  th, td { text-align: left; padding: 2px 6px; border-bottom: 1px solid #333; }
  td.num { text-align: right; font-variant-numeric: tabular-nums; }
  .ok { color: #6d6; } .starting { color: #dd6; } .degraded { color: #fa4; }
  .failed, .stopping, .silent { color: #f55; }
  .band-visible { color: #ee4; } .band-infrared { color: #f93; } .band-fused { color: #6f6; }
  #latency { width: 100%; height: 160px; background: #000; display: block; }
  .figure { font-size: 20px; }
  .small { color: #999; font-size: 12px; }
</style>
</head>
<body>
<h1>thermovis &mdash; live fusion ranging</h1>
<div id="layout">
  <div id="left">
    <div class="views">
      <button data-view="fused" class="active">fused</button>
      <button data-view="visible">visible</button>
      <button data-view="infrared">infrared</button>
      <button data-view="side">side by side</button>
      <span class="small" id="stream-state">connecting&hellip;</span>
    </div>
    <img id="stream" alt="fusion-ranging image">
  </div>
  <div id="right">
    <div>capture to range <span class="figure" id="latency-p50">-</span>
      <span class="small">p50 over the plot</span>;
      on this page <span class="figure" id="display-latency">-</span>
      <span class="small">p50 capture to pixels</span></div>
    <canvas id="latency" width="400" height="160"></canvas>
    <div class="small" id="counters"></div>
    <h1>Targets <span class="small" id="targets-frame"></span></h1>
    <table id="targets">
      <thead><tr><th>#</th><th>class</th><th>distance</th><th>band</th><th>points</th></tr></thead>
      <tbody></tbody>
    </table>
    <h1>Services</h1>
    <table id="health">
      <thead><tr><th>service</th><th>state</th><th>frames</th><th>errors</th><th>DEADLINE</th></tr></thead>
      <tbody></tbody>
    </table>
  </div>
</div>
<script>
"use strict";
const tv = window.thermovis = {
  view: "fused", framesShown: 0, lastStamp: null, displayLatencyMs: [], pending: [],
  targets: null, status: null, errors: 0
};
const img = document.getElementById("stream");

function setView(view) {
  tv.view = view;
  for (const b of document.querySelectorAll(".views button"))
    b.classList.toggle("active", b.dataset.view === view);
  img.src = "/stream.mjpg?view=" + encodeURIComponent(view) + "&t=" + Date.now();
}
for (const b of document.querySelectorAll(".views button"))
  b.addEventListener("click", () => setView(b.dataset.view));
img.addEventListener("error", () => {
  document.getElementById("stream-state").textContent = "stream lost, reconnecting";
  setTimeout(() => setView(tv.view), 1000);
});

// The stamp in the image's top-left corner (frame_stamp.hpp).
const probe = document.createElement("canvas");
probe.width = 512; probe.height = 8;
const probeCtx = probe.getContext("2d", { willReadFrequently: true });
function readStamp() {
  if (!img.complete || img.naturalWidth < 512) return null;
  try {
    probeCtx.drawImage(img, 0, 0, 512, 8, 0, 0, 512, 8);
  } catch (e) { return null; }
  const d = probeCtx.getImageData(0, 0, 512, 8).data;
  const bytes = [0, 0, 0, 0, 0, 0, 0, 0];
  for (let bit = 0; bit < 64; ++bit) {
    let level = 0;
    for (let y = 2; y < 6; ++y)
      for (let x = bit * 8 + 2; x < bit * 8 + 6; ++x) {
        const i = (y * 512 + x) * 4;
        level += (d[i] + d[i + 1] + d[i + 2]) / 3;
      }
    if (level / 16 >= 128) bytes[bit >> 3] |= 1 << (7 - (bit & 7));
  }
  let sum = 0;
  for (let i = 0; i < 7; ++i) sum += bytes[i];
  if ((sum & 255) !== bytes[7]) return null;
  let units = 0;  // 48 bits: exact in a double
  for (let i = 0; i < 6; ++i) units = units * 256 + bytes[i];
  if (units === 0) return null;
  return { units: units, seq: bytes[6] };
}

let lastRaf = 0;
function checkFrame() {
  const stamp = readStamp();
  if (stamp && (!tv.lastStamp || stamp.units !== tv.lastStamp.units)) {
    const shownMs = performance.timeOrigin + performance.now();
    tv.lastStamp = stamp;
    tv.framesShown += 1;
    tv.displayLatencyMs.push(shownMs - stamp.units / 10);
    if (tv.displayLatencyMs.length > 500) tv.displayLatencyMs.shift();
    tv.pending.push([stamp.units, Math.round(shownMs * 1000)]);
    document.getElementById("stream-state").textContent = "live";
  }
}
function onAnimationFrame() {
  lastRaf = performance.now();
  checkFrame();
  requestAnimationFrame(onAnimationFrame);
}
requestAnimationFrame(onAnimationFrame);
// Where animation frames do not run (a hidden tab), a timer looks instead.
setInterval(() => { if (performance.now() - lastRaf > 100) checkFrame(); }, 10);

function median(values) {
  if (!values.length) return NaN;
  const s = values.slice().sort((a, b) => a - b);
  return s[Math.floor(s.length / 2)];
}
function fmt(v, digits) { return Number.isFinite(v) ? v.toFixed(digits) : "-"; }

setInterval(() => {
  const p50 = median(tv.displayLatencyMs.slice(-100));
  document.getElementById("display-latency").textContent = fmt(p50, 1) + " ms";
  if (!tv.pending.length) return;
  const samples = tv.pending; tv.pending = [];
  fetch("/display-latency", { method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ samples: samples }) }).catch(() => { tv.errors += 1; });
}, 1000);

function cell(row, text, cls) {
  const td = row.insertCell();
  td.textContent = text;
  if (cls) td.className = cls;
  return td;
}

function showTargets(t) {
  tv.targets = t;
  document.getElementById("targets-frame").textContent =
    "frame " + t.frame_seq + (t.note ? " (" + t.note + ")" : "");
  const body = document.querySelector("#targets tbody");
  body.textContent = "";
  const sorted = t.targets.slice().sort((a, b) =>
    (a.ranged ? a.distance_m : 1e9) - (b.ranged ? b.distance_m : 1e9));
  for (const target of sorted) {
    const row = body.insertRow();
    row.className = "target";
    row.dataset.id = target.id;
    row.dataset.label = target.label;
    row.dataset.distanceM = target.ranged ? target.distance_m : "";
    row.dataset.sigmaM = target.sigma_m;
    cell(row, target.id, "num");
    cell(row, target.label);
    cell(row, target.ranged ? target.distance_m.toFixed(2) + " \u00b1 " + target.sigma_m.toFixed(2) + " m"
                            : "no range", "num");
    cell(row, target.band, "band-" + target.band);
    cell(row, target.points, "num");
  }
}

function showHealth(s) {
  const body = document.querySelector("#health tbody");
  body.textContent = "";
  for (const h of s.health) {
    const row = body.insertRow();
    cell(row, h.service);
    const silent = h.age_s > 5;
    cell(row, silent ? "silent " + h.age_s.toFixed(0) + " s" : h.state, silent ? "silent" : h.state)
      .title = h.message;
    cell(row, h.frames, "num");
    cell(row, h.errors, "num");
    cell(row, h.deadline_misses, "num");
  }
  document.getElementById("counters").textContent =
    s.frames + " frames ranged, " + s.over_deadline + " over " + s.deadline_ms + " ms, " +
    s.deadline_misses + " DEADLINE misses";
}

function drawLatency(s) {
  const canvas = document.getElementById("latency");
  const w = canvas.width, h = canvas.height, ctx = canvas.getContext("2d");
  ctx.fillStyle = "#000"; ctx.fillRect(0, 0, w, h);
  const values = s.latency.map(p => p[1]);
  const top = Math.max(2.5 * s.deadline_ms, ...values) * 1.1;
  const x = age => w * (1 + age / s.history_s), y = ms => h - 14 - (h - 24) * ms / top;
  ctx.strokeStyle = "#333"; ctx.fillStyle = "#888"; ctx.font = "10px sans-serif";
  for (let ms = 0; ms <= top; ms += top > 200 ? 50 : 10) {
    ctx.beginPath(); ctx.moveTo(0, y(ms)); ctx.lineTo(w, y(ms)); ctx.stroke();
    ctx.fillText(ms + " ms", 2, y(ms) - 2);
  }
  ctx.fillText("-" + s.history_s + " s", 2, h - 2); ctx.fillText("now", w - 22, h - 2);
  ctx.strokeStyle = "#f44"; ctx.setLineDash([6, 4]); ctx.beginPath();
  ctx.moveTo(0, y(s.deadline_ms)); ctx.lineTo(w, y(s.deadline_ms)); ctx.stroke();
  ctx.setLineDash([]);
  ctx.fillStyle = "#f44"; ctx.fillText(s.deadline_ms + " ms", w - 40, y(s.deadline_ms) - 3);
  ctx.strokeStyle = "#4cf"; ctx.beginPath();
  s.latency.forEach((p, i) => i ? ctx.lineTo(x(p[0]), y(p[1])) : ctx.moveTo(x(p[0]), y(p[1])));
  ctx.stroke();
  document.getElementById("latency-p50").textContent = fmt(median(values), 1) + " ms";
}

async function poll() {
  try {
    const [t, s] = await Promise.all([fetch("/targets.json").then(r => r.json()),
                                      fetch("/status.json").then(r => r.json())]);
    showTargets(t);
    if (s.health) { tv.status = s; showHealth(s); drawLatency(s); }
  } catch (e) { tv.errors += 1; }
  setTimeout(poll, 250);
}
setView("fused");
poll();
</script>
</body>
</html>
)PAGE";

}  // namespace thermovis::view
