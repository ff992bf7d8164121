// pipegauge review: what both pages share (requests with the start's token, text helpers)
"use strict";
const review = {
  token: null,
  async init() {
    const r = await fetch("/api/token", {credentials: "same-origin"});
    if (!r.ok) throw new Error(await r.text());
    review.token = (await r.json()).token;
  },
  async get(path) {
    const r = await fetch(path, {credentials: "same-origin"});
    const body = await r.json().catch(() => ({error: r.statusText}));
    if (!r.ok) throw new Error(body.error || r.statusText);
    return body;
  },
  async post(path, data) {
    const r = await fetch(path, {method: "POST", credentials: "same-origin",
      headers: {"content-type": "application/json", "x-review-token": review.token}, body: JSON.stringify(data)});
    const body = await r.json().catch(() => ({error: r.statusText}));
    if (!r.ok) throw new Error(typeof body.error === "string" ? body.error : JSON.stringify(body.detail || body));
    return body;
  },
  esc(text) {
    return String(text ?? "").replace(/[&<>"']/g, c => ({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;"}[c]));
  },
  num(x, digits = 3) { return (x === null || x === undefined || Number.isNaN(x)) ? "-" : Number(x).toPrecision(digits); },
  // value ± U95 with U95 to two significant digits and the value to the same decimal (GUM 7.2.6)
  result(value, U, unit) {
    if (value === null || value === undefined) return "-";
    const step = Math.pow(10, Math.floor(Math.log10(Math.abs(U) || 1)) - 1);
    const dec = Math.max(0, -Math.round(Math.log10(step)));
    return `${value.toFixed(dec)} ± ${U.toFixed(dec)} ${unit}`;
  },
};
