"""Peer for ugvr's level-of-detail engine: ParaView 5.11's "Resample To Image" volume rendering of an unstructured
grid (Debian's paraview package, run by pvbatch), 512x512 frames, same camera / transfer function / background
conventions and JSON-line output as bench/peer_vtk_render.py.

    PYTHONPATH=/opt/ugvr-bench/python3-paraview/usr/lib/python3/dist-packages LP_NUM_THREADS=2 \\
    xvfb-run -a -s "-screen 0 1024x768x24" pvbatch bench/peer_paraview_resample.py \\
        --mesh bf.vtu --field Density --camera cam.json --tf tf.json --size 512 --resample 128 --frames 5 \\
        --dataset blunt-fin --png bf-pv.png --jsonl bench/results/peer-paraview.jsonl --json

Launch: Debian's ParaView is built for X only (no EGL, no OSMesa): pvbatch needs an X display even with
--force-offscreen-rendering (without one it aborts: "vtkXOpenGLRenderWindow: bad X server connection"), so run it
under xvfb-run (or a running Xvfb and DISPLAY); it then renders into a hidden vtkOffscreenOpenGLRenderWindow, i.e.
Mesa llvmpipe on the CPU here. pvbatch's Python modules are python3-paraview, which conflicts with python3-vtk9:
scripts/install-bench-deps.sh unpacks it aside and bench/run_peer_paraview.sh sets PYTHONPATH (above).

What is rendered: the input's UnstructuredGridRepresentation in 'Volume' representation with its volume mapper set to
'Resample To Image' (the property is SelectMapper in 5.11; VolumeRenderingMode in later versions), SamplingDimensions
= --resample per axis. In that mode the representation runs vtkResampleToImage (a probe of the mesh at the
dims^3 lattice over its bounds) when the pipeline updates, then volume-renders the image with a vtkSmartVolumeMapper,
which picks vtkOpenGLGPUVolumeRayCastMapper when the OpenGL context can (the JSON records the mode it used). The
mapper keeps ParaView's own settings (AutoAdjustSampleDistances on: the sample distance follows the image spacing;
still renders get ParaView's 0.002 frames/s desired update rate, so no interactive coarsening).

Timing: the first frame is view.Update() (the resample: vtkResampleToImage runs in the representation's RequestData)
plus the first StillRender() and glFinish (texture upload, shader compilation, the first ray cast); it is reported as
first_frame_seconds, split into update_seconds and first_draw_seconds. Then --frames timed frames, each after a camera
azimuth of --rotate degrees (default +1) so that every frame is a new view: StillRender() then WaitForCompletion()
(glFinish) so llvmpipe's work is inside the timing; process CPU time per frame (all threads, llvmpipe's included) too,
and the main thread's alone (ParaView, the GL driver's front end; llvmpipe rasterizes and shades in LP_NUM_THREADS
threads of its own).
view.StillRender() is called directly, not paraview.simple.Render(), whose first call resets the camera and renders
twice.

Inputs: camera JSON {"position","focal_point","view_up","view_angle","parallel_projection","parallel_scale"} (ugvr's
camera format; default: VTK/ParaView reset camera looking down -z, view up +y, 30 degrees); transfer function as a
ParaView preset JSON array [{"Name","RGBPoints":[x,r,g,b,...],"Points":[x,a,0.5,0,...],"ScalarOpacityUnitDistance":d}]
(default: 5 viridis points over the field range, opacity 0 -> 0.5, unit distance = bounds diagonal / 100, the same
defaults as bench/run_exact_render.sh writes). A vector field is rendered as its magnitude.

Output: --png FILE (the last frame, read back from the render window without re-rendering), --out FILE.pfm (PF, RGB
float32 little-endian, rows bottom-to-top, values in [0,1] from the 8-bit framebuffer), --json: one JSON line on
stdout, --jsonl FILE: the same line appended to FILE.
"""
import argparse
import json
import math
import os
import resource
import statistics
import sys
import time

# Import the concrete classes before any object is wrapped, so that Python wraps them as such, not as their bases.
from vtkmodules.vtkRenderingVolumeOpenGL2 import vtkSmartVolumeMapper  # noqa: F401
import vtkmodules.vtkRenderingVolume  # noqa: F401
from vtkmodules.vtkCommonCore import vtkSMPTools, vtkVersion
from vtkmodules.vtkRenderingCore import vtkWindowToImageFilter
from vtkmodules.vtkIOImage import vtkPNGWriter
from vtkmodules.vtkCommonDataModel import vtkImageData
from vtkmodules.util import numpy_support

