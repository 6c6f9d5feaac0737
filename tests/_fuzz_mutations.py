"""Mutations of CSV records and FIT.json files for the fuzz tests and the corpus run
(``tests/test_fuzz.py``, ``benchmarks/fuzz_corpus.py``).

Every mutation says whether it breaks the file (the reader must refuse it) or keeps it valid
(the reader must accept it with the same values): a broken file read without an error is a
*silently accepted* one, the failure the fuzzing is looking for.
"""

from __future__ import annotations

import copy
import math
import random

import numpy as np

HEADER = ["time", "displacement", "force"]


def base_rows(n: int = 400, dt: float = 0.005, f: float = 2.0) -> list[list[str]]:
    """A clean sine record as text fields (time, displacement, force)."""
    t = np.arange(n) * dt
    d = np.sin(2 * np.pi * f * t)
    y = 1.6 * np.tanh(3 * np.cos(2 * np.pi * f * t))
    return [[f"{a:.6g}", f"{b:.9g}", f"{c:.9g}"] for a, b, c in zip(t, d, y)]


def _join(header, rows, sep=",", eol="\n") -> str:
    return eol.join(sep.join(r) for r in [header, *rows]) + eol


# ---------------------------------------------------------------------------------------- benign
def benign_bom(h, rows, rng):
    return "\ufeff" + _join(h, rows)


def benign_crlf(h, rows, rng):
    return _join(h, rows, eol="\r\n")


def benign_trailing_delimiter(h, rows, rng):
    return _join([*h, ""], [[*r, ""] for r in rows])


def benign_blank_lines(h, rows, rng):
    rows = [list(r) for r in rows]
    for _ in range(rng.randint(1, 5)):
        rows.insert(rng.randrange(len(rows)), [""])
    return _join(h, rows)


def benign_spaces(h, rows, rng):
    return _join([f" {x} " for x in h], [[f" {x}" for x in r] for r in rows])


def benign_quotes(h, rows, rng):
    return _join([f'"{x}"' for x in h], [[f'"{x}"' for x in r] for r in rows])


def benign_semicolon(h, rows, rng):
    return _join(h, rows, sep=";")


def benign_extra_column(h, rows, rng):
    return _join([*h, "note"], [[*r, "x"] for r in rows])


def benign_permuted(h, rows, rng):
    order = list(range(len(h)))
    rng.shuffle(order)
    return _join([h[i] for i in order], [[r[i] for i in order] for r in rows])


def benign_upper_header(h, rows, rng):
    return _join([x.upper() for x in h], rows)


BENIGN = [
    benign_bom,
    benign_crlf,
    benign_trailing_delimiter,
    benign_blank_lines,
    benign_spaces,
    benign_quotes,
    benign_semicolon,
    benign_extra_column,
    benign_permuted,
    benign_upper_header,
]


# ---------------------------------------------------------------------------------------- broken
def _row(rows, rng):
    return rng.randrange(len(rows))


def broken_short_row(h, rows, rng):
    rows = [list(r) for r in rows]
    i = _row(rows, rng)
    rows[i] = rows[i][: rng.randint(1, len(h) - 1)]
    return _join(h, rows)


def broken_long_row(h, rows, rng):
    rows = [list(r) for r in rows]
    i = _row(rows, rng)
    rows[i] = rows[i] + [rng.choice(["1", "0.5", "x"])] * rng.randint(1, 3)  # non-empty: one trailing comma is benign
    return _join(h, rows)


def broken_decimal_comma(h, rows, rng):
    rows = [list(r) for r in rows]
    i, j = _row(rows, rng), rng.randrange(len(h))
    v = rows[i][j]
    rows[i][j] = v.replace(".", ",") if "." in v else v + ",5"
    return _join(h, rows)


def broken_decimal_comma_semicolon(h, rows, rng):
    rows = [list(r) for r in rows]
    i, j = _row(rows, rng), rng.randrange(len(h))
    rows[i][j] = f"{rng.randint(-9, 9)},{rng.randint(1, 99)}"
    return _join(h, rows, sep=";")


