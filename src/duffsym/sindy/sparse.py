r"""The term library and the sparse regression shared by the SINDy cross-check and term discovery.

Term libraries are pysindy's feature libraries, each term also a SymPy expression:

- :func:`expression_library`: given SymPy expressions in given variables as a pysindy ``CustomLibrary``
  (one column per expression). The cross-check's candidates (the model's own terms, the catalogue
  effects' terms, generic powers: :func:`duffsym.sindy.library.candidate_library`) are evaluated so.
- :func:`switching_library`: a plain ``PolynomialLibrary`` in every signal, plus each velocity's
  switching functions (:func:`switches`) alone and times a polynomial in the positions (a
  ``GeneralizedLibrary`` with tensor products). Term discovery
  (:func:`duffsym.diagnose.discover.term_library`) regresses the residual on it.
- :func:`named_matrix`: a pysindy library's matrix with its feature names read back as SymPy
  expressions (duplicates and non-finite columns dropped).

Sparse regression is one *path* of supports from the sparsest (:func:`sparse_path`: exhaustive best
subsets, pysindy's stepwise ``SSR``, or scikit-learn's orthogonal matching pursuit) and a rule that
picks a size on it:

- :func:`sparsest_acceptable`: the sparsest support whose residual is not significantly worse than
  the full library's (the cross-check; with :func:`stlsq`, pysindy's ``STLSQ``, kept for comparison);
- :func:`validated_support`: the fewest terms within a factor of the best held-out error (discovery);
- :func:`stability_selection`: :func:`validated_support` on resampled halves of the data, giving the
  inclusion probability of each column and of each group of columns (discovery's families);
  :func:`bagged`: :func:`sparsest_acceptable` on bootstrap resamples of the rows (the cross-check's
  inclusion probabilities).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from itertools import combinations

import numpy as np
import sympy as sp

#: libraries up to this size get exhaustive best-subset search (2^16 subsets, Gram-based)
MAX_EXHAUSTIVE = 16
#: how a path of supports is built (see :func:`sparse_path`)
PATHS = ("best-subset", "ssr", "omp")


# ---------------------------------------------------------------------------------------------- term libraries
def expression_library(exprs: Sequence[sp.Expr], variables: Sequence[sp.Symbol], names: Sequence[str] | None = None):
    """A pysindy ``CustomLibrary`` with one column per SymPy expression, each a function of all ``variables``
    (in that order; evaluate it on samples ``(n_times, len(variables))``)."""
    import pysindy as ps

    fns = [sp.lambdify(tuple(variables), e, modules="numpy") for e in exprs]  # pysindy counts their arguments
    labels = list(names) if names is not None else [str(e) for e in exprs]
    return ps.CustomLibrary(library_functions=fns, function_names=[_constant_name(n) for n in labels])


def _constant_name(label: str):
    return lambda *args: label


def evaluate(library, X: np.ndarray) -> np.ndarray:
    """The matrix ``(n_times, n_features)`` of a pysindy library on samples ``X`` (fitted here)."""
    return np.asarray(library.fit_transform(np.asarray(X, dtype=float)), dtype=float)


def _rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.asarray(v) ** 2)))


def _grid(frac: float, rms: float) -> str:
    return f"{float(f'{frac * rms:.2g}'):g}"


def switches(
    rms: float, eps_fractions: Sequence[float], stribeck_fractions: Sequence[float]
) -> list[tuple[str, object]]:
    """The switching functions of one velocity ``v`` (RMS ``rms``), as (printable template, function):
    smooth signs ``tanh(v/ε)`` (ε = each of ``eps_fractions`` of the RMS), Stribeck shapes
    ``exp(-(v/v_s)**2)·tanh(v/ε)`` (v_s = each of ``stribeck_fractions``, ε the first eps fraction), the
    smooth ``|v|`` and ``v|v|`` (``v·tanh(v/ε)``, ``v**2·tanh(v/ε)``, ε the second eps fraction). The
    template has ``{v}`` for the signal's name; grid constants are rounded to two significant digits."""

    def sign(e):
        return lambda v: np.tanh(v / e)

    def stribeck(vs, e):
        return lambda v: np.exp(-((v / vs) ** 2)) * np.tanh(v / e)

    def power(k, e):
        return lambda v: v**k * np.tanh(v / e)

    out = []  # pysindy counts a function's arguments: one argument each (closures, no defaults)
    for frac in eps_fractions:
        e = _grid(frac, rms)
        out.append((f"tanh({{v}}/{e})", sign(float(e))))
    e0 = _grid(eps_fractions[0], rms)
    for frac in stribeck_fractions:
        vs = _grid(frac, rms)
        out.append((f"exp(-({{v}}/{vs})**2)*tanh({{v}}/{e0})", stribeck(float(vs), float(e0))))
    e1 = _grid(eps_fractions[1], rms)
    out.append((f"{{v}}*tanh({{v}}/{e1})", power(1, float(e1))))
    out.append((f"{{v}}**2*tanh({{v}}/{e1})", power(2, float(e1))))
    return out


