#!/usr/bin/env bash
# The mechanical part of the lint pass (issue 27): ruff's safe fixes, the formatter, then what is left for a
# human (per rule) and the type checker's count. Run from anywhere, in a venv with the dev extra
# (pip install -e ".[dev]"); pass paths to limit it (default: src tests, as .ci/run checks them).
# Safe fixes only: ruff's "unsafe" fixes (e.g. B007's loop-variable rename) change behaviour or meaning and are
# left to the human pass. Formatting runs after the fixes so that the fixed lines are formatted too.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "$#" -gt 0 ]; then paths=("$@"); else paths=(src tests); fi
ruff check --fix --exit-zero --silent "${paths[@]}"  # what is left is reported below
ruff format "${paths[@]}"
ruff check --fix --exit-zero --silent "${paths[@]}"  # the formatter can expose new import-order findings
echo "--- left for a human (ruff check --statistics):"
ruff check --statistics "${paths[@]}" || true
echo "--- type checker:"
mypy | tail -1 || true