def broken_text_value(h, rows, rng):
    rows = [list(r) for r in rows]
    i, j = _row(rows, rng), rng.randrange(len(h))
    rows[i][j] = rng.choice(["abc", "1.2.3", "--1", "1e", "0x10", "1_0", "½", "١٢", "1 2", "N/A", "#REF!"])
    return _join(h, rows)


def broken_duplicate_header(h, rows, rng):
    j = rng.randrange(len(h))
    return _join([*h, h[j]], [[*r, r[j]] for r in rows])


def broken_empty_header(h, rows, rng):
    h = list(h)
    j = rng.randrange(len(h) + 1)
    h.insert(j, "")
    return _join(h, [[*r[:j], "0", *r[j:]] for r in rows])


def broken_missing_column(h, rows, rng):
    j = rng.randrange(len(h))
    return _join([x for k, x in enumerate(h) if k != j], [[x for k, x in enumerate(r) if k != j] for r in rows])


def broken_unsorted_time(h, rows, rng):
    rows = [list(r) for r in rows]
    i = rng.randrange(1, len(rows) - 1)
    rows[i][0], rows[i + 1][0] = rows[i + 1][0], rows[i][0]
    return _join(h, rows)


def broken_jittered_time(h, rows, rng):
    rows = [list(r) for r in rows]
    for i in rng.sample(range(1, len(rows) - 1), 20):
        rows[i][0] = f"{float(rows[i][0]) + rng.uniform(-1, 1) * 1e-3:.9g}"
    return _join(h, rows)


def broken_nan(h, rows, rng):
    rows = [list(r) for r in rows]
    rows[_row(rows, rng)][rng.randrange(len(h))] = rng.choice(["nan", "inf", "-inf", "NaN", ""])
    return _join(h, rows)


def broken_huge(h, rows, rng):
    rows = [list(r) for r in rows]
    rows[_row(rows, rng)][rng.choice([1, 2])] = rng.choice(["1e308", "-1e305", "1e400"])
    return _join(h, rows)


def broken_binary(h, rows, rng):
    text = _join(h, rows).encode()
    k = rng.randrange(len(text))
    return text[:k] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 8))) + b"\x00" + text[k:]


def broken_latin1(h, rows, rng):
    rows = [list(r) for r in rows]
    i = _row(rows, rng)
    rows[i][rng.randrange(len(h))] = "1\xb05"
    return _join(h, rows).encode("latin-1")


def broken_utf16(h, rows, rng):
    return _join(h, rows).encode("utf-16")


def broken_unclosed_quote(h, rows, rng):
    rows = [list(r) for r in rows]
    i = _row(rows, rng)
    rows[i][rng.randrange(len(h))] = '"' + rows[i][0]
    return _join(h, rows)


def broken_header_only(h, rows, rng):
    return _join(h, [])


def broken_too_few_rows(h, rows, rng):
    return _join(h, rows[: rng.randint(1, 15)])


def broken_constant_signal(h, rows, rng):
    j = rng.choice([1, 2])
    return _join(h, [[*r[:j], "0.5", *r[j + 1 :]] for r in rows])


def broken_long_line(h, rows, rng):
    return "a," * rng.randint(100_000, 600_000) + "\n"


BROKEN = [
    broken_short_row,
    broken_long_row,
    broken_decimal_comma,
    broken_decimal_comma_semicolon,
    broken_text_value,
    broken_duplicate_header,
    broken_empty_header,
    broken_missing_column,
    broken_unsorted_time,
    broken_jittered_time,
    broken_nan,
    broken_huge,
    broken_binary,
    broken_latin1,
    broken_utf16,
    broken_unclosed_quote,
    broken_header_only,
    broken_too_few_rows,
    broken_constant_signal,
    broken_long_line,
]


