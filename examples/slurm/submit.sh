#!/bin/bash
# Shards a Trellis job over a Slurm job array, then merges it in a job that waits for the array:
#   examples/slurm/submit.sh JOB.toml OUT_DIR [SHARDS [SBATCH_OPTION...]]
# Options after SHARDS go to both sbatch calls and win over the scripts' #SBATCH lines, e.g.
#   examples/slurm/submit.sh plate.toml /scratch/plate 16 --partition=short --cpus-per-task=8
# (SBATCH_* environment variables work too, e.g. SBATCH_PARTITION=short.)
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 JOB.toml OUT_DIR [SHARDS [SBATCH_OPTION...]]" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
JOB=$(realpath "$1")
OUT=$(realpath -m "$2")
SHARDS=${3:-8}
shift $(($# < 3 ? $# : 3))
array=$(sbatch --parsable "$@" --array=1-"$SHARDS" \
  --export=ALL,JOB="$JOB",OUT="$OUT",SHARDS="$SHARDS" "$here/shard.sbatch")
array=${array%%;*}
merge=$(sbatch --parsable "$@" --dependency=afterok:"$array" \
  --export=ALL,OUT="$OUT",SHARDS="$SHARDS" "$here/merge.sbatch")
echo "shards: job array $array (1-$SHARDS); merge: job ${merge%%;*} -> $OUT"
