"""How the parts of a Newton iteration grow with the tine's unknowns: factorisation,
assembly, constitutive update, solves, each as CPU ms per iteration over the first five
Newton iterations of the tine's first step (1/64 of its travel, from the K0 state; the
iteration limit ends the step) on four meshes, and the exponent b of ms ~ dofs^b fitted
over them (least squares in logarithms).

Each mesh runs in its own process (scripts/benchmark.py's cases); the table goes between
the iteration-parts markers of docs/performance.md (--page).
"""
import argparse
import sys

import numpy as np

from benchmark import TINE, measure
from doc_tables import add_page_argument, write_between_markers

#: (label, overrides): the scene's mesh, two of the mesh study's levels, refine 2.
MESHES = (("scene's mesh (element 1.5 in)", []),
          ("element 0.75 in", ["mesh.element_size=0.75", "mesh.growth=1.3"]),
          ("element 0.5 in", ["mesh.element_size=0.5", "mesh.growth=1.3"]),
          ("refine 2", ["mesh.refine=2"]))
FIRST_ITERATIONS = ["loading.magnitude=0.0015625", "loading.steps=1", "loading.max_cuts=0",
                    "solver.max_iterations=5"]
PARTS = (("factorisation", "factorisation_s"), ("assembly", "assembly_s"),
         ("constitutive update", "constitutive_s"), ("solves", "linear_solve_s"))


def per_iteration(result, key):
    return 1000.0 * result[key] / max(result["iterations"] + result["failed"], 1)


def table(results):
    head = ["mesh", "dofs", "Newton (failed)", *(name for name, _ in PARTS),
            "outside the factorisation / factorisation"]
    rows = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    for label, r in results:
        parts = [per_iteration(r, key) for _, key in PARTS]
        rows.append("| " + " | ".join([label, str(r["dofs"]), f"{r['iterations']} ({r['failed']})",
                                       *(f"{v:.1f}" for v in parts),
                                       f"{sum(parts[1:]) / parts[0]:.0%}"]) + " |")
    dofs = np.log([r["dofs"] for _, r in results])
    exponents = [np.polyfit(dofs, np.log([per_iteration(r, key) for _, r in results]), 1)[0]
                 for _, key in PARTS]
    rows.append("| exponent b of ms ~ dofs^b | | | "
                + " | ".join(f"{b:.2f}" for b in exponents) + " | |")
    return "\n".join(rows) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_page_argument(parser, "performance.md")
    args = parser.parse_args()
    results = []
    for label, overrides in MESHES:
        results.append((label, measure(label, TINE, overrides + FIRST_ITERATIONS)))
        print(f"{label}: {results[-1][1]['dofs']} dofs", file=sys.stderr, flush=True)
    text = table(results)
    print(text)
    if args.page:
        write_between_markers(args.page, "iteration-parts", text)


if __name__ == "__main__":
    main()
