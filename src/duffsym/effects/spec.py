"""A model as a recipe that rebuilds it: its base model and each effect object with its settings.

:func:`model_spec` writes what a saved fit needs to rebuild the model it was fitted with (FIT.json's
``model_spec``, ``docs/contract.md``); :func:`model_from_spec` rebuilds it and checks that the
equations are identical (their hash, :attr:`SymbolicModel.key`)::

    {"format": 1, "name": "mr-damper", "key": "<equation hash>",
     "base": {"name": "mr-damper", "key": "...", "library": {"name": "mr-damper", "kwargs": {"n": 5}}},
     "effects": [{"effect": "coulomb-friction", "type": "CoulombFriction", "settings": {}}],
     "params": {"c1": [default, lower, upper, scale], ...}}

- ``base``: a model of the library (``duffsym models``) by name and constructor arguments when the library
  builds it identically; any other model (a structure with its elements, a path-time element, a
  ``with_command`` variant, a model with edited parameters) as its equations whole (``"equations"``:
  states, inputs, parameters, right-hand sides and output as SymPy ``srepr`` text, read back without
  ``eval`` by :func:`duffsym.model.serial.expr_from_text`), the parts of a composed model recursively.
- ``effects``: each effect's class (:func:`effect_types`: the catalogue, the rate effects,
  ``directional-damping``, a discovered term, a drifting parameter) and the dataclass settings that
  differ from the class defaults (a discovered term's terms as SymPy text, a drift's parameter and scale).
- ``params``: every parameter's default, bounds and scale (``with_params`` or a scaled start changes them).
"""

from __future__ import annotations

import dataclasses
from typing import Any, cast

from duffsym.effects.base import Effect, apply_effects, effect_chain
from duffsym.errors import ModelError
from duffsym.model.core import SymbolicModel
from duffsym.model.serial import (
    float_from_data,
    float_to_data,
    model_from_data,
    model_to_data,
    value_from_data,
    value_to_data,
)

#: Version of the ``model_spec`` layout.
SPEC_FORMAT = 1
#: Effect fields that are text for people, not settings.
_TEXT_FIELDS = ("physics", "signature", "form", "guess")


def effect_types() -> dict[str, type]:
    """Every effect class of :mod:`duffsym.effects` by class name (what a saved ``model_spec`` may name)."""
    from duffsym.effects import (
        discovered,
        drift,
        gap,
        inputs,
        mechanical,
        output,
        polynomial,
        rate,
    )

    out = {}
    for mod in (output, mechanical, inputs, gap, polynomial, rate, discovered, drift):
        for obj in vars(mod).values():
            ours = isinstance(obj, type) and obj.__module__ == mod.__name__
            if ours and issubclass(obj, Effect) and obj is not Effect:
                out[obj.__name__] = obj
    return out


# ---------------------------------------------------------------------------------------------- effects
def effect_to_spec(effect: Effect) -> dict:
    """``{"effect": name, "type": class name, "settings": {...}}``: the settings that differ from the class's."""
    settings: dict[str, Any] = {}
    if dataclasses.is_dataclass(effect):
        for f in dataclasses.fields(effect):
            if not f.init or f.name in _TEXT_FIELDS:
                continue
            value = getattr(effect, f.name)
            default = f.default if f.default is not dataclasses.MISSING else dataclasses.MISSING
            if default is dataclasses.MISSING or type(value) is not type(default) or value != default:
                settings[f.name] = value_to_data(value, model_spec)
    return {"effect": effect.name, "type": type(effect).__name__, "settings": settings}


def effect_from_spec(data, *, source: str = "model_spec") -> Effect:
    """The effect written by :func:`effect_to_spec` (a :class:`ModelError` naming ``source`` if it is not)."""
    if (
        not isinstance(data, dict)
        or not isinstance(data.get("type"), str)
        or not isinstance(data.get("settings", {}), dict)
    ):
        raise ModelError(
            f"{source}: an effect must be {{'effect': name, 'type': class, 'settings': {{...}}}}; got {str(data)[:60]}"
        )
    types = effect_types()
    cls = types.get(data["type"])
    if cls is None:
        raise ModelError(
            f"{source}: effect type {data['type']!r} ({data.get('effect')}) is unknown to this duffsym; "
            f"known: {sorted(types)}"
        )
    where = f"{source}: effect {data.get('effect', data['type'])}"
    settings = {
        k: value_from_data(v, lambda d: model_from_spec(d, source=where), where)
        for k, v in data.get("settings", {}).items()
    }
    known = {f.name for f in dataclasses.fields(cls) if f.init} if dataclasses.is_dataclass(cls) else set()
    if set(settings) - known:
        raise ModelError(f"{where}: unknown setting(s) {sorted(set(settings) - known)}; known: {sorted(known)}")
    effect = cls(**settings)
    if "effect" in data and effect.name != data["effect"]:
        raise ModelError(f"{where}: rebuilt as {effect.name!r}, not {data['effect']!r}; the file is damaged or edited")
    return effect


# ---------------------------------------------------------------------------------------------- models
def _library_candidates(model: SymbolicModel) -> list[dict]:
    """Constructor arguments that may rebuild ``model`` from the library (checked by the caller)."""
    struct = dict(model.structural)
    if "n_x" in struct:
        nx, nv = struct["n_x"], struct.get("n_v", struct["n_x"])
        if not all(isinstance(v, int) for v in (nx, nv)):
            return []
        return [{"n": nx}] if nx == nv else [{"n_x": nx, "n_v": nv}]
    if "n" in struct:
        n = struct["n"]
        if isinstance(n, int):
            return [{"n": n}]
        try:
            return [{"n": float(n)}]
        except (TypeError, ValueError):
            return []
    return [{}]


