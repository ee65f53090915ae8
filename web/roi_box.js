// ugvr view: the region-of-interest box on the view (issue 17: "a draggable box"). The focus panel's box (its corners
// in #roi-lo / #roi-hi, on with #roi) is drawn over the image as a wireframe (an overlay canvas that takes no pointer
// events). With "drag the box on the view" on, a left drag that starts on the box moves the face the pointer is on
// along its axis (following the pointer's motion projected on that axis on screen, view_rays.js), within the data's
// bounds and never past the opposite face; the corners follow in the panel while dragging, and the focus is applied
// (one interest message) when the drag ends. Loaded after view_rays.js and before app.js, whose globals (scene,
// camera) it reads only when the user acts or a frame is drawn; app.js chains canvasDrag with the planes' own and
// calls draw() at each of its animation frames.
"use strict";

const ugvrRoi = (() => {
  const $ = (id) => document.getElementById(id);
  let dragMode = false;
  let drag = null;  // {axis: 0..2, side: 0 (lo) | 1 (hi), dir, perWorld}
  let drawn = "";   // what the overlay shows (camera, box, size), to redraw only on a change

  const parse = (text) => {
    const v = text.split(",").map((s) => Number.parseFloat(s));
    return v.length === 3 && v.every(Number.isFinite) ? v : null;
  };
  // The box as the panel has it ({lo, hi}, ordered), or null when off or not three numbers each.
  function box() {
    if (!$("roi").checked) return null;
    const a = parse($("roi-lo").value), b = parse($("roi-hi").value);
    if (!a || !b) return null;
    return { lo: a.map((v, k) => Math.min(v, b[k])), hi: a.map((v, k) => Math.max(v, b[k])) };
  }
  const format = (v) => v.map((x) => String(+x.toPrecision(6))).join(",");

  // The face the ray through (x, y) enters the box by (slab method): {axis, side, point}, or null.
  function pickFace(rect, x, y) {
    const b = box();
    if (!b || !camera) return null;
    const ray = viewRayAt(camera, rect, x, y);
    let tin = -Infinity, tout = Infinity, axis = -1, side = 0;
    for (let k = 0; k < 3; ++k) {
      if (ray.dir[k] === 0) {
        if (ray.origin[k] < b.lo[k] || ray.origin[k] > b.hi[k]) return null;
        continue;
      }
      const t0 = (b.lo[k] - ray.origin[k]) / ray.dir[k], t1 = (b.hi[k] - ray.origin[k]) / ray.dir[k];
      const near = Math.min(t0, t1), far = Math.max(t0, t1);
      if (near > tin) tin = near, axis = k, side = t0 < t1 ? 0 : 1;
      tout = Math.min(tout, far);
    }
    if (axis < 0 || !(tin <= tout) || tout <= 0) return null;
    return { axis, side, point: add(ray.origin, mul(ray.dir, Math.max(tin, 0))) };
  }

  function canvasDrag(canvas) {
    return {
      down(e) {
        if (!dragMode || !scene) return false;
        const rect = canvas.getBoundingClientRect();
        const hit = pickFace(rect, e.clientX - rect.left, e.clientY - rect.top);
        if (!hit) return false;
        const unit = [0, 0, 0];
        unit[hit.axis] = 1;
        const span = vlen(sub(scene.bounds.max, scene.bounds.min)) || 1;
        drag = { axis: hit.axis, side: hit.side, ...screenAxis(camera, rect, hit.point, unit, span) };
        return true;
      },
      move(e, dx, dy) {
        const b = box();
        if (!drag || !b) return;
        const k = drag.axis, world = (dx * drag.dir[0] + dy * drag.dir[1]) / drag.perWorld;
        const lo = scene.bounds.min[k], hi = scene.bounds.max[k], gap = 1e-3 * (hi - lo);
        if (drag.side === 0) b.lo[k] = Math.max(lo, Math.min(b.hi[k] - gap, b.lo[k] + world));
        else b.hi[k] = Math.min(hi, Math.max(b.lo[k] + gap, b.hi[k] + world));
        $("roi-lo").value = format(b.lo);
        $("roi-hi").value = format(b.hi);
      },
      up() {
        if (!drag) return;
        drag = null;
        $("interest-apply").click();
      },
    };
  }

  // The overlay: the box's 12 edges, the face being dragged brighter.
  function draw() {
    const overlay = $("roi-overlay"), view = $("canvas");
    const b = box();
    const rect = view.getBoundingClientRect();
    const key = JSON.stringify([b, camera, rect.width, rect.height, drag && [drag.axis, drag.side]]);
    if (key === drawn) return;
    drawn = key;
    if (overlay.width !== Math.round(rect.width) || overlay.height !== Math.round(rect.height))
      overlay.width = Math.round(rect.width), overlay.height = Math.round(rect.height);
    const ctx = overlay.getContext("2d");
    ctx.clearRect(0, 0, overlay.width, overlay.height);
    if (!b || !camera) return;
    const corner = (i) => [i & 1 ? b.hi[0] : b.lo[0], i & 2 ? b.hi[1] : b.lo[1], i & 4 ? b.hi[2] : b.lo[2]];
    for (let i = 0; i < 8; ++i)
      for (let k = 0; k < 3; ++k) {
        const j = i | (1 << k);
        if (j === i) continue;
        const p = viewProject(camera, rect, corner(i)), q = viewProject(camera, rect, corner(j));
        if (!p || !q) continue;
        const onDragged = drag && ((i >> drag.axis) & 1) === drag.side && k !== drag.axis;
        ctx.strokeStyle = onDragged ? "#ffd36b" : "rgba(217, 164, 65, 0.8)";
        ctx.lineWidth = onDragged ? 2.5 : 1.5;
        ctx.beginPath();
        ctx.moveTo(p[0], p[1]);
        ctx.lineTo(q[0], q[1]);
        ctx.stroke();
      }
  }
  return {
    canvasDrag,
    draw,  // app.js's animation frame calls it: redraws only what changed
    set dragMode(on) {
      dragMode = Boolean(on);
      $("roi-drag").checked = dragMode;
    },
    get dragMode() { return dragMode; },
    // For tests: where the centre of a face (axis 0..2, side 0 | 1) appears, in page coordinates, or null.
    faceCentre(axis, side) {
      const b = box();
      if (!b || !camera) return null;
      const p = b.lo.map((v, k) => (k === axis ? (side ? b.hi[k] : b.lo[k]) : 0.5 * (v + b.hi[k])));
      const rect = $("canvas").getBoundingClientRect();
      const s = viewProject(camera, rect, p);
      return s && [rect.left + s[0], rect.top + s[1]];
    },
    get dragging() { return drag !== null; },
    // For tests: the face a drag starting at page point (x, y) would take ({axis, side}), or null.
    faceAt(x, y) {
      const rect = $("canvas").getBoundingClientRect();
      const hit = pickFace(rect, x - rect.left, y - rect.top);
      return hit && { axis: hit.axis, side: hit.side };
    },
    // For tests: where world point p appears, in page coordinates, or null.
    pageOf(p) {
      const rect = $("canvas").getBoundingClientRect();
      const s = camera && viewProject(camera, rect, p);
      return s && [rect.left + s[0], rect.top + s[1]];
    },
  };
})();

document.getElementById("roi-drag").addEventListener("change", (e) => (ugvrRoi.dragMode = e.target.checked));
