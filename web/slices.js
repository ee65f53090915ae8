// ugvr view: cutting planes (docs/slices.md). A panel section of its own, built here: "add plane" adds a plane through
// the data's centre; each plane has an axis (x, y, z or the view direction when added), a position along its normal
// (dragging the slider moves the plane through the data), two turning angles about the axes across it, an opacity and
// a colour map (the volume's or a preset) and a number of contour lines; "hide volume" hides the volume on one side of
// the planes; "drag planes on the view" (or Ctrl) lets a drag on the canvas move the plane under the pointer
// (canvasDrag, used by app.js's camera controls). Every change sends the whole list in one settings message ({"slices":
// [...], "hide_volume": ...}, view_protocol.h), queued like app.js's own so that a drag sends one message per animation
// frame. Loaded after vec.js and before app.js, whose globals (scene, camera, queue) it reads only when the user acts
// or a scene arrives (app.js calls ugvrSlices.onScene).
'use strict';

const ugvrSlices = (() => {
  const MAX_PLANES = 8;  // render_settings.h kMaxSlices
  const planes = [];     // {axis: unit [x, y, z], position in [0, 1], turn1, turn2 (degrees), opacity, map}
  let hide = 'none';
  let sentLists = 0;  // settings messages with slices queued (for the test hook)
  let panel = null;

  const bounds = () => (scene ? scene.bounds : {min: [0, 0, 0], max: [1, 1, 1]});
  const centre = () => mul(add(bounds().min, bounds().max), 0.5);

  // Two unit vectors across the axis: the plane turns about them.
  function across(axis) {
    const helper = Math.abs(axis[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
    const u = norm(cross(axis, helper));
    return [u, cross(axis, u)];
  }

  // The plane's normal (the axis turned by the two angles) and its point: `position` of the way along the normal
  // across the data's bounds (0: touching the corner farthest back, 1: the one farthest forward).
  function planeOf(p) {
    const [u, v] = across(p.axis);
    let n = rotate(p.axis, u, (p.turn1 * Math.PI) / 180);
    n = norm(rotate(n, v, (p.turn2 * Math.PI) / 180));
    const lo = bounds().min, hi = bounds().max, c = centre();
    let a = Infinity, b = -Infinity;
    for (let k = 0; k < 8; ++k) {
      const d = dot(sub([k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]], c), n);
      a = Math.min(a, d), b = Math.max(b, d);
    }
    // Just inside the ends, so that the ends still cut the data.
    const s = a + (b - a) * (0.001 + 0.998 * p.position);
    return {point: add(c, mul(n, s)), normal: n};
  }

  function message() {
    return {
      type: 'settings',
      hide_volume: hide,
      slices: planes.map((p) => {
        const {point, normal} = planeOf(p);
        return {
          point,
          normal,
          opacity: p.opacity,
          color_map: p.map === 'volume' ? '' : p.map,
          range: null,
          contours: p.contours
        };
      }),
    };
  }

  // The last list queued, as text: a change that leaves it as it was (a slider's input event at the same value, a
  // drag pushing a plane against the end of its travel) sends nothing. The server draws every message it accepts,
  // and one that changes nothing after the view has converged costs a full-quality frame, which the next real move
  // then waits for (bench/README.md, "Cutting planes": what made a plane drag slower than a camera drag).
  let lastSent = '';
  function changed() {
    const m = message();
    const text = JSON.stringify(m);
    if (text === lastSent) return;
    lastSent = text;
    queue(m);
    sentLists++;
  }

  // ---- dragging planes on the canvas ----
  // With "drag planes" on (or Ctrl held), a left drag that starts on a plane moves that plane instead of the camera:
  // along its normal, following the pointer's motion projected on the normal's direction on screen; with Shift it
  // turns the plane (horizontal motion: the first angle, vertical: the second). The pick is done here from the camera
  // and the planes (no server round trip): the plane whose hit inside the data's bounds is nearest the camera. The
  // moves are queued like the sliders' (app.js sends one settings message per animation frame).
  let dragMode = false;
  let drag = null;  // {index, canvas, perWorld: screen pixels per world unit along the normal, dir: its unit direction}

  // The plane under canvas point (x, y): {index, t, point}, or null.
  function pick(rect, x, y) {
    if (!camera) return null;
    const ray = viewRayAt(camera, rect, x, y);
    const lo = bounds().min, hi = bounds().max;
    const eps = 1e-9 * vlen(sub(hi, lo));
    let best = null;
    planes.forEach((p, index) => {
      const {point, normal} = planeOf(p);
      const nd = dot(normal, ray.dir);
      if (nd === 0) return;
      const t = dot(normal, sub(point, ray.origin)) / nd;
      const hit = add(ray.origin, mul(ray.dir, t));
      const inside = hit.every((v, k) => v >= lo[k] - eps && v <= hi[k] + eps);
      if (t > 0 && inside && (!best || t < best.t)) best = {index, t, point: hit};
    });
    return best;
  }

  function syncSliders(i) {
    if (!panel) return;
    const box = panel.querySelectorAll('.slice')[i];
    if (!box) return;
    const [position, turn1, turn2] = box.querySelectorAll('input[type=range]');
    const p = planes[i];
    position.value = p.position, turn1.value = p.turn1, turn2.value = p.turn2;
  }

  function canvasDrag(canvas) {
    return {
      down(e) {
        if (!(dragMode || e.ctrlKey) || !planes.length) return false;
        const rect = canvas.getBoundingClientRect();
        const hit = pick(rect, e.clientX - rect.left, e.clientY - rect.top);
        if (!hit) return false;
        // The normal's direction on screen and its length per world unit, at the picked point (view_rays.js).
        const {normal} = planeOf(planes[hit.index]);
        const span = vlen(sub(bounds().max, bounds().min)) || 1;
        const {dir, perWorld} = screenAxis(camera, rect, hit.point, normal, span);
        drag = {index: hit.index, perWorld, dir};
        return true;
      },
      move(e, dx, dy) {
        if (!drag) return;
        const p = planes[drag.index];
        if (!p) return;
        if (e.shiftKey) {
          p.turn1 = Math.max(-90, Math.min(90, p.turn1 + dx * 0.5));
          p.turn2 = Math.max(-90, Math.min(90, p.turn2 - dy * 0.5));
        } else {
          // World distance along the normal, then the fraction of the plane's travel (planeOf: 0.998 of the extent of
          // the bounds along the normal).
          const world = (dx * drag.dir[0] + dy * drag.dir[1]) / drag.perWorld;
          const {normal} = planeOf(p);
          const lo = bounds().min, hi = bounds().max;
          let extent = 0;
          for (let k = 0; k < 3; ++k) extent += Math.abs(normal[k]) * (hi[k] - lo[k]);
          if (extent > 0) p.position = Math.max(0, Math.min(1, p.position + world / (0.998 * extent)));
        }
        syncSliders(drag.index);
        changed();
      },
      up() { drag = null; },
    };
  }

  function row(label, ...controls) {
    const r = document.createElement('div');
    r.className = 'row';
    const l = document.createElement('label');
    l.textContent = label;
    r.append(l, ...controls);
    return r;
  }

  function slider(min, max, step, value, onInput) {
    const s = document.createElement('input');
    Object.assign(s, {type: 'range', min, max, step, value});
    s.addEventListener('input', () => onInput(Number(s.value)));
    return s;
  }

  function render() {
    if (!panel) return;
    const list = panel.querySelector('.slice-list');
    list.replaceChildren();
    planes.forEach((p, i) => {
      const box = document.createElement('div');
      box.className = 'slice';
      box.dataset.index = String(i);
      const remove = document.createElement('button');
      remove.textContent = 'remove';
      remove.className = 'slice-remove';
      remove.addEventListener('click', () => {
        planes.splice(i, 1);
        render();
        changed();
      });
      const title = document.createElement('span');
      title.className = 'note';
      title.textContent = `plane ${i + 1} (${p.axisName})`;
      const head = document.createElement('div');
      head.className = 'row';
      head.append(title, remove);
      const maps = document.createElement('select');
      maps.className = 'slice-map';
      for (const name of ['volume', ...(scene ? scene.presets : [])])
        maps.append(new Option(name === 'volume' ? 'the volume\'s' : name, name, false, name === p.map));
      maps.addEventListener('change', () => {
        p.map = maps.value;
        changed();
      });
      // Contour lines: how many, evenly spaced over the colour map's range (render_settings.h, at most 64).
      const lines = document.createElement('input');
      Object.assign(lines, {type: 'number', min: 0, max: 64, step: 1, value: p.contours, className: 'slice-contours'});
      lines.addEventListener('input', () => {
        const n = Math.round(Number(lines.value));
        if (!(n >= 0 && n <= 64)) return;
        p.contours = n;
        changed();
      });
      const position = slider(0, 1, 0.002, p.position, (v) => ((p.position = v), changed()));
      position.className = 'slice-position';
      box.append(
          head, row('position', position),
          row('turn', slider(-90, 90, 1, p.turn1, (v) => ((p.turn1 = v), changed())),
              slider(-90, 90, 1, p.turn2, (v) => ((p.turn2 = v), changed()))),
          row('opacity', slider(0.05, 1, 0.01, p.opacity, (v) => ((p.opacity = v), changed()))), row('colours', maps),
          row('contour lines', lines));
      list.append(box);
    });
    panel.querySelector('.slice-add').disabled = planes.length >= MAX_PLANES;
  }

  function addPlane(axisName) {
    if (planes.length >= MAX_PLANES) return;
    let axis = {x: [1, 0, 0], y: [0, 1, 0], z: [0, 0, 1]}[axisName];
    if (!axis) axis = camera ? norm(sub(camera.focal_point, camera.position)) : [0, 0, 1];
    planes.push({axis, axisName, position: 0.5, turn1: 0, turn2: 0, opacity: 1, map: 'volume', contours: 0});
    render();
    changed();
  }

  function build() {
    const host = document.getElementById('panel');
    if (!host || panel) return;
    panel = document.createElement('div');
    panel.id = 'slices';
    const axis = document.createElement('select');
    axis.className = 'slice-axis';
    for (const a of ['x', 'y', 'z', 'view']) axis.append(new Option(a === 'view' ? 'view direction' : a, a));
    const addButton = document.createElement('button');
    addButton.className = 'slice-add';
    addButton.textContent = 'add plane';
    addButton.addEventListener('click', () => addPlane(axis.value));
    const hideSelect = document.createElement('select');
    hideSelect.className = 'slice-hide';
    for (const [v, t] of [
             ['none', 'nowhere'], ['front', 'in front of the planes'], ['back', 'behind the planes'],
             ['all', 'everywhere']])
      hideSelect.append(new Option(t, v));
    hideSelect.addEventListener('change', () => {
      hide = hideSelect.value;
      changed();
    });
    const move = document.createElement('input');
    move.type = 'checkbox';
    move.className = 'slice-drag';
    move.title = 'drag a plane on the view to move it along its normal, shift-drag to turn it (or hold Ctrl)';
    move.addEventListener('change', () => (dragMode = move.checked));
    const list = document.createElement('div');
    list.className = 'slice-list';
    panel.append(
        row('slices', axis, addButton), row('hide volume', hideSelect), row('drag planes on the view', move), list);
    const buttons = host.querySelector('.buttons');
    host.insertBefore(panel, buttons);
    render();
  }

  document.addEventListener('DOMContentLoaded', build);
  if (document.readyState !== 'loading') build();

  return {
    // A new scene (bounds, presets): rebuild the colour-map lists; planes keep their place in the new bounds.
    onScene() {
      render();
      if (planes.length || hide !== 'none') changed();
    },
    add: addPlane,
    canvasDrag,
    // "drag planes" on or off (the panel's checkbox does the same).
    set dragMode(on) {
      dragMode = Boolean(on);
      const box = panel && panel.querySelector('.slice-drag');
      if (box) box.checked = dragMode;
    },
    // Where plane i is hit by the pixel ray nearest the canvas centre, searching outwards (for tests that drag it):
    // page coordinates, or null.
    planeOnCanvas(canvas, i) {
      const rect = canvas.getBoundingClientRect();
      for (let r = 0; r < Math.max(rect.width, rect.height) / 2; r += 4)
        for (let a = 0; a < 16; ++a) {
          const x = rect.width / 2 + r * Math.cos((a * Math.PI) / 8),
                y = rect.height / 2 + r * Math.sin((a * Math.PI) / 8);
          const hit = pick(rect, x, y);
          if (hit && hit.index === i) return {x: rect.left + x, y: rect.top + y};
        }
      return null;
    },
    // Read-only state for tests/e2e.
    get state() {
      return {
        planes: planes.map((p) => ({...planeOf(p), opacity: p.opacity, map: p.map, contours: p.contours})),
        hide,
        sentLists,
        dragging: drag !== null,
      };
    },
    // Where the i-th plane's position slider is, in page coordinates, and its width (for tests that drag it).
    positionSlider(i) {
      const s = panel.querySelectorAll('.slice-position')[i];
      const b = s.getBoundingClientRect();
      return {x: b.left, y: b.top + b.height / 2, width: b.width};
    },
  };
})();
window.ugvrSlices = ugvrSlices;
