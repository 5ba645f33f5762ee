#!/usr/bin/env python3
"""usage: same_grid.py A B   (each a .vtu or a .pvtu)
Reads both with VTK's XML readers and exits 0 when they hold the same cells (compared by
their centres, in any order) with the same cell data, value for value; else 1 with the reason.
The MPI run test compares a run's .pvtu on N ranks with the .vtu of one rank this way."""
import sys, vtk
from vtk.util.numpy_support import vtk_to_numpy as np_of
import numpy as np
def load(path):
    r = vtk.vtkXMLPUnstructuredGridReader() if path.endswith('.pvtu') else vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(path); r.Update(); g = r.GetOutput()
    n = g.GetNumberOfCells()
    cc = vtk.vtkCellCenters(); cc.SetInputData(g); cc.Update()
    centres = np_of(cc.GetOutput().GetPoints().GetData())
    arrays = {g.GetCellData().GetArrayName(i): np_of(g.GetCellData().GetArray(i)) for i in range(g.GetCellData().GetNumberOfArrays())}
    order = np.lexsort(centres.T[::-1])
    return n, centres[order], {k: v[order] for k, v in arrays.items()}
a, b = load(sys.argv[1]), load(sys.argv[2])
if a[0] != b[0]:
    sys.exit(f"{a[0]} cells against {b[0]}")
if not np.array_equal(a[1], b[1]):
    sys.exit("the cell centres differ")
if sorted(a[2]) != sorted(b[2]):
    sys.exit(f"arrays {sorted(a[2])} against {sorted(b[2])}")
for k in a[2]:
    if not np.array_equal(a[2][k], b[2][k]):
        sys.exit(f"array {k} differs")
print(f"same {a[0]} cells and values ({', '.join(sorted(a[2]))})")
