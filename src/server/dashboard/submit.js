// The submit form: scene (GET /v1/scenes), algorithm and its parameters
// (GET /v1/algorithms, defaults as placeholders), halt conditions, reference, and the
// rest of a job. Values are sent as typed (JSON where they parse as JSON) and the
// server validates them: its message is shown next to the input of the field its error
// names (the error body's `field`), and that input is marked invalid.

import { api, request } from "./api.js";
import { el, errorBox } from "./util.js";

/// "8" -> 8, "true" -> true, "abc" -> "abc": what a person types, as JSON.
function parseValue(text) {
  try {
    return JSON.parse(text);
  } catch (_) {
    return text;
  }
}

function field(label, path, input, hint) {
  input.id ||= `f-${path.replace(/\./g, "-")}`;
  input.dataset.path = path;
  return el("div", { class: "row" },
    el("label", { for: input.id }, label),
    input,
    hint ? el("span", { class: "muted" }, hint) : null,
    el("span", { class: "field-error", dataset: { errorFor: path } }));
}

/// Defaults of f32 parameters arrive as 0.800000011920929: shown as 0.8.
const tidy = (v) => (typeof v === "number" ? Number(v.toPrecision(7)) : v);

const text = (attrs = {}) => el("input", { type: "text", autocomplete: "off", ...attrs });