def library_reference(model: SymbolicModel) -> dict | None:
    """``{"name": ..., "kwargs": {...}}`` when the library builds ``model``'s equations identically, else None."""
    from duffsym.model.library import MODELS, get_model

    if model.name not in MODELS:
        return None
    for kwargs in _library_candidates(model):
        try:
            built = get_model(model.name, **kwargs)
        except (ModelError, TypeError, ValueError):
            continue
        if built.key == model.key:
            return {"name": model.name, "kwargs": kwargs}
    return None


def _base_and_effects(model: SymbolicModel) -> tuple[SymbolicModel, list[Effect]]:
    steps = model.effect_steps()
    if steps is not None:  # the chain is known, so is its base; the model layer types the effects as objects
        return cast(SymbolicModel, model.base_model), [cast(Effect, e) for e, _ in steps]
    chain = effect_chain(model)  # a model built without Effect.apply: the library's, if identical
    if chain is not None:
        return chain[0], [e for e, _ in chain[1]]
    return model, []  # unknown chain: the model's equations whole (its effects by name only)


def model_spec(model: SymbolicModel) -> dict:
    """What rebuilds ``model``: its base (the library's by name, or its equations) and its effect objects
    (see the module docstring). Raises :class:`ModelError` for a setting that cannot be stored."""
    base, effects = _base_and_effects(model)
    ref = library_reference(base)
    base_data: dict[str, Any] = {"name": base.name, "key": base.key}
    base_data.update({"library": ref} if ref is not None else {"equations": model_to_data(base, model_spec)})
    return {
        "format": SPEC_FORMAT,
        "name": model.name,
        "key": model.key,
        "base": base_data,
        "effects": [effect_to_spec(e) for e in effects],
        "params": {
            p.name: [
                float_to_data(p.default),
                float_to_data(p.lower),
                float_to_data(p.upper),
                None if p.scale is None else float(p.scale),
            ]
            for p in model.params
        },
    }


def model_from_spec(spec, *, source: str = "model_spec") -> SymbolicModel:
    """The model written by :func:`model_spec`, its equations checked against the stored hash.

    Raises
    ------
    ModelError
        For a damaged spec, an unknown model or effect, or a rebuilt model whose equations differ from the
        saved ones (the library changed since the fit): one line naming ``source``.
    """
    if not isinstance(spec, dict) or spec.get("format") != SPEC_FORMAT or not isinstance(spec.get("base"), dict):
        raise ModelError(f"{source}: not a model spec of format {SPEC_FORMAT} (from duffsym fit --out)")
    base = _base_from_spec(spec["base"], source)
    effects = [effect_from_spec(e, source=source) for e in spec.get("effects", [])]
    model = apply_effects(base, effects)
    model = _with_param_settings(model, spec.get("params", {}), source)
    if model.key != spec.get("key"):
        raise ModelError(
            f"{source}: the rebuilt model {model.name} has other equations than the saved one "
            f"(hash {model.key} vs {spec.get('key')}): the file was edited, or this duffsym builds "
            "the model differently; use the duffsym of the fit"
        )
    return model


def _base_from_spec(data: dict, source: str) -> SymbolicModel:
    from duffsym.model.library import get_model

    if "library" in data:
        ref = data["library"]
        if not isinstance(ref, dict) or not isinstance(ref.get("kwargs", {}), dict):
            raise ModelError(f"{source}: base.library must be {{'name': ..., 'kwargs': {{...}}}}")
        try:
            base = get_model(str(ref.get("name")), **ref.get("kwargs", {}))
        except (TypeError, ValueError) as exc:
            raise ModelError(f"{source}: cannot build {ref.get('name')} with {ref.get('kwargs')} ({exc})") from None
    elif "equations" in data:
        base = model_from_data(data["equations"], lambda d: model_from_spec(d, source=source), source=source)
    else:
        raise ModelError(f"{source}: the base model needs 'library' or 'equations'")
    if base.key != data.get("key"):
        raise ModelError(
            f"{source}: this duffsym builds the base model {base.name} with other equations than "
            f"the one fitted (hash {base.key} vs {data.get('key')}); use the duffsym of the fit"
        )
    return base


def _with_param_settings(model: SymbolicModel, settings: Any, source: str) -> SymbolicModel:
    """``model`` with each parameter's stored default, bounds and scale (unchanged where they agree)."""
    if not isinstance(settings, dict):
        raise ModelError(f"{source}: 'params' must map each parameter to [default, lower, upper, scale]")
    params, changed = [], False
    for p in model.params:
        s = settings.get(p.name)
        if s is None:
            params.append(p)
            continue
        if not isinstance(s, list) or len(s) != 4:
            raise ModelError(f"{source}: params.{p.name} must be [default, lower, upper, scale]; got {str(s)[:40]}")
        where = f"{source}: params.{p.name}"
        new = dataclasses.replace(
            p,
            default=float_from_data(s[0], where),
            lower=float_from_data(s[1], where),
            upper=float_from_data(s[2], where),
            scale=None if s[3] is None else float_from_data(s[3], where),
        )
        changed |= new != p
        params.append(new)
    return dataclasses.replace(model, params=tuple(params)) if changed else model
