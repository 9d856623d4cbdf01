// Small DOM and formatting helpers shared by the pages.

/// el("td", {class: "x", onclick: f}, child, "text", ...): an element.
export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else if (k === "class") e.className = v;
    else if (k === "dataset") Object.assign(e.dataset, v);
    else if (k in e && typeof v !== "string") e[k] = v;
    else e.setAttribute(k, v === true ? "" : v);
  }
  for (const c of children.flat()) {
    if (c === undefined || c === null || c === false) continue;
    e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return e;
}

export const TERMINAL = ["completed", "cancelled", "failed"];

export function fmtDuration(s) {
  if (s === undefined || s === null || !isFinite(s)) return "–";
  if (s < 60) return `${s.toFixed(1)} s`;
  const m = Math.floor(s / 60);
  if (m < 60) return `${m} min ${Math.round(s - 60 * m)} s`;
  return `${Math.floor(m / 60)} h ${m % 60} min`;
}

export function fmtNum(x, digits = 3) {
  if (x === undefined || x === null || !isFinite(x)) return "–";
  const a = Math.abs(x);
  if (Number.isInteger(x) && a < 1e4) return String(x);
  if (a >= 1e6) return `${(x / 1e6).toPrecision(digits)} M`;
  if (a >= 1e3) return `${(x / 1e3).toPrecision(digits)} k`;
  if (a < 1e-3) return x.toExponential(digits - 1);
  return x.toPrecision(digits);
}

/// A job's progress in [0, 1] from its halting rule, or null when it cannot tell.
export function progressOf(job) {
  if (job.state === "completed") return 1;
  const h = job.spec.halt || {};
  const spp = h.spp ?? h.iterations;
  const parts = [];
  if (spp) parts.push(job.iteration / spp);
  if (h.time_s) parts.push(job.elapsed_s / h.time_s);
  if (job.eta_s !== undefined && job.elapsed_s > 0) {
    parts.push(job.elapsed_s / (job.elapsed_s + job.eta_s));
  }
  return parts.length ? Math.min(1, Math.max(...parts)) : null;
}

export function progressBar(job) {
  const p = progressOf(job);
  const bar = el("progress", { max: 1, class: `state-${job.state}` });
  if (p !== null) bar.value = p;
  return bar;
}

export function stateBadge(state) {
  return el("span", { class: `badge state-${state}` }, state);
}

/// An <img> showing a blob (fetched with the token); revokes the previous URL.
export function showBlob(img, b) {
  const old = img.dataset.url;
  const url = URL.createObjectURL(b);
  img.dataset.url = url;
  img.src = url;
  if (old) URL.revokeObjectURL(old);
}

export function errorBox(err) {
  return el("p", { class: "error", role: "alert" }, String(err));
}
