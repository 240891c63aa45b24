#!/usr/bin/env bash
# swarm-ga with --homogeneous 5 on each foragers-qd run, the same seeds as the study's swarm-ga runs
cd "$(dirname "$0")/../.."
run_one() {
  r=$1
  seed=$(python3 -c "import json;d=json.load(open('experiments/foraging/experiment.json'));print([a for a in d['arms'] if a['dir']=='arms/swarm-ga/run%02d'%$r][0]['seed'])")
  out=experiments/foraging-seeded/swarm-ga-h5/run$(printf %02d $r)
  if [ -f $out/summary.json ] && grep -q '"finished": true' $out/summary.json; then return; fi
  resume=""; [ -f $out/config.json ] && resume="--resume"
  if [ -n "$resume" ]; then
    nice -n 5 ws/run evolution_manager evolve --out $out --resume
  else
    nice -n 5 ws/run evolution_manager evolve --task foraging --swarm-from experiments/foraging/arms/foragers-qd/run$(printf %02d $r) \
      --algorithm ga --evaluations 25000 --seed $seed --trials 10 --profile paper --scenario-seed 2776541142159560860 \
      --homogeneous 5 --out $out
  fi
}
for r in 0 2 4 6 8; do run_one $r & run_one $((r+1)); wait; done
