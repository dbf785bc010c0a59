#!/usr/bin/env bash
# A Slurm job array that runs `slothsim matrix` in 8 shards, then merges them.
#
#   sbatch tools/cluster/matrix-slurm.sh            # the 8 shards (array 0-7)
#   sbatch --dependency=afterok:JOBID --wrap \
#     'slothsim merge out/matrix-parts/matrix-part-*-of-8.json --out out/matrix'
#
# Each task takes its shard from SLURM_ARRAY_TASK_ID / SLURM_ARRAY_TASK_COUNT
# (minus SLURM_ARRAY_TASK_MIN, so `--array=1-8` works too); no --shard needed.
# Keep the array contiguous. Every part records the build and config it ran;
# `merge` refuses parts of another build or config.
#SBATCH --job-name=slothsim-matrix
#SBATCH --array=0-7
#SBATCH --cpus-per-task=4
#SBATCH --time=00:30:00
#SBATCH --output=slothsim-matrix-%A_%a.log
set -euo pipefail
STEP="${STEP:-0.5}"
slothsim matrix --step "$STEP" --threads "${SLURM_CPUS_PER_TASK:-1}" --out out/matrix-parts
