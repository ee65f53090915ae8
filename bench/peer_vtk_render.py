#!/usr/bin/python3
"""Peer for ugvr's exact CPU ray caster: renders the same tetrahedral .vtu, camera and transfer function with one of
VTK 9.1's unstructured-grid volume mappers (Debian python3-vtk9, not a project dependency) and times the frames.

    xvfb-run -a -s "-screen 0 1024x768x24" /usr/bin/python3 bench/peer_vtk_render.py \
        --mesh bf.vtu --field Density --camera cam.json --tf tf.json --size 512 --mapper bunyk --frames 6 \
        --out bf-bunyk.pfm --png bf-bunyk.png --json

Mappers (each set to full quality, see setup_mapper):
  bunyk   vtkUnstructuredGridVolumeRayCastMapper (Bunyk ray casting, CPU, NumberOfThreads threads)
  pt      vtkProjectedTetrahedraMapper (-> vtkOpenGLProjectedTetrahedraMapper, Shirley-Tuchman cell projection on
          the OpenGL context: under Xvfb that is Mesa llvmpipe, i.e. the CPU too)
  zsweep  vtkUnstructuredGridVolumeZSweepMapper (ZSweep, CPU, single-threaded)

Inputs: camera JSON {"position","focal_point","view_up","view_angle","parallel_projection","parallel_scale"} (ugvr's
camera format); transfer function as a ParaView preset JSON array [{"Name","RGBPoints":[x,r,g,b,...],
"Points":[x,a,0.5,0,...],"ScalarOpacityUnitDistance":d}].

Timing: frame 0 is the first renderWindow.Render() (it includes the mapper's setup: Bunyk's face list, ZSweep's use
sets, PT's cell analysis and colour mapping, the pre-integration table); every later frame is one Render() followed
by WaitForCompletion() (glFinish) so GPU/llvmpipe work is inside the timing. Each frame's process CPU time (all
threads, llvmpipe's included) is recorded too: on a shared, loaded machine it says more than wall time.
Re-rendering: before every frame after the first the camera and the volume are marked Modified() (--rerender
modified, the default). None of these mappers keeps an image cache (each re-casts / re-sorts / re-sweeps on every
Render), and Modified() makes every view-dependent MTime check fail as an interactive camera move would, without
moving the camera, so the image is the one the JSON camera defines. --rerender jitter rotates the camera by
+-1e-3 degrees each frame (a real move, 0.02 px); --rerender none changes nothing. Checked on the blunt fin: all three
cost the same CPU time per frame (Bunyk 0.55-0.62 s, PT 0.28-0.33 s), so nothing is cached.

Output: --out FILE.pfm (PF, RGB float32 little-endian, rows bottom-to-top, values in [0,1] from the 8-bit
framebuffer), --png FILE.png (vtkPNGWriter, same framebuffer), --json: one JSON line on stdout.
"""
import argparse
import json
import os
import resource
import statistics
import sys
import time

import vtk
from vtk.util import numpy_support

BACKGROUND = (0.32, 0.34, 0.43)  # ugvr's default background


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--mesh", required=True, help="tetrahedral .vtu")
    p.add_argument("--field", required=True, help="point array; a vector array is rendered as its magnitude")
    p.add_argument("--camera", required=True, help="ugvr camera JSON")
    p.add_argument("--tf", required=True, help="ParaView preset JSON array (first entry used)")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--mapper", choices=["bunyk", "pt", "zsweep"], required=True)
    p.add_argument("--integrator", choices=["auto", "preint", "partial", "linear", "homogeneous"], default="auto",
                   help="ray integrator for bunyk/zsweep: auto = VTK's own choice (vtkUnstructuredGridPreIntegration "
                        "for point scalars with independent components)")
    p.add_argument("--threads", type=int, default=0, help="bunyk threads (0 = VTK default = cores)")
    p.add_argument("--frames", type=int, default=6)
    p.add_argument("--rerender", choices=["modified", "jitter", "none"], default="modified")
    p.add_argument("--out", help="PFM image of the last frame")
    p.add_argument("--png", help="PNG image of the last frame")
    p.add_argument("--json", action="store_true", help="print one JSON line")
    return p.parse_args()


def load_mesh(path, field):
    t0 = time.perf_counter()
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    pd = grid.GetPointData()
    arr = pd.GetArray(field)
    if arr is None:
        names = [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())]
        sys.exit(f"peer_vtk_render: no point array {field!r} in {path}; have {names}")
    name = field
    if arr.GetNumberOfComponents() > 1:  # vector: render the magnitude, like ugvr does for vector fields
        import numpy as np
        mag = np.linalg.norm(numpy_support.vtk_to_numpy(arr).astype(np.float64), axis=1).astype(np.float32)
        marr = numpy_support.numpy_to_vtk(mag, deep=1)
        name = field + "_magnitude"
        marr.SetName(name)
        pd.AddArray(marr)
    pd.SetActiveScalars(name)
    types = vtk.vtkCellTypes()
    grid.GetCellTypes(types)
    only_tets = types.GetNumberOfTypes() == 1 and types.GetCellType(0) == vtk.VTK_TETRA
    return grid, name, time.perf_counter() - t0, only_tets


