"""A FIT.json rebuilds the model it was fitted with (issue 27, item 4): save -> load -> free run.

For every model of the library (``duffsym models``), every effect (``duffsym effects``, the rate effects,
``directional-damping``, a discovered term, a drifting parameter) and the models built outside the library
(a ``with_command`` variant, a path-time element, the Bouc-Wen benchmark's structure, a structure whose
element carries an effect): the model is built, run on a short record with every parameter acting, put in
a fit result, saved as FIT.json, loaded, rebuilt from the file alone, and run again: the free-run outputs
must agree to 1e-12 (they are the same equations; the code cache is keyed by them). The rebuild is also
checked against a model that lacks one piece (an effect, a setting), so the comparison can fail.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp

from duffsym.data.record import Record
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.effects.discovered import DiscoveredEffect
from duffsym.effects.drift import ParameterDrift
from duffsym.effects.mechanical import DirectionalDamping
from duffsym.effects.rate import FieldYield, MaxwellBranch
from duffsym.effects.spec import effect_types, model_from_spec
from duffsym.errors import ModelError
from duffsym.identify.result import IdentificationResult, load_result
from duffsym.model import MODELS, get_model
from duffsym.model.classical import bingham, with_command
from duffsym.model.library import mr_damper, mr_damper_current_path, path_time
from duffsym.model.serial import expr_from_text
from duffsym.model.structure import structure
from duffsym.model.symbols import state_symbol
from duffsym.simulate import simulate_record

#: Values of parameters whose default is 0 (so that the term they scale acts on the record).
ACTING = {
    "k3": 5.0,
    "off_y0": 0.3,
    "gas_k": 0.4,
    "inertia_m": 0.02,
    "pd_c": 0.3,
    "pd_c_u": 0.2,
    "fric_mu": 0.5,
    "asym_a": 0.1,
    "fa_a": 0.3,
    "quad_k": 20.0,
    "cdamp_c": 5.0,
    "curv_k": 1e-4,
    "dir_c": 0.3,
    "drift_a": 0.2,
    "delay_tau": 0.004,
    "shift_tau": 0.002,
    "mx_k": 2.0,
    "fy_F": 0.3,
    "fy_F_u": 0.2,
    "c0": 0.2,
    "c0_u": 0.1,
}


def _record(n: int = 400, dt: float = 0.0025) -> Record:
    """A short record: a two-tone input, a command stepping between two levels (smoothly), a placeholder output."""
    t = np.arange(n) * dt
    d = 0.6 * np.sin(2 * np.pi * 2.0 * t) + 0.15 * np.sin(2 * np.pi * 7.0 * t + 0.4)
    command = 0.5 + 0.3 * np.tanh(np.sin(2 * np.pi * 1.5 * t) / 0.2)
    y = np.cos(2 * np.pi * 2.0 * t)
    return Record(t=t, d=d, y=y, command=command, command_name="current", name="spec-roundtrip")


REC = _record()


def _params(model) -> dict:
    """Every parameter acting: the defaults, and :data:`ACTING` (or a small value) for the ones at 0."""
    out = {}
    for p in model.params:
        v = p.default
        if v == 0.0:
            v = ACTING.get(p.name, ACTING.get(p.name.rsplit("_", 1)[0], 0.1 * p.typical_scale))
        out[p.name] = float(min(max(v, p.lower), p.upper))
    return out


def _run(model, params, x0=None) -> np.ndarray:
    tr = simulate_record(model, params, REC, x0=x0, on_failure="return")
    assert tr.success, f"{model.name} + {model.effects}: {tr.message}"
    return np.asarray(tr.y, dtype=float)


def _result(model, params, x0) -> IdentificationResult:
    """An IdentificationResult as ``fit`` makes it (the model object, its parameters, one record's x0)."""
    return IdentificationResult(
        model=model,
        params=params,
        free=tuple(params),
        fixed={},
        stderr=dict.fromkeys(params, 0.0),
        covariance=np.zeros((len(params), len(params))),
        cost=0.0,
        nrmse=0.0,
        r2=1.0,
        status="Solve_Succeeded",
        success=True,
        message="IPOPT converged",
        n_iter=1,
        timings={},
        effects=tuple(model.effects),
        structural={k: v for k, v in model.structural if isinstance(v, int)},
        x0=(tuple(x0),),
        records=(REC.name,),
    )


def _save_and_load(model, tmp_path) -> tuple:
    """Save a fit of ``model`` and load it from the file alone: (loaded result, the JSON written)."""
    params = _params(model)
    path = tmp_path / "FIT.json"
    _result(model, params, np.zeros(model.n_states)).save(path)
    data = json.loads(path.read_text())
    assert "model_spec" in data
    loaded = load_result(path)
    assert loaded.fitted_model is None  # nothing but the file
    return loaded, data


def _numeric(model, seed: int = 0) -> np.ndarray:
    """The state equations and the output at a random point (states, inputs, parameters), by lambdify."""
    rng = np.random.default_rng(seed)
    syms = (*model.states, *model.input_symbols, *model.param_symbols)
    f = sp.lambdify(syms, [*model.rhs, model.output], "numpy")
    return np.array(f(*rng.uniform(0.2, 0.9, len(syms))), dtype=float)


def _check(model, tmp_path):
    """Save -> load -> rebuild: the same equations, effect objects, parameter settings and values."""
    loaded, data = _save_and_load(model, tmp_path)
    rebuilt = loaded.model_obj
    assert rebuilt.key == model.key and rebuilt == model
    assert rebuilt.effects == model.effects and rebuilt.effect_objects == model.effect_objects
    assert [(p.default, p.lower, p.upper, p.scale) for p in rebuilt.params] == [
        (p.default, p.lower, p.upper, p.scale) for p in model.params
    ]
    assert np.array_equal(_numeric(rebuilt), _numeric(model))
    return rebuilt, data, loaded


# ---------------------------------------------------------------------------------------------- the cases
def _on_a_model(effect):
    """``effect`` applied to the first model it fits: the MR damper, its command-driven variant, Duffing's."""
    for name in ("mr-damper", "mr-damper-current", "duffing-gain"):
        try:
            return effect.apply(get_model(name))
        except ModelError:
            continue
    raise AssertionError(f"effect {effect.name} applies to none of the test models")


OUTSIDE = {
    "maxwell-branch": MaxwellBranch(),
    "field-yield": FieldYield(),
    "directional-damping": DirectionalDamping(),
    "directional-damping position": DirectionalDamping(shape="position", epsilon=2e-3),
    "discovered": DiscoveredEffect(
        (sp.tanh(state_symbol("d_dot") / 0.27), state_symbol("d") ** 2, state_symbol("x_dot") ** 3),
        (0.3019, -1.25, 0.5),
        1,
    ),
    "drift energy": ParameterDrift("c3", "energy", 12.0, 0.1),
    "drift time": ParameterDrift("k1", "time", 0.8),
}
CHAIN = [
    CATALOGUE["force-offset"],
    CATALOGUE["input-delay"],
    CATALOGUE["coulomb-friction"],
    OUTSIDE["drift energy"],
    CATALOGUE["output-lag"],
]


def _bouc_wen_benchmark_model():
    from duffsym.benchmark.bouc_wen import BoucWenOptions, bouc_wen_model

    return bouc_wen_model(BoucWenOptions(n_elements=2))


BUILT = {
    "with_command(bingham, fc, eta=120)": lambda: with_command(bingham(), ("fc",), eta=120.0),
    "mr-damper-physical": lambda: mr_damper(3, physical=True),
    "path_time(mr-damper 3, 0.2)": lambda: path_time(mr_damper(3), 0.2),
    "mr-damper-current-path, epsilon 0.5, no viscous": lambda: mr_damper_current_path(3, epsilon=0.5, viscous=False),
    "structure, element with directional damping": lambda: structure(
        DirectionalDamping().apply(path_time(mr_damper(3), 0.2))
    ),
    "bouc-wen benchmark (two elements, scaled start)": _bouc_wen_benchmark_model,
    "mr-damper with new defaults + seal-friction": lambda: CATALOGUE["seal-friction"].apply(
        mr_damper(5).with_params(c3=250.0)
    ),
    "chain of five effects": lambda: apply_effects(get_model("mr-damper", 3), CHAIN),
    "extended without an Effect object (as diagnose/scenarios.py does)": lambda: _extended_by_hand(),
}


def _extended_by_hand():
    """A term added by SymbolicModel.extend directly: the model has an effect name but no effect object; it is
    saved as its equations whole (the name kept)."""
    from duffsym.model.symbols import ParamSpec

    m = get_model("mr-damper", 3)
    cx = ParamSpec("cx", "c_x", 0.2, -10.0, 10.0)
    out = m.extend(effect="hand-made", params=(cx,), output_add=cx.symbol * sp.sin(m.position))
    assert out.effects == ("hand-made",) and out.effect_objects is None
    return out


#: Every case by name: each library model (default power, and other powers), each effect, each built model.
CASES = {
    **{f"model {n}": (lambda n=n: get_model(n)) for n in sorted(MODELS)},
    **{
        f"model {n} n={k}": (lambda n=n, k=k: get_model(n, k))
        for n, k in (
            ("mr-damper", 3),
            ("duffing-like", 7),
            ("mr-damper-current", 3),
            ("bouc-wen", 1),
            ("spencer", 3),
            ("bouc-wen", 1.5),
        )
    },  # a non-integer exponent: FIT.json's "structural" stores int(n) = 1, model_spec 1.5
    "model duffing-like n_x=3 n_v=5": lambda: get_model("duffing-like", n_x=3, n_v=5),
    **{f"effect {n}": (lambda n=n: _on_a_model(CATALOGUE[n])) for n in sorted(CATALOGUE)},
    **{f"effect {n}": (lambda n=n: _on_a_model(OUTSIDE[n])) for n in sorted(OUTSIDE)},
    **{f"built {n}": f for n, f in BUILT.items()},
}
#: The cases whose free run the default suite compares (each compiles its model once; the rest are slow).
RUN_BY_DEFAULT = (
    "built bouc-wen benchmark (two elements, scaled start)",
    "built chain of five effects",
    "effect discovered",
)


@pytest.mark.parametrize("case", sorted(CASES))
def test_every_model_and_effect_rebuilds_from_its_fit_file(case, tmp_path):
    model = CASES[case]()
    rebuilt, data, _ = _check(model, tmp_path)
    spec = data["model_spec"]
    if case.startswith("model "):  # the library's, by name: a small file
        assert spec["base"]["library"]["name"] == model.name and not spec["effects"]
    if case.startswith("effect "):
        (saved,) = spec["effects"]
        (effect,) = model.effect_objects
        assert saved["type"] == type(effect).__name__ and saved["effect"] == effect.name
    if model.composition:  # a structure keeps its parts, the elements' effects as objects
        comp, back = dict(model.composition), dict(rebuilt.composition)
        assert back["element_model"] == comp["element_model"] and back["equation"] == comp["equation"]
        assert back["element_model"].effect_objects == comp["element_model"].effect_objects


@pytest.mark.parametrize(
    "case", [c if c in RUN_BY_DEFAULT else pytest.param(c, marks=pytest.mark.slow) for c in sorted(CASES)]
)
def test_the_rebuilt_model_runs_as_the_original(case, tmp_path):
    """The free run (simulate_record) of the model rebuilt from FIT.json equals the original's to 1e-12; an
    effect acts on the record (a rebuild without it would differ)."""
    model = CASES[case]()
    rebuilt, _, loaded = _check(model, tmp_path)
    params, x0 = _params(model), np.zeros(model.n_states)
    y = _run(model, params, x0)
    y_back = _run(rebuilt, loaded.params, loaded.x0[0])
    assert np.max(np.abs(y_back - y)) <= 1e-12 * max(1.0, float(np.max(np.abs(y))))
    base = model.base_model
    if base is not None and base is not model:
        y_base = _run(base, {k: v for k, v in params.items() if k in base.param_names}, np.zeros(base.n_states))
        if y_base.shape == y.shape:
            assert np.max(np.abs(y - y_base)) > 1e-6 * np.max(np.abs(y))


def test_a_discovered_term_is_stored_as_its_expression_and_read_without_eval(tmp_path):
    model = _on_a_model(OUTSIDE["discovered"])
    _, data, _ = _check(model, tmp_path)
    terms = data["model_spec"]["effects"][0]["settings"]["terms"]
    assert [expr_from_text(t["sympy"]) for t in terms] == list(OUTSIDE["discovered"].terms)
    # an edited file that smuggles code in is refused with one line, never run
    bad = json.loads(json.dumps(data))
    bad["model_spec"]["effects"][0]["settings"]["terms"][0]["sympy"] = "__import__('os').system('true')"
    with pytest.raises(ModelError, match="not allowed in a stored expression"):
        model_from_spec(bad["model_spec"])


def test_every_effect_class_can_be_saved():
    """Every Effect subclass of duffsym.effects is known to the reader of FIT.json."""
    from duffsym.effects.base import Effect

    def subclasses(c):
        return {c} | {s for k in c.__subclasses__() for s in subclasses(k)}

    ours = {c.__name__ for c in subclasses(Effect) - {Effect} if c.__module__.startswith("duffsym.effects")}
    assert ours <= set(effect_types()), ours - set(effect_types())
    assert {"DirectionalDamping", "DiscoveredEffect", "ParameterDrift", "MaxwellBranch", "FieldYield"} <= ours


def test_the_bouc_wen_benchmark_model_could_not_be_rebuilt_by_name():
    """Before model_spec: model_from_result knew only library names and catalogue effects."""
    model = _bouc_wen_benchmark_model()
    with pytest.raises(ModelError):
        get_model(model.name)


# ---------------------------------------------------------------------------------------------- failures
def test_a_changed_model_is_refused_not_silently_rebuilt(tmp_path):
    model = CATALOGUE["coulomb-friction"].apply(get_model("mr-damper"))
    _, data = _save_and_load(model, tmp_path)
    spec = data["model_spec"]
    # a setting edited in the file (another friction smoothing): other equations than the saved hash
    spec["effects"][0]["settings"]["epsilon"] = 0.02
    with pytest.raises(ModelError, match="other equations than the saved one"):
        model_from_spec(spec)
    spec["effects"][0] = {"effect": "x", "type": "NoSuchEffect", "settings": {}}
    with pytest.raises(ModelError, match="unknown to this duffsym"):
        model_from_spec(spec)


def test_a_file_without_model_spec_rebuilds_by_name_as_before(tmp_path):
    model = apply_effects(get_model("mr-damper", 3), [CATALOGUE["force-offset"]])
    _, data = _save_and_load(model, tmp_path)
    del data["model_spec"]
    old = IdentificationResult.from_dict(data)
    assert old.model_spec == {} and old.model_obj == model
    assert "model_spec" not in old.to_dict()  # a loaded old file is saved as it was


def test_result_status_is_the_status_enum_with_the_same_json(tmp_path):
    from duffsym.status import Status

    res = _result(get_model("mr-damper"), _params(get_model("mr-damper")), np.zeros(2))
    assert res.status is Status.SOLVED and res.to_dict()["status"] == "Solve_Succeeded"
    odd = IdentificationResult.from_dict({**res.to_dict(), "status": "Some_New_Ipopt_Status"})
    assert odd.status == "Some_New_Ipopt_Status" and odd.to_dict()["status"] == "Some_New_Ipopt_Status"
    assert math.isfinite(res.nrmse)
