"""Material-point driver: one point of a constitutive model along a loading path.

The same model classes as the finite element solve (:data:`soilbin.models.MODELS`)
are driven along the paths of :mod:`soilbin.material_point.paths` under mixed control: at each
step the strain-controlled components of the strain increment are prescribed
and the others are found by Newton's method on the residual
``sigma(deps)[s] - target[s]`` of the stress-controlled components ``s``, with
the model's consistent tangent ``C[s, s]`` as the Jacobian. Every iteration
updates from the committed state, as the global solve does. A step whose
iteration does not converge (or whose return map fails) is cut in halves.

Output (compression positive, the geomechanics convention): p = -tr(sigma)/3,
q = sqrt(3 J2) (negative when the axial stress is the smaller, as in triaxial
extension; unsigned in simple shear), eps_v = -tr(eps), eps_axial = -eps_zz,
principal stresses sigma1 >= sigma2 >= sigma3; the shear strain gamma = 2 eps_xz
and stress tau = sigma_xz keep their sign.
"""
import csv
import dataclasses
import enum
import json
import math
import time
from pathlib import Path

import numpy as np

from ..errors import ConvergenceError, InputError, ReturnMapError
from ..models import MODELS
from ..params import from_table
from ..plotting import pyplot
from ..records.toml_in import assignment, read_scene_tables, scene_path
from ..tensors import IDENTITY, SQRT2, deviator, from_mandel, trace
from .paths import PATHS

#: Newton iteration of one step: relative tolerance on the stress residual,
#: iterations before the step is cut, and cuts (halvings) of one step.
RTOL = 1e-10
MAX_ITERATIONS = 30
MAX_CUTS = 10

CONVENTION = ("compression positive: p = -tr(sigma)/3, eps_v = -tr(eps), eps_axial = -eps_zz, "
              "sigma1 >= sigma2 >= sigma3 principal stresses; q = sqrt(3 J2), negative when the "
              "axial stress is the smaller (unsigned in simple shear); gamma = 2 eps_xz, "
              "tau = sigma_xz")
BASE_COLUMNS = ("step", "leg", "eps_axial", "eps_v", "gamma", "p", "q", "sigma_axial",
                "sigma_lateral", "tau", "sigma1", "sigma2", "sigma3")


class _NotConverged(Exception):
    """A step failed; the driver cuts it."""


# --------------------------------------------------------------------------- input

def split_overrides(overrides):
    """'key=value' items -> (model table, path table); keys 'path.X' go to the path."""
    model, path = {}, {}
    for item in overrides:
        key, value = assignment(item, "key=value (path.key=value for the path)")
        target, name = (path, key[5:]) if key.startswith("path.") else (model, key)
        if not name or "." in name:
            raise InputError(f"--set {key}: expected a model parameter or path.KEY")
        target[name] = value
    return model, path


def material_table(spec):
    """(model name, parameter table) of ``SCENE.toml:MATERIAL`` (a scene file, or a
    scene's name in the project's scenes/ folder)."""
    file, sep, material = spec.rpartition(":")
    if not sep or not file or not material:
        raise InputError(f"{spec!r}: expected SCENE.toml:MATERIAL")
    path = scene_path(file)
    materials = read_scene_tables(path).get("materials", {})
    materials = materials if isinstance(materials, dict) else {}
    if not isinstance(materials.get(material), dict):
        raise InputError(f"{path}: no material {material!r}; defined: {', '.join(materials)}")
    table = dict(materials[material])
    return table.pop("model", None), table


def build_model(name, table, where=None):
    """A validated model record; every error names the parameter (as ``where.key``;
    ``where`` defaults to the model's name)."""
    if name not in MODELS:
        raise InputError(f"unknown model {name!r}; known: {', '.join(MODELS)}")
    return from_table(MODELS[name], table, where or name)


def build_path(name, table):
    """A validated path parameter record."""
    if name not in PATHS:
        raise InputError(f"unknown path {name!r}; known: {', '.join(PATHS)}")
    return from_table(PATHS[name], table, "path")


def _both(*builds):
    """The results of every build, or one InputError naming all their problems at once."""
    results, errors = [], []
    for build in builds:
        try:
            results.append(build())
        except InputError as err:
            errors.append(str(err))
    if errors:
        raise InputError("; ".join(errors))
    return results


# --------------------------------------------------------------------------- driver

@dataclasses.dataclass
class PointResult:
    rows: list
    converged: bool
    message: str
    newton_iterations: int
    max_newton_iterations: int
    cuts: int