def make_property(tf_path):
    with open(tf_path) as f:
        preset = json.load(f)
    if isinstance(preset, list):
        preset = preset[0]
    ctf = vtk.vtkColorTransferFunction()
    ctf.SetColorSpaceToRGB()
    rgb = preset["RGBPoints"]
    for i in range(0, len(rgb), 4):
        ctf.AddRGBPoint(rgb[i], rgb[i + 1], rgb[i + 2], rgb[i + 3])
    otf = vtk.vtkPiecewiseFunction()
    pts = preset["Points"]
    for i in range(0, len(pts), 4):
        otf.AddPoint(pts[i], pts[i + 1], pts[i + 2], pts[i + 3])
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(float(preset.get("ScalarOpacityUnitDistance", 1.0)))
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    return prop, preset.get("Name", "")


def make_integrator(kind):
    return {"auto": None,
            "preint": vtk.vtkUnstructuredGridPreIntegration,
            "partial": vtk.vtkUnstructuredGridPartialPreIntegration,
            "linear": vtk.vtkUnstructuredGridLinearRayIntegrator,
            "homogeneous": vtk.vtkUnstructuredGridHomogeneousRayIntegrator}[kind]


def setup_mapper(args):
    """Full-quality settings; returns (mapper, dict of what was set)."""
    opts = {}
    if args.mapper == "bunyk":
        m = vtk.vtkUnstructuredGridVolumeRayCastMapper()
        # AutoAdjustSampleDistances would raise ImageSampleDistance (cast 1 ray per ISD^2 pixels, up to 10) when the
        # previous frame took longer than the volume's allocated render time; off, and pinned to 1 ray per pixel.
        m.SetAutoAdjustSampleDistances(0)
        m.SetImageSampleDistance(1.0)
        m.SetMinimumImageSampleDistance(1.0)
        m.SetMaximumImageSampleDistance(1.0)
        # No opaque geometry in the scene: do not read back the z-buffer.
        m.SetIntermixIntersectingGeometry(0)
        if args.threads > 0:
            m.SetNumberOfThreads(args.threads)
        opts.update(AutoAdjustSampleDistances=0, ImageSampleDistance=1.0, IntermixIntersectingGeometry=0,
                    NumberOfThreads=m.GetNumberOfThreads(), RayCastFunction=m.GetRayCastFunction().GetClassName())
    elif args.mapper == "zsweep":
        m = vtk.vtkUnstructuredGridVolumeZSweepMapper()
        m.SetAutoAdjustSampleDistances(0)  # same auto-coarsening as the ray caster: off
        m.SetImageSampleDistance(1.0)
        m.SetMinimumImageSampleDistance(1.0)
        m.SetMaximumImageSampleDistance(1.0)
        m.SetIntermixIntersectingGeometry(0)
        # MaxPixelListSize (64) only triggers early incremental compositing of the front of a pixel list: a memory
        # knob, not a quality one; left at its default.
        opts.update(AutoAdjustSampleDistances=0, ImageSampleDistance=1.0, IntermixIntersectingGeometry=0,
                    MaxPixelListSize=m.GetMaxPixelListSize(), NumberOfThreads=1)
    else:
        m = vtk.vtkProjectedTetrahedraMapper()  # the object factory gives vtkOpenGLProjectedTetrahedraMapper
        # The PT mapper has no image-sample-distance or level-of-detail: every tet is projected every frame. Keep the
        # float framebuffer (default on): blending in a float FBO instead of the 8-bit window buffer.
        if hasattr(m, "SetUseFloatingPointFrameBuffer"):
            m.SetUseFloatingPointFrameBuffer(True)
            opts["UseFloatingPointFrameBuffer"] = 1
        opts["VisibilitySort"] = m.GetVisibilitySort().GetClassName()
    opts["class"] = m.GetClassName()
    integ = make_integrator(args.integrator) if args.mapper != "pt" else None
    if integ is not None:
        m.SetRayIntegrator(integ())
    return m, opts


def set_camera(cam, c):
    cam.SetPosition(*c["position"])
    cam.SetFocalPoint(*c["focal_point"])
    cam.SetViewUp(*c["view_up"])
    cam.SetViewAngle(float(c.get("view_angle", 30.0)))
    cam.SetParallelProjection(1 if c.get("parallel_projection", False) else 0)
    if "parallel_scale" in c:
        cam.SetParallelScale(float(c["parallel_scale"]))


