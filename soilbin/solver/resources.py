"""The PETSc objects of a problem that is done with, freed."""


def release(*objects):
    """Destroy these PETSc objects (None skipped) of a problem that is done with: Python's
    collection of their wrappers left 90 MB a problem of the tine's 1-in mesh (its matrix,
    MUMPS's factors) in place, and a run that remeshes makes a problem for each mesh."""
    for item in objects:
        if item is not None:
            item.destroy()
