"""Loading paths of the material-point driver (:mod:`soilbin.material_point.driver`).

A path is a sequence of :class:`Leg` s. In a leg every one of the six Mandel
components is either strain-controlled (its strain changes by a given amount
over the leg) or stress-controlled (its stress goes linearly from its value at
the start of the leg to a given value, or is held). The 3-axis (z) is the
axial direction; x and y are lateral; simple shear is in the x-z plane.

Inside, the convention of :mod:`soilbin.tensors` holds (tension positive);
path parameters are given compression positive, as in the driver's output.
Each path has a parameter record (``--set path.KEY=VALUE``), built and
checked with :func:`soilbin.params.from_table` like a scene's tables.
"""
import dataclasses
import enum
import math

import numpy as np

from ..errors import InputError
from ..params import Params, param
from ..tensors import SQRT2

#: Component kinds in a leg.
STRAIN, STRESS = "e", "s"
#: A stress-controlled component whose value is held at its start-of-leg value.
HOLD = math.nan
#: Largest strain a path prescribes: the driver's strains are small strains.
MAX_STRAIN = 1.0


@dataclasses.dataclass(frozen=True)
class Leg:
    """One leg: ``control[i]`` is STRAIN or STRESS; ``end[i]`` is the strain change
    over the leg (STRAIN) or the stress at its end (STRESS; nan: held), tension positive."""
    name: str
    steps: int
    control: tuple
    end: tuple

    @property
    def stress_controlled(self):
        return np.array([c == STRESS for c in self.control])


def targets(stress_controlled, end, eps0, sigma0, fraction):
    """Target at ``fraction`` of a leg: total strain on the strain-controlled components,
    stress on the stress-controlled ones, from the strain and stress at the leg's start.
    Every argument broadcasts: (6,) for one point, (n, 6) with (n, 1) fractions for n."""
    stress_end = np.where(np.isnan(end), sigma0, end)   # nan: held
    return np.where(stress_controlled, sigma0 + fraction * (stress_end - sigma0),
                    eps0 + fraction * np.where(stress_controlled, 0.0, end))


def _leg(name, steps, **components):
    """A leg from components xx, yy, zz, yz, xz, xy = (kind, value); unnamed
    components are strain-controlled with no change."""
    order = ("xx", "yy", "zz", "yz", "xz", "xy")
    unknown = set(components) - set(order)
    assert not unknown, unknown
    control, end = [], []
    for key in order:
        kind, value = components.get(key, (STRAIN, 0.0))
        control.append(kind)
        end.append(value)
    return Leg(name, steps, tuple(control), tuple(end))


def _isotropic(name, steps, pressure):
    """Stress-controlled isotropic leg to the mean stress ``pressure`` (compression +)."""
    return _leg(name, steps, xx=(STRESS, -pressure), yy=(STRESS, -pressure), zz=(STRESS, -pressure))


class Control(enum.Enum):
    STRESS = "stress"
    STRAIN = "strain"


def _nan_default(doc):
    return param(math.nan, doc=doc)


def _require_finite(record, name, why):
    value = getattr(record, name)
    if not math.isfinite(value):
        raise InputError(f"{name} = {value!r}: {why}")


def _resolve(record, name, value):
    """Fill a nan default (frozen record; called from __post_init__)."""
    if math.isnan(getattr(record, name)):
        object.__setattr__(record, name, value)


@dataclasses.dataclass(frozen=True, kw_only=True)
class PathParams(Params):
    """Fields every path has."""

    p_initial: float = param(0.0, doc="mean stress of the isotropic initial state "
                                      "(compression positive), given to the model's "
                                      "initial_state; strains count from it")
    steps: int = param(50, lo=1, hi=100000, doc="steps of each loading or unloading leg")

    def __post_init__(self):
        super().__post_init__()
        _require_finite(self, "p_initial", "expected a finite number")

    def legs(self):
        """The legs of the path after the initial state."""
        raise NotImplementedError


