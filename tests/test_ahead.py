"""The kernels compiled ahead of a run (soilbin.solver.ahead, and by ``make setup`` the
assembler's loops) are those the run calls."""
import subprocess
import sys

from conftest import ROOT

# In a fresh process (numba's disk cache warm: loading is what compiling would be), the
# warm-up of the coarse tine's soil and interface and the assembler's loops of ``make setup``,
# then a load step of the tine: every kernel the step calls must already hold the argument
# types it is called with.
STEP_AFTER_WARM_UP = """
import sys
sys.path.insert(0, "tests")
import numba
from conftest import SCENES, make_problem
from test_soil_bin import COARSE
from soilbin.solver.ahead import compile_run_kernels
from soilbin.solver.assembly import compile_loops
from soilbin.records.scene import load_scene

def kernels():
    return {id(value): (f"{name}.{attr}", len(value.signatures))
            for name, module in list(sys.modules.items()) if name.startswith("soilbin.")
            for attr, value in vars(module).items()
            if isinstance(value, numba.core.registry.CPUDispatcher)}

scene = load_scene(SCENES / "tine-2in-90deg.toml", COARSE)
compile_run_kernels([scene.materials[material] for material in scene.regions.values()],
                    scene.tool.law)
compile_loops()
before = kernels()
problem = make_problem("tine-2in-90deg", *COARSE)
problem.set_load_factor(0.25)
problem.solve()
print(sorted(name for key, (name, count) in kernels().items()
             if count > before.get(key, ("", 0))[1]))
"""


def test_a_load_step_compiles_no_kernel_the_warm_up_did_not():
    done = subprocess.run([sys.executable, "-c", STEP_AFTER_WARM_UP], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "[]"
