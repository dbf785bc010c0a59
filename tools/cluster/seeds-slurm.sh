#!/usr/bin/env bash
# A Slurm job array for a seed sweep: seeds 1..64 over 16 tasks, each task
# running every 16th seed into out/seeds/seed-S/; then
#   slothsim merge out/seeds/seed-*/stats.json --out out/seeds
# writes out/seeds/sweep.json (one row per seed).
#SBATCH --job-name=slothsim-seeds
#SBATCH --array=0-15
#SBATCH --cpus-per-task=2
#SBATCH --time=01:00:00
#SBATCH --output=slothsim-seeds-%A_%a.log
set -euo pipefail
slothsim run --seeds 1..64 --sloths 2000 --seconds 60 --no-plots --record none \
  --threads "${SLURM_CPUS_PER_TASK:-1}" --out out/seeds
