#!/usr/bin/python3
"""The memory ugvr.from_vtk adds over VTK's own arrays: reads a .vtu with VTK (vtkXMLUnstructuredGridReader), then
measures the process's resident set around ugvr.from_vtk(grid). The peak is reset just before the call (Linux:
`5` into /proc/self/clear_refs resets VmHWM), so `extra_peak` is the most the call ever added, temporaries included,
over what VTK already held. ugvr keeps its own arrays (float32 points, uint32 connectivity, uint64 offsets, uint8
types, fields in their dtype: include/ugvr/grid/unstructured_mesh.h) and VTK's int64 connectivity cannot be shared
with them, so the floor is the ugvr dataset's own size (Dataset.memory_bytes); anything above it is a hidden copy.

    ugvr generate -o tet10m.vtu --cells 10000000 --kind tet
    PYTHONPATH=build/python /usr/bin/python3 bench/python_from_vtk_rss.py tet10m.vtu   # one JSON line
"""
import gc
import json
import sys
import time

import vtk
from vtk.util import numpy_support

import ugvr


def status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    raise KeyError(key)


def reset_peak():
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def main():
    path = sys.argv[1]
    t0 = time.perf_counter()
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    read_seconds = time.perf_counter() - t0
    cells = grid.GetCells()
    vtk_bytes = (grid.GetPoints().GetData().GetActualMemorySize() + cells.GetConnectivityArray().GetActualMemorySize()
                 + cells.GetOffsetsArray().GetActualMemorySize() + grid.GetCellTypesArray().GetActualMemorySize()
                 + sum(grid.GetPointData().GetArray(i).GetActualMemorySize()
                       for i in range(grid.GetPointData().GetNumberOfArrays()))
                 + sum(grid.GetCellData().GetArray(i).GetActualMemorySize()
                       for i in range(grid.GetCellData().GetNumberOfArrays()))) * 1024
    gc.collect()
    reset_peak()
    before = status("VmRSS")
    t0 = time.perf_counter()
    ds = ugvr.from_vtk(grid)
    seconds = time.perf_counter() - t0
    peak = status("VmHWM")
    after = status("VmRSS")
    print(json.dumps({
        "input": path, "cells": ds.cell_count, "points": ds.point_count,
        "vtk_read_seconds": round(read_seconds, 2), "from_vtk_seconds": round(seconds, 2),
        "vtk_arrays_bytes": vtk_bytes, "rss_before_bytes": before,
        "extra_peak_bytes": peak - before, "extra_after_bytes": after - before,
        "ugvr_dataset_bytes": ds.memory_bytes,
        "extra_peak_over_dataset": round((peak - before) / ds.memory_bytes, 3),
        "vtk_connectivity_dtype": str(numpy_support.vtk_to_numpy(cells.GetConnectivityArray()).dtype),
    }))


if __name__ == "__main__":
    main()
