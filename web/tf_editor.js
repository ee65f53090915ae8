// ugvr view: the transfer-function editor. One canvas shows, over the field's range, the histogram of its values
// (log-scaled counts), the colour map as a gradient bar along the bottom, and the opacity curve as a polyline whose
// points can be edited: drag a point to move it (between its neighbours, within the range and [0, 1]); click on empty
// space to add one; double-click or right-click a point to remove it (at least two stay). onEdit() is called after
// each change; the page sends the points at most once per animation frame.
"use strict";

// A histogram's bars, log(1 + count) scaled to the tallest bin, across x0..x1 and rising from y1 towards y0 (canvas
// pixels); fill(b) is bin b's colour. Also the focus brush's (focus_brush.js).
function drawLogHistogram(ctx, histogram, x0, x1, y0, y1, fill) {
  const bins = histogram.length;
  if (bins === 0) return;
  const top = Math.log1p(Math.max(...histogram));
  const bw = (x1 - x0) / bins;
  for (let b = 0; b < bins; ++b) {
    const bh = (top > 0 ? Math.log1p(histogram[b]) / top : 0) * (y1 - y0);
    ctx.fillStyle = fill(b);
    ctx.fillRect(x0 + b * bw, y1 - bh, Math.max(1, bw - 0.5), bh);
  }
}