import paraview.simple as pvs
from paraview import servermanager

BACKGROUND = (0.32, 0.34, 0.43)  # ugvr's default background
VIRIDIS = [(0.267004, 0.004874, 0.329415), (0.229739, 0.322361, 0.545706), (0.127568, 0.566949, 0.550556),
           (0.369214, 0.788888, 0.382914), (0.993248, 0.906157, 0.143936)]
RENDER_MODES = {0: "DefaultRenderMode", 1: "RayCastRenderMode", 2: "GPURenderMode", 3: "OSPRayRenderMode",
                4: "UndefinedRenderMode"}


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--mesh", required=True, help="dataset ParaView reads as an unstructured grid (e.g. .vtu)")
    p.add_argument("--field", required=True, help="point array; a vector array is rendered as its magnitude")
    p.add_argument("--camera", help="ugvr camera JSON (default: reset camera looking down -z)")
    p.add_argument("--tf", help="ParaView preset JSON array, first entry used (default: viridis ramp, see above)")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--resample", default="128", help="SamplingDimensions: N (N^3) or NX,NY,NZ")
    p.add_argument("--frames", type=int, default=5, help="timed frames after the first")
    p.add_argument("--rotate", type=float, default=1.0, help="camera azimuth step per timed frame, degrees")
    p.add_argument("--dataset", help="label for the JSON line (default: the file name)")
    p.add_argument("--out", help="PFM image of the last frame")
    p.add_argument("--png", help="PNG image of the last frame")
    p.add_argument("--json", action="store_true", help="print one JSON line")
    p.add_argument("--jsonl", help="append the JSON line to this file")
    # Tolerate options a pvbatch version may leave in the script's sys.argv.
    args, _unknown = p.parse_known_args()
    dims = [int(x) for x in args.resample.split(",")]
    if len(dims) == 1:
        dims *= 3
    if len(dims) != 3 or min(dims) < 2:
        p.error("--resample wants N or NX,NY,NZ with every N >= 2")
    args.dims = dims
    return args


def load(path, field):
    """Reader proxy (pipeline updated, timed), the array's association info, its range and component count."""
    t0 = time.perf_counter()
    reader = pvs.OpenDataFile(path)
    if reader is None:
        sys.exit(f"peer_paraview_resample: ParaView has no reader for {path}")
    reader.UpdatePipeline()
    load_s = time.perf_counter() - t0
    info = reader.GetDataInformation()
    arr = reader.PointData.GetArray(field)
    if arr is None:
        sys.exit(f"peer_paraview_resample: no point array {field!r} in {path}; have {list(reader.PointData.keys())}")
    ncomp = arr.GetNumberOfComponents()
    rng = arr.GetRange(-1 if ncomp > 1 else 0)
    return reader, info, load_s, ncomp, rng


def default_camera(bounds, angle=30.0):
    """vtkRenderer::ResetCamera's framing of the bounds: centre, radius = half diagonal, distance = r / sin(a/2)."""
    lo, hi = bounds[0::2], bounds[1::2]
    centre = [(a + b) / 2 for a, b in zip(lo, hi)]
    radius = math.dist(lo, hi) / 2
    dist = radius / math.sin(math.radians(angle / 2))
    return {"position": [centre[0], centre[1], centre[2] + dist], "focal_point": centre, "view_up": [0.0, 1.0, 0.0],
            "view_angle": angle, "parallel_projection": False, "parallel_scale": radius}


def default_tf(field, rng, bounds):
    r0, r1 = rng
    rgb = []
    for i, c in enumerate(VIRIDIS):
        rgb += [r0 + (r1 - r0) * i / (len(VIRIDIS) - 1), *c]
    diag = math.dist(bounds[0::2], bounds[1::2])
    return {"Name": f"viridis-ramp {field}", "ColorSpace": "RGB", "RGBPoints": rgb,
            "Points": [r0, 0.0, 0.5, 0.0, r1, 0.5, 0.5, 0.0], "ScalarOpacityUnitDistance": diag / 100}


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
    w2i = vtkWindowToImageFilter()
    w2i.SetInput(ren_win)
    w2i.SetInputBufferTypeToRGB()
    w2i.ShouldRerenderOff()
    w2i.ReadFrontBufferOff()
    w2i.Update()
    img = vtkImageData()
    img.DeepCopy(w2i.GetOutput())
    return img


