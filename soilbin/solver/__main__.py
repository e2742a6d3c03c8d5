"""``python -m soilbin.solver``: compile the Jacobian assembler's loops into numba's disk
cache (:func:`.assembly.compile_loops`); ``make setup`` runs it after ``python -m
soilbin.models``."""
from .assembly import compile_loops

if __name__ == "__main__":
    compile_loops()
