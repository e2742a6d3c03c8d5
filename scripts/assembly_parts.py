"""Where the tine's assembly goes, and what the C compiler's flags change: per Jacobian,
the coefficients packed by DOLFINx, the element matrices (FFCx's kernels in soilbin's
compiled loop) and their sum into PETSc's matrix (MatSetValuesCOO), beside DOLFINx's own
assembler of the same matrix (MatSetValuesLocal per cell); the residual vector; and the
problem's set-up on an empty form cache (its forms compiled), for each set of flags given
to FFCx's C code.

Each set of flags runs in its own process with its own empty form cache (a DOLFINx
``dolfinx_jit_parameters.json`` in a temporary XDG_CONFIG_HOME), on the default tine's mesh
(scenes/tine-2in-90deg.toml) at a Newton iterate of its first step. The table goes between
the assembly-parts markers of docs/performance.md (--page).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from doc_tables import ROOT, add_page_argument, write_between_markers

#: The flag sets compared: DOLFINx's default, and the two of issue 34's question.
FLAGS = (("-O2 (DOLFINx's default)", ["-O2", "-g0"]),
         ("-O2 -march=native", ["-O2", "-march=native", "-g0"]),
         ("-O3 -march=native", ["-O3", "-march=native", "-g0"]))
REPEATS = 15


def best_ms(action, repeats=REPEATS):
    """The least CPU ms of ``repeats`` calls (the machine's noise only adds)."""
    times = []
    for _ in range(repeats):
        start = time.process_time()
        action()
        times.append(time.process_time() - start)
    return 1000.0 * min(times)


def measure_here():
    """One flag set's measurements (this process's DOLFINx parameters)."""
    sys.path.insert(0, str(ROOT))
    from mpi4py import MPI
    from dolfinx import cpp, fem
    import dolfinx.fem.petsc  # noqa: F401
    from soilbin.meshes import scene_mesh
    from soilbin.problem import SoilProblem
    from soilbin.records.scene import load_scene

    scene = load_scene(ROOT / "scenes" / "tine-2in-90deg.toml", [])
    tagged = scene_mesh(scene, MPI.COMM_WORLD)
    start = time.perf_counter()   # wall: gcc runs in processes of its own
    problem = SoilProblem(scene, tagged)
    compile_s = time.perf_counter() - start
    newton = problem.newton
    problem.set_load_factor(0.01)
    b = newton._b.duplicate()
    newton.residual(b)

    def vector():
        with b.localForm() as local:
            local.set(0.0)
        fem.petsc.assemble_vector(b, newton._L)

    def dolfinx_jacobian():
        A.zeroEntries()
        fem.petsc.assemble_matrix(A, newton._a, bcs=newton._bcs)
        A.assemble()
    assembler, form = newton._assembler, newton._a
    coefficients, constants = cpp.fem.pack_coefficients(form), cpp.fem.pack_constants(form)
    A = fem.petsc.create_matrix(form)
    return dict(dofs=problem.n_dofs, cells=tagged.mesh.topology.index_map(3).size_local,
                element=assembler._element.shape[0],
                jacobian=best_ms(newton.jacobian),
                packing=best_ms(lambda: (cpp.fem.pack_coefficients(form),
                                         cpp.fem.pack_constants(form))),
                elements=best_ms(lambda: assembler.tabulate(coefficients, constants)),
                insertion=best_ms(lambda: assembler.insert(newton.matrix)),
                dolfinx=best_ms(dolfinx_jacobian), vector=best_ms(vector),
                compile_s=compile_s)


def measure(flags):
    """measure_here() in a process of its own with ``flags`` and an empty form cache."""
    with tempfile.TemporaryDirectory() as config:
        folder = Path(config, "dolfinx")
        folder.mkdir()
        (folder / "dolfinx_jit_parameters.json").write_text(json.dumps(
            {"cffi_extra_compile_args": flags, "cache_dir": str(Path(config, "cache"))}))
        proc = subprocess.run([sys.executable, __file__, "--here"], cwd=ROOT, text=True,
                              capture_output=True,
                              env={**os.environ, "XDG_CONFIG_HOME": config,
                                   "OMP_NUM_THREADS": "1"})
    if proc.returncode != 0:
        sys.exit(f"assembly_parts failed with {flags}:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def table(results):
    first = results[0][1]
    rows = [f"Tine, scene's mesh: {first['dofs']} dofs, {first['cells']} cells, element "
            f"matrix {first['element']} x {first['element']} (CPU ms, best of {REPEATS}; "
            "the problem's set-up with the forms' first compilation in wall s):", "",
            "| C flags | Jacobian | of it: packing | of it: element matrices "
            "| of it: COO sum | DOLFINx's assembler | residual vector "
            "| set-up with first compilation |", "|" + " --- |" * 8]
    for label, r in results:
        rows.append(f"| {label} | {r['jacobian']:.1f} | {r['packing']:.1f} | "
                    f"{r['elements']:.1f} | {r['insertion']:.1f} | {r['dolfinx']:.1f} | "
                    f"{r['vector']:.1f} | {r['compile_s']:.1f} |")
    return "\n".join(rows) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_page_argument(parser, "performance.md")
    parser.add_argument("--here", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.here:
        print(json.dumps(measure_here()))
        return
    results = []
    for label, flags in FLAGS:
        results.append((label, measure(flags)))
        print(f"{label}: done", file=sys.stderr, flush=True)
    text = table(results)
    print(text)
    if args.page:
        write_between_markers(args.page, "assembly-parts", text)


if __name__ == "__main__":
    main()
