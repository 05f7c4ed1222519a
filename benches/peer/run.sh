#!/usr/bin/env bash
# Peer comparison, interleaved: flatten the scene, then ROUNDS x (pygfx_peer.py, oit compare),
# then the table. See README.md beside this file.
#
#   benches/peer/run.sh [OUT_DIR]        (default /tmp/oit-peer)
#   env: OIT (oit binary, default target/release/oit), SCENE, RES, ROUNDS (2),
#        PYGFX_FRAMES (50), OIT_FRAMES (20), TARGET_FORMAT (rgba8unorm: oit-lab's final target,
#        8 bits a channel as pygfx's rgba8unorm-srgb; rgba16float is oit-lab's default)
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${1:-/tmp/oit-peer}
OIT=${OIT:-target/release/oit}
SCENE=${SCENE:-scenes/many-layers-64.json}
RES=${RES:-256x256}
ROUNDS=${ROUNDS:-2}
PYGFX_FRAMES=${PYGFX_FRAMES:-50}
OIT_FRAMES=${OIT_FRAMES:-20}
TARGET_FORMAT=${TARGET_FORMAT:-rgba8unorm}
# oit-lab names the files of a run at another format than its default TECHNIQUE@FORMAT.*.
SUFFIX=""
[ "$TARGET_FORMAT" = rgba16float ] || SUFFIX="@$TARGET_FORMAT"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
[ -x "$OIT" ] || { echo "run.sh: no oit binary at $OIT (build it with cargo build --release -p oit-cli, or set OIT)" >&2; exit 1; }
mkdir -p "$OUT"

cargo run -q --release -p oit-tools --bin flatten -- "$SCENE" --resolution "$RES" > "$OUT/flat.json"
for i in $(seq 1 "$ROUNDS"); do
    compare=()
    if [ "$i" -gt 1 ]; then
        # Images: this round's pygfx frames against the first round's oit-lab EXRs.
        d="$OUT/round1-oit/$(basename "$SCENE" .json)"
        compare=(--png-dir "$OUT/pygfx-png"
            --compare-exr "blend=$d/sorted-object$SUFFIX.exr"
            --compare-exr "weighted_blend=$d/wboit_accum-rgba16f_reveal-r8_weight-alpha$SUFFIX.exr"
            --compare-exr "dither=$d/stochastic_pattern-blue_seed-object_spp-1$SUFFIX.exr"
            --compare-exr "bayer=$d/stochastic_pattern-bayer8_seed-object_spp-1$SUFFIX.exr")
    fi
    echo "== round $i: pygfx ($(uptime))"
    python3 benches/peer/pygfx_peer.py --scene "$OUT/flat.json" --frames "$PYGFX_FRAMES" \
        --json "$OUT/round$i-pygfx.json" "${compare[@]}"
    echo "== round $i: oit-lab ($(uptime))"
    "$OIT" compare "$SCENE" -t sorted-object -t 'wboit:weight=alpha,reveal=r8' \
        -t 'stochastic:pattern=blue' -t 'stochastic:pattern=bayer8' \
        --resolution "$RES" --frames "$OIT_FRAMES" --target-format "$TARGET_FORMAT" \
        --out "$OUT/round$i-oit"
done
echo
python3 benches/peer/table.py "$OUT" | tee "$OUT/table.md"
