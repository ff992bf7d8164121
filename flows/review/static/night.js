// the night's page: the inspections, sortable; an inspection's observations with links to each
"use strict";
let rows = [];
let sortKey = "inspection_id", sortUp = true;

function renderNight() {
  const body = document.querySelector("#night tbody");
  const sorted = [...rows].sort((a, b) => {
    const x = a[sortKey], y = b[sortKey];
    const c = (typeof x === "number" && typeof y === "number") ? x - y : String(x ?? "").localeCompare(String(y ?? ""));
    return sortUp ? c : -c;
  });
  body.innerHTML = sorted.map(r => `<tr data-id="${review.esc(r.inspection_id)}">
    <td><a href="#" class="open">${review.esc(r.inspection_id)}</a></td><td>${review.esc(r.date)}</td>
    <td>${review.esc(r.section)} <span class="note">${review.esc(r.nodes)}</span></td>
    <td class="status-${review.esc(r.status)}" title="${review.esc(r.error || "")}">${review.esc(r.status)}</td>
    <td>${review.esc(r.section_grade || "-")}</td>
    <td class="${r.disagreements ? "bad" : ""}">${r.disagreements}</td>
    <td class="${r.untrusted ? "bad" : ""}">${r.untrusted}</td>
    <td class="note">${r.not_measured.map(review.esc).join("<br>") || "-"}</td>
    <td>${review.esc(r.reviewed.join(", ")) || "-"}</td>
    <td>${r.report ? `<a href="/report?id=${encodeURIComponent(r.inspection_id)}" target="_blank">PDF</a>` : "-"}</td>
  </tr>`).join("");
  body.querySelectorAll("a.open").forEach(a => a.addEventListener("click", ev => {
    ev.preventDefault();
    openInspection(a.closest("tr").dataset.id);
  }));
}

async function openInspection(id) {
  document.querySelectorAll("#night tr").forEach(tr => tr.classList.toggle("selected", tr.dataset.id === id));
  const data = await review.get(`/api/inspection?id=${encodeURIComponent(id)}`);
  const lines = data.observations.map(o => {
    const ms = o.measurements.map(m => {
      const text = m.status === "ok" ? review.result(m.value, m.U95, m.unit) : `not measured: ${m.error}`;
      const who = m.marked_by ? ` <span class="note">marked in review by ${review.esc(m.marked_by)} on ${review.esc((m.marked_at || "").slice(0, 10))}</span>` : "";
      const check = m.log_check ? ` <span class="${m.log_check === "disagrees" ? "bad" : "note"}" title="the contractor's logged value checked against the measurement (E_n, the class)">log ${review.esc(m.log_check)}</span>` : "";
      const trust = m.confident === false ? ` <span class="bad" title="the fitted pipe contour at this frame is doubtful">outline not trusted</span>` : "";
      return `${review.esc(m.quantity)} (${review.esc(m.source)}): ${review.esc(text)}${check}${trust}${who}`;
    }).join("<br>");
    const logged = [o.q1 !== null ? `Q1 ${o.q1} ${o.q1_unit || ""}` : "", o.q2 !== null ? `Q2 ${o.q2} ${o.q2_unit || ""}` : ""].filter(Boolean).join(", ");
    const link = o.markable.length
      ? `<a class="observation" href="/observation?id=${encodeURIComponent(id)}&row=${o.row}">mark ${o.markable.join(", ")}</a>` : "";
    return `<tr><td>${o.row}</td><td>${review.num(o.distance_m, 3)} m</td>
      <td title="${review.esc(o.meaning)}">${review.esc(o.code)} ${review.esc(o.char1 || "")}${review.esc(o.char2 || "")}</td>
      <td>${review.esc(logged) || "-"}</td><td>${ms || "-"}</td><td>${review.esc(o.grade || "-")}</td><td>${link}</td></tr>`;
  }).join("");
  document.getElementById("observations").innerHTML = `<h2>Observations of ${review.esc(id)}</h2>
    <table id="observation-list"><thead><tr><th>row</th><th>distance</th><th>code</th><th title="the contractor's values">logged</th>
    <th title="value ± U95 (95 % coverage)">measured</th><th title="VSA 2023 class, most probable">grade</th><th></th></tr></thead>
    <tbody>${lines}</tbody></table>`;
}

document.querySelectorAll("th.sortable").forEach(th => th.addEventListener("click", () => {
  sortUp = sortKey === th.dataset.key ? !sortUp : true;
  sortKey = th.dataset.key;
  renderNight();
}));

(async () => {
  await review.init();
  const data = await review.get("/api/night");
  const out = document.getElementById("out");
  out.textContent = data.out.split("/").slice(-2).join("/");
  out.title = data.out;
  rows = data.inspections;
  renderNight();
  const wanted = new URLSearchParams(location.search).get("inspection");
  if (wanted) openInspection(wanted);
})();
