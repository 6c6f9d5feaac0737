"""Physical effects that extend a model (composable; see :class:`Effect`)."""
from duffsym.effects.base import CoulombFriction, Effect, ForceOffset, OutputLag, apply_effects

#: Effects by name.
CATALOGUE = {e.name: e for e in (ForceOffset(), CoulombFriction(), OutputLag())}

__all__ = ["Effect", "ForceOffset", "CoulombFriction", "OutputLag", "apply_effects", "CATALOGUE"]