def _layout(text: str, rng) -> str:
    """A benign text-level change on top of another mutation: BOM, CRLF line ends, or nothing."""
    k = rng.randrange(4)
    return "\ufeff" + text if k == 0 else (text.replace("\n", "\r\n") if k == 1 else text)


def mutate_csv(seed: int, rows=None) -> tuple[str, bytes, bool]:
    """``(mutation name, file bytes, broken)``: one mutation of a clean record, sometimes with a BOM or
    CRLF line ends on top (which never change whether it is broken)."""
    rng = random.Random(seed)
    rows = base_rows() if rows is None else rows
    m = rng.choice(BENIGN + BROKEN)
    out = m(list(HEADER), rows, rng)
    if isinstance(out, str):
        out = _layout(out, rng)
        out = out.encode("utf-8")
    return m.__name__, out, m in BROKEN


# ---------------------------------------------------------------------------------------- FIT.json
def tamper_fit(fit: dict, seed: int) -> tuple[str, object]:
    """``(description, tampered JSON value)`` of a valid FIT.json dict."""
    rng = random.Random(seed)
    d = copy.deepcopy(fit)
    keys = list(d)
    kind = rng.choice(
        [
            "delete",
            "retype",
            "number",
            "nest",
            "param",
            "structural",
            "mask",
            "x0",
            "covariance",
            "effects",
            "model",
            "toplevel",
            "success",
        ]
    )
    junk = [None, True, "text", [], {}, [1, 2], {"a": 1}, -1, 0, 1e308, -1e308, 10**30, "1e400", 1.5]
    if kind == "delete":
        k = rng.choice(keys)
        d.pop(k)
        return f"delete {k}", d
    if kind == "retype":
        k = rng.choice(keys)
        d[k] = rng.choice(junk)
        return f"retype {k}", d
    if kind == "number":
        k = rng.choice(["nrmse", "r2", "cost", "n_iter", "n_samples", "nrmse_objective"])
        d[k] = rng.choice(junk)
        return f"number {k}", d
    if kind == "nest":
        deep = []
        for _ in range(rng.choice([10, 1000, 5000])):
            deep = [deep]
        d[rng.choice(keys)] = deep
        return "nest", d
    if kind == "param":
        name = rng.choice(list(d["params"]) + ["bogus"])
        d["params"][name] = rng.choice(junk + [-5.0, 0.0, 1e6, -1e6])
        return f"param {name}", d
    if kind == "structural":
        d["structural"] = {"n_x": rng.choice(junk + [2, 4, 99999, -3]), "n_v": rng.choice([5, 3, 0, "x"])}
        return "structural", d
    if kind == "mask":
        d["mask"] = rng.choice(
            [
                [
                    {
                        "n_times": rng.choice(junk + [5, 10**12]),
                        "ranges": rng.choice(junk + [[[0, 3]], [[5, 2]], [[0, 10**9]]]),
                    }
                ],
                "x",
                [None],
                [[1, 2]],
            ]
        )
        return "mask", d
    if kind == "x0":
        d["x0"] = rng.choice([[["a"]], [[1e308, -1e308]], [[1, 2, 3, 4]], [[]], "x", [[math.pi] * 2] * 3])
        return "x0", d
    if kind == "covariance":
        n = len(d.get("free", []))
        d["covariance"] = rng.choice(
            [[[1.0]], "x", [[1.0] * n] * (n + 1), [[-1.0] * n for _ in range(n)], [[1e308] * n for _ in range(n)]]
        )
        return "covariance", d
    if kind == "effects":
        d["effects"] = rng.choice([["backlash"], ["nope"], "backlash", [1], [["a"]], ["backlash", "backlash"]])
        return "effects", d
    if kind == "model":
        d["model"] = rng.choice(["duffing", "nope", "", "mr-damper-current", 5, None])
        return "model", d
    if kind == "success":
        d["success"] = rng.choice([False, "true", 1, None])
        return "success", d
    return "toplevel", rng.choice([[], "x", 5, None, [d]])
