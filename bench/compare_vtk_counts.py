#!/usr/bin/python3
"""Counts of VTK 9.1's own readers against `ugvr info --json`, per block with volume cells (issue 21's "Must show").

Usage: bench/compare_vtk_counts.py [UGVR_BINARY] [DATA_DIR]
  (defaults: build/ugvr and $UGVR_DATA or ../shared/data). Needs Debian's python3-vtk9 (scripts/install-bench-deps.sh).

CASES below is the table of (file under DATA_DIR, VTK reader class); other formats' readers add rows (OpenFOAM:
vtkOpenFOAMReader, CGNS: vtkCGNSReader). For each file, every VTK block with 3-D cells is matched, in order, with a
ugvr block, and compared on
  - points: VTK's point count = ugvr's minus the centre points the polyhedron decomposition added;
  - cells:  VTK's 3-D cells (polyhedra counted once) = ugvr's cells minus the pieces of decomposed polyhedra plus
            the polyhedra they came from (both numbers from ugvr's decomposition warning);
  - polyhedra: VTK's VTK_POLYHEDRON cells = the polyhedra ugvr's warning counts.
A file where VTK finds no 3-D cell must be refused by ugvr (exit status 1, "volume cell" in the message).
Lower-dimensional cells (which ugvr drops with a warning) are not compared. Exit status 0 when every row agrees.
"""
import json
import os
import re
import subprocess
import sys

import vtk

# (file relative to the data directory, VTK reader class)
CASES = [
    ("ensight-samples/TEST.case", "vtkGenericEnSightReader"),
    ("ensight-samples/elements.case", "vtkGenericEnSightReader"),
    ("ensight-samples/LShape.case", "vtkGenericEnSightReader"),
    ("ensight-samples/office_bin.case", "vtkGenericEnSightReader"),
    ("ensight-samples/RectGrid_bin.case", "vtkGenericEnSightReader"),
    ("ensight-samples/blow1_bin.case", "vtkGenericEnSightReader"),
    ("ensight-samples/elements.sos", "vtkEnSightMasterServerReader"),
    ("cgns-sqnz/sqnz_s.adf.cgns", "vtkCGNSReader"),
]

VTK_POLYHEDRON = 42


def vtk_blocks(path, reader_class):
    """[(name, points, 3-D cells, polyhedra)] for every leaf block that has 3-D cells."""
    reader = getattr(vtk, reader_class)()
    if reader_class in ("vtkGenericEnSightReader", "vtkEnSightMasterServerReader"):
        reader.SetCaseFileName(path)
        reader.ReadAllVariablesOn()
        if reader_class == "vtkEnSightMasterServerReader":
            reader.SetCurrentPiece(0)  # one server's piece per call; the samples' .sos lists one server
    else:
        reader.SetFileName(path)
    reader.Update()
    out = []
    it = reader.GetOutputDataObject(0).NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        ds = it.GetCurrentDataObject()
        name = it.GetCurrentMetaData().Get(vtk.vtkCompositeDataSet.NAME()) if it.HasCurrentMetaData() else ""
        cells3d = polyhedra = 0
        for c in range(ds.GetNumberOfCells()):
            t = ds.GetCellType(c)
            if ds.GetCell(c).GetCellDimension() == 3:
                cells3d += 1
                polyhedra += t == VTK_POLYHEDRON
        if cells3d:
            out.append((name, ds.GetNumberOfPoints(), cells3d, polyhedra))
        it.GoToNextItem()
    return out


def ugvr_blocks(binary, path):
    r = subprocess.run([binary, "--quiet", "info", "--json", path], capture_output=True, text=True)
    if r.returncode != 0:
        return None, (r.stdout + r.stderr).strip()
    info = json.loads(r.stdout)
    out = []
    for b in info["blocks"]:
        polyhedra = pieces = decomposed = centres = 0
        for w in info.get("warnings", []):
            if "(" + b["name"] + "):" not in w:
                continue
            m = re.search(r"(\d+) polyhedra:", w)
            if m:
                polyhedra = int(m.group(1))
            m = re.search(r"(\d+) decomposed around their centres into (\d+) tetrahedra and pyramids \((\d+) centre", w)
            if m:
                decomposed, pieces, centres = int(m.group(1)), int(m.group(2)), int(m.group(3))
        out.append((b["name"], b["points"] - centres, b["cells"] - pieces + decomposed, polyhedra))
    return out, ""


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else "build/ugvr"
    data = sys.argv[2] if len(sys.argv) > 2 else os.environ.get("UGVR_DATA", "../shared/data")
    failures = 0
    print("%-34s %-30s %-28s %8s %8s %8s %8s %6s %6s  %s" % ("file", "vtk reader", "block", "vtk pts", "ugvr pts",
                                                            "vtk 3d", "ugvr in", "vtk ph", "ugvr ph", "result"))
    for rel, reader_class in CASES:
        path = os.path.join(data, rel)
        if not os.path.exists(path):
            print("%-34s skipped: not found" % rel)
            continue
        theirs = vtk_blocks(path, reader_class)
        ours, error = ugvr_blocks(binary, path)
        if not theirs:
            ok = ours is None and "volume cell" in error
            failures += not ok
            print("%-34s %-30s %-28s %s" % (rel, reader_class, "(no 3-D cells)",
                                             "ok: refused" if ok else "MISMATCH: ugvr did not refuse it"))
            continue
        if ours is None or len(ours) != len(theirs):
            failures += 1
            print("%-34s %-30s MISMATCH: VTK has %d blocks with 3-D cells, ugvr %s" %
                  (rel, reader_class, len(theirs), error or len(ours)))
            continue
        # Blocks pair in order, or by name where VTK names every block after one of ugvr's (CGNS: VTK orders the
        # zones its own way; ugvr names them BASE/ZONE in file order).
        by_name = {u[0].split("/")[-1]: u for u in ours}
        if all(t[0] and t[0].split("/")[-1] in by_name for t in theirs):
            ours = [by_name[t[0].split("/")[-1]] for t in theirs]
        for (vname, vpts, vcells, vph), (uname, upts, ucells, uph) in zip(theirs, ours):
            ok = (vpts, vcells, vph) == (upts, ucells, uph)
            failures += not ok
            print("%-34s %-30s %-28s %8d %8d %8d %8d %6d %6d  %s" % (rel, reader_class, uname[:28], vpts, upts, vcells,
                                                                     ucells, vph, uph, "ok" if ok else "MISMATCH"))
    print("all agree" if failures == 0 else "%d mismatch(es)" % failures)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