class MaterialPoint:
    """One point of ``model``: committed strain, stress, history and tangent."""

    def __init__(self, model, p_initial=0.0):
        self.model = model
        self.state = model.initial_state(1, -p_initial * IDENTITY)
        self.eps = np.zeros(6)
        #: Residuals below this are zero: the stress of a strain of 1e-14 (for a
        #: point with no stress at all, where the relative tolerance has no scale).
        self.atol = 1e-14 * np.linalg.norm(self._tangent_at_rest())
        self.iterations = 0
        self.max_iterations = 0

    @property
    def sigma(self):
        return self.state["stress"][0]

    def _tangent_at_rest(self):
        """Tangent for a zero increment from the committed state: the elastic one on
        the yield surface too, so the predictor also suits unloading."""
        return self.model.update(np.zeros((1, 6)), self.state)[1][0]

    def solve(self, stress_ctrl, target):
        """Advance to ``target`` (total strain where not ``stress_ctrl``, stress where
        it is); commits on success, raises _NotConverged otherwise."""
        s, e = stress_ctrl, ~stress_ctrl
        deps = np.zeros(6)
        deps[e] = target[e] - self.eps[e]
        if s.any():   # predictor
            C = self._tangent_at_rest()
            deps[s] = _solve(C[np.ix_(s, s)], target[s] - self.sigma[s] - C[np.ix_(s, e)] @ deps[e])
        for iteration in range(1, MAX_ITERATIONS + 1):
            try:
                sigma, tangent, state = self.model.update(deps[None], self.state)
            except ReturnMapError as err:
                raise _NotConverged(str(err)) from None
            sigma, tangent = sigma[0], tangent[0]
            residual = sigma[s] - target[s]
            norm = np.linalg.norm(residual)
            tol = RTOL * max(np.linalg.norm(sigma), np.linalg.norm(self.sigma),
                             np.linalg.norm(target[s])) + self.atol
            if norm <= tol:
                self.state, self.eps = state, self.eps + deps
                self.iterations += iteration
                self.max_iterations = max(self.max_iterations, iteration)
                return
            if not np.isfinite(norm):
                break
            deps[s] -= _solve(tangent[np.ix_(s, s)], residual)
        raise _NotConverged(f"stress residual {norm:.3g} after {iteration} iterations, "
                            f"tolerance {tol:.3g}")


def _solve(A, b):
    """A^-1 b, or the least-squares solution when the tangent block is singular."""
    try:
        return np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, b, rcond=None)[0]


def drive(model, path_params, path_name="path"):
    """Drive ``model`` along the path; a :class:`PointResult` with one row per step
    (the initial state is step 0). Stops at the first step that cannot be
    converged (rows so far kept, converged False)."""
    try:
        point = MaterialPoint(model, path_params.p_initial)
    except ReturnMapError as err:
        raise InputError(f"{type(model).__name__} cannot start from the isotropic state "
                         f"p_initial = {path_params.p_initial:g} ({err}); set path.p_initial") from None
    rows = [_row(point, 0, "initial", path_name)]
    cuts = 0

    def advance(leg, eps0, sigma0, f0, f1, depth):
        nonlocal cuts
        try:
            point.solve(leg.stress_controlled, leg.targets(eps0, sigma0, f1))
            return
        except _NotConverged as err:
            if depth >= MAX_CUTS:
                raise ConvergenceError(
                    f"{path_name}, leg {leg.name!r} at {f1:.6g} of the leg: the mixed-control "
                    f"Newton iteration failed even after {MAX_CUTS} step cuts ({err}); the "
                    f"prescribed stress may be beyond the model's strength") from None
        cuts += 1
        middle = 0.5 * (f0 + f1)
        advance(leg, eps0, sigma0, f0, middle, depth + 1)
        advance(leg, eps0, sigma0, middle, f1, depth + 1)

    message = ""
    try:
        for leg in path_params.legs():
            eps0, sigma0 = point.eps.copy(), point.sigma.copy()
            for k in range(1, leg.steps + 1):
                advance(leg, eps0, sigma0, (k - 1) / leg.steps, k / leg.steps, 0)
                rows.append(_row(point, len(rows), leg.name, path_name))
    except ConvergenceError as err:
        message = str(err)
    return PointResult(rows, not message, message, point.iterations, point.max_iterations, cuts)


def invariants(sigma, eps, signed=True):
    """Output quantities (compression positive) of one Mandel stress and strain."""
    p = -trace(sigma) / 3.0
    s = deviator(sigma)
    q = math.sqrt(1.5) * float(np.linalg.norm(s))   # sqrt(3 J2), J2 = |s|^2 / 2
    sigma_axial, sigma_lateral = -sigma[2], -0.5 * (sigma[0] + sigma[1])
    if signed and sigma_axial < sigma_lateral:
        q = -q
    principal = np.sort(np.linalg.eigvalsh(-from_mandel(sigma)))[::-1]
    return {"eps_axial": -eps[2], "eps_v": -trace(eps), "gamma": SQRT2 * eps[4],
            "p": p, "q": q, "sigma_axial": sigma_axial, "sigma_lateral": sigma_lateral,
            "tau": sigma[4] / SQRT2, "sigma1": principal[0], "sigma2": principal[1],
            "sigma3": principal[2]}


