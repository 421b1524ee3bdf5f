#!/usr/bin/env bash
# Do wild clips look like faces to a face detector? Makes wild clips (`facecap synth clip`) of
# several people and runs dlib's HOG frontal face detector on every frame
# (facecap_bench_synth_detect), printing the fraction of frames where it finds the face, per
# clip and pooled, overall and per |yaw| bucket of the true pose. dlib's frontal detector is
# trained on faces up to about 30-45 degrees of yaw, so on real footage too its rate falls
# towards the paper's extreme yaws (60-80 degrees).
#
#   analysis/synth_detect_rate.sh [BUILD_DIR] [-- extra `synth clip` options]
#
# BUILD_DIR defaults to $FACECAP_BUILD_DIR, then build/ under the source tree. SEEDS (default
# "7 11 23") are the identity seeds (each clip also gets its own lighting, background and
# motion seed), FRAMES (default 240) and SIZE (default 128) the clip length and frame size,
# UPSAMPLE (default 1) the detector's pyramid_up steps. The last line is one JSON object.
set -euo pipefail

source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${FACECAP_BUILD_DIR:-${source_dir}/build}"
if [[ $# -gt 0 && "$1" != "--" ]]; then
  build_dir="$1"
  shift
fi
[[ $# -gt 0 && "$1" == "--" ]] && shift
seeds="${SEEDS:-7 11 23}"
frames="${FRAMES:-240}"
size="${SIZE:-128}"
upsample="${UPSAMPLE:-1}"

if [[ -f "${build_dir}/build.ninja" || -f "${build_dir}/Makefile" ]]; then
  build_log="$(mktemp)"
  if ! cmake --build "${build_dir}" --target facecap facecap_bench_synth_detect >"${build_log}" 2>&1; then
    tail -n 40 "${build_log}" >&2
    echo "error: building facecap and facecap_bench_synth_detect in ${build_dir} failed" >&2
    exit 1
  fi
  rm -f "${build_log}"
fi
facecap="${build_dir}/facecap"
detect="${build_dir}/facecap_bench_synth_detect"
for binary in "${facecap}" "${detect}"; do
  if [[ ! -x "${binary}" ]]; then
    echo "error: ${binary} not found; configure and build first (cmake -S . -B build -G Ninja)" >&2
    exit 1
  fi
done

tmp_dir="$(mktemp -d)"
trap 'rm -rf "${tmp_dir}"' EXIT
"${facecap}" rig demo --out "${tmp_dir}/rig.h5" >/dev/null

echo "# wild clips seen by dlib's HOG frontal face detector: ${frames} frames of ${size}x${size} per person, upsample ${upsample}"
results=()
for seed in ${seeds}; do
  clip="${tmp_dir}/clip_${seed}.h5"
  "${facecap}" synth clip --rig "${tmp_dir}/rig.h5" --frames "${frames}" --size "${size}" \
    --identity-seed "${seed}" --motion-seed "${seed}" --lighting-seed "${seed}" \
    --background-seed "${seed}" --camera-seed "${seed}" --out "${clip}" "$@" >"${tmp_dir}/clip.log" 2>&1 \
    || { cat "${tmp_dir}/clip.log" >&2; exit 1; }
  echo
  echo "## identity seed ${seed}"
  "${detect}" --clip "${clip}" --upsample "${upsample}" | tee "${tmp_dir}/detect_${seed}.txt" | sed '$d'
  results+=("$(tail -n 1 "${tmp_dir}/detect_${seed}.txt")")
done

echo
printf '%s\n' "${results[@]}" | python3 -c '
import json, sys
runs = [json.loads(line) for line in sys.stdin if line.strip()]
frames = sum(r["frames"] for r in runs)
found = sum(r["found"] for r in runs)
print("## pooled over %d clips" % len(runs))
print("faces found on %d of %d frames: %.1f%%" % (found, frames, 100.0 * found / max(1, frames)))
print("%-14s %8s %8s %8s" % ("|yaw| (deg)", "frames", "found", "rate"))
buckets = []
for b in range(len(runs[0]["by_yaw"])):
    lo, hi = runs[0]["by_yaw"][b]["yaw_deg"]
    n = sum(r["by_yaw"][b]["frames"] for r in runs)
    k = sum(r["by_yaw"][b]["found"] for r in runs)
    print("%-14s %8d %8d %7.1f%%" % ("[%d, %d)" % (lo, hi), n, k, 100.0 * k / n if n else 0.0))
    buckets.append({"yaw_deg": [lo, hi], "frames": n, "found": k, "rate": round(k / n, 4) if n else None})
print(json.dumps({"clips": len(runs), "frames": frames, "found": found,
                  "rate": round(found / max(1, frames), 4), "by_yaw": buckets}))
'