@dataclasses.dataclass(frozen=True, kw_only=True)
class ConfinedPathParams(PathParams):
    """A path that first brings the isotropic stress to ``confining``."""

    confining: float = _nan_default("isotropic confining pressure (compression positive) "
                                    "reached by a stress-controlled leg before shearing; "
                                    "nan (the default): p_initial, no confining leg")
    confining_steps: int = param(10, lo=1, hi=100000, doc="steps of the confining leg")

    def __post_init__(self):
        super().__post_init__()
        _resolve(self, "confining", self.p_initial)
        _require_finite(self, "confining", "expected a finite number")

    def confine(self):
        if self.confining == self.p_initial:
            return []
        return [_isotropic("confine", self.confining_steps, self.confining)]


@dataclasses.dataclass(frozen=True, kw_only=True)
class Hydrostatic(PathParams):
    """Isotropic compression to ``pressure`` (or by ``volumetric_strain``), then
    stress-controlled isotropic unloading to ``unload_to``."""

    control: Control = param(Control.STRESS, doc="loading by mean stress (pressure) or "
                                                 "by volumetric strain (volumetric_strain)")
    pressure: float = _nan_default("mean stress at the end of loading (compression "
                                   "positive); required with control = stress")
    volumetric_strain: float = _nan_default("volumetric strain of the loading leg "
                                            "(compression positive, within [-1, 1]); "
                                            "required with control = strain")
    unload: bool = param(True, doc="unload after loading")
    unload_to: float = _nan_default("mean stress at the end of unloading; nan (the "
                                    "default): p_initial")

    def __post_init__(self):
        super().__post_init__()
        needed = "pressure" if self.control is Control.STRESS else "volumetric_strain"
        _require_finite(self, needed, f"required with control = {self.control.value!r}")
        if self.control is Control.STRAIN and abs(self.volumetric_strain) > MAX_STRAIN:
            raise InputError(f"volumetric_strain = {self.volumetric_strain!r} is outside the "
                             f"accepted range [{-MAX_STRAIN:g}, {MAX_STRAIN:g}]")
        _resolve(self, "unload_to", self.p_initial)

    def legs(self):
        if self.control is Control.STRESS:
            legs = [_isotropic("load", self.steps, self.pressure)]
        else:
            d = -self.volumetric_strain / 3.0
            legs = [_leg("load", self.steps, xx=(STRAIN, d), yy=(STRAIN, d), zz=(STRAIN, d))]
        if self.unload:
            legs.append(_isotropic("unload", self.steps, self.unload_to))
        return legs


@dataclasses.dataclass(frozen=True, kw_only=True)
class Triaxial(ConfinedPathParams):
    """Drained conventional triaxial test: confining pressure, then axial strain at
    constant lateral stress; optional unloading of the axial stress back to the
    confining pressure."""

    axial_strain: float = param(0.05, lo=0.0, lo_open=True, hi=MAX_STRAIN,
                                doc="axial strain of the shearing leg (magnitude; "
                                    "shortening in compression, lengthening in extension)")
    unload: bool = param(False, doc="after shearing, unload the axial stress to the "
                                    "confining pressure (stress-controlled)")

    #: -1: axial shortening (compression), +1: lengthening (extension); set by the subclass.
    sense = -1.0

    def legs(self):
        lateral = (STRESS, HOLD)
        legs = self.confine() + [_leg("shear", self.steps, xx=lateral, yy=lateral,
                                      zz=(STRAIN, self.sense * self.axial_strain))]
        if self.unload:
            legs.append(_leg("unload", self.steps, xx=lateral, yy=lateral,
                             zz=(STRESS, -self.confining)))
        return legs


