// The REST client of the dashboard: every call goes through `api`, which adds the
// bearer token (kept in sessionStorage, asked for when the server answers 401) and
// turns the server's JSON errors, {"error": {"code", "message", "field"}}, into ApiError.

const TOKEN_KEY = "caustic-token";

export class ApiError extends Error {
  /// `field`: the parameter at fault as the request wrote it (`params.radius`), when
  /// the server names one.
  constructor(status, code, message, field) {
    super(message);
    this.status = status;
    this.code = code;
    this.field = field;
  }
  toString() {
    return `${this.status} ${this.code}: ${this.message}`;
  }
}

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || "";
}

export function setToken(t) {
  if (t) sessionStorage.setItem(TOKEN_KEY, t);
  else sessionStorage.removeItem(TOKEN_KEY);
}

export function headers(extra = {}) {
  const h = { ...extra };
  const t = token();
  if (t) h["authorization"] = `Bearer ${t}`;
  return h;
}

/// Reads an error answer as ApiError, whatever its body holds.
async function errorOf(resp) {
  let code = "error";
  let message = resp.statusText || "request failed";
  let field;
  try {
    const body = await resp.json();
    if (body && body.error) {
      code = body.error.code || code;
      message = body.error.message || message;
      field = body.error.field;
    }
  } catch (_) {
    // Not JSON: keep the status line.
  }
  if (resp.status === 401) {
    window.dispatchEvent(new CustomEvent("caustic-unauthorized", { detail: message }));
  }
  return new ApiError(resp.status, code, message, field);
}

/// A raw response for `path` (throws ApiError on 4xx/5xx and on network failures).
/// `body` is sent as JSON, `raw` (a Blob or bytes) as it is.
export async function request(path, { method = "GET", body, raw, accept, signal } = {}) {
  const h = headers(accept ? { accept } : {});
  let payload = raw;
  if (body !== undefined) {
    h["content-type"] = "application/json";
    payload = JSON.stringify(body);
  }
  let resp;
  try {
    resp = await fetch(path, { method, headers: h, body: payload, signal });
  } catch (e) {
    if (e.name === "AbortError") throw e;
    throw new ApiError(0, "network", `the server did not answer (${e.message})`);
  }
  if (!resp.ok) throw await errorOf(resp);
  return resp;
}

/// JSON of `path` (null for 204).
export async function api(path, opts = {}) {
  const resp = await request(path, { accept: "application/json", ...opts });
  if (resp.status === 204) return null;
  return resp.json();
}

export async function text(path, opts = {}) {
  return (await request(path, opts)).text();
}

export async function blob(path, opts = {}) {
  return (await request(path, opts)).blob();
}

/// Saves what `path` answers as a file: the download goes through fetch so that the
/// token travels in a header, never in a URL.
export async function download(path, filename) {
  const b = await blob(path);
  const url = URL.createObjectURL(b);
  const a = document.createElement("a");
  a.href = url;
  a.download = filename;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}
