"""Figures say what the numbers say: the steady cycle drawn, every candidate listed, diverged ones
off the scale, ladder titles from the outcome (issue 11)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from duffsym.plot.loops import steady_window


def test_steady_window_skips_the_start_up_and_the_ramp_down():
    t = np.arange(0, 10, 0.01)
    envelope = np.clip(t / 2, 0, 1) * np.clip((10 - t) / 1.5, 0, 1)  # 2 s ramp up, 1.5 s ramp down
    d = envelope * np.sin(2 * np.pi * 1.0 * t)
    sl = steady_window(d)
    assert 2.5 <= t[sl][0] and t[sl][-1] <= 8.6  # a full-amplitude cycle, not the last (ramping) one
    assert np.ptp(d[sl]) == pytest.approx(2.0, rel=1e-3)
    assert 0.99 <= t[sl][-1] - t[sl][0] <= 1.02  # one period (and the sample closing it)
    assert steady_window(np.sin(2 * np.pi * np.arange(0, 1.5, 0.01))) is None  # too short: whole record


def test_loop_panels_call_a_window_of_a_random_record_a_window_not_a_steady_cycle():
    # the Dyke ladder's figure titled its loops "one steady cycle (5.72-5.86 s)" on a random displacement
    from duffsym.data.record import Record
    from duffsym.diagnose.figures import _steady, _steady_label

    t = np.arange(0, 10, 0.01)
    sine = Record(t=t, d=np.sin(2 * np.pi * t), y=np.cos(2 * np.pi * t))
    assert _steady_label(sine, _steady(sine)).startswith("one steady cycle (")
    d = np.convolve(np.random.default_rng(0).standard_normal(t.size), np.ones(25) / 25, mode="same")
    rand = Record(t=t, d=d, y=d)
    assert _steady_label(rand, _steady(rand)).startswith("a window (")
    assert _steady_label(rand, _steady(rand)).endswith(" s)")  # short: the panel is narrow


def _cand(effect, nrmse, success=True, needed=False, supported=False, message="ok"):
    return SimpleNamespace(
        effect=effect,
        nrmse_after=nrmse,
        delta_bic=-10.0 if success else np.nan,
        success=success,
        needed=needed,
        supported=supported,
        message=message,
    )


def _texts(fig):
    ax = fig.axes[0]
    return [t.get_text() for t in ax.texts], [t.get_text() for t in ax.get_yticklabels()], ax


def test_candidates_chart_lists_every_candidate_and_keeps_a_diverged_one_off_the_scale():
    from duffsym.diagnose.figures import plot_candidates

    cands = [
        _cand("force-offset", 0.04, needed=True, supported=True),
        _cand("asymmetry", 0.05, needed=True),
        _cand("inertia", 0.11),
        _cand("backlash", 0.92),
        _cand("input-delay", np.nan, success=False, message="screened out: not converged in 30 IPOPT iterations"),
    ]
    diag = SimpleNamespace(
        candidates=cands, needed=("force-offset",), nrmse_heldout=0.114, noise=0.01, split={"n_fit": 10}
    )
    fig = plot_candidates(diag)
    texts, ticks, ax = _texts(fig)
    assert len(ticks) == 5 and any("input-delay" in t for t in ticks)  # all five listed
    assert any(t.startswith("screened out") for t in texts)
    assert any("diverged: 0.92" in t for t in texts)
    assert ax.get_xlim()[1] < 0.2  # the scale is set by the base model (0.114), not the diverged 0.92
    colours = [tuple(np.round(p.get_facecolor()[:3], 2)) for p in ax.patches]
    assert len(colours) == 4 and colours[0] != colours[1]  # only the chosen effect is "called missing" green
    assert "5 candidates tried, 4 fitted, 1 not" in ax.get_title()


def test_ladder_title_says_nothing_was_added_when_nothing_was():
    from duffsym.diagnose.figures import ladder_outcome

    step = SimpleNamespace(effects=(), nrmse_heldout=0.113)
    assert ladder_outcome(SimpleNamespace(steps=[step])).startswith("nothing added")
    two = [step, SimpleNamespace(effects=("force-offset",), nrmse_heldout=0.045)]
    assert ladder_outcome(SimpleNamespace(steps=two)) == "added force-offset: held-out NRMSE falls, 0.113 -> 0.045"
    worse = [step, SimpleNamespace(effects=("inertia",), nrmse_heldout=0.2)]
    assert "does not fall" in ladder_outcome(SimpleNamespace(steps=worse))
