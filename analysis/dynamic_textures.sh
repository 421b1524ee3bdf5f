#!/usr/bin/env bash
# Dynamic textures (paper 001 Sec. 5, eq. 10-14) in one command: the textured scan database
# (60 people, 12 held out), the expression texture networks trained on its 48 training people
# (`textures train`), `eval textures` on the held-out people at several sharpnesses of eq. 12's
# softmax (1 is the paper's equation with influences in cm) with the networks' rows at the
# default (the strain texture beside eq. 14 as printed), eq. 10-13 checked against a direct
# numpy implementation, a contact sheet, and the strain texture's runtime at 1024 x 1024 on one
# core beside eq. 14 as printed (sparse and dense) and per-blendshape maps.
#
#   analysis/dynamic_textures.sh [BUILD_DIR]
#
# Environment: WORK (out/dynamic_textures), RANKS (2). Takes about 25 minutes on 2 cores, most
# of it training the networks.
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
build_targets facecap facecap_bench_dynamic_texture
require_facecap
work="$(mkdir -p "${WORK:-out/dynamic_textures}" && cd "${WORK:-out/dynamic_textures}" && pwd)"
ranks="${RANKS:-2}"
log() { echo "[dynamic_textures] $*" >&2; }

log "scans synth (textured) -> ${work}/scans.h5"
"${mpirun_cmd[@]}" -n "${ranks}" "${facecap}" scans synth --out "${work}/scans.h5" --people 60 --test-people 12
log "textures train -> ${work}/texnet.h5"
"${mpirun_cmd[@]}" -n "${ranks}" "${facecap}" textures train --scans "${work}/scans.h5" --out "${work}/texnet.h5"
for b in 1 30 100 300 1000; do
  log "eval textures, sharpness ${b}"
  maps=()
  [[ "${b}" == 300 ]] && maps=(--maps "${work}/maps.h5" --model "${work}/texnet.h5")
  "${facecap}" eval textures --scans "${work}/scans.h5" --sharpness "${b}" --out "${work}/eval_b${b}.json" \
    "${maps[@]}" > /dev/null
done
/usr/bin/python3 "${source_dir}/analysis/dynamic_textures.py" "${work}/scans.h5" "${work}/maps.h5" \
  --sheet "${work}/sheet.png"
log "runtime textures at 1024 x 1024, one core"
"${build_dir}/facecap_bench_dynamic_texture" --size 1024 --frames 10 | tee "${work}/bench_all.txt"
"${build_dir}/facecap_bench_dynamic_texture" --size 1024 --frames 10 --active 12 | tee "${work}/bench_12.txt"
/usr/bin/python3 - "${work}" <<'PY'
import json, sys
work = sys.argv[1]
print("\nPSNR (dB) against the true expression textures where the expression moves the skin "
      "(held-out people; albedo / specular / displacement):\n")
print("| sharpness b (per cm) | static neutral | dynamic, strain texture (leave one out) | eq. 14 as printed "
      "(leave one out) | per-blendshape maps |")
print("| --- | --- | --- | --- | --- |")
for b in (1, 30, 100, 300, 1000):
    d = json.load(open(f"{work}/eval_b{b}.json"))
    cell = lambda k: " / ".join(f"{d[k][x]:.2f}" for x in ("albedo_db", "specular_db", "displacement_db"))
    print(f"| {b} | {cell('static_neutral')} | {cell('dynamic')} | {cell('eq14_as_printed')} | "
          f"{cell('per_blendshape_maps')} |")
d = json.load(open(f"{work}/eval_b300.json"))
print("\nThe networks (sharpness 300): their expression textures of the held-out people's expression scans, and "
      "the strain texture of the library fitted to them, against the truth:\n")
print("| static neutral | network expression textures | dynamic (predicted library) | dynamic (true textures, leave one out) |")
print("| --- | --- | --- | --- |")
print(f"| {cell('static_neutral')} | {cell('network_expressions')} | {cell('dynamic_predicted')} | {cell('dynamic')} |")
print(f"\nlibrary {d['library_mb']:.2f} MB against {d['per_blendshape_maps_mb']:.2f} MB of per-blendshape maps "
      f"at {d['texture_size']}^2 ({d['library_size_ratio']:.1f}x; {d['library_size_ratio_1024']:.1f}x at 1024^2); "
      f"{d['people']} people, {d['expressions']} expressions, {d['blendshapes']} blendshapes")
PY
