#!/usr/bin/env bash
# Secondary parts (paper 001 Sec. 6) in one command: a scan database (60 people, 12 held out,
# skin maps of 64 x 64 for the iris match), the blendshape generator trained as jobs/assets.toml trains it, `eval assembly`
# on the held-out people (parts assembled onto their true and their predicted shapes, beside
# the generic parts and the coefficient fit alone; then without the eyeball setback), and one
# held-out person assembled: its sagittal sections (sections.png) and its glTF.
#
#   analysis/assembly.sh [BUILD_DIR]
#
# Environment: WORK (out/assembly). Takes about 6 minutes on 2 cores, most of it training.
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
build_targets facecap
require_facecap
work="$(mkdir -p "${WORK:-out/assembly}" && cd "${WORK:-out/assembly}" && pwd)"
log() { echo "[assembly] $*" >&2; }

log "scans synth -> ${work}/scans.h5"
"${facecap}" scans synth --out "${work}/scans.h5" --people 60 --test-people 12 --texture-size 64
log "blendshapes train -> ${work}/bsgen.h5"
"${facecap}" blendshapes train --scans "${work}/scans.h5" --out "${work}/bsgen.h5" --estimation-epochs 60 \
  --tuning-epochs 30 --nominal-weight 0.85 --reg-weight 0.1 --weight-decay 0.5 --average-fraction 0.3
log "eval assembly"
"${facecap}" eval assembly --scans "${work}/scans.h5" --model "${work}/bsgen.h5" --json=false \
  --out "${work}/eval_assembly.json"
log "eval assembly without the eyeball setback (clearance_shapes 0)"
"${facecap}" eval assembly --scans "${work}/scans.h5" --model "${work}/bsgen.h5" --json=false \
  --clearance-shapes 0 --out "${work}/eval_assembly_no_setback.json"
log "one held-out person: blendshapes infer, assemble, sections, glTF"
"${facecap}" blendshapes infer --model "${work}/bsgen.h5" --scans "${work}/scans.h5" --person 59 \
  --out "${work}/rig.h5"
start=$(date +%s%N)
"${facecap}" assemble --rig "${work}/rig.h5" --out "${work}/assembled.h5"
echo "assemble: $(( ($(date +%s%N) - start) / 1000000 )) ms (process start included)"
/usr/bin/python3 "${source_dir}/analysis/assembly_sections.py" "${work}/assembled.h5" "${work}/sections.png"
"${facecap}" rig export --rig "${work}/assembled.h5" --gltf "${work}/assembled.glb"
