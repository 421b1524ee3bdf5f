#!/usr/bin/env bash
# Lip-sync on three voices and sentences (paper 000 Sec. 8.1): jobs/lipsync.toml run once per
# (espeak-ng voice, sentence), each in its own folder, with the demo's person rig and deepfake
# (run jobs/demo.toml first). Prints one markdown table per voice: the video solve, the blends
# with the lip video and with the audio-only sources, beside the neutral mouth (mouth and
# upper-face control MAE, pose error, lip-closure F1 within 40 ms), and the offset between the
# lip video and the talking video recovered from their sound (the truth: 180 ms).
#
#   analysis/lipsync_voices.sh
#
# Environment: RANKS (2), WORK (out/lipsync_voices), DEMO (out/demo, the demo's outputs),
# FACECAP_BUILD_DIR (build/).
set -euo pipefail

source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${FACECAP_BUILD_DIR:-${source_dir}/build}"
facecap="${build_dir}/facecap"
[[ -x "${facecap}" ]] || { echo "error: ${facecap} not built" >&2; exit 1; }
ranks="${RANKS:-2}"
demo="$(cd "${DEMO:-out/demo}" && pwd)"
for f in person.h5 rig.h5 deepfake.h5; do
  [[ -f "${demo}/${f}" ]] || { echo "error: ${demo}/${f} missing: run jobs/demo.toml first" >&2; exit 1; }
done
work="$(mkdir -p "${WORK:-out/lipsync_voices}" && cd "${WORK:-out/lipsync_voices}" && pwd)"
job="${source_dir}/jobs/lipsync.toml"

run() { mpirun --oversubscribe --allow-run-as-root -n "${ranks}" "${facecap}" "$@"; }
log() { echo "[lipsync_voices] $*" >&2; }

voices=("en" "en+f3" "en-us+m3")
sentences=("Peter bought a bamboo umbrella, and Maria made warm apple pie for the family."
           "My brother moved the blue boat past the big white pier before supper."
           "Bobby played the piano while the puppy slept by the warm fireplace.")

for i in 0 1 2; do
  voice="${voices[$i]}"
  text="${sentences[$i]}"
  d="${work}/voice_${i}"
  mkdir -p "${d}/out"
  ln -sfn "${demo}" "${d}/out/demo"
  log "${voice}: ${text}"
  start=$(date +%s)
  (cd "${d}" && run run "${job}" \
      --set "synth.clip-talk.voice=${voice}" --set "synth.clip-lips.voice=${voice}" \
      --set "synth.clip-talk.speech=${text}" --set "synth.clip-lips.speech=${text}" \
      --set "lipsync.audio-transcript.transcript=${text}" \
      --set "lipsync.track-transcript.transcript=${text}" >run.log 2>&1) ||
    { echo "error: the lipsync job failed for ${voice}; see ${d}/run.log" >&2; exit 1; }
  log "${voice}: $(( $(date +%s) - start )) s"
done

/usr/bin/python3 - "${work}" "${voices[@]}" <<'EOF'
import json, sys
import h5py
work, voices = sys.argv[1], sys.argv[2:]
for i, voice in enumerate(voices):
    d = f"{work}/voice_{i}/out/lipsync"
    m = json.load(open(f"{d}/metrics.json"))
    lips = json.load(open(f"{d}/metrics_lips.json"))
    with h5py.File(f"{d}/track_blended.h5", "r") as f:
        offset = float(f["/track"].attrs["lipsync_offset_seconds"])
    rows = m["rows"]
    video = next(r for r in rows if r["name"] == "video solve")
    print(f"\n### {voice} ({m['closures_true']} true lip closures; offset recovered "
          f"{1000 * offset:.1f} ms, true 180 ms)\n")
    print("| row | mouth MAE | vs video | upper MAE | pose (deg) | closure F1 (matched/found) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for r in rows:
        change = 100 * (r["mouth_mae"] / video["mouth_mae"] - 1)
        print(f"| {r['name']} | {r['mouth_mae']:.4f} | {change:+.1f}% | {r['upper_mae']:.4f} | "
              f"{r['pose_err_deg']:.3f} | {r['closure_f1']:.2f} ({r['closures_matched']}/"
              f"{r['closures_found']}) |")
    for r in lips["rows"]:
        print(f"| {r['name']}, against the lip view's truth | {r['mouth_mae']:.4f} | | "
              f"{r['upper_mae']:.4f} | {r['pose_err_deg']:.3f} | {r['closure_f1']:.2f} "
              f"({r['closures_matched']}/{r['closures_found']}) |")
EOF
