#!/usr/bin/env bash
# VTK peer comparison, interleaved pair by pair: flatten each scene, then ROUNDS x (for every
# scene and VTK mode: vtk_peer.py on that mode, then at once `oit compare` of that mode's
# oit-lab counterparts), then one untimed VTK frame per mode compared with an untimed oit-lab
# frame of every counterpart, then the table. Each pair is timed within seconds: this VM's
# speed drifts by up to 1.5x over minutes. See README.md beside this file.
#
#   benches/peer/run_vtk.sh [OUT_DIR]        (default /tmp/oit-vtk-peer)
#   env: OIT (oit binary, default target/release/oit)
#        FLATTEN (a built flatten binary; default `cargo run --release -p oit-tools --bin flatten`)
#        PYTHON (a python with vtk, numpy, imageio, OpenEXR; default python3)
#        SCENES ("scenes/many-layers-64.json scenes/particles.json"), RES (256x256), ROUNDS (3)
#        VTK_MODES (peel,oit,blend), VTK_FRAMES (20), VTK_WARMUP (3), OIT_FRAMES (20), OIT_WARMUP (3)
#        TARGET_FORMAT (rgba8unorm: oit-lab's final target, as VTK's 8-bit framebuffer; rgba16float
#        is oit-lab's default)
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${1:-/tmp/oit-vtk-peer}
OIT=${OIT:-target/release/oit}
PYTHON=${PYTHON:-python3}
read -r -a SCENES <<< "${SCENES:-scenes/many-layers-64.json scenes/particles.json}"
RES=${RES:-256x256}
ROUNDS=${ROUNDS:-3}
VTK_MODES=${VTK_MODES:-peel,oit,blend}
VTK_FRAMES=${VTK_FRAMES:-20}
VTK_WARMUP=${VTK_WARMUP:-3}
OIT_FRAMES=${OIT_FRAMES:-20}
OIT_WARMUP=${OIT_WARMUP:-3}
TARGET_FORMAT=${TARGET_FORMAT:-rgba8unorm}
# The oit-lab techniques each VTK mode stands next to (as vtk_peer.py's MODES).
counterparts() {
    case "$1" in
        peel) echo "-t dual-peel:passes=auto,depth=rg32f,accum=auto -t dual-peel:passes=auto,depth=rg32f,accum=rgba8" ;;
        oit) echo "-t wboit:weight=const" ;;
        blend) echo "-t unsorted -t sorted-object" ;;
        *) echo "run_vtk.sh: unknown VTK mode $1" >&2; exit 1 ;;
    esac
}
IFS=, read -r -a MODE_LIST <<< "$VTK_MODES"
for m in "${MODE_LIST[@]}"; do
    case "$m" in peel|oit|blend) ;; *) echo "run_vtk.sh: VTK_MODES: unknown mode $m (allowed: peel, oit, blend)" >&2; exit 1 ;; esac
done
TECHNIQUES=()
for m in "${MODE_LIST[@]}"; do read -r -a t <<< "$(counterparts "$m")"; TECHNIQUES+=("${t[@]}"); done
[ -x "$OIT" ] || { echo "run_vtk.sh: no oit binary at $OIT (build it with cargo build --release -p oit-cli, or set OIT)" >&2; exit 1; }
"$PYTHON" -c 'import vtkmodules, numpy' 2>/dev/null \
    || { echo "run_vtk.sh: $PYTHON has no vtk/numpy (see README.md: pip install vtk ...; or set PYTHON)" >&2; exit 1; }
mkdir -p "$OUT"

flatten() {
    if [ -n "${FLATTEN:-}" ]; then "$FLATTEN" "$@"; else cargo run -q --release -p oit-tools --bin flatten -- "$@"; fi
}
names=()
for s in "${SCENES[@]}"; do
    n=$(basename "$s" .json)
    names+=("$n")
    flatten "$s" --resolution "$RES" > "$OUT/$n.flat.json"
done

for i in $(seq 1 "$ROUNDS"); do
    for k in "${!names[@]}"; do
        n=${names[$k]}
        for m in "${MODE_LIST[@]}"; do
            echo "== round $i: $n $m: VTK, then oit-lab ($(uptime))"
            "$PYTHON" benches/peer/vtk_peer.py --scene "$OUT/$n.flat.json" --modes "$m" \
                --frames "$VTK_FRAMES" --warmup "$VTK_WARMUP" --json "$OUT/round$i-vtk-$n-$m.json"
            read -r -a t <<< "$(counterparts "$m")"
            "$OIT" compare "${SCENES[$k]}" "${t[@]}" --resolution "$RES" \
                --frames "$OIT_FRAMES" --warmup "$OIT_WARMUP" --target-format "$TARGET_FORMAT" \
                --out "$OUT/round$i-oit-$n-$m" > /dev/null
        done
    done
done

# Images (untimed): one VTK frame per mode against one oit-lab frame of every counterpart and
# the reference, drawn with --flip-y so that edges on pixel centres fall as in oit-lab (see
# README.md).
"$OIT" compare "${SCENES[@]}" "${TECHNIQUES[@]}" --resolution "$RES" --frames 1 --warmup 0 \
    --target-format "$TARGET_FORMAT" --out "$OUT/images-oit" > /dev/null
for n in "${names[@]}"; do
    echo "== images: VTK $n vs oit-lab"
    "$PYTHON" benches/peer/vtk_peer.py --scene "$OUT/$n.flat.json" --modes "$VTK_MODES" \
        --frames 1 --warmup 0 --flip-y --png-dir "$OUT/vtk-png" --compare-results "$OUT/images-oit" \
        --json "$OUT/images-vtk-$n.json"
done
echo
"$PYTHON" benches/peer/table.py "$OUT" | tee "$OUT/table.md"