def _namer(template: str):
    return lambda v: template.format(v=v)


def switching_library(
    cols: Mapping[str, np.ndarray],
    *,
    positions: Sequence[str],
    velocities: Sequence[str],
    plain_degree: int,
    position_degree: int,
    eps_fractions: Sequence[float],
    stribeck_fractions: Sequence[float],
):
    """(pysindy ``GeneralizedLibrary``, the signal names it takes, in order) over the non-constant signals
    of ``cols``: a ``PolynomialLibrary`` (degree ``plain_degree``, with bias) in every signal, plus each
    velocity's switching functions (:func:`switches`) alone and times a ``PolynomialLibrary`` (degree
    ``position_degree``) in the positions — the tensor product ``positions ⊗ switches(v)``."""
    import pysindy as ps

    names = [k for k in cols if np.ptp(cols[k]) > 0]
    pos = [names.index(k) for k in positions if k in names]
    libs, inputs, tensor = [ps.PolynomialLibrary(degree=plain_degree, include_bias=True)], [list(range(len(names)))], []
    libs.append(ps.PolynomialLibrary(degree=position_degree, include_bias=False))
    inputs.append(pos)
    for key in (k for k in velocities if k in names):
        sw = switches(_rms(cols[key]), eps_fractions, stribeck_fractions)
        libs.append(ps.CustomLibrary(library_functions=[f for _, f in sw], function_names=[_namer(t) for t, _ in sw]))
        inputs.append([names.index(key)])
        tensor.append([0, 1] + [int(i == len(libs) - 1) for i in range(2, len(libs))])
    tensor = [row + [0] * (len(libs) - len(row)) for row in tensor]
    return ps.GeneralizedLibrary(libs, tensor_array=tensor or None, inputs_per_library=inputs), names


def named_matrix(
    library, cols: Mapping[str, np.ndarray], names: Sequence[str], symbols: Mapping[str, sp.Symbol]
) -> tuple[list[sp.Expr], np.ndarray]:
    """(terms, matrix ``(n_times, n_terms)``): ``library`` evaluated on the signals ``names`` of ``cols``, its
    feature names read back as SymPy expressions in ``symbols``; a repeated or non-finite column is dropped."""
    X = np.column_stack([np.asarray(cols[k], float) for k in names])
    Theta = np.asarray(library.fit_transform(X), float)
    terms, keep, seen = [], [], set()
    for j, name in enumerate(library.get_feature_names(list(names))):
        expr = sp.sympify(name.replace("^", "**").replace(" ", "*"), locals=dict(symbols))
        if expr in seen or not np.all(np.isfinite(Theta[:, j])):
            continue
        seen.add(expr)
        terms.append(expr)
        keep.append(j)
    return terms, Theta[:, keep]


# ---------------------------------------------------------------------------------------------- paths
def _full(p: int, support, values) -> np.ndarray:
    out = np.zeros(p)
    out[np.asarray(support, dtype=int)] = values
    return out


