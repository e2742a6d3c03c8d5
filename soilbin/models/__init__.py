"""Constitutive models. :data:`MODELS` maps a scene's model name to its class;
build one with ``soilbin.params.from_table(MODELS[name], table, where)``."""
from .base import Model, State
from .cap import DiMaggioSandler, ModifiedCap
from .critical_state import CamClay, CriticalStateElasticity, ModifiedCamClay
from .drucker_prager import DruckerPrager
from .elastic import LinearElastic
from .matching import Matching
from .von_mises import VonMises

MODELS: dict[str, type] = {
    "elastic": LinearElastic,
    "von_mises": VonMises,
    "drucker_prager": DruckerPrager,
    "cam_clay": CamClay,
    "modified_cam_clay": ModifiedCamClay,
    "dimaggio_sandler": DiMaggioSandler,
    "modified_cap": ModifiedCap,
}

__all__ = ["MODELS", "CamClay", "CriticalStateElasticity", "DiMaggioSandler", "DruckerPrager",
           "LinearElastic", "Matching", "Model", "ModifiedCamClay", "ModifiedCap", "State",
           "VonMises"]
