#!/usr/bin/env bash
# Tracking of footage against its baselines, in the same run, on the outputs of the demo or
# video job (frames.h5, translated.h5, person.h5 in OUT_DIR), rows side by side:
#   landmarks only          the person's rig fitted to dlib's 68 landmarks (no deepfake)
#   translations            inverse rendering of the deepfake's translations alone
#   translations + lmk W    the same with the landmark term of weight W (LANDMARK_WEIGHTS; in
#                           units of each point's noise that person fit measured; the track
#                           stage's default is 1)
# The demo (OUT_DIR holds clip.h5) is scored against the truth, with the neutral face's
# figures beside; a real video is scored against a reference landmarker's JSON (REF_JSON, from
# the ref_landmarks tools), held-out and trained frames apart.
#
#   analysis/footage_baselines.sh OUT_DIR [REF_JSON]
#
# Environment: RANKS (2), LANDMARK_WEIGHTS ("0.5 1 2"), FACECAP_BUILD_DIR (build/).
set -euo pipefail

source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${FACECAP_BUILD_DIR:-${source_dir}/build}"
facecap="${build_dir}/facecap"
[[ -x "${facecap}" ]] || { echo "error: ${facecap} not built" >&2; exit 1; }
[[ $# -ge 1 ]] || { sed -n '2,16p' "$0"; exit 2; }
out="$1"
ref="${2:-}"
ranks="${RANKS:-2}"
weights="${LANDMARK_WEIGHTS:-0.5 1 2}"
for f in frames.h5 translated.h5 person.h5; do
  [[ -f "${out}/${f}" ]] || { echo "error: ${out}/${f} missing: run the demo or video job first" >&2; exit 3; }
done
work="${out}/baselines"
mkdir -p "${work}"

run() {
  if [[ "${ranks}" -gt 1 ]]; then
    mpirun --oversubscribe --allow-run-as-root -n "${ranks}" "${facecap}" "$@"
  else
    "${facecap}" "$@"
  fi
}

common=(--rig "${out}/person.h5" --frames "${out}/frames.h5" --targets "${out}/translated.h5"
        --targets-dataset /frames/translated --init previous --weight-prior 30)
declare -a names=("landmarks only" "translations")
declare -a opts=("--objective landmarks" "--landmark-weight 0")
for w in ${weights}; do
  names+=("translations + lmk ${w}")
  opts+=("--landmark-weight ${w}")
done

if [[ -f "${out}/clip.h5" ]]; then
  printf "| %-24s | %8s | %8s | %10s | %10s | %10s | %9s |\n" method pose_deg lmk_nme \
    active_mae expr_rel w_mae sec/frame
  printf "|%s|\n" "--------------------------|----------|----------|------------|------------|------------|-----------"
else
  printf "| %-24s | %9s | %9s | %9s | %9s | %9s |\n" method nme held_out trained inner jaw
  printf "|%s|\n" "--------------------------|-----------|-----------|-----------|-----------|-----------"
fi
for i in "${!names[@]}"; do
  track="${work}/track_${i}.h5"
  rm -f "${track}" "${track}.partial"
  # shellcheck disable=SC2086
  run track "${common[@]}" ${opts[$i]} --out "${track}" >"${work}/track_${i}.log" 2>&1
  if [[ -f "${out}/clip.h5" ]]; then
    "${facecap}" eval track --truth "${out}/clip.h5" --track "${track}" --rig "${out}/person.h5" \
      --json >"${work}/metrics_${i}.json"
    /usr/bin/python3 - "${work}/metrics_${i}.json" "${names[$i]}" "$i" <<'EOF'
import json, sys
m = json.load(open(sys.argv[1]))
print("| %-24s | %8.3f | %8.4f | %10.4f | %10.4f | %10.4f | %9.3f |" % (
    sys.argv[2], m["pose_err_deg_mean"], m["landmark_nme"], m["active_weights_mae"],
    m["expression_err_rel"], m["weights_mae"], m["sec_per_frame"]))
if sys.argv[3] == "0":
    print("| %-24s | %8s | %8s | %10.4f | %10.4f | %10.4f | %9s |" % (
        "neutral face", "", "", m["active_weights_mae_neutral"],
        m["expression_err_rel_neutral"], m["weights_mae_neutral"], ""))
EOF
  else
    "${facecap}" export landmarks --track "${track}" --rig "${out}/person.h5" \
      --frames "${out}/frames.h5" --out "${work}/landmarks_${i}.csv" >/dev/null 2>&1
    if [[ -n "${ref}" ]]; then
      /usr/bin/python3 "${source_dir}/analysis/compare_landmarks.py" "${ref}" \
        "${work}/landmarks_${i}.csv" --holdout-every 5 --json "${work}/compare_${i}.json" >/dev/null
      /usr/bin/python3 - "${work}/compare_${i}.json" "${names[$i]}" <<'EOF'
import json, sys
e = json.load(open(sys.argv[1]))[0]
a, h, t = e["all"], e["held_out"], e["trained"]
print("| %-24s | %9.4f | %9.4f | %9.4f | %9.4f | %9.4f |" % (
    sys.argv[2], a["nme"], h["nme"], t["nme"], a["nme_inner"], a["nme_jaw"]))
EOF
    fi
  fi
done
if [[ ! -f "${out}/clip.h5" && -n "${ref}" ]]; then
  /usr/bin/python3 "${source_dir}/analysis/compare_landmarks.py" "${ref}" "${out}/frames.h5" \
    --holdout-every 5 --json "${work}/compare_dlib.json" >/dev/null
  /usr/bin/python3 - "${work}/compare_dlib.json" <<'EOF'
import json, sys
e = json.load(open(sys.argv[1]))[0]
a, h, t = e["all"], e["held_out"], e["trained"]
print("| %-24s | %9.4f | %9.4f | %9.4f | %9.4f | %9.4f |" % (
    "dlib itself", a["nme"], h["nme"], t["nme"], a["nme_inner"], a["nme_jaw"]))
EOF
fi
