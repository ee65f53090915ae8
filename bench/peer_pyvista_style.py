#!/usr/bin/python3
"""What PyVista's `Plotter.add_volume` does for an unstructured grid, in plain VTK 9.1 (Debian python3-vtk9; PyVista
itself is not packaged in Debian 12), against ugvr.render of the same grid, camera and transfer function.

The VTK path ("pyvista-style"), as the [python] issue and PyVista's reports describe it (pyvista PRs 531 and 3930,
pyvista-support 500): a mesh that is not all tetrahedra is tetrahedralised (vtkDataSetTriangleFilter, PyVista's
`triangulate()`); cell scalars are turned into point scalars (vtkCellDataToPointData, `cell_data_to_point_data()`),
since the unstructured-grid ray caster interpolates point scalars; then vtkUnstructuredGridVolumeRayCastMapper
(Bunyk's CPU ray caster, full quality: one ray per pixel, no auto-adjust; bench/peer_vtk_render.py's setup) draws
it, offscreen under Xvfb. Times: the filters (`prepare`), the first frame (the mapper's setup), and the median of the
later frames.

The ugvr path: ugvr.from_vtk of the same vtkUnstructuredGrid (the mixed cells and cell data as they are), then
ugvr.render with the exact engine (first render: the walk mesh; later renders reuse it) and, with --lod, the
level-of-detail engine over a brick store built from it (build time reported apart).

Quality: PSNR (dB) and SSIM of each image against the exact engine's (`ugvr compare`'s figures, RGB 8-bit).
One JSON line per path on stdout; --out DIR keeps the images (NAME-vtk.png, NAME-exact.png, NAME-lod.png).

    xvfb-run -a -s "-screen 0 1024x768x24" env PYTHONPATH=build/python /usr/bin/python3 bench/peer_pyvista_style.py \
        --mesh bf.vtu --field Density --name blunt-fin --size 384 --frames 3 --out /tmp/pv
"""
import argparse
import json
import os
import statistics
import sys
import tempfile
import time

import numpy as np
import vtk
from vtk.util import numpy_support

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peer_vtk_render as peer  # noqa: E402  (make_property, set_camera, grab)

import ugvr  # noqa: E402


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--mesh", required=True, help=".vtu (any cells VTK reads)")
    p.add_argument("--field", required=True, help="point or cell array (a vector: its magnitude)")
    p.add_argument("--name", default=None)
    p.add_argument("--size", type=int, default=384)
    p.add_argument("--frames", type=int, default=3)
    p.add_argument("--camera", default=None, help="camera JSON (default: ugvr render's first view)")
    p.add_argument("--tf", default=None, help="ParaView preset JSON in data values (default: viridis over the range)")
    p.add_argument("--background", default=None, help="R,G,B (default ParaView's)")
    p.add_argument("--lod", action="store_true", help="also the level-of-detail engine over a brick store")
    p.add_argument("--out", default=None, help="directory for the images")
    return p.parse_args()


def pyvista_style(grid, field, camera_json, tf_path, size, frames):
    """add_volume's pipeline for an unstructured grid; returns (image H x W x 4 uint8 top row first, record)."""
    t0 = time.perf_counter()
    data = grid
    types = vtk.vtkCellTypes()
    data.GetCellTypes(types)
    all_tets = types.GetNumberOfTypes() == 1 and types.GetCellType(0) == vtk.VTK_TETRA
    if not all_tets:
        tri = vtk.vtkDataSetTriangleFilter()
        tri.SetInputData(data)
        tri.Update()
        data = tri.GetOutput()
    association = "point" if data.GetPointData().GetArray(field) is not None else "cell"
    if association == "cell":
        c2p = vtk.vtkCellDataToPointData()
        c2p.SetInputData(data)
        c2p.Update()
        data = c2p.GetOutput()
    array = data.GetPointData().GetArray(field)
    name = field
    if array.GetNumberOfComponents() > 1:
        magnitude = np.linalg.norm(numpy_support.vtk_to_numpy(array).astype(np.float64), axis=1).astype(np.float32)
        marr = numpy_support.numpy_to_vtk(magnitude, deep=1)
        name = field + "_magnitude"
        marr.SetName(name)
        data.GetPointData().AddArray(marr)
    data.GetPointData().SetActiveScalars(name)
    prepare = time.perf_counter() - t0

    prop, _ = peer.make_property(tf_path)
    mapper = vtk.vtkUnstructuredGridVolumeRayCastMapper()
    mapper.SetAutoAdjustSampleDistances(0)
    mapper.SetImageSampleDistance(1.0)
    mapper.SetMinimumImageSampleDistance(1.0)
    mapper.SetMaximumImageSampleDistance(1.0)
    mapper.SetIntermixIntersectingGeometry(0)
    mapper.SetInputData(data)
    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    ren = vtk.vtkRenderer()
    ren.SetBackground(*peer.BACKGROUND)
    ren.AddVolume(volume)
    win = vtk.vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.SetMultiSamples(0)
    win.AddRenderer(ren)
    win.SetSize(size, size)
    win.SetDesiredUpdateRate(0.0001)
    peer.set_camera(ren.GetActiveCamera(), camera_json)
    ren.ResetCameraClippingRange()
    seconds = []
    for i in range(frames):
        if i:
            ren.GetActiveCamera().Modified()
            volume.Modified()
        t0 = time.perf_counter()
        win.Render()
        win.WaitForCompletion()
        seconds.append(time.perf_counter() - t0)
    img = peer.grab(win)
    w, h, _ = img.GetDimensions()
    rgb = numpy_support.vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[::-1, :, :3]
    rgba = np.concatenate([rgb, np.full((h, w, 1), 255, np.uint8)], axis=2)
    return rgba, {"path": "pyvista-style", "association": association, "tetrahedralised": not all_tets,
                  "cells_rendered": data.GetNumberOfCells(), "prepare_seconds": round(prepare, 3),
                  "first_frame_seconds": round(seconds[0], 3),
                  "median_frame_seconds": round(statistics.median(seconds[1:] or seconds), 3)}


