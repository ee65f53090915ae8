#!/usr/bin/python3
"""Counts VTK 9.1's vtkOpenFOAMReader reports for the OpenFOAM cases of tests/data/openfoam (python3-vtk9).

Prints, per case and per "Decompose polyhedra" setting, the internal mesh's points and cells (summed over the
pieces of a decomposed case), the cell types, the time values and the cell arrays of the latest time; with
--compare it also runs `ugvr info --json` on each case and compares. The figures are copied into
tests/test_openfoam_reader.cpp (kVtkCounts).

    /usr/bin/python3 bench/compare_vtk_counts_openfoam.py [--ugvr build/src/cli/ugvr] [--compare]

VTK options used: CaseType = reconstructed (1) for the plain cases and decomposed (0) for cavity_decomposed (which
holds only processor*/), ReadZones on, CreateCellToPoint off (cell data stays cell data, as ugvr keeps it),
only the internalMesh block (no patches), DecomposePolyhedra on (VTK 9.1's default) and off.
"""
import argparse
import collections
import json
import os
import subprocess
import sys

import vtk

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "tests", "data", "openfoam")
CASES = ["cavity", "cavity_binary", "cavity_gzip", "cavity_ascii_gz", "cavity_decomposed", "dual"]
TYPE_NAMES = {10: "tetra", 12: "hexahedron", 13: "wedge", 14: "pyramid", 42: "polyhedron"}


def internal_meshes(block, out):
    """Every vtkUnstructuredGrid under the 'internalMesh' blocks of the reader's multiblock output."""
    it = block.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        name = it.GetCurrentMetaData().Get(vtk.vtkCompositeDataSet.NAME())
        ds = it.GetCurrentDataObject()
        if name == "internalMesh" and isinstance(ds, vtk.vtkUnstructuredGrid):
            out.append(ds)
        it.GoToNextItem()
    return out


def vtk_counts(case, decompose):
    r = vtk.vtkPOpenFOAMReader()  # the parallel subclass: it has CaseType (reads processor*/ serially here)
    r.SetFileName(os.path.join(DATA, case, case + ".foam"))
    controller = vtk.vtkDummyController()  # without a controller vtkPOpenFOAMReader crashes
    vtk.vtkMultiProcessController.SetGlobalController(controller)
    r.SetController(controller)
    r.SetCaseType(0 if case.endswith("_decomposed") else 1)
    r.SetCreateCellToPoint(0)
    r.SetReadZones(1)
    r.SetDecomposePolyhedra(1 if decompose else 0)
    r.UpdateInformation()
    r.EnableAllCellArrays()
    r.EnableAllPointArrays()
    times = [r.GetTimeValues().GetValue(i) for i in range(r.GetTimeValues().GetNumberOfTuples())]
    r.UpdateTimeStep(times[-1] if times else 0)
    r.Update()
    meshes = internal_meshes(r.GetOutput(), [])
    types = collections.Counter()
    for m in meshes:
        for c in range(m.GetNumberOfCells()):
            types[TYPE_NAMES.get(m.GetCellType(c), str(m.GetCellType(c)))] += 1
    arrays = sorted(meshes[0].GetCellData().GetArrayName(i) for i in range(meshes[0].GetCellData().GetNumberOfArrays()))
    return {
        "pieces": len(meshes),
        "points": sum(m.GetNumberOfPoints() for m in meshes),
        "cells": sum(m.GetNumberOfCells() for m in meshes),
        "types": dict(sorted(types.items())),
        "times": times,
        "cell_arrays": arrays,
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ugvr", default=os.path.join(HERE, "..", "build", "src", "cli", "ugvr"))
    ap.add_argument("--compare", action="store_true")
    args = ap.parse_args()
    print("VTK", vtk.vtkVersion.GetVTKVersion())
    ok = True
    for case in CASES:
        counts = {}
        for decompose in (True, False):
            c = counts[decompose] = vtk_counts(case, decompose)
            print("%-18s decompose_polyhedra=%d %s" % (case, decompose, json.dumps(c)))
        if not args.compare:
            continue
        info = json.loads(subprocess.check_output([args.ugvr, "info", "--json", os.path.join(DATA, case)]))
        types = {k: v for k, v in info["blocks"][0]["cell_types"].items() if v}
        poly = [w for w in info["warnings"] if " polyhedra: " in w]
        print("%-18s ugvr: points %d cells %d %s; %s" % (case, info["points"], info["cells"], types, poly[0][:80] if poly else ""))
        off = counts[False]
        if off["types"].get("polyhedron", 0) == 0:
            # No polyhedra: the same mesh as VTK's.
            same = info["points"] == off["points"] and info["cells"] == off["cells"] and types == off["types"]
        else:
            # Polyhedra: as many input cells as VTK's cells, its hexahedra kept as ours, more points than VTK's
            # decomposition (our face centres on top of its cell centres).
            n_in, n_native = [int(x) for x in poly[0].replace(" polyhedra:", "").split()[:2]]
            same = (n_in == off["cells"] and n_native == off["types"].get("hexahedron", 0) and
                    types.get("hexahedron", 0) == off["types"].get("hexahedron", 0) and
                    info["points"] >= counts[True]["points"])
        print("%-18s %s" % (case, "agrees" if same else "DIFFERS"))
        ok = ok and same
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
