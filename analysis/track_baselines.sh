#!/usr/bin/env bash
# Inverse-rendering tracking against its baselines, on the same synthetic frames (paper 000
# Sec. 8, Figs. 20-21), rows side by side:
#   segmentation (oracle)  the tracker on the true segmentation renders (an upper bound for
#                          tracking the deepfake's translations)
#   landmarks only         the rig's 68 landmarks fitted to the true 2D landmarks (Ceres, same
#                          parametrization and blocks)
#   realistic texture      the same solve with a skin-like albedo per region instead of the
#                          segmentation texture (target recoloured region by region)
#   + landmark init        the oracle started from the pose fitted to the landmarks
#
#   analysis/track_baselines.sh [BUILD_DIR] [-- extra facecap track options]
#
# Environment: FRAMES (default 24), SIZE (128), RANKS (1), WORK (a temporary folder).
set -euo pipefail

source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${FACECAP_BUILD_DIR:-${source_dir}/build}"
if [[ $# -gt 0 && "$1" != "--" ]]; then
  build_dir="$1"
  shift
fi
[[ $# -gt 0 && "$1" == "--" ]] && shift
facecap="${build_dir}/facecap"
[[ -x "${facecap}" ]] || { echo "error: ${facecap} not built" >&2; exit 1; }
frames="${FRAMES:-24}"
size="${SIZE:-128}"
ranks="${RANKS:-1}"
work="${WORK:-$(mktemp -d)}"
mkdir -p "${work}"

run() {
  if [[ "${ranks}" -gt 1 ]]; then
    mpirun --oversubscribe --allow-run-as-root -n "${ranks}" "${facecap}" "$@"
  else
    "${facecap}" "$@"
  fi
}

"${facecap}" rig demo --out "${work}/rig.h5" >/dev/null 2>&1
"${facecap}" synth samples --rig "${work}/rig.h5" --count "${frames}" --size "${size}" \
  --out "${work}/samples.h5" >/dev/null 2>&1

declare -a names=("segmentation (oracle)" "landmarks only" "realistic texture" "+ landmark init")
declare -a opts=("" "--objective landmarks" "--texture skin" "--init landmarks")
printf "%-24s %7s %10s %10s %10s %12s %10s\n" "method" "frames" "pose_deg" "w_mae" \
  "lmk_nme" "vertex_rel" "sec/frame"
for i in "${!names[@]}"; do
  out="${work}/track_${i}.h5"
  rm -f "${out}" "${out}.partial"
  # shellcheck disable=SC2086
  run track --rig "${work}/rig.h5" --targets "${work}/samples.h5" --out "${out}" \
    --threads 1 ${opts[$i]} "$@" >/dev/null 2>&1
  json="$("${facecap}" eval track --truth "${work}/samples.h5" --track "${out}" \
    --rig "${work}/rig.h5" --json 2>/dev/null)"
  python3 - "${names[$i]}" "${json}" <<'PY'
import json, sys
m = json.loads(sys.argv[2])
print("%-24s %7d %10.3f %10.4f %10.4f %12.4f %10.3f" % (sys.argv[1], m["frames"],
      m["pose_err_deg_mean"], m["weights_mae"], m["landmark_nme"], m["vertex_err_rel_mean"],
      m["sec_per_frame"]))
PY
done
echo "(work files in ${work})"