@dataclasses.dataclass(frozen=True, kw_only=True)
class TriaxialCompression(Triaxial):
    __doc__ = Triaxial.__doc__
    sense = -1.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class TriaxialExtension(Triaxial):
    __doc__ = Triaxial.__doc__
    sense = 1.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class UndrainedTriaxial(ConfinedPathParams):
    """Drained confinement, then undrained (constant volume) axisymmetric shearing:
    the strain is prescribed fully (eps_x = eps_y = -eps_z / 2); the output stresses
    are effective stresses."""

    axial_strain: float = param(0.05, lo=-MAX_STRAIN, hi=MAX_STRAIN,
                                doc="axial strain of the shearing leg (compression "
                                    "positive; negative for undrained extension)")

    def __post_init__(self):
        super().__post_init__()
        if self.axial_strain == 0.0:
            raise InputError("axial_strain = 0.0: expected a nonzero strain")

    def legs(self):
        d = -self.axial_strain
        return self.confine() + [_leg("shear", self.steps, xx=(STRAIN, -d / 2),
                                      yy=(STRAIN, -d / 2), zz=(STRAIN, d))]


@dataclasses.dataclass(frozen=True, kw_only=True)
class SimpleShear(ConfinedPathParams):
    """Confinement, then simple shear: engineering shear strain gamma_xz with no
    lateral strain and either the normal stress held (normal = stress) or the
    height held (normal = strain, constant volume); optional unloading of the
    shear stress to zero."""

    shear_strain: float = param(0.05, lo=-MAX_STRAIN, hi=MAX_STRAIN,
                                doc="engineering shear strain gamma_xz of the shearing leg")
    normal: Control = param(Control.STRESS, doc="normal (z) direction: constant normal stress "
                                                "(stress) or constant height (strain)")
    unload: bool = param(False, doc="after shearing, unload the shear stress to zero")

    def __post_init__(self):
        super().__post_init__()
        if self.shear_strain == 0.0:
            raise InputError("shear_strain = 0.0: expected a nonzero strain")

    def legs(self):
        normal = (STRESS, HOLD) if self.normal is Control.STRESS else (STRAIN, 0.0)
        legs = self.confine() + [_leg("shear", self.steps, zz=normal,
                                      xz=(STRAIN, self.shear_strain / SQRT2))]
        if self.unload:
            legs.append(_leg("unload", self.steps, zz=normal, xz=(STRESS, 0.0)))
        return legs


@dataclasses.dataclass(frozen=True, kw_only=True)
class Oedometer(PathParams):
    """Uniaxial strain (no lateral strain): axial loading by strain or stress, then
    stress-controlled unloading of the axial stress to ``unload_to``."""

    control: Control = param(Control.STRAIN, doc="loading by axial strain (axial_strain) or "
                                                 "by axial stress (axial_stress)")
    axial_strain: float = param(0.05, lo=0.0, lo_open=True, hi=MAX_STRAIN,
                                doc="axial strain of the loading leg (compression positive)")
    axial_stress: float = _nan_default("axial stress at the end of loading (compression "
                                       "positive); required with control = stress")
    unload: bool = param(True, doc="unload after loading")
    unload_to: float = _nan_default("axial stress at the end of unloading; nan (the "
                                    "default): p_initial")

    def __post_init__(self):
        super().__post_init__()
        if self.control is Control.STRESS:
            _require_finite(self, "axial_stress", "required with control = 'stress'")
        _resolve(self, "unload_to", self.p_initial)

    def legs(self):
        axial = ((STRAIN, -self.axial_strain) if self.control is Control.STRAIN
                 else (STRESS, -self.axial_stress))
        legs = [_leg("load", self.steps, zz=axial)]
        if self.unload:
            legs.append(_leg("unload", self.steps, zz=(STRESS, -self.unload_to)))
        return legs


#: Path name -> parameter record.
PATHS: dict[str, type] = {
    "hydrostatic": Hydrostatic,
    "triaxial-compression": TriaxialCompression,
    "triaxial-extension": TriaxialExtension,
    "undrained-triaxial": UndrainedTriaxial,
    "simple-shear": SimpleShear,
    "oedometer": Oedometer,
}
