"""Material-point driver: points of a constitutive model along loading paths.

The same model classes as the finite element solve (:data:`soilbin.models.MODELS`)
are driven along the paths of :mod:`soilbin.material_point.paths` under mixed control: at each
step the strain-controlled components of the strain increment are prescribed
and the others are found by Newton's method on the residual
``sigma(deps)[s] - target[s]`` of the stress-controlled components ``s``, with
the model's consistent tangent ``C[s, s]`` as the Jacobian. Every iteration
updates from the committed state, as the global solve does. A step whose
iteration does not converge (or whose return map fails) is cut in halves.
Several paths are driven together (:func:`drive_all`), each at its own point, all
points updated in one vectorised call a step.

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

from ..errors import InputError, ReturnMapError
from ..models import MODELS
from ..params import from_table
from ..plotting import pyplot
from ..records.toml_in import assignment, read_scene_tables, scene_path
from ..tensors import IDENTITY, SQRT2, deviator, from_mandel, trace
from .paths import PATHS, targets as path_targets

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


class MaterialPoints:
    """Points of one ``model``, each on its own path: committed strain, stress and history
    of every point in one state, updated together (:meth:`Model.update` is vectorised)."""

    def __init__(self, model, p_initial):
        self.model = model
        p_initial = np.asarray(p_initial, dtype=float)
        self.state = model.initial_state(p_initial.size, -p_initial[:, None] * IDENTITY)
        self.eps = np.zeros((p_initial.size, 6))
        everyone = np.arange(p_initial.size)
        _, tangent, _, ok = self.update(everyone, np.zeros((p_initial.size, 6)))
        if not ok.all():
            raise InputError(f"{type(model).__name__} cannot start from the isotropic state "
                             f"p_initial = {p_initial[~ok][0]:g}; set path.p_initial")
        #: Residuals below this are zero: the stress of a strain of 1e-14 (for a point with
        #: no stress at all, where the relative tolerance has no scale).
        self.atol = 1e-14 * np.linalg.norm(tangent, axis=(1, 2))
        self.iterations = np.zeros(p_initial.size, dtype=int)
        self.max_iterations = np.zeros(p_initial.size, dtype=int)

    @property
    def sigma(self):
        return self.state["stress"]

    def update(self, idx, deps):
        """(sigma, tangent, state, ok) of the points ``idx`` for the increments ``deps``
        from their committed state; ``ok`` False where the return map fails (found point
        by point when the update of them all fails)."""
        state = {name: value[idx] for name, value in self.state.items()}
        try:
            return (*self.model.update(deps, state), np.ones(len(idx), dtype=bool))
        except ReturnMapError:
            if len(idx) == 1:
                return (np.full((1, 6), np.nan), np.full((1, 6, 6), np.nan), state,
                        np.zeros(1, dtype=bool))
        parts = [self.update(idx[k:k + 1], deps[k:k + 1]) for k in range(len(idx))]
        return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                {name: np.concatenate([p[2][name] for p in parts]) for name in state},
                np.concatenate([p[3] for p in parts]))

    def solve(self, idx, stress_ctrl, target):
        """Advance the points ``idx`` to ``target`` ((m, 6): total strain where not
        ``stress_ctrl``, stress where it is) by Newton's method on their stress-controlled
        components; commits every point that converges and returns the (m,) mask of them."""
        s = stress_ctrl
        deps = np.where(s, 0.0, target - self.eps[idx])
        if s.any():   # predictor from the tangent at rest (elastic on the yield surface too)
            _, C, _, _ = self.update(idx, np.zeros_like(deps))
            predicted = self.sigma[idx] + np.einsum("nij,nj->ni", C, deps)
            deps -= _masked_solve(C, s, predicted - target)
        converged = np.zeros(len(idx), dtype=bool)
        pending = np.arange(len(idx))
        for iteration in range(1, MAX_ITERATIONS + 1):
            points = idx[pending]
            sigma, tangent, state, ok = self.update(points, deps[pending])
            residual = np.where(s[pending], sigma - target[pending], 0.0)
            norm = np.linalg.norm(residual, axis=1)
            scale = np.maximum.reduce([np.linalg.norm(sigma, axis=1),
                                       np.linalg.norm(self.sigma[points], axis=1),
                                       np.linalg.norm(np.where(s[pending], target[pending], 0.0),
                                                      axis=1)])
            tol = RTOL * scale + self.atol[points]
            done = ok & (norm <= tol)
            if done.any():
                self._commit(points[done], deps[pending[done]], state, done, iteration)
                converged[pending[done]] = True
            going = ok & ~done & np.isfinite(norm)
            if not going.any():
                break
            deps[pending[going]] -= _masked_solve(tangent[going], s[pending[going]],
                                                  residual[going])
            pending = pending[going]
        return converged

    def _commit(self, points, deps, state, done, iteration):
        for name, value in state.items():
            self.state[name][points] = value[done]
        self.eps[points] += deps
        self.iterations[points] += iteration
        self.max_iterations[points] = np.maximum(self.max_iterations[points], iteration)


def _masked_solve(C, s, r):
    """(m, 6) solutions d of C[s, s] d[s] = r[s], d = 0 off ``s``: the strain-controlled
    rows become identity rows; the least-squares solution where the block is singular."""
    both = s[:, :, None] & s[:, None, :]
    A = np.where(both, C, np.eye(6))
    b = np.where(s, r, 0.0)
    try:
        return np.linalg.solve(A, b[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.stack([np.linalg.lstsq(a, c, rcond=None)[0] for a, c in zip(A, b)])


def drive(model, path_params, path_name="path"):
    """Drive ``model`` along the path; a :class:`PointResult` with one row per step
    (the initial state is step 0). Stops at the first step that cannot be
    converged (rows so far kept, converged False)."""
    return drive_all(model, [(path_params, path_name)])[0]


def drive_all(model, paths):
    """One :class:`PointResult` per (path parameters, path name) of ``paths``: every path
    at its own point, the points stepped together (step j of every path that has one in
    one vectorised update). A step of a point that does not converge is cut in halves,
    for that point alone; a point that fails even after MAX_CUTS cuts stops there."""
    points = MaterialPoints(model, [params.p_initial for params, _ in paths])
    schedules = [[(leg, k) for leg in params.legs() for k in range(1, leg.steps + 1)]
                 for params, _ in paths]
    names = [name for _, name in paths]
    rows = [[_row(points, i, 0, "initial", names[i])] for i in range(len(paths))]
    messages = [""] * len(paths)
    cuts = np.zeros(len(paths), dtype=int)
    stress_ctrl = np.zeros((len(paths), 6), dtype=bool)
    end = np.zeros((len(paths), 6))
    eps0, sigma0 = points.eps.copy(), points.sigma.copy()

    def advance(idx, f0, f1, depth):
        target = path_targets(stress_ctrl[idx], end[idx], eps0[idx], sigma0[idx], f1[:, None])
        failed = ~points.solve(idx, stress_ctrl[idx], target)
        if not failed.any():
            return
        if depth >= MAX_CUTS:
            for i, f in zip(idx[failed], f1[failed]):
                leg = schedules[i][len(rows[i]) - 1][0]
                messages[i] = (f"{names[i]}, leg {leg.name!r} at {f:.6g} of the leg: the "
                               f"mixed-control Newton iteration failed even after {MAX_CUTS} "
                               f"step cuts; the prescribed stress may be beyond the model's "
                               f"strength")
            return
        cuts[idx[failed]] += 1
        middle = 0.5 * (f0[failed] + f1[failed])
        advance(idx[failed], f0[failed], middle, depth + 1)
        alive = np.array([not messages[i] for i in idx[failed]], dtype=bool)
        if alive.any():
            advance(idx[failed][alive], middle[alive], f1[failed][alive], depth + 1)

    for j in range(max(map(len, schedules))):
        idx = np.array([i for i, schedule in enumerate(schedules)
                        if j < len(schedule) and not messages[i]], dtype=int)
        if idx.size == 0:
            break
        steps = [schedules[i][j] for i in idx]
        for i, (leg, k) in zip(idx, steps):
            if k == 1:   # a new leg starts from the committed strain and stress
                stress_ctrl[i], end[i] = leg.stress_controlled, leg.end
                eps0[i], sigma0[i] = points.eps[i], points.sigma[i]
        f0 = np.array([(k - 1) / leg.steps for leg, k in steps])
        f1 = np.array([k / leg.steps for leg, k in steps])
        advance(idx, f0, f1, 0)
        for i, (leg, _) in zip(idx, steps):
            if not messages[i]:
                rows[i].append(_row(points, i, len(rows[i]), leg.name, names[i]))
    return [PointResult(rows[i], not messages[i], messages[i], int(points.iterations[i]),
                        int(points.max_iterations[i]), int(cuts[i])) for i in range(len(paths))]


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


def _row(points, i, step, leg, path_name):
    """The output row of point ``i`` at its ``step``."""
    row = {"step": step, "leg": leg}
    row.update({k: float(v) + 0.0 for k, v in   # + 0.0: no -0 in the CSV
                invariants(points.sigma[i], points.eps[i],
                           signed=path_name != "simple-shear").items()})
    for name, value in points.state.items():
        if name != "stress" and value.ndim == 1:   # the scalar history variables
            row[name] = float(value[i]) + 0.0
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
