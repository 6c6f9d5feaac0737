"""Physical effects that extend a model (composable; see :class:`Effect` and ``duffsym effects``).

An effect is a model extension with its data-based guesses; fitting an extended model is
:func:`duffsym.identify.extended_start` / :func:`duffsym.identify.fit_with_effects` (effects never
import the fitting code).

The catalogue, in the order ``duffsym effects`` lists it:

===================  ================================================================  ================
effect               form                                                              parameters
===================  ================================================================  ================
force-offset         y += off_y0                                                       off_y0
gas-accumulator      y += off_y0 + gas_k d (preload = the force offset)                off_y0, gas_k
inertia              y += inertia_m d''                                                inertia_m
parallel-damping     y += (pd_c + pd_c_u u) d' (pd_c_u on command models)              pd_c, pd_c_u
coulomb-friction     x'' += -fric_mu tanh(x'/0.01) (inside the fluid model)            fric_mu
seal-friction        y += seal_F tanh(d'/seal_eps) (on the piston velocity)            seal_F, seal_eps
asymmetry            y += asym_a F tanh(x'/0.05)                                       asym_a
output-lag           z' = (y - z)/lag_tau, output z                                    lag_tau
field-asymmetry      u' = -eta (1 + fa_a tanh((i-u)/fa_eps)) (u - i) (command models)  fa_a, fa_eps
input-delay          Pade all-pass state q; d -> 2q - d                                delay_tau
input-shift          d -> d - tau d', d' -> d' - tau d'' (hold vs interpolation)       shift_tau
backlash             smooth play state b; d -> b                                       bl_h
contact-gap          y -> smooth deadzone of y, half-width gap_w (gap.py; play)        gap_w
quadratic-stiffness  x'' += -quad_k x^2 (polynomial.py)                                quad_k
cubic-damping        x'' += -cdamp_c x'^3 (polynomial.py)                              cdamp_c
input-curvature      d -> d + curv_k d'' (polynomial.py; reconstruction, even part)    curv_k
===================  ================================================================  ================

Outside the catalogue (:data:`EXTENSIONS`: ``fit --add`` and ``ladder --add`` take them, the diagnosis and the
ladder never try them on their own): ``directional-damping`` (:class:`duffsym.effects.mechanical.DirectionalDamping`,
x'' += -dir_c d' |x'|, for path-time elements inside a structure; ``duffsym benchmark bouc-wen`` applies it to
its element), the rate physics of a device campaign (:mod:`duffsym.effects.rate`: ``maxwell-branch``,
``field-yield``), ``pressure-force`` (:class:`duffsym.effects.output.PressureForce`, y += pf_A p, a pneumatic
actuator's chamber pressure), and ``discovered: ...`` terms (:class:`duffsym.effects.discovered.DiscoveredEffect`,
found by :func:`duffsym.diagnose.discover.discover_term`; on by default in ``duffsym ladder``).

A model holds the effect objects applied to it (:attr:`~duffsym.model.SymbolicModel.effect_objects`, its
:attr:`~duffsym.model.SymbolicModel.base_model`); :mod:`duffsym.effects.spec` writes a model as its base and
effects with their settings (FIT.json's ``model_spec``) and rebuilds it.
"""

from duffsym.effects.base import (
    Effect,
    apply_effects,
    effect_chain,
    initial_states_with_effects,
)
from duffsym.effects.gap import ContactGap
from duffsym.effects.inputs import Backlash, InputDelay, InputShift
from duffsym.effects.mechanical import CoulombFriction, DirectionalDamping
from duffsym.effects.output import (
    Asymmetry,
    FieldAsymmetry,
    ForceOffset,
    GasAccumulator,
    OutputLag,
    ParallelDamping,
    PistonInertia,
    PressureForce,
    SealFriction,
)
from duffsym.effects.polynomial import CubicDamping, InputCurvature, QuadraticStiffness
from duffsym.effects.rate import RATE_EFFECTS

#: Effects by name.
CATALOGUE: dict[str, Effect] = {
    e.name: e
    for e in (
        ForceOffset(),
        GasAccumulator(),
        PistonInertia(),
        ParallelDamping(),
        CoulombFriction(),
        SealFriction(),
        Asymmetry(),
        OutputLag(),
        FieldAsymmetry(),
        InputDelay(),
        InputShift(),
        Backlash(),
        ContactGap(),
        QuadraticStiffness(),
        CubicDamping(),
        InputCurvature(),
    )
}

#: Effects outside the catalogue that a user may add by name (``fit --add``): the diagnosis and the ladder never
#: try them on their own (they need a command or a pressure column, or a path-time element).
EXTENSIONS: dict[str, Effect] = {
    **RATE_EFFECTS,
    **{e.name: e for e in (PressureForce(), DirectionalDamping())},
}

#: Every effect a user may add by name: the catalogue, then the extensions.
ADDABLE: dict[str, Effect] = {**CATALOGUE, **EXTENSIONS}

__all__ = [
    "ADDABLE",
    "CATALOGUE",
    "EXTENSIONS",
    "Asymmetry",
    "Backlash",
    "ContactGap",
    "CoulombFriction",
    "CubicDamping",
    "Effect",
    "FieldAsymmetry",
    "ForceOffset",
    "GasAccumulator",
    "InputCurvature",
    "InputDelay",
    "InputShift",
    "OutputLag",
    "ParallelDamping",
    "PistonInertia",
    "QuadraticStiffness",
    "SealFriction",
    "apply_effects",
    "effect_chain",
    "initial_states_with_effects",
]