def main():
    args = parse_args()
    name = args.name or os.path.splitext(os.path.basename(args.mesh))[0]
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(args.mesh)
    reader.Update()
    grid = reader.GetOutput()
    size = (args.size, args.size)
    background = tuple(float(c) for c in args.background.split(",")) if args.background else None
    if background:
        peer.BACKGROUND = background

    t0 = time.perf_counter()
    ds = ugvr.from_vtk(grid)
    from_vtk_seconds = time.perf_counter() - t0
    # The exact engine: first render (walk mesh included), then the steady state. Its camera and transfer function
    # (ugvr render's defaults: the oblique view, viridis over the field's range, unit distance = diagonal / 10) are
    # what the VTK path is given.
    seconds = []
    for _ in range(args.frames):
        t0 = time.perf_counter()
        exact = ugvr.render(ds, field=args.field, size=size, engine="exact", device="cpu", camera=args.camera,
                            tf=args.tf, keep_range=args.tf is not None, background=background)
        seconds.append(time.perf_counter() - t0)
    tmp = tempfile.mkdtemp(prefix="pv-style-")
    tf_path = os.path.join(tmp, "tf.json")
    exact.tf.write(tf_path)
    records = [{"path": "ugvr-exact", "from_vtk_seconds": round(from_vtk_seconds, 3), "cells_rendered": ds.cell_count,
                "first_frame_seconds": round(seconds[0], 3),
                "median_frame_seconds": round(statistics.median(seconds[1:] or seconds), 3),
                "psnr_db": "inf", "ssim": 1.0}]
    images = {"exact": exact.array}

    vtk_image, rec = pyvista_style(grid, args.field, exact.camera.to_json(), tf_path, args.size, args.frames)
    q = ugvr.compare(vtk_image, exact.array)
    rec.update(psnr_db=round(q["psnr_db"], 2), ssim=round(q["ssim"], 4))
    records.append(rec)
    images["vtk"] = vtk_image

    if args.lod:
        t0 = time.perf_counter()
        store = ugvr.build(ds, os.path.join(tmp, "store.ugvr"), fields=[args.field])
        build_seconds = time.perf_counter() - t0
        seconds = []
        for _ in range(args.frames):
            t0 = time.perf_counter()
            lod = ugvr.render(store, camera=exact.camera, tf=exact.tf, keep_range=True, size=size,
                              background=background)
            seconds.append(time.perf_counter() - t0)
        q = ugvr.compare(lod.array, exact.array)
        records.append({"path": "ugvr-lod", "build_seconds": round(build_seconds, 3), "store_bytes": store.info["bytes"],
                        "first_frame_seconds": round(seconds[0], 3),
                        "median_frame_seconds": round(statistics.median(seconds[1:] or seconds), 3),
                        "device": lod.stats.get("device", ""),
                        "psnr_db": round(q["psnr_db"], 2), "ssim": round(q["ssim"], 4)})
        images["lod"] = lod.array
    for r in records:
        r.update(bench="pyvista-style", dataset=name, field=args.field, size=args.size, cells=ds.cell_count,
                 frames=args.frames)
        print(json.dumps(r), flush=True)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        for key, array in images.items():
            ugvr.Image(array).save(os.path.join(args.out, f"{name}-{key}.png"))


if __name__ == "__main__":
    main()
