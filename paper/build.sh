#!/usr/bin/env bash
# Build the report paper/ms.pdf from the FULL run's figures (paper/figures/) and numbers (paper/output/).
#
#   bash paper/build.sh          # after `duffsym reproduce`; from any folder
#
# Needs pdflatex (TeX Live: texlive-latex-recommended, texlive-latex-extra; on Debian/Ubuntu
# `apt-get install texlive-latex-recommended texlive-latex-extra`), and the LaTeX packages geometry,
# amsmath, amssymb, graphicx, booktabs, hyperref. It refuses to build when a number or figure the
# report uses is missing, or when a number file was made by a smoke run (`reproduce --smoke` writes
# to paper/smoke/, so this only happens if files were copied by hand). Build products (ms.pdf,
# ms.aux, ms.log, ms.out) stay in paper/ and are git-ignored.
set -euo pipefail
cd "$(dirname "$0")"

if ! command -v pdflatex >/dev/null 2>&1; then
    echo "paper/build.sh: error: pdflatex not found; install TeX Live (e.g. apt-get install texlive-latex-recommended texlive-latex-extra)" >&2
    exit 2
fi
if [ ! -f output/derivations.tex ] && command -v duffsym >/dev/null 2>&1; then
    duffsym derive --latex > output/derivations.tex.tmp && mv output/derivations.tex.tmp output/derivations.tex || true
fi

missing=()
for name in $(grep -o '\\num{[^}]*}' ms.tex | sed 's/\\num{\(.*\)}/\1/' | sort -u) \
            $(grep -o '\\input{output/[^}]*}' ms.tex | sed 's/\\input{output\/\(.*\)}/\1/' | sort -u); do
    case "$name" in derivations|*'#'*) continue ;; esac
    [ -f "output/$name.tex" ] || missing+=("output/$name.tex")
done
for fig in $(grep -o '\\includegraphics\(\[[^]]*\]\)\?{[^}]*}' ms.tex | sed 's/.*{\(.*\)}/\1/' | sort -u); do
    [ -f "figures/${fig#figures/}" ] || missing+=("figures/${fig#figures/}")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "paper/build.sh: error: ${#missing[@]} file(s) the report uses are missing (first: ${missing[0]}); run \`duffsym reproduce\` (the full run) first" >&2
    exit 2
fi
smoke=$(grep -l "^% made by .*, smoke run$" output/*.tex 2>/dev/null || true)
if [ -n "$smoke" ]; then
    echo "paper/build.sh: error: $(echo "$smoke" | wc -l) number file(s) in paper/output/ were made by a smoke run (first: $(echo "$smoke" | head -1)); run \`duffsym reproduce\` (the full run) to replace them" >&2
    exit 2
fi

for pass in 1 2; do
    if ! pdflatex -interaction=nonstopmode -halt-on-error ms.tex > ms.build.log 2>&1; then
        echo "paper/build.sh: error: pdflatex failed (pass $pass); the first error:" >&2
        grep -m1 -A3 '^!' ms.log >&2 || tail -20 ms.build.log >&2
        exit 1
    fi
done
rm -f ms.build.log
echo "wrote $(pwd)/ms.pdf ($(grep -o 'Output written on ms.pdf ([0-9]* pages' ms.log | grep -o '[0-9]* pages'))"