def _row(point, step, leg, path_name):
    row = {"step": step, "leg": leg}
    row.update({k: float(v) + 0.0 for k, v in   # + 0.0: no -0 in the CSV
                invariants(point.sigma, point.eps, signed=path_name != "simple-shear").items()})
    for name, value in point.state.items():
        if name != "stress" and value.shape == (1,):
            row[name] = float(value[0]) + 0.0
    return row


# --------------------------------------------------------------------------- output

def _plain(value):
    """JSON-friendly parameter value."""
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def record_table(record):
    return {f.name: _plain(getattr(record, f.name)) for f in dataclasses.fields(record)}


def write_csv(rows, path):
    columns = list(BASE_COLUMNS) + [k for k in rows[0] if k not in BASE_COLUMNS]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([row["step"], row["leg"]]
                            + [f"{row[c]:.12g}" for c in columns[2:]])


def plot(rows, path_name, title, path):
    """Three panels: q-p stress path, q (tau in simple shear) against the axial strain
    (gamma), eps_v against the axial strain (gamma; ln p for hydrostatic and oedometer)."""
    plt = pyplot()
    legs = []   # (name, rows), each leg starting at the last row of the one before
    for row in rows:
        if row["leg"] == "initial":
            legs.append((None, [row]))
        elif legs and legs[-1][0] in (None, row["leg"]):
            legs[-1] = (row["leg"], legs[-1][1] + [row])
        else:
            legs.append((row["leg"], [legs[-1][1][-1], row]))
    shear = path_name == "simple-shear"
    log_p = (path_name in ("hydrostatic", "oedometer")
             and sum(r["p"] > 0 for r in rows) >= 2)   # rows with p <= 0 left out there
    x2, x2_label = ("gamma", "shear strain γ = 2ε_xz") if shear else \
        ("eps_axial", "axial strain ε_a (compression +)")
    y2, y2_label = ("tau", "shear stress τ = σ_xz") if shear else \
        ("q", "deviatoric stress q = ±√(3J₂)")
    x3, x3_label = ("p", "mean stress p (log scale)") if log_p else (x2, x2_label)

    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for name, leg_rows in legs:
        def col(key):
            return [r[key] for r in leg_rows]
        axes[0].plot(col("p"), col("q"), "o-", ms=2, label=name)
        axes[1].plot(col(x2), col(y2), "o-", ms=2, label=name)
        shown = [r for r in leg_rows if r["p"] > 0] if log_p else leg_rows
        axes[2].plot([r[x3] for r in shown], [r["eps_v"] for r in shown], "o-", ms=2, label=name)
    axes[0].set_xlabel("mean stress p = −tr σ/3 (compression +)")
    axes[0].set_ylabel("q = √(3J₂)" + ("" if shear else ", − in extension"))
    axes[1].set_xlabel(x2_label)
    axes[1].set_ylabel(y2_label)
    axes[2].set_xlabel(x3_label)
    axes[2].set_ylabel("volumetric strain ε_v = −tr ε (compression +)")
    if log_p:
        axes[2].set_xscale("log")
        axes[2].invert_yaxis()   # the usual e-ln p picture: compression downwards
    for ax in axes:
        ax.grid(alpha=0.3)
    if len(legs) > 1:
        axes[0].legend(fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summarize(model_name, model, path_name, path_params, result, material=None):
    rows = result.rows
    peak = max(rows, key=lambda r: abs(r["q"]))
    final = rows[-1]
    return {
        "model": model_name,
        "material": material,
        "parameters": record_table(model),
        "path": path_name,
        "path_parameters": record_table(path_params),
        "convention": CONVENTION,
        "converged": result.converged,
        "status": "done" if result.converged else "failed",
        "message": result.message,
        "n_steps": len(rows) - 1,
        "newton_iterations": result.newton_iterations,
        "max_newton_iterations": result.max_newton_iterations,
        "cuts": result.cuts,
        "q_peak": peak["q"],
        "p_at_q_peak": peak["p"],
        "eps_axial_at_q_peak": peak["eps_axial"],
        "gamma_at_q_peak": peak["gamma"],
        "final": {k: v for k, v in final.items() if k not in ("step", "leg")},
    }


def run_point(model_name, model_table, path_name, path_table, out=None, material=None):
    """Validate, drive, write ``path.csv``, ``path.png`` and ``summary.json`` into
    ``out`` (when given); returns the summary. ``material`` (``SCENE.toml:NAME``)
    only labels the output and the error messages."""
    start = time.perf_counter()
    model, path_params = _both(lambda: build_model(model_name, model_table, material),
                               lambda: build_path(path_name, path_table))
    result = drive(model, path_params, path_name)
    summary = summarize(model_name, model, path_name, path_params, result, material)
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        write_csv(result.rows, out / "path.csv")
        plot(result.rows, path_name, f"{material or model_name}, {path_name}", out / "path.png")
        summary["files"] = ["path.csv", "path.png", "summary.json"]
        summary["wall_s"] = round(time.perf_counter() - start, 3)
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    else:
        summary["wall_s"] = round(time.perf_counter() - start, 3)
    return summary