def grab(ren_win):
    """RGB uint8 framebuffer of the last frame as a vtkImageData (rows bottom-to-top); no re-render."""
    w2i = vtk.vtkWindowToImageFilter()
    w2i.SetInput(ren_win)
    w2i.SetInputBufferTypeToRGB()
    w2i.ShouldRerenderOff()
    w2i.ReadFrontBufferOff()
    w2i.Update()
    img = vtk.vtkImageData()
    img.DeepCopy(w2i.GetOutput())
    return img


def write_pfm(path, img):
    w, h, _ = img.GetDimensions()
    a = numpy_support.vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[:, :, :3]
    data = (a.astype("<f4") / 255.0).tobytes()  # vtkImageData rows already run bottom-to-top, as PFM wants
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(data)


def main():
    args = parse_args()
    with open(args.camera) as f:
        camjson = json.load(f)
    grid, scalar_name, load_s, only_tets = load_mesh(args.mesh, args.field)
    if args.mapper == "pt" and not only_tets:
        print("peer_vtk_render: warning: the PT mapper renders tetrahedra only", file=sys.stderr)
    prop, tf_name = make_property(args.tf)
    mapper, opts = setup_mapper(args)
    mapper.SetInputData(grid)

    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)

    ren = vtk.vtkRenderer()
    ren.SetBackground(*BACKGROUND)
    ren.AddVolume(volume)
    ren_win = vtk.vtkRenderWindow()
    ren_win.SetOffScreenRendering(1)
    ren_win.SetMultiSamples(0)  # no MSAA, same as a ray caster's one sample per pixel centre
    ren_win.AddRenderer(ren)
    ren_win.SetSize(args.size, args.size)
    # Full quality on every frame: the default DesiredUpdateRate (0.0001 frames/s) gives the volume ~10^4 s of
    # allocated render time, so no level-of-detail reduction even where a mapper would adjust; set explicitly.
    ren_win.SetDesiredUpdateRate(0.0001)
    cam = ren.GetActiveCamera()
    set_camera(cam, camjson)
    ren.ResetCameraClippingRange()

    frames, cpu = [], []
    for i in range(args.frames):
        if i > 0:
            if args.rerender == "modified":
                cam.Modified()
                volume.Modified()
            elif args.rerender == "jitter":
                cam.Azimuth(1e-3 if i % 2 else -1e-3)
                ren.ResetCameraClippingRange()
        t0, c0 = time.perf_counter(), time.process_time()
        ren_win.Render()
        ren_win.WaitForCompletion()
        frames.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)  # all threads of this process, llvmpipe's included

    img = grab(ren_win)
    if args.out:
        write_pfm(args.out, img)
    if args.png:
        wr = vtk.vtkPNGWriter()
        wr.SetFileName(args.png)
        wr.SetInputData(img)
        wr.Write()

    caps = ren_win.ReportCapabilities() or ""
    gl = next((l.split(":", 1)[1].strip() for l in caps.splitlines() if l.startswith("OpenGL renderer string")), "")
    rng = grid.GetPointData().GetArray(scalar_name).GetRange()
    if args.mapper == "pt":
        integ = "n/a (cell projection)"
    elif mapper.GetRayIntegrator() is not None:
        integ = mapper.GetRayIntegrator().GetClassName()
    else:  # VTK picks it in Render(): point scalars + independent components
        integ = "auto: vtkUnstructuredGridPreIntegration"
    after = frames[1:] if len(frames) > 1 else frames
    rec = {"bench": "render-vtk", "mapper": args.mapper, "mesh": os.path.basename(args.mesh), "field": scalar_name,
           "field_range": [rng[0], rng[1]], "tf": tf_name, "size": args.size, "frames": args.frames,
           "frames_seconds": [round(t, 4) for t in frames], "first_frame_seconds": round(frames[0], 4),
           "median_after_first": round(statistics.median(after), 4),
           "cpu_seconds": [round(t, 4) for t in cpu],
           "median_cpu_after_first": round(statistics.median(cpu[1:] if len(cpu) > 1 else cpu), 4),
           "load_seconds": round(load_s, 3),
           "cells": grid.GetNumberOfCells(), "points": grid.GetNumberOfPoints(), "only_tets": only_tets,
           "vtk_version": vtk.vtkVersion.GetVTKVersion(), "mapper_class": opts.pop("class"), "integrator": integ,
           "options": opts, "rerender": args.rerender, "gl_renderer": gl, "nproc": os.cpu_count(),
           "peak_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}
    if args.json:
        print(json.dumps(rec), flush=True)
    else:
        print(f"{args.mapper}: median {rec['median_after_first']} s after first ({rec['first_frame_seconds']} s "
              f"first) over {args.frames} frames, {rec['cells']} cells", flush=True)


if __name__ == "__main__":
    main()