def write_pfm(path, img):
    w, h, _ = img.GetDimensions()
    a = numpy_support.vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[:, :, :3]
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write((a.astype("<f4") / 255.0).tobytes())


def main():
    args = parse_args()
    reader, info, load_s, ncomp, rng = load(args.mesh, args.field)
    bounds = info.GetBounds()
    camjson = None
    if args.camera:
        with open(args.camera) as f:
            camjson = json.load(f)
    if args.tf:
        with open(args.tf) as f:
            preset = json.load(f)
        if isinstance(preset, list):
            preset = preset[0]
    else:
        preset = default_tf(args.field, rng, bounds)

    view = pvs.CreateRenderView()
    view.ViewSize = [args.size, args.size]
    view.OrientationAxesVisibility = 0
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    view.Background = list(BACKGROUND)
    view.UseFXAA = 0
    view.UseToneMapping = 0
    pvs.SetActiveView(view)

    disp = pvs.Show(reader, view)
    if disp.GetXMLName() != "UnstructuredGridRepresentation":
        sys.exit(f"peer_paraview_resample: {args.mesh} gets a {disp.GetXMLName()}, not an "
                 "UnstructuredGridRepresentation (convert it to an unstructured .vtu first: ugvr convert / ugvr refine --levels 0)")
    disp.SetRepresentationType("Volume")
    if hasattr(disp, "VolumeRenderingMode"):  # ParaView >= 5.12
        disp.VolumeRenderingMode = "Resample To Image"
        mode_prop = "VolumeRenderingMode"
    else:  # 5.11: SelectMapper
        disp.SelectMapper = "Resample To Image"
        mode_prop = "SelectMapper"
    disp.SamplingDimensions = args.dims
    if ncomp > 1:
        pvs.ColorBy(disp, ("POINTS", args.field, "Magnitude"))
    else:
        pvs.ColorBy(disp, ("POINTS", args.field))

    lut = pvs.GetColorTransferFunction(args.field)
    if hasattr(lut, "AutomaticRescaleRangeMode"):
        lut.AutomaticRescaleRangeMode = "Never"
    lut.ColorSpace = "RGB"
    lut.RGBPoints = [float(x) for x in preset["RGBPoints"]]
    if ncomp > 1:
        lut.VectorMode = "Magnitude"
    lut.ScalarRangeInitialized = 1.0
    pwf = pvs.GetOpacityTransferFunction(args.field)
    pwf.Points = [float(x) for x in preset["Points"]]
    pwf.ScalarRangeInitialized = 1
    disp.LookupTable = lut
    disp.ScalarOpacityFunction = pwf
    disp.ScalarOpacityUnitDistance = float(preset.get("ScalarOpacityUnitDistance", 1.0))

    cam = view.GetActiveCamera()
    if camjson is not None:
        set_camera(cam, camjson)
        cam_src = args.camera
    else:
        camjson = default_camera(bounds)
        set_camera(cam, camjson)
        cam_src = "default (reset camera looking down -z)"
    pvs._funcs_internals.first_render = False  # no camera reset on a first paraview.simple.Render()

    ren_win = view.GetRenderWindow()

    # ---- first frame: resample (pipeline update) + first draw ----
    t0, c0 = time.perf_counter(), time.process_time()
    view.Update()
    t1, c1 = time.perf_counter(), time.process_time()
    view.StillRender()
    ren_win.WaitForCompletion()
    t2, c2 = time.perf_counter(), time.process_time()
    update_s, first_draw_s = t1 - t0, t2 - t1

    # ---- timed frames: a new view each ----
    frames, cpu, main_cpu = [], [], []
    for _ in range(args.frames):
        cam.Azimuth(args.rotate)
        t0, c0f, m0 = time.perf_counter(), time.process_time(), time.thread_time()
        view.StillRender()
        ren_win.WaitForCompletion()
        frames.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0f)
        main_cpu.append(time.thread_time() - m0)  # this thread only: ParaView's side, not llvmpipe's rasterizer threads

    img = grab(ren_win)
    if args.out:
        write_pfm(args.out, img)
    if args.png:
        wr = vtkPNGWriter()
        wr.SetFileName(args.png)
        wr.SetInputData(img)
        wr.Write()

    # ---- what actually ran ----
    rep = disp.GetClientSideObject().GetActiveRepresentation()
    mapper = rep.GetActiveVolumeMapper()
    opts = {"representation": rep.GetClassName(), mode_prop: "Resample To Image",
            "SamplingDimensions": list(disp.SamplingDimensions), "mapper_class": mapper.GetClassName()}
    if hasattr(mapper, "GetLastUsedRenderMode"):
        opts.update(LastUsedRenderMode=RENDER_MODES.get(mapper.GetLastUsedRenderMode(), mapper.GetLastUsedRenderMode()),
                    RequestedRenderMode=RENDER_MODES.get(mapper.GetRequestedRenderMode(),
                                                         mapper.GetRequestedRenderMode()),
                    AutoAdjustSampleDistances=mapper.GetAutoAdjustSampleDistances(),
                    InteractiveAdjustSampleDistances=mapper.GetInteractiveAdjustSampleDistances(),
                    InterpolationMode=mapper.GetInterpolationMode(),
                    SampleDistance=mapper.GetSampleDistance())
    opts["DesiredUpdateRate"] = ren_win.GetDesiredUpdateRate()
    opts["render_window"] = ren_win.GetClassName()
    caps = ren_win.ReportCapabilities() or ""
    gl = next((l.split(":", 1)[1].strip() for l in caps.splitlines() if l.startswith("OpenGL renderer string")), "")
    glver = next((l.split(":", 1)[1].strip() for l in caps.splitlines() if l.startswith("OpenGL version string")), "")
    pos = list(cam.GetPosition())

    rec = {"bench": "render-paraview", "dataset": args.dataset or os.path.basename(args.mesh),
           "mesh": os.path.basename(args.mesh), "mode": "Resample To Image", "resample_dims": args.dims,
           "field": args.field + ("_magnitude" if ncomp > 1 else ""), "field_range": [rng[0], rng[1]],
           "tf": preset.get("Name", ""), "size": args.size, "frames": args.frames, "rotate_degrees": args.rotate,
           "frames_seconds": [round(t, 4) for t in frames],
           "median": round(statistics.median(frames), 4) if frames else None,
           "cpu_seconds": [round(t, 4) for t in cpu],
           "median_cpu": round(statistics.median(cpu), 4) if cpu else None,
           "main_thread_cpu_seconds": [round(t, 4) for t in main_cpu],
           "median_main_thread_cpu": round(statistics.median(main_cpu), 4) if main_cpu else None,
           "first_frame_seconds": round(update_s + first_draw_s, 4),
           "update_seconds": round(update_s, 4), "first_draw_seconds": round(first_draw_s, 4),
           "first_frame_cpu_seconds": round(c2 - c0, 4), "update_cpu_seconds": round(c1 - c0, 4),
           "load_seconds": round(load_s, 3),
           "cells": info.GetNumberOfCells(), "points": info.GetNumberOfPoints(),
           "camera": cam_src, "camera_position_last": [round(x, 6) for x in pos],
           "paraview_version": servermanager.vtkSMProxyManager.GetParaViewSourceVersion().split()[-1],
           "vtk_version": vtkVersion.GetVTKVersion(), "mapper_class": opts.pop("mapper_class"), "options": opts,
           "gl_renderer": gl, "gl_version": glver, "lp_num_threads": os.environ.get("LP_NUM_THREADS", ""),
           "smp_backend": vtkSMPTools.GetBackend(), "smp_threads": vtkSMPTools.GetEstimatedNumberOfThreads(),
           "nproc": os.cpu_count(), "peak_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}
    line = json.dumps(rec)
    if args.jsonl:
        with open(args.jsonl, "a") as f:
            f.write(line + "\n")
    if args.json:
        print(line, flush=True)
    else:
        print(f"{rec['dataset']} resample {'x'.join(map(str, args.dims))}: median {rec['median']} s over "
              f"{args.frames} frames after the first ({rec['first_frame_seconds']} s first, of which "
              f"{rec['update_seconds']} s resampling), {gl}", flush=True)


if __name__ == "__main__":
    main()
