// an observation's page: the frame with its contour, the stepper, the best-frame table, marking, the value as you click
"use strict";
const params = new URLSearchParams(location.search);
const state = {
  id: params.get("id"), row: Number(params.get("row")), obs: null, frame: 0, ideal: false, quantity: null,
  marks: {},          // quantity -> {frame: {a: [x, y], b: [x, y]}} in the frame as recorded [px]
  history: [], overlay: null, image: new Image(), scale: 1, seq: 0, drag: null, lastResult: null,
  idealMarks: {},     // frame -> {a, b} of the current quantity on the undistorted view [px] (drawn, dragged there)
};
const canvas = document.getElementById("canvas");
const ctx = canvas.getContext("2d");
window.reviewState = state;          // the browser tests read the scale and the frame from here

function marksOf(q = state.quantity) { return state.marks[q] || (state.marks[q] = {}); }
function snapshot() { state.history.push(JSON.stringify(state.marks)); if (state.history.length > 200) state.history.shift(); }

function fitScale() {
  // the whole frame in view: beside the side panel, under the toolbar
  const room = Math.max(480, window.innerWidth - 480), tall = Math.max(300, window.innerHeight - 140);
  state.scale = Math.min(2, room / state.obs.width, tall / state.obs.height);
  canvas.width = Math.round(state.obs.width * state.scale);
  canvas.height = Math.round(state.obs.height * state.scale);
}

// image [px] <-> canvas: pixel centres at integers (marks.csv's convention)
function toCanvas(p) { return [(p[0] + 0.5) * state.scale, (p[1] + 0.5) * state.scale]; }
function toImage(x, y) { return [x / state.scale - 0.5, y / state.scale - 0.5]; }

