#!/bin/bash
# Submits one frame as NX x NY tile tasks and a merge job that runs once they all succeed.
#
#   submit-tiles.sh SCENE.rib NX,NY IMAGE.exr DEPTH [lrt-depth flags...]
#
# Prints the two job ids (tiles, merge). Watch them with `squeue -j ID`, `scontrol show job
# ID` and, where accounting is configured, `sacct -j ID`. Options for the tile tasks (partition,
# time limit, CPUs per task) go in LRT_SBATCH_ARGS, e.g. LRT_SBATCH_ARGS="--cpus-per-task=8".
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
scene=${1:?usage: submit-tiles.sh SCENE.rib NX,NY IMAGE.exr DEPTH [flags...]}
tiles=${2:?usage: submit-tiles.sh SCENE.rib NX,NY IMAGE.exr DEPTH [flags...]}
image=${3:?usage: submit-tiles.sh SCENE.rib NX,NY IMAGE.exr DEPTH [flags...]}
depth=${4:?usage: submit-tiles.sh SCENE.rib NX,NY IMAGE.exr DEPTH [flags...]}
shift 4
count=$(( ${tiles%,*} * ${tiles#*,} ))
read -r -a sbatch_args <<< "${LRT_SBATCH_ARGS:-}"
tiles_job=$(sbatch --parsable "${sbatch_args[@]}" --array=0-$((count - 1)) "$here/tiles.sbatch" "$scene" "$tiles" "$@")
tiles_job=${tiles_job%%;*}
merge_job=$(sbatch --parsable --dependency=afterok:"$tiles_job" "$here/merge.sbatch" "$image" "$depth" "$count")
merge_job=${merge_job%%;*}
echo "$tiles_job $merge_job"
