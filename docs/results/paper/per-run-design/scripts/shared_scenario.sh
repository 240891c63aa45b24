#!/usr/bin/env bash
# Table 6's nest rows under the authors' design: GP_nest, QD_nest and GP_fnd re-run with the experiment's run
# seeds, but every run on ONE shared scenario (--scenario-seed 1), then compared as table 6 compares them.
#
#   docs/results/paper/per-run-design/scripts/shared_scenario.sh experiments/paper runs/shared-scenario
#
# Two lanes in parallel (GP_fnd; GP_nest then QD_nest); a finished run is left alone when started again.
set -euo pipefail
experiment=$1 out=$2
lane() {
  for spec in "$@"; do
    read -r label options <<< "$spec"
    r=0
    for seed in $(awk -F, -v a="$label" '$1 == a && $2 == "nest" {print $3}' "$experiment/runs.csv"); do
      dir="$out/$label/run$(printf %02d $r)"
      [ -f "$dir/summary.json" ] || { rm -rf "$dir"; ws/run evolution_manager evolve $options --seed "$seed" \
        --scenario-seed 1 --out "$dir" --no-progress --no-figures > /dev/null; }
      r=$((r + 1))
    done
  done
}
lane "GP_fnd --algorithm gp-fnd" &
lane "GP_nest --algorithm gp --objective nest" "QD_nest --algorithm qd --objective nest" &
wait
source ws/env.sh
python - "$out" <<'PY'
import json, sys
from pathlib import Path
from evolution_manager.statistics import compare

out = Path(sys.argv[1])
best = {
    label: [json.loads((run / "summary.json").read_text())["objectives"]["nest"]["best_fitness"]
            for run in sorted((out / label).iterdir())]
    for label in ("GP_nest", "GP_fnd", "QD_nest")
}
for other in ("GP_fnd", "QD_nest"):
    c = compare("best fitness", "nest", "GP_nest", best["GP_nest"], other, best[other])
    print(f"shared scenario: GP_nest {c.mean_first:.4f} vs {other} {c.mean_second:.4f}: {c.test} p = {c.p_value:.4f}")
PY
