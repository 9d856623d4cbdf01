// Workers of a pool (GET /v1/workers, filled when the server runs with --nats) and
// the server's Prometheus figures (GET /metrics), refreshed every 2 s.

import { api, text } from "./api.js";
import { el, errorBox, fmtNum } from "./util.js";

/// Prometheus text format -> [{name, labels, value}] (comments skipped).
export function parseMetrics(body) {
  const out = [];
  for (const line of body.split("\n")) {
    if (!line.trim() || line.startsWith("#")) continue;
    const m = line.match(/^([a-zA-Z_:][\w:]*)(\{[^}]*\})?\s+(\S+)/);
    if (m) out.push({ name: m[1], labels: (m[2] || "").replace(/^\{|\}$/g, ""), value: Number(m[3]) });
  }
  return out;
}

export function workersPage(view, route, signal) {
  const workers = el("tbody");
  const metrics = el("tbody");
  const status = el("div");
  view.append(
    el("h1", {}, "Workers"),
    el("table", { id: "workers" },
      el("thead", {}, el("tr", {},
        ["name", "threads", "last heartbeat", "ranges", "iterations", "job in hand"].map((h) => el("th", {}, h)))),
      workers),
    el("h2", {}, "Metrics"),
    el("table", { id: "metrics" },
      el("thead", {}, el("tr", {}, el("th", {}, "metric"), el("th", {}, "labels"), el("th", { class: "num" }, "value"))),
      metrics),
    status);
  const refresh = async () => {
    try {
      const [ws, m] = await Promise.all([api("/v1/workers", { signal }), text("/metrics", { signal })]);
      const now = Date.now() / 1000;
      workers.replaceChildren(...(ws.length
        ? ws.map((w) => el("tr", {},
          el("td", {}, w.name),
          el("td", {}, w.threads),
          el("td", {}, `${Math.max(0, now - w.last_heartbeat).toFixed(1)} s ago`),
          el("td", {}, w.ranges_done),
          el("td", {}, w.iterations_done),
          el("td", {}, w.current_job ? el("a", { href: `#/job/${encodeURIComponent(w.current_job)}` }, w.current_job) : "–")))
        : [el("tr", {}, el("td", { colSpan: 6, class: "muted" }, "No pool workers: this server renders in-process (start it with --nats to use a pool)."))]));
      metrics.replaceChildren(...parseMetrics(m).map((x) => el("tr", {},
        el("td", {}, x.name), el("td", { class: "muted" }, x.labels), el("td", { class: "num" }, fmtNum(x.value, 4)))));
      status.replaceChildren();
    } catch (e) {
      if (e.name !== "AbortError") status.replaceChildren(errorBox(e));
    }
  };
  refresh();
  const timer = setInterval(refresh, 2000);
  return () => clearInterval(timer);
}
