// ugvr view: mouse and touch on the view canvas turned into camera moves (the camera is camera.h's JSON form, moved
// in place; onChange() is called after each move, and the page sends at most one camera message per frame).
//   left drag: orbit about the focal point (or, where slices.js takes it, move a plane);  shift + left drag, right or
//   middle drag: pan;  wheel: zoom
//   one finger: orbit;  two fingers: pinch to zoom, move to pan
"use strict";

// Orbit: horizontal motion turns about view up through the focal point, vertical motion about the camera's right axis.
function orbitCamera(camera, dx, dy) {
  const up = norm(camera.view_up);
  let offset = sub(camera.position, camera.focal_point);
  offset = rotate(offset, up, -dx * 0.01);
  const right = norm(cross(mul(offset, -1), up));
  const turned = rotate(offset, right, -dy * 0.01);
  // Stop short of the poles, where view up would become parallel to the view direction.
  if (Math.abs(dot(norm(turned), up)) < 0.99) offset = turned;
  camera.position = add(camera.focal_point, offset);
  camera.view_up = norm(cross(right, mul(offset, -1)));
}

// Pan: moves position and focal point together in the view plane, so that the scene follows the pointer at the focal
// point's depth (world units per pixel = the view's height there / the canvas height).
function panCamera(camera, dx, dy, viewHeightPx) {
  const offset = sub(camera.position, camera.focal_point);
  const dir = norm(mul(offset, -1));
  const right = norm(cross(dir, camera.view_up));
  const up = cross(right, dir);
  const height = camera.parallel_projection ? 2 * camera.parallel_scale
                                            : 2 * vlen(offset) * Math.tan((camera.view_angle * Math.PI) / 360);
  const perPixel = height / Math.max(1, viewHeightPx);
  const move = add(mul(right, -dx * perPixel), mul(up, dy * perPixel));
  camera.position = add(camera.position, move);
  camera.focal_point = add(camera.focal_point, move);
}

// Zoom: factor > 1 moves away from the focal point (and widens a parallel view).
function zoomCamera(camera, factor) {
  const offset = sub(camera.position, camera.focal_point);
  camera.position = add(camera.focal_point, mul(offset, factor));
  if (camera.parallel_projection) camera.parallel_scale *= factor;
}

// `grab` (optional): another control that may take a one-pointer drag before the camera does (slices.js drags planes):
// grab.down(event) returns true to take it, then gets grab.move(event, dx, dy) and grab.up(event) for that pointer.
function installCameraControls(canvas, getCamera, onChange, grab = null) {
  const pointers = new Map();  // pointerId -> {x, y}
  let mode = null;             // "orbit" | "pan" | "grab" (mouse / pen / one finger); two touches pinch
  let pinch = null;            // {distance, x, y} of the last two-finger position

  const twoTouches = () => {
    const [a, b] = [...pointers.values()];
    return { distance: Math.hypot(a.x - b.x, a.y - b.y), x: (a.x + b.x) / 2, y: (a.y + b.y) / 2 };
  };

  canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  canvas.addEventListener("pointerdown", (e) => {
    // Capture keeps the drag when the pointer leaves the canvas; it throws for a pointer that is no longer active
    // (lifted between the event and this handler), which must not lose the touch.
    try { canvas.setPointerCapture(e.pointerId); } catch { /* not active: no capture */ }
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    if (pointers.size === 2) {
      mode = null;
      pinch = twoTouches();
    } else if (pointers.size === 1) {
      if (grab && e.button === 0 && grab.down(e)) mode = "grab";
      else mode = e.pointerType !== "touch" && (e.shiftKey || e.button === 1 || e.button === 2) ? "pan" : "orbit";
    }
    e.preventDefault();
  });
  const release = (e) => {
    if (mode === "grab" && pointers.has(e.pointerId)) grab.up(e);
    pointers.delete(e.pointerId);
    pinch = null;
    // Lifting one of two fingers leaves the other orbiting from where it is.
    mode = pointers.size === 1 ? "orbit" : null;
  };
  canvas.addEventListener("pointerup", release);
  canvas.addEventListener("pointercancel", release);
  canvas.addEventListener("pointermove", (e) => {
    const last = pointers.get(e.pointerId);
    const camera = getCamera();
    if (!last || !camera) return;
    const dx = e.clientX - last.x, dy = e.clientY - last.y;
    last.x = e.clientX, last.y = e.clientY;
    const height = canvas.getBoundingClientRect().height;
    if (mode === "grab" && pointers.size === 1) {
      grab.move(e, dx, dy);  // the grabbing control sends its own change
      return;
    } else if (pointers.size === 2 && pinch) {
      const now = twoTouches();
      if (now.distance > 0 && pinch.distance > 0) zoomCamera(camera, pinch.distance / now.distance);
      panCamera(camera, now.x - pinch.x, now.y - pinch.y, height);
      pinch = now;
    } else if (mode === "pan") {
      panCamera(camera, dx, dy, height);
    } else if (mode === "orbit") {
      orbitCamera(camera, dx, dy);
    } else {
      return;
    }
    onChange();
  });
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    const camera = getCamera();
    if (!camera) return;
    zoomCamera(camera, Math.pow(1.1, Math.sign(e.deltaY)));
    onChange();
  }, { passive: false });
}
