// The live view: polls /api/state (schema stend.live/1, docs/live-view.md) once a second and
// draws it. Read-only; everything comes from the stend process that serves this page.
"use strict";
const POLL_MS = 1000;
const RAD_TO_DEG = 180 / Math.PI;
const COLORS = ["#d62728", "#2ca02c", "#1f77b4"];  // x, y, z
let charts = null;
let updates = 0;

function duration(s) {
  if (s === null || !isFinite(s)) return "?";
  const t = Math.round(s);
  const h = Math.floor(t / 3600), m = Math.floor(t / 60) % 60, sec = t % 60;
  const two = (v) => String(v).padStart(2, "0");
  if (t >= 3600) return `${h}h${two(m)}m${two(sec)}s`;
  if (t >= 60) return `${m}m${two(sec)}s`;
  return `${sec}s`;
}
function num(v, digits) { return v === null || v === undefined || !isFinite(v) ? "–" : v.toFixed(digits); }
function rows(el, pairs) {
  el.replaceChildren(...pairs.map(([k, v]) => {
    const tr = document.createElement("tr");
    const a = document.createElement("td"); a.textContent = k;
    const b = document.createElement("td"); b.textContent = v;
    tr.append(a, b);
    return tr;
  }));
}
const AXES = ["x", "y", "z"];
function sixRows(v) {
  const r = [];
  for (let i = 0; i < 3; i++) r.push([`f${AXES[i]} (m/s²)`, num(v[i], 4)]);
  for (let i = 0; i < 3; i++) r.push([`ω${AXES[i]} (deg/s)`, num(v[i + 3] === null ? null : v[i + 3] * RAD_TO_DEG, 4)]);
  return r;
}

function makeChart(el, labels, colors, yLabel) {
  const width = Math.min(620, Math.max(320, window.innerWidth / 2 - 60));
  const series = [{ label: "t (s)" }].concat(labels.map((l, i) => ({ label: l, stroke: colors[i], width: 1.5 })));
  return new uPlot({ width: width, height: 220, series: series, scales: { x: { time: false } },
                     axes: [{ label: "run time (s)" }, { label: yLabel }], legend: { show: true } },
                   [[]].concat(labels.map(() => [])), el);
}
function setupCharts() {
  if (typeof uPlot === "undefined") { document.getElementById("no-charts").hidden = false; return null; }
  return {
    accel: makeChart(document.getElementById("chart-accel"), ["fx", "fy", "fz"], COLORS, "m/s²"),
    gyro: makeChart(document.getElementById("chart-gyro"), ["ωx", "ωy", "ωz"], COLORS, "deg/s"),
    temp: makeChart(document.getElementById("chart-temp"), ["setpoint", "air", "die"], ["#888", "#1f77b4", "#ff7f0e"], "°C"),
  };
}

function draw(s) {
  document.getElementById("run").textContent = s.run;
  const st = document.getElementById("status");
  st.textContent = s.status + (s.message ? " — " + s.message : "");
  st.className = "status " + s.status;
  const pct = Math.round(100 * (s.fraction_done || 0));
  document.getElementById("bar-fill").style.width = pct + "%";
  const left = s.status === "running" && s.remaining_s !== null ? ` · ~${duration(s.remaining_s)} left` : "";
  document.getElementById("progress-text").textContent =
    `${s.fraction_done === null ? "?" : pct} %${left} · run time ${duration(s.run_time_s)} · ${s.samples} samples`;
  const item = s.item_count > 0 ? ` · ${s.step_kind === "rates" ? "rate" : "orientation"} ${s.item}/${s.item_count}` : "";
  document.getElementById("step").textContent =
    s.step_count > 0 ? `step ${s.step}/${s.step_count} ${s.step_kind}${item}` : "procedure not known";
  document.getElementById("phase").textContent = (s.step_label ? `“${s.step_label}” · ` : "") + s.phase;
  rows(document.getElementById("chamber"), [["setpoint", num(s.setpoint_c, 2)], ["air", num(s.air_c, 2)], ["die", num(s.die_c, 2)]]);
  const angles = Object.entries(s.table_deg).map(([k, v]) => [k, num(v, 3)]);
  rows(document.getElementById("table"), angles.length ? angles : [["no table", ""]]);
  rows(document.getElementById("latest"), sixRows(s.latest));
  document.getElementById("segment-head").textContent =
    s.segment.id >= 0 ? `segment #${s.segment.id}, ${s.segment.samples} samples` : "no segment open";
  rows(document.getElementById("segment"), sixRows(s.segment.mean));

  const means = document.getElementById("means");
  const head = document.createElement("tr");
  for (const h of ["#", "segment", "fx", "fy", "fz", "ωx", "ωy", "ωz"]) {
    const th = document.createElement("th"); th.textContent = h; head.append(th);
  }
  const body = s.means.slice(-12).reverse().map((m) => {
    const tr = document.createElement("tr");
    const cells = [String(m.segment), m.label].concat(m.mean.map((v, i) => num(v === null ? null : (i < 3 ? v : v * RAD_TO_DEG), 4)));
    for (const c of cells) { const td = document.createElement("td"); td.textContent = c; tr.append(td); }
    return tr;
  });
  means.replaceChildren(head, ...body);

  if (charts) {
    const t = s.trace.t_s;
    const deg = (a) => a.map((v) => (v === null ? null : v * RAD_TO_DEG));
    charts.accel.setData([t, s.trace.ax_mps2, s.trace.ay_mps2, s.trace.az_mps2]);
    charts.gyro.setData([t, deg(s.trace.gx_radps), deg(s.trace.gy_radps), deg(s.trace.gz_radps)]);
    const tt = s.temperatures;
    charts.temp.setData([tt.t_s, tt.setpoint_c, tt.air_c, tt.die_c]);
  }
  document.getElementById("updates").textContent = String(++updates);
}

async function poll() {
  try {
    const r = await fetch("/api/state", { cache: "no-store" });
    if (!r.ok) throw new Error(`HTTP ${r.status}`);
    draw(await r.json());
    document.getElementById("error").textContent = "";
  } catch (e) {
    // The server is gone (the run ended and stend exited): keep the last picture, say so.
    document.getElementById("error").textContent = "no answer from stend (the command ended?); showing the last state";
    const st = document.getElementById("status");
    if (!st.className.includes("complete")) st.className = "status lost";
  }
  setTimeout(poll, POLL_MS);
}

charts = setupCharts();
poll();
