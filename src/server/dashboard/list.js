// The job list: state, progress, samples/s, ETA, last RMSE, dropped samples, tags;
// filtered by state, tag and sweep (kept in the URL: #/jobs?state=running&tag=x);
// refreshed every second.

import { api } from "./api.js";
import { el, errorBox, fmtDuration, fmtNum, progressBar, stateBadge } from "./util.js";

const STATES = ["", "queued", "running", "paused", "completed", "cancelled", "failed"];

export function listPage(view, route, signal) {
  const q = route.query;
  const state = el("select", { id: "filter-state" },
    STATES.map((s) => el("option", { value: s, selected: s === (q.get("state") || "") }, s || "any state")));
  const tag = el("input", { id: "filter-tag", type: "text", placeholder: "tag", value: q.get("tag") || "" });
  const sweep = el("input", { id: "filter-sweep", type: "text", placeholder: "sweep id", value: q.get("sweep") || "" });
  const apply = () => {
    const p = new URLSearchParams();
    if (state.value) p.set("state", state.value);
    if (tag.value.trim()) p.set("tag", tag.value.trim());
    if (sweep.value.trim()) p.set("sweep", sweep.value.trim());
    const h = `#/jobs${p.toString() ? "?" + p : ""}`;
    if (location.hash !== h) location.hash = h;
  };
  state.addEventListener("change", apply);
  for (const i of [tag, sweep]) i.addEventListener("change", apply);
  const body = el("tbody");
  const status = el("p", { class: "muted" });
  view.append(
    el("h1", {}, "Jobs"),
    el("div", { class: "filters" }, state, tag, sweep,
      q.get("sweep") ? el("a", { href: `#/sweep/${encodeURIComponent(q.get("sweep"))}` }, "sweep table") : null),
    el("table", { id: "jobs" },
      el("thead", {}, el("tr", {},
        ["job", "state", "progress", "iteration", "samples/s", "ETA", "last RMSE", "dropped", "tags"]
          .map((h) => el("th", { class: ["iteration", "samples/s", "ETA", "last RMSE", "dropped"].includes(h) ? "num" : "" }, h)))),
      body),
    status,
  );
  const query = new URLSearchParams();
  for (const k of ["state", "tag", "sweep"]) if (q.get(k)) query.set(k, q.get(k));
  const refresh = async () => {
    try {
      const jobs = await api(`/v1/jobs${query.toString() ? "?" + query : ""}`, { signal });
      jobs.sort((a, b) => b.created_at - a.created_at);
      body.replaceChildren(...jobs.map(row));
      status.replaceChildren(jobs.length ? "" : "No jobs match.");
    } catch (e) {
      if (e.name !== "AbortError") status.replaceChildren(errorBox(e));
    }
  };
  refresh();
  const timer = setInterval(refresh, 1000);
  return () => clearInterval(timer);
}

function row(job) {
  const link = el("a", { href: `#/job/${encodeURIComponent(job.id)}` }, job.spec.name || job.id);
  return el("tr", { dataset: { job: job.id, state: job.state } },
    el("td", {}, link, job.spec.name ? el("div", { class: "muted" }, job.id) : null),
    el("td", {}, stateBadge(job.state)),
    el("td", {}, progressBar(job)),
    el("td", { class: "num" }, job.iteration),
    el("td", { class: "num" }, fmtNum(job.samples_per_s)),
    el("td", { class: "num" }, job.state === "running" ? fmtDuration(job.eta_s) : "–"),
    el("td", { class: "num" }, fmtNum(job.last_rmse)),
    el("td", { class: "num" }, job.dropped),
    el("td", {},
      (job.spec.tags || []).map((t) => el("a", { class: "tag", href: `#/jobs?tag=${encodeURIComponent(t)}` }, t)),
      job.spec.sweep ? el("a", { class: "tag", href: `#/sweep/${encodeURIComponent(job.spec.sweep)}` }, `sweep ${job.spec.sweep}`) : null),
  );
}
