// A job page: the preview, updated live from the job's event stream; an exposure
// slider; a snapshot scrubber; the RMSE and rel-MSE vs time plot (log-log) from the
// log; the log table; downloads; and the state transitions, with the server's error
// shown when it refuses one.

import { api, blob, download } from "./api.js";
import { followEvents } from "./sse.js";
import { logLogPlot } from "./plot.js";
import { el, errorBox, fmtDuration, fmtNum, progressBar, stateBadge, TERMINAL } from "./util.js";

/// The radius layers' curves in the error plot, in layer order.
const LAYER_COLOURS = ["#7fd47f", "#d47fd4", "#d4d47f", "#7fd4d4", "#f07f7f", "#a0a0f0"];

export function jobPage(view, route, signal) {
  const id = route.arg;
  const base = `/v1/jobs/${encodeURIComponent(id)}`;
  let job = null;
  let snapshots = [];
  let live = true;

  const title = el("h1", {}, id);
  const canvas = el("canvas", { id: "preview", width: 32, height: 32 });
  const previewNote = el("p", { id: "preview-note", class: "muted" });
  const stats = el("dl", { class: "stats", id: "stats" });
  const exposure = el("input", { id: "exposure", type: "range", min: -6, max: 6, step: 0.25, value: 0 });
  const exposureLabel = el("span", { id: "exposure-value" }, "0 stops");
  const scrub = el("input", { id: "scrubber", type: "range", min: 0, max: 0, step: 1, value: 0 });
  const scrubLabel = el("span", { id: "scrubber-value" }, "live");
  const actionError = el("p", { id: "action-error", class: "error", role: "alert" });
  const plot = el("canvas", { class: "plot", id: "plot", width: 560, height: 300 });
  const logBody = el("tbody");
  const actions = el("div", { class: "actions" });

  const act = (name, method, path) =>
    el("button", {
      id: `action-${name}`,
      onclick: async () => {
        actionError.textContent = "";
        try {
          const r = await api(`${base}${path}`, { method });
          if (name === "delete") {
            location.hash = "#/jobs";
            return;
          }
          if (r) showJob(r);
        } catch (e) {
          actionError.textContent = `${name} refused: ${e}`;
        }
      },
    }, name);
  actions.append(
    act("pause", "POST", "/pause"),
    act("resume", "POST", "/resume"),
    act("cancel", "POST", "/cancel"),
    act("retry", "POST", "/retry"),
    act("delete", "DELETE", ""),
  );
  const dl = (label, path, file) =>
    el("button", {
      class: "download",
      dataset: { download: label },
      onclick: () => download(`${base}${path}`, `${id}-${file}`).catch((e) => {
        actionError.textContent = `download: ${e}`;
      }),
    }, label);

  view.append(
    title,
    el("div", { class: "job-top" },
      el("div", {},
        el("div", { class: "preview-box" }, canvas),
        previewNote,
        el("div", { class: "controls" }, el("label", { for: "exposure" }, "exposure"), exposure, exposureLabel),
        el("div", { class: "controls" }, el("label", { for: "scrubber" }, "snapshot"), scrub, scrubLabel)),
      el("div", {},
        stats,
        actions,
        actionError,
        el("div", { class: "actions" }, dl("EXR", "/image.exr", "image.exr"), dl("PNG", "/preview.png", "preview.png"), dl("log CSV", "/log", "log.csv")))),
    el("h2", {}, "Error vs time"),
    plot,
    el("h2", {}, "Log"),
    el("div", { class: "scroll" },
      el("table", { id: "log" },
        el("thead", {}, el("tr", {},
          ["iteration", "elapsed", "samples", "RMSE", "rel MSE", "est. RMSE", "est. rel MSE", "dropped", "rays/s", "merge radius"].map((h) => el("th", { class: "num" }, h)))),
        logBody)),
  );

  function showJob(j) {
    job = j;
    title.replaceChildren(j.spec.name || j.id, " ", stateBadge(j.state));
    const row = (k, v) => [el("dt", {}, k), el("dd", { dataset: { stat: k } }, v)];
    stats.replaceChildren(
      ...row("state", j.state),
      ...row("progress", progressBar(j)),
      ...row("iteration", j.iteration),
      ...row("elapsed", fmtDuration(j.elapsed_s)),
      ...row("samples/s", fmtNum(j.samples_per_s)),
      ...row("ETA", j.state === "running" ? fmtDuration(j.eta_s) : "–"),
      ...row("last RMSE", fmtNum(j.last_rmse)),
      ...row("noise", j.noise != null ? `${fmtNum(100 * j.noise, 3)} %` : "–"),
      ...row("dropped", j.dropped),
      ...row("scene", j.spec.scene),
      ...row("algorithm", j.settings?.algorithm ?? j.spec.algorithm ?? "–"),
      ...row("size", `${j.width} × ${j.height}`),
      ...row("tags", (j.spec.tags || []).join(", ") || "–"),
      ...(j.spec.sweep ? row("sweep", el("a", { href: `#/sweep/${encodeURIComponent(j.spec.sweep)}` }, j.spec.sweep)) : []),
      ...(j.workers !== undefined ? row("workers", j.workers) : []),
      ...(j.error ? row("error", el("span", { class: "error" }, j.error)) : []),
    );
  }

  // Draws a PNG blob; for stored snapshots (which carry no exposure) the exposure is
  // applied here, on the sRGB bytes decoded to linear.
  async function draw(b, stops) {
    const bitmap = await createImageBitmap(b);
    canvas.width = bitmap.width;
    canvas.height = bitmap.height;
    const g = canvas.getContext("2d", { willReadFrequently: true });
    g.drawImage(bitmap, 0, 0);
    if (stops) {
      const img = g.getImageData(0, 0, canvas.width, canvas.height);
      const k = 2 ** stops;
      const lut = new Uint8ClampedArray(256);
      for (let i = 0; i < 256; i++) {
        const c = i / 255;
        const lin = c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4;
        const v = Math.min(1, lin * k);
        lut[i] = Math.round(255 * (v <= 0.0031308 ? 12.92 * v : 1.055 * v ** (1 / 2.4) - 0.055));
      }
      for (let i = 0; i < img.data.length; i += 4) {
        img.data[i] = lut[img.data[i]];
        img.data[i + 1] = lut[img.data[i + 1]];
        img.data[i + 2] = lut[img.data[i + 2]];
      }
      g.putImageData(img, 0, 0);
    }
    canvas.dataset.version = String(Number(canvas.dataset.version || 0) + 1);
  }

  let drawing = false;
  let again = false;
  async function refreshPreview() {
    if (drawing) {
      again = true;
      return;
    }
    drawing = true;
    try {
      const stops = Number(exposure.value);
      if (live) {
        await draw(await blob(`${base}/preview.png?exposure=${stops}`, { signal }), 0);
        previewNote.textContent = `latest image, iteration ${job?.iteration ?? "?"}`;
      } else {
        const it = snapshots[Number(scrub.value)];
        await draw(await blob(`${base}/snapshots/${it}.png`, { signal }), stops);
        previewNote.textContent = `snapshot at iteration ${it}`;
      }
    } catch (e) {
      if (e.name !== "AbortError") previewNote.textContent = e.status === 404 ? "no image yet" : String(e);
    } finally {
      drawing = false;
    }
    if (again) {
      again = false;
      refreshPreview();
    }
  }

  async function refreshSnapshots() {
    try {
      const list = await api(`${base}/snapshots`, { signal });
      snapshots = list.map((s) => s.iteration);
      const atEnd = live;
      scrub.max = Math.max(0, snapshots.length);
      if (atEnd) scrub.value = scrub.max;
    } catch (_) {
      // The job may have no directory listing yet.
    }
  }

  // The radius layers' RMSE (jobs with `radii`, from layers.csv), one curve each, at
  // the render time of the log row of the same iteration.
  async function layerSeries(rows) {
    const layers = await api(`${base}/layers`, { signal });
    const time = new Map(rows.map((r) => [r.iteration, r.elapsed_s]));
    const names = [...new Set(layers.map((l) => l.layer))];
    return names.map((name, i) => {
      const own = layers.filter((l) => l.layer === name && l.rmse != null && time.has(l.iteration));
      const radius = own.length ? ` (r ${fmtNum(own[0].radius, 3)})` : "";
      return {
        name: `RMSE ${name}${radius}`,
        color: LAYER_COLOURS[i % LAYER_COLOURS.length],
        points: own.map((l) => [time.get(l.iteration), l.rmse]),
      };
    });
  }

  async function refreshLog() {
    try {
      const rows = await api(`${base}/log`, { signal });
      logBody.replaceChildren(...rows.map((r) => el("tr", {},
        el("td", { class: "num" }, r.iteration),
        el("td", { class: "num" }, r.elapsed_s.toFixed(2)),
        el("td", { class: "num" }, r.samples),
        el("td", { class: "num" }, fmtNum(r.rmse, 4)),
        el("td", { class: "num" }, fmtNum(r.rel_mse, 4)),
        el("td", { class: "num" }, fmtNum(r.est_rmse, 4)),
        el("td", { class: "num" }, fmtNum(r.est_rel_mse, 4)),
        el("td", { class: "num" }, r.dropped),
        el("td", { class: "num" }, fmtNum(r.rays_per_s)),
        el("td", { class: "num" }, fmtNum(r.merge_radius)))));
      logLogPlot(plot, [
        { name: "RMSE", color: "#f0a53a", points: rows.filter((r) => r.rmse != null).map((r) => [r.elapsed_s, r.rmse]) },
        { name: "rel MSE", color: "#5cb3f0", points: rows.filter((r) => r.rel_mse != null).map((r) => [r.elapsed_s, r.rel_mse]) },
        // From the job's own iterations, no reference needed (variance only).
        { name: "est. RMSE", color: "#c77dff", points: rows.filter((r) => r.est_rmse != null).map((r) => [r.elapsed_s, r.est_rmse]) },
        { name: "est. rel MSE", color: "#7ddf9a", points: rows.filter((r) => r.est_rel_mse != null).map((r) => [r.elapsed_s, r.est_rel_mse]) },
        ...(await layerSeries(rows)),
      ], { xLabel: "render time (s)", yLabel: "error" });
    } catch (e) {
      if (e.name !== "AbortError") logBody.replaceChildren(el("tr", {}, el("td", {}, errorBox(e))));
    }
  }

  exposure.addEventListener("input", () => {
    exposureLabel.textContent = `${exposure.value} stops`;
    refreshPreview();
  });
  scrub.addEventListener("input", () => {
    live = Number(scrub.value) >= snapshots.length;
    scrubLabel.textContent = live ? "live" : `iteration ${snapshots[Number(scrub.value)]}`;
    refreshPreview();
  });

  const refreshAll = () => Promise.all([refreshSnapshots(), refreshLog()]).then(refreshPreview);

  (async () => {
    try {
      showJob(await api(base, { signal }));
    } catch (e) {
      if (e.name !== "AbortError") view.append(errorBox(e));
      return;
    }
    await refreshAll();
    followEvents(`${base}/events`, async (name, ev) => {
      if (!job) return;
      if (name === "progress") {
        showJob({ ...job, iteration: ev.iteration, elapsed_s: ev.elapsed_s, samples_per_s: ev.samples_per_s, eta_s: ev.eta_s, dropped: ev.dropped });
      } else if (name === "snapshot") {
        if (ev.rmse != null) job.last_rmse = ev.rmse;
        if (ev.est_rel_mse != null) job.noise = Math.sqrt(ev.est_rel_mse);
        refreshAll();
      } else if (name === "state" || name === "done") {
        try {
          showJob(await api(base, { signal }));
        } catch (_) {
          // Deleted meanwhile.
        }
        if (name === "done" || TERMINAL.includes(ev.state)) refreshAll();
      }
    }, { signal, onError: (e) => (previewNote.textContent = `event stream: ${e}`) });
  })();
  return null;
}