function draw() {
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (state.image.complete) ctx.drawImage(state.image, 0, 0, canvas.width, canvas.height);
  const ov = state.overlay;
  if (ov && ov.frame === state.frame) {
    const pts = state.ideal ? ov.ideal : ov.recorded;
    ctx.save();
    ctx.strokeStyle = ov.confident ? "#3ddc5f" : "#ff9d2e";
    if (!ov.confident) ctx.setLineDash([6, 4]);
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    pts.forEach((p, i) => { const [x, y] = toCanvas(p); i ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
    ctx.closePath(); ctx.stroke(); ctx.restore();
    ctx.fillStyle = "#e6ffe9"; ctx.font = "12px DejaVu Sans, sans-serif";
    ov.clocks.forEach(c => { const [x, y] = toCanvas(state.ideal ? c.ideal : c.recorded); ctx.fillText(String(c.hour), x - 4, y - 4); });
  }
  {
    // marks are kept as recorded; on the undistorted view they are drawn where the certificate puts them
    const m = state.ideal ? state.idealMarks[state.frame] : marksOf()[state.frame];
    if (m) {
      ctx.strokeStyle = "#ff3b3b"; ctx.fillStyle = "#ff3b3b"; ctx.lineWidth = 1.5;
      const ends = ["a", "b"].filter(k => m[k]).map(k => [k, toCanvas(m[k])]);
      ends.forEach(([k, [x, y]]) => { ctx.beginPath(); ctx.arc(x, y, 5, 0, 2 * Math.PI); ctx.stroke(); ctx.fillText(k, x + 6, y - 6); });
      if (ends.length === 2) { ctx.beginPath(); ctx.moveTo(...ends[0][1]); ctx.lineTo(...ends[1][1]); ctx.stroke(); }
    }
  }
}

async function showFrame(n) {
  state.frame = n;
  document.getElementById("frame-no").textContent = n;
  const view = state.ideal ? "ideal" : "recorded";
  const img = new Image();
  const loaded = new Promise((ok, bad) => { img.onload = ok; img.onerror = bad; });
  img.src = `/api/frame?id=${encodeURIComponent(state.id)}&n=${n}&view=${view}`;
  await loaded;
  if (state.frame !== n) return;
  state.image = img;
  draw();
  if (state.ideal) syncIdealMarks();
  document.querySelectorAll("#candidates tr").forEach(tr => tr.classList.toggle("current", Number(tr.dataset.frame) === n));
  loadOverlay(n);
}

async function loadOverlay(n) {
  const q = state.obs.quantities.find(q => q.quantity === state.quantity);
  const feature = q && q.feature_m !== null ? `&feature_m=${q.feature_m}` : "";
  try {
    const ov = await review.get(`/api/overlay?id=${encodeURIComponent(state.id)}&n=${n}${feature}`);
    if (state.frame !== n) return;
    state.overlay = ov;
    document.getElementById("chainage").textContent =
      `${ov.chainage_m.toFixed(2)} m` + (ov.confident ? "" : " · outline not trusted");
    document.getElementById("chainage").title = ov.confident ? "the camera's chainage at this frame" : ov.problems.join("; ");
    draw();
    // a candidate shown for the first time now has its pose fitted: its prediction can include it
    if (currentCandidates().some(c => c.frame === n && !c.pose)) refreshCandidates(false);
  } catch (e) { /* a frame whose contour cannot be fitted: the image alone */ }
}

function currentCandidates() {
  const q = state.obs.quantities.find(q => q.quantity === state.quantity);
  return q ? q.candidates : [];
}

function renderCandidates() {
  const body = document.querySelector("#candidates tbody");
  body.innerHTML = currentCandidates().map(c => `<tr data-frame="${c.frame}" data-pose="${c.pose ? 1 : 0}" class="${c.best ? "best" : ""}" title="${review.esc(c.basis)}">
    <td><a href="#">${c.frame}</a>${c.best ? " (best)" : ""}</td><td>${c.chainage_m.toFixed(2)} m</td><td>${c.depth_mm} mm</td>
    <td>${c.U95.toPrecision(2)} ${review.esc(c.unit)}</td>
    <td title="${c.pose ? `marks ${c.U95_marks.toPrecision(2)}, pose ${c.U95_pose.toPrecision(2)} ${review.esc(c.unit)} (U95 of each alone)` : "the pose of this frame is not fitted yet: the marking noise alone, a lower bound"}">${c.pose ? "marks + pose" + (c.pose_confident ? "" : " (outline not trusted)") : "marks only (lower bound)"}</td></tr>`).join("");
  body.querySelectorAll("a").forEach(a => a.addEventListener("click", ev => { ev.preventDefault(); showFrame(Number(a.closest("tr").dataset.frame)); }));
}

async function refreshCandidates(fit) {
  // the table again with the pose's part for the frames fitted by now; fit: the candidates' poses fitted one
  // request at a time (each a second or two), the table redrawn after each, so that frame steps never wait long
  const quantity = state.quantity;
  if (!quantity) return;
  const q = state.obs.quantities.find(q => q.quantity === quantity);
  if (!q) return;
  const base = `/api/candidates?id=${encodeURIComponent(state.id)}&row=${state.row}&quantity=${quantity}`;
  const tried = new Set();
  for (;;) {
    const next = fit ? q.candidates.find(c => !c.pose && !tried.has(c.frame)) : null;
    if (fit && !next) break;
    try {
      const r = await review.get(base + (next ? `&frame=${next.frame}` : ""));
      q.candidates = r.candidates;
      if (state.quantity === quantity) { renderCandidates(); document.querySelectorAll("#candidates tr").forEach(tr => tr.classList.toggle("current", Number(tr.dataset.frame) === state.frame)); }
    } catch (e) { /* the table keeps the marking-noise bound */ }
    if (!fit || state.quantity !== quantity) break;
    tried.add(next.frame);
  }
}

function renderMarks() {
  const frames = Object.entries(marksOf()).filter(([, m]) => m.a || m.b);
  document.getElementById("marks").innerHTML = frames.length ? frames.map(([f, m]) =>
    `frame ${f}: ` + ["a", "b"].filter(k => m[k]).map(k => `${k} (${m[k][0].toFixed(1)}, ${m[k][1].toFixed(1)}) px`).join(", ")).join("<br>")
    : "none yet: click point a, then b";
}

function views() {
  return Object.entries(marksOf()).filter(([, m]) => m.a && m.b).map(([f, m]) => ({frame: Number(f), a: m.a, b: m.b}));
}

async function update() {
  renderMarks(); draw();
  if (state.ideal) syncIdealMarks();
  const v = views();
  const seq = ++state.seq;
  const out = document.getElementById("value");
  if (!v.length) { out.textContent = "-"; out.className = "pending"; document.getElementById("how").textContent = ""; return; }
  const body = {id: state.id, row: state.row, quantity: state.quantity, views: v};
  try {
    const lin = await review.post("/api/measure", body);
    if (seq !== state.seq) return;
    showResult(lin, true);
    const mc = await review.post("/api/measure", {...body, monte_carlo: true});     // in the background
    if (seq !== state.seq) return;
    showResult(mc, false);
  } catch (e) {
    if (seq !== state.seq) return;
    out.textContent = "not measurable"; out.className = "pending";
    document.getElementById("how").textContent = e.message;
  }
}

function showResult(r, preview) {
  state.lastResult = r;
  const out = document.getElementById("value");
  out.textContent = review.result(r.value, r.U95, r.unit) + " (U95)";
  out.className = preview ? "pending" : "";
  out.dataset.value = r.value; out.dataset.u95 = r.U95; out.dataset.final = preview ? "0" : "1";
  document.getElementById("how").textContent = (preview ? "linear, Monte Carlo running… " : "") + r.interval
    + (r.confident === false ? " · outline not trusted" : "") + (r.warnings && !preview ? ` · ${r.warnings}` : "");
  document.getElementById("check").innerHTML = r.log_check
    ? `<span class="${r.log_check === "disagrees" ? "bad" : ""}" title="E_n = |logged - measured| / sqrt(U95² + U_res²): the contractor's logged value against the measurement">log check: ${review.esc(r.log_check)}</span>`
      + (r.E_n !== null ? `, E_n ${r.E_n.toFixed(2)}` : "") + `<div class="note">${review.esc(r.log_check_reason || "")}</div>` : "";
  document.querySelector("#budget tbody").innerHTML = r.budget.map(b =>
    `<tr><td title="input ${review.esc(b.input)} of the model">${review.esc(b.description || b.input)}</td><td>${b.share.toFixed(0)} %</td></tr>`).join("");
  document.getElementById("classes").innerHTML = r.grade_probabilities.length
    ? `<span title="probability of each VSA 2023 class (EZ0 worst ... EZ4 none) from the measurement's distribution">classes:</span> `
      + r.grade_probabilities.map(g => `${review.esc(g.grade)} ${(100 * g.probability).toFixed(0)} %`).join(", ") : "";
}

// -- marking: click, drag, undo ----------------------------------------------------------------------------------
function nearest(x, y) {
  const m = (state.ideal ? state.idealMarks[state.frame] : marksOf()[state.frame]) || {};
  let best = null;
  ["a", "b"].forEach(k => { if (m[k]) { const [cx, cy] = toCanvas(m[k]); const d = Math.hypot(cx - x, cy - y); if (d < 9 && (!best || d < best.d)) best = {k, d}; } });
  return best && best.k;
}
// the undistorted view: points carried to and from the frame as recorded with the certificate (server side, exact)
async function convert(points, to) {
  const r = await review.post("/api/points", {id: state.id, to, points});
  return r.points;
}

async function syncIdealMarks() {
  // the current quantity's marks of the shown frame, drawn on the undistorted view
  const n = state.frame, m = marksOf()[n];
  const keys = m ? ["a", "b"].filter(k => m[k]) : [];
  if (!keys.length) { delete state.idealMarks[n]; draw(); return; }
  try {
    const pts = await convert(keys.map(k => m[k]), "ideal");
    state.idealMarks[n] = Object.fromEntries(keys.map((k, i) => [k, pts[i]]));
    draw();
  } catch (e) { message(e.message, true); }
}

async function placeOnIdeal(key, point) {
  // a click or a drag's end on the undistorted view: kept as recorded, like marks.csv
  const n = state.frame;
  try {
    const [recorded] = await convert([point], "recorded");
    (marksOf()[n] || (marksOf()[n] = {}))[key] = recorded;
    update();
  } catch (e) { message(e.message, true); syncIdealMarks(); }
}

canvas.addEventListener("mousedown", ev => {
  const x = ev.offsetX, y = ev.offsetY;
  const hit = nearest(x, y);
  snapshot();
  if (hit) { state.drag = hit; return; }
  const m = state.ideal ? (state.idealMarks[state.frame] ||= {}) : (marksOf()[state.frame] || (marksOf()[state.frame] = {}));
  const key = !m.a ? "a" : !m.b ? "b" : null;
  if (!key) { state.history.pop(); return; }
  m[key] = toImage(x, y);
  if (state.ideal) { draw(); placeOnIdeal(key, m[key]); return; }
  update();
});
canvas.addEventListener("mousemove", ev => {
  if (!state.drag) return;
  const m = state.ideal ? state.idealMarks[state.frame] : marksOf()[state.frame];
  m[state.drag] = toImage(ev.offsetX, ev.offsetY);
  draw();
});
window.addEventListener("mouseup", () => {
  if (!state.drag) return;
  const key = state.drag;
  state.drag = null;
  if (state.ideal) placeOnIdeal(key, state.idealMarks[state.frame][key]); else update();
});

function undo() { if (state.history.length) { state.marks = JSON.parse(state.history.pop()); update(); } }
function cancelMarks() { snapshot(); state.marks[state.quantity] = {}; update(); }
function message(text, bad = false) { const m = document.getElementById("message"); m.textContent = text; m.className = bad ? "bad" : "note"; }

async function save() {
  const reviewer = document.getElementById("reviewer").value.trim();
  if (!reviewer) { message("a reviewer's name is required to save", true); document.getElementById("reviewer").focus(); return; }
  if (!views().length) { message("mark both points first", true); return; }
  localStorage.setItem("pipegauge-reviewer", reviewer);
  try {
    const r = await review.post("/api/save", {id: state.id, row: state.row, quantity: state.quantity, views: views(), reviewer});
    message(`saved to ${r.saved}; the next run (or "measure again") measures from it`);
  } catch (e) { message(e.message, true); }
}

async function measureAgain() {
  message("measuring the package again…");
  try {
    const r = await review.post("/api/measure-again", {id: state.id});
    const data = await review.get(`/api/inspection?id=${encodeURIComponent(state.id)}`);
    const o = data.observations.find(o => o.row === state.row);
    document.getElementById("stored").innerHTML = "<b>stored:</b> " + o.measurements.map(m =>
      `${review.esc(m.quantity)} ${m.status === "ok" ? review.esc(review.result(m.value, m.U95, m.unit)) : "not measured"}`
      + (m.marked_by ? ` — marked in review by ${review.esc(m.marked_by)} on ${review.esc((m.marked_at || "").slice(0, 10))}` : "")).join("<br>");
    // said last, when what was stored is shown
    message(`measured again: ${r.status}${r.error ? ` (${r.error})` : ""}`, r.status === "failed");
  } catch (e) { message(e.message, true); }
}

async function step(by, dir) {
  const r = await review.get(`/api/step?id=${encodeURIComponent(state.id)}&n=${state.frame}&by=${by}&dir=${dir}`);
  showFrame(r.frame);
}

document.getElementById("prev-frame").onclick = () => showFrame(Math.max(0, state.frame - 1));
document.getElementById("next-frame").onclick = () => showFrame(Math.min(state.obs.frames - 1, state.frame + 1));
document.getElementById("prev-step").onclick = () => step("0.1m", -1);
document.getElementById("next-step").onclick = () => step("0.1m", 1);
document.getElementById("prev-joint").onclick = () => step("joint", -1);
document.getElementById("next-joint").onclick = () => step("joint", 1);
document.getElementById("ideal").onchange = ev => { state.ideal = ev.target.checked; showFrame(state.frame); };
document.getElementById("undo").onclick = undo;
document.getElementById("clear").onclick = cancelMarks;
document.getElementById("save").onclick = save;
document.getElementById("again").onclick = measureAgain;
document.getElementById("quantity").onchange = ev => { state.quantity = ev.target.value; renderCandidates(); update(); refreshCandidates(true); };

window.addEventListener("keydown", ev => {
  if (ev.target.tagName === "INPUT" && ev.key !== "Enter" && ev.key !== "Escape") return;
  if (ev.key === "ArrowRight") { ev.preventDefault(); ev.shiftKey ? step("0.1m", 1) : showFrame(Math.min(state.obs.frames - 1, state.frame + 1)); }
  else if (ev.key === "ArrowLeft") { ev.preventDefault(); ev.shiftKey ? step("0.1m", -1) : showFrame(Math.max(0, state.frame - 1)); }
  else if (ev.key === "PageDown") { ev.preventDefault(); step("joint", 1); }
  else if (ev.key === "PageUp") { ev.preventDefault(); step("joint", -1); }
  else if (ev.key === "Enter") { ev.preventDefault(); save(); }
  else if (ev.key === "Escape") { ev.preventDefault(); cancelMarks(); }
  else if (ev.key === "Backspace" && ev.target.tagName !== "INPUT") { ev.preventDefault(); undo(); }
});
window.addEventListener("resize", () => { if (state.obs) { fitScale(); draw(); } });

(async () => {
  await review.init();
  document.getElementById("back").href = `/?inspection=${encodeURIComponent(state.id)}`;
  const o = await review.get(`/api/observation?id=${encodeURIComponent(state.id)}&row=${state.row}`);
  state.obs = o;
  document.getElementById("title").textContent = `${o.inspection_id} · row ${o.row}`;
  const logged = [o.q1 !== null ? `Q1 ${o.q1} ${o.q1_unit || ""}` : "", o.q2 !== null ? `Q2 ${o.q2} ${o.q2_unit || ""}` : ""].filter(Boolean).join(", ");
  document.getElementById("observation").innerHTML = `<b>${review.esc(o.code)} ${review.esc(o.char1 || "")}${review.esc(o.char2 || "")}</b>
    ${review.esc(o.meaning || "")} at ${o.distance_m} m` + (o.clock_from !== null ? `, ${o.clock_from}${o.clock_to !== null ? "-" + o.clock_to : ""} o'clock` : "")
    + `<div class="note">logged by the contractor: ${review.esc(logged) || "-"}</div>`;
  const sel = document.getElementById("quantity");
  sel.innerHTML = o.quantities.map(q => `<option value="${q.quantity}" title="method ${review.esc(q.method)}, an extent ${review.esc(q.extent)} the pipe">${q.quantity}: ${review.esc(q.meaning)} [${review.esc(q.unit)}]</option>`).join("");
  state.quantity = o.quantities.length ? o.quantities[0].quantity : null;
  for (const s of o.saved) { (state.marks[s.quantity] ||= {})[s.frame] = {a: s.a, b: s.b}; }
  document.getElementById("reviewer").value = localStorage.getItem("pipegauge-reviewer") || "";
  fitScale();
  renderCandidates();
  renderMarks();
  await showFrame(o.frame);
  document.body.dataset.ready = "1";
  // the candidates' poses fitted in the background; the table then ranks them with the pose's part
  for (const q of o.quantities) { if (q.quantity === state.quantity) await refreshCandidates(true); }
  document.body.dataset.poses = "1";
})();
