// ugvr view: the focus brush (issue 17, SimVis's brush on a histogram). One canvas shows the histogram of the focus
// field's values (tf_editor.js's drawLogHistogram, loaded before) with the brushed value range highlighted. Drag
// across it to brush a new range; onBrush(lo, hi) is called when the drag ends (the page then sends the focus, so a
// drag costs one frame of the new interest, not one per pointer move). A drag shorter than 3 pixels is a click and
// changes nothing. The brush has a smooth edge (docs/hybrid.md): onBrush's third argument, over which the interest
// falls to 0 outside the range, drawn as a fainter band on either side; EDGE_FRACTION of the field's range to start
// with. Dragging a band's outer end (within HANDLE_PX of it) sets the edge instead of the range: both bands follow,
// and onBrush is called when that drag ends too.
"use strict";

class FocusBrush {
  // A fiftieth of the field's range: narrow enough to keep the brushed range what the user drew, wide enough to span
  // a few samples of a node's brick, so that the focus border is seen to follow the data rather than the nodes.
  static EDGE_FRACTION = 0.02;
  static HANDLE_PX = 4;

  constructor(canvas, onBrush) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.onBrush = onBrush;
    this.lo = 0, this.hi = 1;         // the field's range
    this.histogram = [];
    this.range = null;                // [min, max] brushed, in data values; null: none
    this.anchor = null;               // the drag's start in canvas pixels, while dragging
    this.edgeDrag = false;            // whether the drag under way sets the edge (a band's end was grabbed)
    this.edgeFraction = FocusBrush.EDGE_FRACTION;
    this.pad = 4;
    canvas.addEventListener("pointerdown", (e) => this.pointerDown(e));
    canvas.addEventListener("pointermove", (e) => this.pointerMove(e));
    canvas.addEventListener("pointerup", (e) => this.pointerUp(e));
    canvas.addEventListener("pointercancel", () => { this.anchor = null; });
  }

  setField(lo, hi, histogram) {
    this.lo = lo, this.hi = hi > lo ? hi : lo + 0.5;
    if (!(hi > lo)) this.lo = lo - 0.5;
    this.histogram = histogram || [];
    this.draw();
  }
  setRange(min, max) {
    this.range = Number.isFinite(min) && Number.isFinite(max) ? [Math.min(min, max), Math.max(min, max)] : null;
    this.draw();
  }

  // The brush's edge in data values.
  edge() { return this.edgeFraction * (this.hi - this.lo); }
  // The edge's width in canvas pixels.
  edgePx() { return this.toPx(this.lo + this.edge()) - this.toPx(this.lo); }
  // Whether canvas x is on the outer end of either edge band (the handles that set the edge).
  onEdgeHandle(x) {
    if (!this.range) return false;
    const e = this.edgePx();
    return Math.abs(x - (this.toPx(this.range[0]) - e)) <= FocusBrush.HANDLE_PX ||
           Math.abs(x - (this.toPx(this.range[1]) + e)) <= FocusBrush.HANDLE_PX;
  }
  // The edge fraction that puts a band's outer end at canvas x: its distance from the nearer end of the range (0
  // inside it), x clamped to the plot.
  edgeAt(x) {
    const v = this.fromPx(x);
    const d = v < this.range[0] ? this.range[0] - v : v > this.range[1] ? v - this.range[1] : 0;
    return d / (this.hi - this.lo);
  }

  // Data value <-> canvas x (the plot spans the canvas less its padding).
  toPx(v) { return this.pad + ((v - this.lo) / (this.hi - this.lo)) * (this.canvas.width - 2 * this.pad); }
  fromPx(px) {
    const f = Math.min(1, Math.max(0, (px - this.pad) / (this.canvas.width - 2 * this.pad)));
    return this.lo + f * (this.hi - this.lo);
  }
  eventPx(e) {
    const b = this.canvas.getBoundingClientRect();
    return ((e.clientX - b.left) * this.canvas.width) / b.width;
  }

  pointerDown(e) {
    this.anchor = this.eventPx(e);
    this.edgeDrag = this.onEdgeHandle(this.anchor);
    this.canvas.setPointerCapture?.(e.pointerId);
  }
  pointerMove(e) {
    if (this.anchor === null) return;
    const x = this.eventPx(e);
    if (Math.abs(x - this.anchor) < 3) return;
    if (this.edgeDrag) {
      this.edgeFraction = this.edgeAt(x);
      this.draw();
    } else {
      this.setRange(this.fromPx(this.anchor), this.fromPx(x));
    }
  }
  pointerUp(e) {
    if (this.anchor === null) return;
    const x = this.eventPx(e), anchor = this.anchor;
    this.anchor = null;
    if (Math.abs(x - anchor) < 3) return;
    if (this.edgeDrag) this.edgeFraction = this.edgeAt(x);
    else this.setRange(this.fromPx(anchor), this.fromPx(x));
    this.onBrush(this.range[0], this.range[1], this.edge());
  }

  draw() {
    const ctx = this.ctx, w = this.canvas.width, h = this.canvas.height, p = this.pad;
    ctx.clearRect(0, 0, w, h);
    const bins = this.histogram.length;
    const inRange = (b) => {
      const centre = this.lo + ((b + 0.5) / bins) * (this.hi - this.lo);
      return this.range && centre >= this.range[0] && centre <= this.range[1];
    };
    drawLogHistogram(ctx, this.histogram, p, w - p, p, h - p, (b) => (inRange(b) ? "#d9a441" : "#4a4f5c"));
    if (this.range) {
      const x0 = this.toPx(this.range[0]), x1 = this.toPx(this.range[1]);
      const e = this.edgePx();
      ctx.fillStyle = "rgba(217, 164, 65, 0.08)";  // the edges, where the interest falls off
      ctx.fillRect(x0 - e, 0, e, h);
      ctx.fillRect(x1, 0, e, h);
      ctx.fillStyle = "rgba(217, 164, 65, 0.18)";
      ctx.fillRect(x0, 0, Math.max(1, x1 - x0), h);
      ctx.strokeStyle = "#d9a441";
      ctx.lineWidth = 1;
      ctx.strokeRect(x0 + 0.5, 0.5, Math.max(1, x1 - x0 - 1), h - 1);
      ctx.strokeStyle = "rgba(217, 164, 65, 0.5)";  // the handles: the bands' outer ends
      ctx.beginPath();
      ctx.moveTo(x0 - e + 0.5, 0), ctx.lineTo(x0 - e + 0.5, h);
      ctx.moveTo(x1 + e - 0.5, 0), ctx.lineTo(x1 + e - 0.5, h);
      ctx.stroke();
    }
  }
}
