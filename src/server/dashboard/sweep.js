// A sweep's table (GET /v1/sweeps/ID): one row per grid point with a thumbnail of its
// job's latest image (points rendered as a radius layer of a shared job name the
// layer instead: previews show main images), sortable by any column, refreshed while
// jobs run; CSV download.

import { api, blob, download } from "./api.js";
import { el, errorBox, fmtNum, showBlob, stateBadge, TERMINAL } from "./util.js";

export function sweepPage(view, route, signal) {
  const id = route.arg;
  const path = `/v1/sweeps/${encodeURIComponent(id)}`;
  const head = el("thead");
  const body = el("tbody");
  const status = el("div", { class: "muted" });
  let table = null;
  let sort = { key: null, dir: 1 };
  const thumbs = new Map();

  view.append(
    el("h1", { id: "sweep-title" }, `Sweep ${id}`),
    el("div", { class: "actions" },
      el("button", { id: "sweep-csv", onclick: () => download(`${path}?format=csv`, `${id}.csv`).catch((e) => status.replaceChildren(errorBox(e))) }, "CSV"),
      el("a", { href: `#/jobs?sweep=${encodeURIComponent(id)}` }, "its jobs in the list")),
    el("table", { id: "sweep" }, head, body),
    status);

  const columns = () => {
    const keys = [...new Set(table.rows.flatMap((r) => Object.keys(r.point)))].sort();
    return [
      { key: "thumb", label: "image", sortable: false },
      { key: "job", label: "job", get: (r) => r.job },
      ...keys.map((k) => ({ key: `point.${k}`, label: k, get: (r) => r.point[k], num: true })),
      { key: "state", label: "state", get: (r) => r.state },
      { key: "iterations", label: "iterations", get: (r) => r.iterations, num: true },
      { key: "time_s", label: "time (s)", get: (r) => r.time_s, num: true },
      { key: "rmse", label: "RMSE", get: (r) => r.rmse, num: true },
      ...(table.rows.some((r) => r.layer) ? [{ key: "layer", label: "layer", get: (r) => r.layer }] : []),
    ];
  };

  const thumb = (r) => {
    if (r.layer) return el("span", { class: "muted" }, `layer ${r.layer}`);
    let t = thumbs.get(r.job);
    if (!t) {
      t = { img: el("img", { class: "thumb", alt: r.job }), iteration: -1 };
      thumbs.set(r.job, t);
    }
    if (t.iteration !== r.iterations && r.iterations > 0) {
      t.iteration = r.iterations;
      blob(`/v1/jobs/${encodeURIComponent(r.job)}/preview.png`, { signal })
        .then((b) => showBlob(t.img, b))
        .catch(() => {});
    }
    return t.img;
  };

  const render = () => {
    const cols = columns();
    head.replaceChildren(el("tr", {}, cols.map((c) => el("th", {
      class: [c.num ? "num" : "", c.sortable === false ? "" : "sortable",
        sort.key === c.key ? (sort.dir > 0 ? "sorted-asc" : "sorted-desc") : ""].join(" ").trim(),
      dataset: { key: c.key },
      onclick: c.sortable === false ? undefined : () => {
        sort = { key: c.key, dir: sort.key === c.key ? -sort.dir : 1 };
        render();
      },
    }, c.label))));
    const rows = [...table.rows];
    const col = cols.find((c) => c.key === sort.key);
    if (col) {
      rows.sort((a, b) => {
        const x = col.get(a);
        const y = col.get(b);
        if (x == null) return 1;
        if (y == null) return -1;
        return (x < y ? -1 : x > y ? 1 : 0) * sort.dir;
      });
    }
    body.replaceChildren(...rows.map((r) => el("tr", { dataset: { job: r.job } },
      cols.map((c) => {
        if (c.key === "thumb") return el("td", {}, thumb(r));
        if (c.key === "job") return el("td", {}, el("a", { href: `#/job/${encodeURIComponent(r.job)}` }, r.job));
        if (c.key === "state") return el("td", {}, stateBadge(r.state));
        const v = c.get(r);
        if (c.key === "layer") return el("td", {}, v ?? "main");
        return el("td", { class: "num" }, typeof v === "number" ? fmtNum(v, 4) : v == null ? "–" : JSON.stringify(v));
      }))));
  };

  let timer = null;
  const refresh = async () => {
    try {
      table = await api(path, { signal });
      if (table.name) document.getElementById("sweep-title").textContent = `Sweep ${table.name} (${id})`;
      render();
      const running = table.rows.some((r) => !TERMINAL.includes(r.state));
      status.textContent = running ? "updating every 2 s while jobs run" : "all jobs finished";
      if (!running && timer) {
        clearInterval(timer);
        timer = null;
      }
    } catch (e) {
      if (e.name !== "AbortError") status.replaceChildren(errorBox(e));
    }
  };
  refresh();
  timer = setInterval(refresh, 2000);
  return () => timer && clearInterval(timer);
}
