#!/usr/bin/python3
"""Peer for bench_load: reads the same .vtu with VTK's own reader (Debian package python3-vtk9, not a project
dependency: `apt-get install python3-vtk9`) and prints the same JSON fields, so both can be run in turn and compared."""
import json
import resource
import sys
import time

import vtk

path = sys.argv[1]
t0 = time.perf_counter()
reader = vtk.vtkXMLUnstructuredGridReader()
reader.SetFileName(path)
reader.Update()
seconds = time.perf_counter() - t0
grid = reader.GetOutput()
print(json.dumps({"bench": "load-vtk", "input": path, "seconds": round(seconds, 3),
                  "cells": grid.GetNumberOfCells(), "cells_per_second": round(grid.GetNumberOfCells() / seconds),
                  "dataset_bytes": grid.GetActualMemorySize() * 1024,
                  "peak_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}))