def _best_subsets(G: np.ndarray, b: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """For each size k, the support with the smallest residual (exhaustive; Gram matrices, batched solves)."""
    p = G.shape[1]
    A = G.T @ G
    g = G.T @ b
    bb = float(b @ b)
    ridge = 1e-13 * np.trace(A) / p  # keeps exactly collinear subsets solvable; far below any real effect
    out = []
    for k in range(1, p + 1):
        combos = np.array(list(combinations(range(p), k)))
        Ak = A[combos[:, :, None], combos[:, None, :]] + ridge * np.eye(k)
        gk = g[combos]
        coef = np.linalg.solve(Ak, gk[..., None])[..., 0]
        rss = bb - np.einsum("ck,ck->c", gk, coef)
        i = int(np.argmin(rss))
        out.append((combos[i], _full(p, combos[i], coef[i])))
    return out


def _ssr(G: np.ndarray, b: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Supports from one term up to the full library, by pysindy's stepwise sparse regression.

    ``SSR(criteria="model_residual")`` drops, at each step, the term whose removal raises the
    residual least: unlike a threshold on coefficient size (STLSQ), it is not fooled by large,
    cancelling coefficients of nearly collinear terms (x'^3, x'^5, x'^7 ...).
    """
    import pysindy as ps

    p = G.shape[1]
    opt = ps.SSR(alpha=1e-10, criteria="model_residual", max_iter=p, unbias=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        opt.fit(G, b)
    path: dict[int, tuple] = {}
    for coef in opt.history_:
        coef = np.asarray(coef, dtype=float).reshape(-1)
        sup = tuple(np.flatnonzero(coef))
        path.setdefault(len(sup), (sup, coef))
    if len(path.get(p, ((),))[0]) != p:
        path[p] = (tuple(range(p)), np.linalg.lstsq(G, b, rcond=None)[0])
    return [(np.array(path[k][0]), path[k][1]) for k in sorted(path)]


def _omp(G: np.ndarray, b: np.ndarray, max_terms: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """scikit-learn's orthogonal matching pursuit (no intercept) for 1..``max_terms`` terms."""
    from sklearn.linear_model import OrthogonalMatchingPursuit

    out = []
    for k in range(1, max_terms + 1):
        omp = OrthogonalMatchingPursuit(n_nonzero_coefs=k, fit_intercept=False).fit(G, b)
        out.append((np.flatnonzero(omp.coef_), np.asarray(omp.coef_, dtype=float)))
    return out


def sparse_path(
    G: np.ndarray, b: np.ndarray, method: str = "best-subset", max_terms: int | None = None
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Supports of ``b ≈ G c`` from the sparsest up: ``[(columns, coefficients over all columns), ...]``.

    ``"best-subset"``: the support with the smallest residual of each size 1..p (exhaustive; greedy
    elimination can lose the true term among nearly collinear powers, x'^5 against x'^3 + x'^7);
    ``"ssr"``: pysindy's ``SSR`` elimination path, each size it passes, and the full library;
    ``"omp"``: scikit-learn's ``OrthogonalMatchingPursuit`` for each size 1..``max_terms`` (the
    coefficients are the estimator's own, so ``G @ coefficients`` is its prediction).
    """
    if method == "best-subset":
        return _best_subsets(G, b)
    if method == "ssr":
        return _ssr(G, b)
    if method == "omp":
        return _omp(G, b, int(max_terms or G.shape[1]))
    raise ValueError(f"method must be one of {PATHS}; got {method!r}")


# ---------------------------------------------------------------------------------------------- size rules
def stlsq(G: np.ndarray, b: np.ndarray, threshold: float) -> np.ndarray:
    """pysindy's STLSQ (the plain SINDy choice): coefficients over all columns."""
    import pysindy as ps

    opt = ps.STLSQ(threshold=threshold, alpha=1e-10, max_iter=50)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        opt.fit(G, b)
    return np.asarray(opt.coef_, dtype=float).reshape(-1)


def allowance(k: int, p: int, rss_full: float, bb: float, n_eff: float, tolerance: float) -> float:
    """How much a support of ``k`` of ``p`` terms may raise the residual sum of squares over the full library's:
    ``tolerance * |b|^2`` (practical significance) plus ``(p - k) log(n_eff) RSS_full / n_eff`` (a BIC-like
    allowance for noise; ``n_eff`` counts independent rows)."""
    return tolerance * bb + (p - k) * math.log(max(n_eff, 2.0)) * rss_full / max(n_eff, 1.0)


def acceptable(rss: float, k: int, p: int, rss_full: float, bb: float, n_eff: float, tolerance: float) -> bool:
    """A support of ``k`` of ``p`` terms with residual ``rss`` is as good as the full library (:func:`allowance`)."""
    return rss - rss_full <= allowance(k, p, rss_full, bb, n_eff, tolerance)


def sparsest_acceptable(
    G: np.ndarray, b: np.ndarray, n_eff: float, tolerance: float, method: str = "best-subset", threshold: float = 0.05
) -> np.ndarray:
    """Coefficients of the sparsest support on the path whose residual is :func:`acceptable`.

    ``method``: ``"best-subset"`` (exhaustive for at most :data:`MAX_EXHAUSTIVE` columns, else pysindy's
    SSR path), ``"ssr"``, or ``"stlsq"`` (pysindy's STLSQ with ``threshold``, no path). ``n_eff`` counts
    independent rows. Each support is refitted by least squares; the full fit if none is acceptable.
    """
    if method == "stlsq":
        return stlsq(G, b, threshold)
    p = G.shape[1]
    c_full, *_ = np.linalg.lstsq(G, b, rcond=None)
    rss_full = float(np.sum((b - G @ c_full) ** 2))
    bb = float(b @ b)
    path = sparse_path(G, b, "best-subset" if p <= MAX_EXHAUSTIVE and method == "best-subset" else "ssr")
    for sup, _ in path:
        c, *_ = np.linalg.lstsq(G[:, sup], b, rcond=None)
        rss = float(np.sum((b - G[:, sup] @ c) ** 2))
        if acceptable(rss, sup.size, p, rss_full, bb, n_eff, tolerance):
            return _full(p, sup, c)
    return c_full


def validated_support(Theta: np.ndarray, r: np.ndarray, n_train: int, max_terms: int, parsimony: float):
    """Sparse support of ``r ≈ Theta c``: the OMP path (:func:`sparse_path`) on the standardised library for
    1..``max_terms`` terms, fitted on the first ``n_train`` rows and scored on the rest; the fewest terms within
    ``parsimony`` of the best validation MSE. Returns (column indices, per-size validation MSE, the other
    sizes' supports, best validation first)."""
    scale = np.sqrt(np.mean(Theta[:n_train] ** 2, axis=0))
    ok = scale > 0
    Z = np.where(ok, Theta / np.where(ok, scale, 1.0), 0.0)
    tr, va = slice(0, n_train), slice(n_train, None)
    supports: dict[int, list[int]] = {0: []}
    scores = {0: float(np.mean(r[va] ** 2))}
    for k, (sup, coef) in enumerate(sparse_path(Z[tr], r[tr], "omp", max_terms), start=1):
        scores[k] = float(np.mean((r[va] - Z[va] @ coef) ** 2))
        supports[k] = [int(i) for i in sup]
    best = min(scores.values())
    k = min(k for k, s in scores.items() if s <= best * parsimony)
    others = [supports[j] for j in sorted(supports, key=lambda j: scores[j]) if j and j != k]
    return supports[k], scores, others


def stability_selection(
    Theta: np.ndarray,
    r: np.ndarray,
    parts: list[np.ndarray],
    groups: Sequence[str],
    *,
    resamples: int,
    max_terms: int,
    parsimony: float,
    seed: int = 0,
) -> dict:
    """Stability selection over resampled blocks of rows: ``resamples`` times, half the blocks (``parts``) train
    the path and the other half choose its size (:func:`validated_support`); returns the inclusion probability
    of every group of columns (``groups[j]`` labels column j; any member selected) and of every column, and
    each group's most selected column."""
    rng = np.random.default_rng(seed)
    hits = np.zeros(Theta.shape[1])
    group_hits: dict[str, int] = {}
    for _ in range(resamples):
        order = rng.permutation(len(parts))
        tr = np.concatenate([parts[i] for i in order[: len(parts) // 2]])
        va = np.concatenate([parts[i] for i in order[len(parts) // 2 :]])
        rows = np.concatenate([tr, va])
        support, _, _ = validated_support(Theta[rows], r[rows], tr.size, max_terms, parsimony)
        hits[support] += 1
        for f in dict.fromkeys(groups[i] for i in support):  # in column order (a set: the hash seed's order)
            group_hits[f] = group_hits.get(f, 0) + 1
    best: dict[str, int] = {}
    for i in np.argsort(-hits):
        if hits[i] > 0:
            best.setdefault(groups[i], int(i))
    return {"family": {f: n / resamples for f, n in group_hits.items()}, "term": hits / resamples, "best": best}


def bagged(
    G: np.ndarray,
    b: np.ndarray,
    n_models: int,
    rng: np.random.Generator,
    n_eff: float,
    tolerance: float,
    method: str = "best-subset",
    threshold: float = 0.05,
) -> np.ndarray:
    """:func:`sparsest_acceptable` on ``n_models`` bootstrap resamples of the rows (drawn from ``rng``):
    the ``(n_models, n_columns)`` coefficients; ``np.mean(out != 0, axis=0)`` is each column's inclusion
    probability."""
    n_rows = G.shape[0]
    out = np.zeros((n_models, G.shape[1]))
    for m in range(n_models):
        rows = rng.integers(0, n_rows, n_rows)
        out[m] = sparsest_acceptable(G[rows], b[rows], n_eff, tolerance, method, threshold)
    return out
