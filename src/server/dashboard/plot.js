// A log-log line plot on a canvas: error vs time, one line per series, with a tick
// and a grid line at every power of ten.

/// series: [{name, color, points: [[x, y], ...]}]; non-positive values are skipped.
export function logLogPlot(canvas, series, { xLabel = "", yLabel = "" } = {}) {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth || canvas.width;
  const h = canvas.clientHeight || canvas.height;
  canvas.width = Math.round(w * dpr);
  canvas.height = Math.round(h * dpr);
  const g = canvas.getContext("2d");
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, w, h);
  const style = getComputedStyle(document.documentElement);
  const muted = style.getPropertyValue("--muted").trim() || "#999";
  const line = style.getPropertyValue("--line").trim() || "#444";
  g.font = "11px system-ui, sans-serif";
  const pts = series.flatMap((s) => s.points).filter(([x, y]) => x > 0 && y > 0 && isFinite(x) && isFinite(y));
  if (pts.length === 0) {
    g.fillStyle = muted;
    g.fillText("no error figures yet (a job logs RMSE only against a reference)", 12, h / 2);
    return;
  }
  const lx = pts.map(([x]) => Math.log10(x));
  const ly = pts.map(([, y]) => Math.log10(y));
  let [x0, x1] = [Math.floor(Math.min(...lx)), Math.ceil(Math.max(...lx))];
  let [y0, y1] = [Math.floor(Math.min(...ly)), Math.ceil(Math.max(...ly))];
  if (x1 === x0) x1 += 1;
  if (y1 === y0) y1 += 1;
  const m = { l: 52, r: 12, t: 12, b: 34 };
  const px = (x) => m.l + ((Math.log10(x) - x0) / (x1 - x0)) * (w - m.l - m.r);
  const py = (y) => h - m.b - ((Math.log10(y) - y0) / (y1 - y0)) * (h - m.t - m.b);
  g.strokeStyle = line;
  g.fillStyle = muted;
  g.lineWidth = 1;
  for (let e = x0; e <= x1; e++) {
    const x = px(10 ** e);
    g.beginPath();
    g.moveTo(x, m.t);
    g.lineTo(x, h - m.b);
    g.stroke();
    g.fillText(`1e${e}`, x - 10, h - m.b + 14);
  }
  for (let e = y0; e <= y1; e++) {
    const y = py(10 ** e);
    g.beginPath();
    g.moveTo(m.l, y);
    g.lineTo(w - m.r, y);
    g.stroke();
    g.fillText(`1e${e}`, 6, y + 4);
  }
  g.fillText(xLabel, w / 2 - 20, h - 6);
  let ly0 = m.t + 12;
  for (const s of series) {
    const p = s.points.filter(([x, y]) => x > 0 && y > 0 && isFinite(x) && isFinite(y));
    g.strokeStyle = s.color;
    g.fillStyle = s.color;
    g.lineWidth = 1.5;
    g.beginPath();
    p.forEach(([x, y], i) => (i ? g.lineTo(px(x), py(y)) : g.moveTo(px(x), py(y))));
    g.stroke();
    for (const [x, y] of p) g.fillRect(px(x) - 1.5, py(y) - 1.5, 3, 3);
    if (p.length) {
      g.fillText(s.name, w - m.r - Math.max(70, g.measureText(s.name).width + 4), ly0);
      ly0 += 14;
    }
  }
  if (yLabel) {
    g.fillStyle = muted;
    g.fillText(yLabel, m.l + 6, m.t + 12);
  }
}
