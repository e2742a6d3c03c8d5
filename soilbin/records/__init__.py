"""The validated records of a run: scene, parameters, elements, in-situ state.

Pure Python and NumPy: nothing here imports dolfinx, gmsh, PETSc or MPI.
"""
