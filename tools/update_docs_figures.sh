#!/usr/bin/env sh
# Regenerate the figures and the summary the README shows, from `lpik reproduce`.
#
#   tools/update_docs_figures.sh        (from anywhere; uses .venv/bin/lpik when present)
#
# Writes docs/fig4-joint-motion.png, docs/fig9-bounded-multipliers.png,
# docs/fig11-obstacle.png and docs/summary.md. Every number and curve in them is computed by the run.
set -eu

root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
if [ -x .venv/bin/lpik ]; then lpik=.venv/bin/lpik; else lpik=lpik; fi

out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT INT TERM

MPLBACKEND=Agg "$lpik" reproduce --out "$out"
mkdir -p docs
for name in fig4-joint-motion.png fig9-bounded-multipliers.png fig11-obstacle.png summary.md; do
    cp "$out/$name" "docs/$name"
    echo "updated docs/$name"
done
