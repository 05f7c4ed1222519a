#!/usr/bin/env python3
"""Markdown table of pygfx_peer.py results next to `oit compare` results, round by round.

usage: table.py DIR   (DIR holds roundN-pygfx.json and roundN-oit/results.json, as run.sh writes)
"""

import glob
import json
import os
import re
import sys

# pygfx alpha mode -> prefix of the canonical oit-lab technique it stands next to.
COUNTERPART = {
    "blend": "sorted-object",
    "weighted_blend": "wboit:",
    "dither": "stochastic:pattern=blue,",
    "bayer": "stochastic:pattern=bayer8,",
}


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__.strip())
    out = sys.argv[1]
    rounds = sorted(
        int(m.group(1))
        for p in glob.glob(os.path.join(out, "round*-pygfx.json"))
        if (m := re.search(r"round(\d+)-pygfx\.json$", p))
    )
    if not rounds:
        sys.exit(f"{out}: no roundN-pygfx.json files")
    print("| round | pygfx mode | pygfx wall ms | pygfx GPU ms (scene) | oit-lab technique | oit-lab GPU ms | wall / oit | GPU / oit | load avg (1 min) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i in rounds:
        with open(os.path.join(out, f"round{i}-pygfx.json")) as f:
            pg = json.load(f)
        oit_path = os.path.join(out, f"round{i}-oit", "results.json")
        runs = []
        if os.path.exists(oit_path):
            with open(oit_path) as f:
                runs = json.load(f)["runs"]
        for r in pg["results"]:
            wall = r["wall_ms"]["median"]
            gpu = r.get("gpu_scene_ms", {}).get("median")
            match = [x for x in runs if x["technique"].startswith(COUNTERPART[r["mode"]]) and x.get("gpu_ms")]
            tech, oit = (match[0]["technique"], match[0]["gpu_ms"]["median"]) if match else ("-", None)
            ratio = f"{wall / oit:.2f}" if oit else "-"
            gratio = f"{gpu / oit:.2f}" if oit and gpu else "-"
            gpu_s = f"{gpu:.2f}" if gpu else "-"
            oit_s = f"{oit:.2f}" if oit else "-"
            print(f"| {i} | {r['mode']} | {wall:.2f} | {gpu_s} | {tech} | {oit_s} | {ratio} | {gratio} | {pg['load_average'][0]:.2f} |")


if __name__ == "__main__":
    main()
