#!/bin/bash
# Renders frames FIRST..LAST of an animation on a Slurm cluster, one per
# array task, and a check that runs after them and names missing frames.
#
#   scripts/farm/submit-frames.sh SCENE FIRST LAST [tslc render options...]
#   scripts/farm/submit-frames.sh examples/orbit.tsl 1 96 --spp 64
#
# Writes $OUT/frames/NAME.NNNN.exr (OUT defaults to out); logs in logs/.
set -euo pipefail
if [ $# -lt 3 ]; then
    sed -n '2,8p' "$0" >&2
    exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
export SCENE=$1 FIRST=$2 LAST=$3
shift 3
export TSLC_ARGS="${TSLC_ARGS:-} $*"
export OUT=${OUT:-out}
export NAME=${NAME:-$(basename "$SCENE" .tsl)}
mkdir -p logs "$OUT/frames"
jid=$(sbatch --parsable --array="$FIRST-$LAST" "$here/frames.sbatch")
jid=${jid%%;*}
cid=$(sbatch --parsable --dependency=afterany:"$jid" "$here/frames-done.sbatch")
cid=${cid%%;*}
echo "frames: job $jid (frames $FIRST-$LAST), check: job $cid -> $OUT/frames/$NAME.####.exr"