/// The form path of the error's `field`: the field itself, or the nearest enclosing
/// path that the form has (`params.light_paths.count` -> `params.light_paths`).
export function pathFor(field, paths) {
  const parts = field.split(/[.[]/);
  for (let n = parts.length; n > 0; n--) {
    const p = parts.slice(0, n).join(".");
    if (paths.includes(p)) return p;
  }
  return undefined;
}

export function submitPage(view, route, signal) {
  const scene = el("select", { id: "scene" });
  const algorithm = el("select", { id: "algorithm" }, el("option", { value: "" }, "(the scene's own, else pt)"));
  const paramsBox = el("div", { id: "params" }, el("p", { class: "muted" }, "Choose an algorithm to set its parameters."));
  const spp = text({ id: "halt-spp", value: "64" });
  const time = text({ id: "halt-time_s" });
  const target = text({ id: "halt-target_rmse" });
  const noise = text({ id: "halt-noise", placeholder: "0.01" });
  const variance = el("input", { id: "variance-layer", type: "checkbox" });
  const refJob = el("select", { id: "reference-job" }, el("option", { value: "" }, "none"));
  const refFile = el("input", { id: "reference-file", type: "file", accept: ".exr" });
  const seed = text({ id: "seed", value: "0" });
  const priority = text({ id: "priority", value: "0" });
  const name = text({ id: "name" });
  const tags = text({ id: "tags", placeholder: "a, b" });
  const everyKind = el("select", { id: "snapshot-kind" },
    el("option", { value: "seconds" }, "seconds"), el("option", { value: "iterations" }, "iterations"));
  const every = text({ id: "snapshot-every", placeholder: "5" });
  const formError = el("div", { id: "form-error", class: "error", role: "alert" });
  const submit = el("button", { type: "submit", id: "submit" }, "Submit");
  let algorithms = [];

  const form = el("form", { class: "submit", id: "submit-form" },
    el("fieldset", {}, el("legend", {}, "Scene and algorithm"),
      field("scene", "scene", scene),
      field("algorithm", "algorithm", algorithm),
      paramsBox),
    el("fieldset", {}, el("legend", {}, "Halt (at whichever comes first)"),
      field("samples per pixel", "halt.spp", spp),
      field("time (s)", "halt.time_s", time),
      field("target RMSE", "halt.target_rmse", target, "needs a reference"),
      field("noise", "halt.noise", noise, "estimated relative error, e.g. 0.01 for 1 %; no reference needed")),
    el("fieldset", {}, el("legend", {}, "Reference (for RMSE logs)"),
      field("a completed job", "reference.job", refJob),
      field("or upload an EXR", "reference.upload", refFile)),
    el("fieldset", {}, el("legend", {}, "Job"),
      field("seed", "seed", seed),
      field("priority", "priority", priority),
      field("name", "name", name),
      field("tags", "tags", tags, "comma-separated"),
      field("variance layer", "variance_layer", variance, "estimated per-pixel variance in the EXRs"),
      el("div", { class: "row" }, el("label", { for: "snapshot-every" }, "snapshot every"), every, everyKind,
        el("span", { class: "field-error", dataset: { errorFor: "snapshot_every" } }))),
    formError,
    submit);
  view.append(el("h1", {}, "Submit a job"), form);

  const renderParams = () => {
    const a = algorithms.find((x) => x.name === algorithm.value);
    if (!a) {
      paramsBox.replaceChildren(el("p", { class: "muted" }, "Choose an algorithm to set its parameters."));
      return;
    }
    const entries = Object.entries(a.params);
    paramsBox.replaceChildren(
      el("p", { class: "muted", id: "algorithm-about" }, a.about),
      ...(entries.length ? [] : [el("p", { class: "muted" }, `${a.name} takes no parameters.`)]),
      ...entries.map(([k, v]) =>
        field(k, `params.${k}`, text({ id: `param-${k}`, class: "param", placeholder: JSON.stringify(tidy(v)), dataset: { param: k } }), "empty: default")));
  };
  algorithm.addEventListener("change", renderParams);

  (async () => {
    try {
      const [scenes, algs, done] = await Promise.all([
        api("/v1/scenes", { signal }),
        api("/v1/algorithms", { signal }),
        api("/v1/jobs?state=completed", { signal }),
      ]);
      scene.replaceChildren(...scenes.map((s) =>
        el("option", { value: s.id }, `${s.id} (${s.width}×${s.height}${s.builtin ? ", built-in" : ""})`)));
      algorithms = algs;
      algorithm.append(...algs.map((a) => el("option", { value: a.name }, a.name)));
      refJob.append(...done.map((j) => el("option", { value: j.id }, `${j.spec.name || j.id} (${j.width}×${j.height})`)));
      if (route.query.get("scene")) scene.value = route.query.get("scene");
      form.dataset.ready = "true";
    } catch (e) {
      if (e.name !== "AbortError") formError.replaceChildren(errorBox(e));
    }
  })();

  const showError = (e) => {
    const paths = [...form.querySelectorAll("[data-error-for]")].map((s) => s.dataset.errorFor);
    const p = e.field && pathFor(e.field, paths);
    const spot = p && form.querySelector(`[data-error-for="${CSS.escape(p)}"]`);
    if (!spot) {
      formError.textContent = String(e);
      return;
    }
    spot.textContent = e.message;
    const input = form.querySelector(`[data-path="${CSS.escape(p)}"]`);
    if (input) input.setAttribute("aria-invalid", "true");
  };

  form.addEventListener("submit", async (ev) => {
    ev.preventDefault();
    for (const s of form.querySelectorAll(".field-error")) s.textContent = "";
    for (const i of form.querySelectorAll("[aria-invalid]")) i.removeAttribute("aria-invalid");
    formError.textContent = "";
    submit.disabled = true;
    try {
      const job = { scene: scene.value, halt: {} };
      if (algorithm.value) job.algorithm = algorithm.value;
      const params = {};
      for (const i of paramsBox.querySelectorAll("input.param")) {
        if (i.value.trim() !== "") params[i.dataset.param] = parseValue(i.value.trim());
      }
      if (Object.keys(params).length) job.params = params;
      if (spp.value.trim()) job.halt.spp = parseValue(spp.value.trim());
      if (time.value.trim()) job.halt.time_s = parseValue(time.value.trim());
      if (target.value.trim()) job.halt.target_rmse = parseValue(target.value.trim());
      if (noise.value.trim()) job.halt.noise = parseValue(noise.value.trim());
      if (variance.checked) job.variance_layer = true;
      if (refFile.files.length) {
        const resp = await request("/v1/references", { method: "POST", raw: refFile.files[0] });
        job.reference = { upload: (await resp.json()).id };
      } else if (refJob.value) {
        job.reference = { job: refJob.value };
      }
      if (seed.value.trim()) job.seed = parseValue(seed.value.trim());
      if (priority.value.trim()) job.priority = parseValue(priority.value.trim());
      if (name.value.trim()) job.name = name.value.trim();
      const t = tags.value.split(",").map((x) => x.trim()).filter(Boolean);
      if (t.length) job.tags = t;
      if (every.value.trim()) job.snapshot_every = { [everyKind.value]: parseValue(every.value.trim()) };
      const created = await api("/v1/jobs", { method: "POST", body: job });
      location.hash = `#/job/${encodeURIComponent(created.id)}`;
    } catch (e) {
      if (e.name !== "AbortError") showError(e);
    } finally {
      submit.disabled = false;
    }
  });
}
