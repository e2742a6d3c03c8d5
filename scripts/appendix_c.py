"""Appendix C: the cubical-device tests of the modified cap (hydrostatic, CTC, CTE,
simple shear) driven at one material point with the section VII.5 parameters.

Runs `soilbin point modified_cap PATH` for the four paths (confining 10 psi)
and draws their stress paths and stress-strain curves on one PNG
(runs/appendix-c/appendix-c.png, copied into docs/figures: --figures DIR); each
run folder keeps its own CSV and PNG. The extension path takes the longest
(its mixed control keeps cutting steps at the cap's corner).
"""
import argparse
import csv
import shutil
import os
import subprocess
import sys
from pathlib import Path

import matplotlib

from soilbin.models.cap import SECTION_VII5

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SOILBIN = Path(sys.executable).with_name("soilbin")
OUT = ROOT / "runs" / "appendix-c"
PARAMETERS = SECTION_VII5   # as printed: A = C = 5.6 psi
TESTS = {
    "hydrostatic": ["path.pressure=30", "path.unload=true"],
    "triaxial-compression": ["path.confining=10"],
    "triaxial-extension": ["path.confining=10"],
    "simple-shear": ["path.confining=10"],
}
#: Each path's name in the legends.
NAMES = {"hydrostatic": "hydrostatic, to 30 psi and back",
         "triaxial-compression": "triaxial compression (CTC), 10 psi",
         "triaxial-extension": "triaxial extension (CTE), 10 psi",
         "simple-shear": "simple shear, 10 psi"}


def run(path, settings):
    sets = [f"{k}={v}" for k, v in PARAMETERS.items()] + settings
    cmd = [SOILBIN, "point", "modified_cap", path, "--out", OUT / path]
    for s in sets:
        cmd += ["--set", s]
    done = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    if done.returncode != 0:
        sys.exit(f"{path}: {done.stderr.strip()}")
    with open(OUT / path / "path.csv") as f:
        return [{k: float(v) for k, v in row.items() if k != "leg"} for row in csv.DictReader(f)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures",
                        help="copy the figure into this folder (default docs/figures)")
    args = parser.parse_args()
    fig, (paths, curves) = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, settings in TESTS.items():
        rows = run(name, settings)
        paths.plot([r["p"] for r in rows], [r["q"] for r in rows], ".-", ms=2, label=NAMES[name])
        if name == "hydrostatic":
            curves.plot([r["eps_v"] for r in rows], [r["p"] for r in rows], ".-", ms=2,
                        label="hydrostatic: mean stress p against volumetric strain ε_v")
        elif name == "simple-shear":
            curves.plot([r["gamma"] for r in rows], [r["tau"] for r in rows], ".-", ms=2,
                        label="simple shear: shear stress τ against shear strain γ")
        else:
            kind = "CTC" if name == "triaxial-compression" else "CTE"
            curves.plot([r["eps_axial"] for r in rows], [r["q"] for r in rows], ".-", ms=2,
                        label=f"{kind}: deviatoric stress q against axial strain ε_a")
    paths.set_xlabel("mean stress p [psi] (compression +)")
    paths.set_ylabel("deviatoric stress q [psi] (negative in extension)")
    curves.set_xlabel("strain [-] (compression +)")
    curves.set_ylabel("stress [psi]")
    for ax in (paths, curves):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Appendix C tests, modified cap (VII.5 parameters)", fontsize=10)
    fig.tight_layout()
    fig.savefig(OUT / "appendix-c.png", dpi=120)
    shutil.copy(OUT / "appendix-c.png", args.figures / "appendix-c.png")
    print(OUT / "appendix-c.png")


if __name__ == "__main__":
    main()
