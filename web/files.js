// ugvr view: downloads and uploads. The camera and transfer-function files are the ones `ugvr render --camera FILE
// --tf FILE` reads: camera.h's JSON form, and a ParaView preset (transfer_function.h: an array with one object
// {"Name", "ColorSpace", "RGBPoints": [x, r, g, b, ...], "Points": [x, opacity, 0.5, 0, ...]}).
"use strict";

// Offers `blob` as a download called `name` (an <a download> on a Blob URL).
function downloadBlob(blob, name) {
  const url = URL.createObjectURL(blob);
  const a = document.createElement("a");
  a.href = url;
  a.download = name;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10_000);
}

const downloadJson = (value, name) =>
  downloadBlob(new Blob([JSON.stringify(value, null, 2) + "\n"], { type: "application/json" }), name);

// The text of the file an <input type=file> holds.
const readFileText = (input) => input.files[0].text();

// A camera file's camera (the keys of camera.h's JSON form only), or throws an Error saying what is wrong.
function parseCameraFile(text) {
  let j;
  try { j = JSON.parse(text); } catch (e) { throw new Error(`camera file: not valid JSON (${e.message})`); }
  if (!j || typeof j !== "object" || Array.isArray(j)) throw new Error("camera file: expected a JSON object");
  const camera = {};
  for (const key of ["position", "focal_point", "view_up"]) {
    if (!isVec3(j[key])) throw new Error(`camera file: "${key}" must be [x, y, z] (finite numbers)`);
    camera[key] = j[key].slice();
  }
  const known = ["position", "focal_point", "view_up", "view_angle", "parallel_projection", "parallel_scale"];
  for (const key of Object.keys(j))
    if (!known.includes(key)) throw new Error(`camera file: unknown key "${key}"`);
  for (const key of ["view_angle", "parallel_scale"]) {
    if (key in j && !(typeof j[key] === "number" && isFinite(j[key])))
      throw new Error(`camera file: "${key}" must be a finite number`);
    if (key in j) camera[key] = j[key];
  }
  if ("parallel_projection" in j) {
    if (typeof j.parallel_projection !== "boolean") throw new Error('camera file: "parallel_projection" must be true or false');
    camera.parallel_projection = j.parallel_projection;
  }
  if (vlen(sub(camera.position, camera.focal_point)) === 0) throw new Error("camera file: position == focal_point");
  return camera;
}

// A flat list of numbers, `stride` per point, x strictly increasing, the `unitCount` numbers after each x in [0, 1];
// throws naming `key`.
function flatPoints(v, key, stride, unitCount) {
  if (!Array.isArray(v) || v.length === 0 || v.length % stride !== 0)
    throw new Error(`TF file: "${key}" must be a non-empty list of ${stride} numbers per point`);
  if (!v.every((x) => typeof x === "number" && isFinite(x))) throw new Error(`TF file: "${key}" must hold finite numbers`);
  for (let i = stride; i < v.length; i += stride)
    if (!(v[i] > v[i - stride])) throw new Error(`TF file: "${key}" x values must be strictly increasing`);
  for (let i = 0; i < v.length; i += stride)
    for (let k = 1; k <= unitCount; ++k)
      if (v[i + k] < 0 || v[i + k] > 1) throw new Error(`TF file: "${key}" values must be in [0, 1]`);
  return v.slice();
}

// A ParaView preset file's first preset: {rgb: [x, r, g, b, ...], opacity: [[x, a], ...]}, or throws.
function parseTfFile(text) {
  let j;
  try { j = JSON.parse(text); } catch (e) { throw new Error(`TF file: not valid JSON (${e.message})`); }
  if (Array.isArray(j)) {
    if (j.length === 0) throw new Error("TF file: an empty list of presets");
    j = j[0];
  }
  if (!j || typeof j !== "object" || Array.isArray(j)) throw new Error("TF file: expected a ParaView preset object");
  const rgb = flatPoints(j.RGBPoints, "RGBPoints", 4, 3);
  if (rgb.length / 4 > 1024) throw new Error("TF file: at most 1024 RGBPoints");
  let opacity;
  if (j.Points === undefined) {
    // ParaView's default: a ramp from 0 at the first colour point to 1 at the last.
    opacity = [[rgb[0], 0], [rgb[rgb.length - 4], 1]];
    if (rgb.length === 4) opacity = [[rgb[0], 1]];
  } else {
    const p = flatPoints(j.Points, "Points", 4, 1);
    opacity = [];
    for (let i = 0; i < p.length; i += 4) opacity.push([p[i], p[i + 1]]);
  }
  if (opacity.length > 1024) throw new Error("TF file: at most 1024 Points");
  return { name: typeof j.Name === "string" ? j.Name : "ugvr", rgb, opacity };
}

// ParaView's form of the colours (flat, data values) and opacity points ([[x, a], ...]).
const tfFileJson = (name, rgb, opacity) =>
  [{ Name: name, ColorSpace: "RGB", RGBPoints: rgb, Points: opacity.flatMap(([x, a]) => [x, a, 0.5, 0]) }];
