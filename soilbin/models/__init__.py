"""Constitutive models. :data:`MODELS` maps a scene's model name to its class;
build one with ``soilbin.params.from_table(MODELS[name], table, where)``."""
from .base import Model, State
from .drucker_prager import DruckerPrager
from .elastic import LinearElastic
from .matching import Matching
from .von_mises import VonMises

MODELS: dict[str, type] = {
    "elastic": LinearElastic,
    "von_mises": VonMises,
    "drucker_prager": DruckerPrager,
}

__all__ = ["MODELS", "DruckerPrager", "LinearElastic", "Matching", "Model", "State", "VonMises"]
