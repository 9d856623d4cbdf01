// Server-Sent Events read through fetch streaming, so that the bearer token goes in a
// header (EventSource cannot send one, and a token in the URL would end up in logs).

import { request } from "./api.js";

/// Parses an SSE byte stream: calls onEvent(name, data) per event; resolves when the
/// stream ends. Comments (keep-alives) and ids are ignored.
export async function readEvents(body, onEvent) {
  const reader = body.pipeThrough(new TextDecoderStream()).getReader();
  let buffer = "";
  let name = "message";
  let data = [];
  for (;;) {
    const { value, done } = await reader.read();
    if (done) return;
    buffer += value;
    let nl;
    while ((nl = buffer.search(/\r\n|\n|\r/)) >= 0) {
      const line = buffer.slice(0, nl);
      buffer = buffer.slice(nl + (buffer.startsWith("\r\n", nl) ? 2 : 1));
      if (line === "") {
        if (data.length) onEvent(name, data.join("\n"));
        name = "message";
        data = [];
      } else if (!line.startsWith(":")) {
        const colon = line.indexOf(":");
        const field = colon < 0 ? line : line.slice(0, colon);
        let val = colon < 0 ? "" : line.slice(colon + 1);
        if (val.startsWith(" ")) val = val.slice(1);
        if (field === "event") name = val;
        else if (field === "data") data.push(val);
      }
    }
  }
}

/// Follows a job's event stream: onEvent(name, parsedJson). Reconnects after a drop
/// until a `done` event arrives or `signal` aborts; onError(err) reports failures.
export async function followEvents(path, onEvent, { signal, onError } = {}) {
  let finished = false;
  while (!finished && !signal?.aborted) {
    try {
      const resp = await request(path, { accept: "text/event-stream", signal });
      await readEvents(resp.body, (name, raw) => {
        let parsed = raw;
        try {
          parsed = JSON.parse(raw);
        } catch (_) {
          // Keep the text.
        }
        if (name === "done") finished = true;
        onEvent(name, parsed);
      });
    } catch (e) {
      if (e.name === "AbortError") return;
      onError?.(e);
      if (e.status && e.status < 500) return;
    }
    if (!finished && !signal?.aborted) await new Promise((r) => setTimeout(r, 1000));
  }
}
