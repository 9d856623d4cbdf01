// The dashboard's entry point: hash-based routing (#/jobs, #/job/ID, #/submit,
// #/sweep/ID, #/server: workers and metrics) and the token prompt.

import { setToken, token } from "./api.js";
import { listPage } from "./list.js";
import { jobPage } from "./job.js";
import { submitPage } from "./submit.js";
import { sweepPage } from "./sweep.js";
import { workersPage } from "./workers.js";

const routes = {
  jobs: listPage,
  job: jobPage,
  submit: submitPage,
  sweep: sweepPage,
  server: workersPage,
};

let cleanup = null;

/// "#/job/ID?x=1" -> {name: "job", arg: "ID", query: URLSearchParams}
export function parseHash(hash) {
  const h = hash.replace(/^#\/?/, "");
  const [path, q = ""] = h.split("?");
  const [name, ...rest] = path.split("/");
  return {
    name: name || "jobs",
    arg: rest.length ? decodeURIComponent(rest.join("/")) : undefined,
    query: new URLSearchParams(q),
  };
}

function route() {
  if (cleanup) cleanup();
  cleanup = null;
  const r = parseHash(location.hash);
  const page = routes[r.name] || listPage;
  for (const a of document.querySelectorAll("nav a")) {
    a.classList.toggle("active", a.dataset.route === r.name);
  }
  const view = document.getElementById("view");
  view.replaceChildren();
  window.scrollTo(0, 0);
  const controller = new AbortController();
  const c = page(view, r, controller.signal);
  cleanup = () => {
    controller.abort();
    if (typeof c === "function") c();
  };
}

function tokenUi() {
  const form = document.getElementById("token-form");
  const input = document.getElementById("token-input");
  const forget = document.getElementById("token-forget");
  const message = document.getElementById("token-message");
  const show = () => {
    forget.hidden = !token();
  };
  form.addEventListener("submit", (e) => {
    e.preventDefault();
    setToken(input.value.trim());
    input.value = "";
    form.hidden = true;
    message.hidden = true;
    show();
    route();
  });
  forget.addEventListener("click", () => {
    setToken("");
    show();
    form.hidden = false;
  });
  window.addEventListener("caustic-unauthorized", (e) => {
    form.hidden = false;
    message.hidden = false;
    message.textContent = token()
      ? `The server refused the token (${e.detail}); enter the right one.`
      : "This server needs a token (caustic serve --token): enter it above. It is kept in this tab's sessionStorage only.";
    input.focus();
  });
  show();
}

tokenUi();
window.addEventListener("hashchange", route);
route();