class TfEditor {
  constructor(canvas, onEdit) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.onEdit = onEdit;
    this.lo = 0, this.hi = 1;
    this.histogram = [];
    this.colors = [0, 0, 0, 0, 1, 1, 1, 1];  // flat [x, r, g, b, ...] in data values
    this.points = [[0, 0], [1, 1]];          // [x, opacity] in data values, x strictly increasing
    this.dragging = -1;
    this.pad = 6;          // pixels around the plot
    this.barHeight = 12;   // the colour bar below the plot
    canvas.addEventListener("pointerdown", (e) => this.pointerDown(e));
    canvas.addEventListener("pointermove", (e) => this.pointerMove(e));
    canvas.addEventListener("pointerup", () => { this.dragging = -1; });
    canvas.addEventListener("pointercancel", () => { this.dragging = -1; });
    canvas.addEventListener("dblclick", (e) => this.remove(this.hit(e)));
    canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  }

  // The field's range (a constant field is widened to [lo - 0.5, lo + 0.5], as the server does) and its histogram.
  setField(lo, hi, histogram) {
    this.lo = lo, this.hi = hi > lo ? hi : lo + 0.5;
    if (!(hi > lo)) this.lo = lo - 0.5;
    this.histogram = histogram || [];
    this.draw();
  }
  setColors(flat) { this.colors = flat.slice(); this.draw(); }
  setPoints(points) { this.points = points.map((p) => [p[0], p[1]]); this.draw(); }
  // ParaView's flat layout [x, a, x, a, ...].
  flatPoints() { return this.points.flat(); }

  // Plot area in canvas pixels.
  get plot() {
    const w = this.canvas.width, h = this.canvas.height, p = this.pad;
    return { x0: p, x1: w - p, y0: p, y1: h - p - this.barHeight - 2 };
  }
  toPx(x, a) {
    const r = this.plot;
    return [r.x0 + ((x - this.lo) / (this.hi - this.lo)) * (r.x1 - r.x0), r.y1 - a * (r.y1 - r.y0)];
  }
  fromPx(px, py) {
    const r = this.plot;
    const clamp = (v, lo, hi) => Math.min(hi, Math.max(lo, v));
    return [this.lo + clamp((px - r.x0) / (r.x1 - r.x0), 0, 1) * (this.hi - this.lo),
            clamp((r.y1 - py) / (r.y1 - r.y0), 0, 1)];
  }
  // The event's position in canvas pixels (the canvas may be scaled by CSS).
  eventPx(e) {
    const b = this.canvas.getBoundingClientRect();
    return [((e.clientX - b.left) * this.canvas.width) / b.width, ((e.clientY - b.top) * this.canvas.height) / b.height];
  }
  // Index of the point within 8 pixels of the event, or -1.
  hit(e) {
    const [px, py] = this.eventPx(e);
    let best = -1, bestD = 8;
    this.points.forEach(([x, a], i) => {
      const [qx, qy] = this.toPx(x, a);
      const d = Math.hypot(qx - px, qy - py);
      if (d <= bestD) best = i, bestD = d;
    });
    return best;
  }

  pointerDown(e) {
    e.preventDefault();
    const i = this.hit(e);
    if (e.button === 2) {
      this.remove(i);
      return;
    }
    if (e.button !== 0) return;
    this.canvas.setPointerCapture(e.pointerId);
    if (i >= 0) {
      this.dragging = i;
      return;
    }
    // A new point where the pointer is, then dragged like any other.
    const [x, a] = this.fromPx(...this.eventPx(e));
    let at = this.points.findIndex((p) => p[0] > x);
    if (at < 0) at = this.points.length;
    const eps = (this.hi - this.lo) * 1e-6;
    if ((at > 0 && x - this.points[at - 1][0] < eps) || (at < this.points.length && this.points[at][0] - x < eps)) return;
    this.points.splice(at, 0, [x, a]);
    this.dragging = at;
    this.changed();
  }

  pointerMove(e) {
    const i = this.dragging;
    if (i < 0) return;
    let [x, a] = this.fromPx(...this.eventPx(e));
    // Strictly between the neighbours, so that x stays increasing.
    const eps = (this.hi - this.lo) * 1e-4;
    if (i > 0) x = Math.max(x, this.points[i - 1][0] + eps);
    if (i < this.points.length - 1) x = Math.min(x, this.points[i + 1][0] - eps);
    this.points[i] = [x, a];
    this.changed();
  }

  remove(i) {
    if (i < 0 || this.points.length <= 2) return;
    this.points.splice(i, 1);
    this.dragging = -1;
    this.changed();
  }

  changed() {
    this.draw();
    this.onEdit();
  }

  // The colour at data value x (piecewise linear, clamped), as CSS.
  colorAt(x) {
    const c = this.colors, n = c.length / 4;
    let k = 0;
    while (k < n - 1 && c[4 * (k + 1)] < x) ++k;
    let t = 0;
    if (k < n - 1) {
      const x0 = c[4 * k], x1 = c[4 * (k + 1)];
      t = Math.min(1, Math.max(0, (x - x0) / (x1 - x0)));
    }
    const ch = (j) => Math.round(255 * (c[4 * k + j] + t * ((k < n - 1 ? c[4 * (k + 1) + j] : c[4 * k + j]) - c[4 * k + j])));
    return `rgb(${ch(1)}, ${ch(2)}, ${ch(3)})`;
  }

  draw() {
    const ctx = this.ctx, w = this.canvas.width, h = this.canvas.height, r = this.plot;
    ctx.clearRect(0, 0, w, h);
    drawLogHistogram(ctx, this.histogram, r.x0, r.x1, r.y0, r.y1, () => "#4a4f5c");
    // Colour bar.
    const by = h - this.pad - this.barHeight;
    for (let px = r.x0; px < r.x1; ++px) {
      ctx.fillStyle = this.colorAt(this.fromPx(px + 0.5, 0)[0]);
      ctx.fillRect(px, by, 1, this.barHeight);
    }
    // Opacity curve and its points.
    ctx.strokeStyle = "#e8e8e8";
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    this.points.forEach(([x, a], i) => {
      const [px, py] = this.toPx(x, a);
      if (i === 0) ctx.moveTo(px, py);
      else ctx.lineTo(px, py);
    });
    ctx.stroke();
    for (const [x, a] of this.points) {
      const [px, py] = this.toPx(x, a);
      ctx.fillStyle = this.colorAt(x);
      ctx.beginPath();
      ctx.arc(px, py, 4, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
    }
  }
}
