#!/bin/bash
# Renders one image on a Slurm cluster in tiles: an array job of TILES tasks
# and a merge job that runs after all of them succeeded.
#
#   scripts/farm/submit-tiles.sh SCENE [TILES [tslc render options...]]
#   scripts/farm/submit-tiles.sh shot.tsl 16 --spp 256
#
# Writes $OUT/tiles/NAME.tile-I.exr, then $OUT/NAME.exr (OUT defaults to
# out); logs in logs/. Prints the two job ids. To resubmit failed tiles:
#
#   TILES=16 sbatch --array=7,12 --export=ALL,SCENE=shot.tsl scripts/farm/tiles.sbatch
set -euo pipefail
if [ $# -lt 1 ]; then
    sed -n '2,11p' "$0" >&2
    exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
export SCENE=$1
export TILES=${2:-16}
shift $(( $# >= 2 ? 2 : 1 ))
export TSLC_ARGS="${TSLC_ARGS:-} $*"
export OUT=${OUT:-out}
export NAME=${NAME:-$(basename "$SCENE" .tsl)}
# Slurm opens the log files before the job starts: their directory must exist.
mkdir -p logs "$OUT/tiles"
jid=$(sbatch --parsable --array=0-$((TILES - 1)) "$here/tiles.sbatch")
jid=${jid%%;*}
mid=$(sbatch --parsable --dependency=afterok:"$jid" "$here/merge.sbatch")
mid=${mid%%;*}
echo "tiles: job $jid ($TILES tasks), merge: job $mid (after all tiles succeed) -> $OUT/$NAME.exr"
