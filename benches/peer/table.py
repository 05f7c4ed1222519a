#!/usr/bin/env python3
"""Markdown tables of peer results next to `oit compare` results, round by round.

usage: table.py DIR

DIR holds what run.sh or run_vtk.sh wrote: roundN-oit/results.json with roundN-pygfx.json
(pygfx_peer.py); and/or roundN-vtk-SCENE-MODE.json (vtk_peer.py) with roundN-oit-SCENE-MODE/
results.json (the pair timed back to back), and for VTK images-vtk-SCENE.json.

pygfx: ratios pygfx / oit-lab. VTK: ratios oit-lab / VTK, i.e. oit-lab's GPU ms (timestamps of
its passes: `gpu_ms.median` in results.json) over VTK's per-frame wall ms (Render() + glFinish,
median), so a ratio above 1 means VTK's frame is faster.
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
    pygfx_rounds = sorted(
        int(m.group(1))
        for p in glob.glob(os.path.join(out, "round*-pygfx.json"))
        if (m := re.search(r"round(\d+)-pygfx\.json$", p))
    )
    vtk_files = sorted(glob.glob(os.path.join(out, "round*-vtk-*.json")))
    if not pygfx_rounds and not vtk_files:
        sys.exit(f"{out}: no roundN-pygfx.json or roundN-vtk-SCENE.json files")
    if pygfx_rounds:
        pygfx_table(out, pygfx_rounds)
    if vtk_files:
        if pygfx_rounds:
            print()
        vtk_tables(out, vtk_files)


def load_runs(out, i):
    """oit-lab's runs of round i (`roundI-oit/` and, from run_vtk.sh, every `roundI-oit-*/`), or []."""
    runs = []
    for path in sorted(glob.glob(os.path.join(out, f"round{i}-oit", "results.json"))
                       + glob.glob(os.path.join(out, f"round{i}-oit-*", "results.json"))):
        with open(path) as f:
            runs.extend(json.load(f)["runs"])
    return runs


def pygfx_table(out, rounds):
    print("| round | pygfx mode | pygfx wall ms | pygfx GPU ms (scene) | oit-lab technique | oit-lab GPU ms | wall / oit | GPU / oit | load avg (1 min) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i in rounds:
        with open(os.path.join(out, f"round{i}-pygfx.json")) as f:
            pg = json.load(f)
        runs = load_runs(out, i)
        for r in pg["results"]:
            wall = r["wall_ms"]["median"]
            gpu = r.get("gpu_scene_ms", {}).get("median")
            match = [x for x in runs if x["technique"].startswith(COUNTERPART[r["mode"]]) and x.get("gpu_ms")]
            tech, oit = (match[0]["technique"], match[0]["gpu_ms"]["median"]) if match else ("-", None)
            if match and match[0].get("target_format"):
                tech += f" @ {match[0]['target_format']}"
            ratio = f"{wall / oit:.2f}" if oit else "-"
            gratio = f"{gpu / oit:.2f}" if oit and gpu else "-"
            gpu_s = f"{gpu:.2f}" if gpu else "-"
            oit_s = f"{oit:.2f}" if oit else "-"
            print(f"| {i} | {r['mode']} | {wall:.2f} | {gpu_s} | {tech} | {oit_s} | {ratio} | {gratio} | {pg['load_average'][0]:.2f} |")


def spec_matches(technique, spec):
    """Whether a canonical oit-lab technique string is the spec `name[:k=v,...]` (keys not in
    the spec may have any value). Same rule as vtk_peer.py."""
    name, _, params = technique.partition(":")
    sname, _, sparams = spec.partition(":")
    if name != sname:
        return False
    have = dict(kv.split("=", 1) for kv in params.split(",") if "=" in kv)
    return all(have.get(k) == v for k, v in (kv.split("=", 1) for kv in sparams.split(",") if "=" in kv))


def fmt(x, spec=".2f"):
    return "-" if x is None else format(x, spec)


def vtk_tables(out, files):
    rows = []  # (round, scene, mode, vtk wall, vtk min, technique, oit gpu, ratio, load, other)
    for path in files:
        m = re.search(r"round(\d+)-vtk-(.+)\.json$", path)
        if not m:
            continue
        i = int(m.group(1))
        with open(path) as f:
            v = json.load(f)
        runs = [x for x in load_runs(out, i) if x.get("scene") == v["scene"]]
        for r in v["results"]:
            wall = r["wall_ms"]["median"]
            for spec in r["oit_lab_counterparts"]:
                match = [x for x in runs if spec_matches(x["technique"], spec)]
                run = match[0] if match else None
                gpu = run["gpu_ms"]["median"] if run and run.get("gpu_ms") else None
                other = ((run or {}).get("gpu_ms") or {}).get("interference", {}).get("other_processes")
                tech = run["technique"] if run else spec
                # The final target format, where it is not oit-lab's default Rgba16Float.
                if run and run.get("target_format"):
                    tech += f" @ {run['target_format']}"
                if run and run.get("status", "ok") != "ok":
                    tech += f" ({run['status']})"
                passes = (r.get("geometry_passes"), ((run or {}).get("stats") or {}).get("geometry_passes"))
                rows.append((i, v["scene"], r["mode"], wall, r["wall_ms"]["min"], tech, gpu,
                             gpu / wall if gpu else None, v["load_average"][0], other, passes))
    rows.sort(key=lambda x: (x[0], x[1]))
    print("Times are medians in ms. VTK: per-frame wall time, Render() + glFinish (CPU work included). "
          "oit-lab: GPU time from timestamps around its passes (no CPU submission, no read-back). "
          "oit-lab ÷ VTK above 1: VTK's frame is faster.")
    print()
    print("| round | scene | VTK mode | VTK wall ms (min) | oit-lab technique | oit-lab GPU ms | oit-lab ÷ VTK | geometry passes VTK / oit-lab | load avg after VTK (1 min) | oit-lab: other processes' CPU share |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for i, scene, mode, wall, wmin, tech, gpu, ratio, load, other, passes in rows:
        print(f"| {i} | {scene} | {mode} | {wall:.2f} ({wmin:.2f}) | {tech} | {fmt(gpu)} | {fmt(ratio)} | "
              f"{fmt(passes[0], '.0f')} / {fmt(passes[1], 'd')} | {load:.2f} | {fmt(other, '.0%')} |")

    # Over the rounds: the range of each ratio.
    groups = {}
    for row in rows:
        scene, mode, tech, ratio = row[1], row[2], row[5], row[7]
        if ratio is not None:
            groups.setdefault((scene, mode, tech), []).append(ratio)
    if groups:
        print()
        print("| scene | VTK mode | oit-lab technique | rounds | oit-lab ÷ VTK, min–max (median) |")
        print("|---|---|---|---|---|")
        for (scene, mode, tech), rs in groups.items():
            rs = sorted(rs)
            med = rs[len(rs) // 2] if len(rs) % 2 else (rs[len(rs) // 2 - 1] + rs[len(rs) // 2]) / 2
            print(f"| {scene} | {mode} | {tech} | {len(rs)} | {rs[0]:.2f}–{rs[-1]:.2f} ({med:.2f}) |")

    images = sorted(glob.glob(os.path.join(out, "images-vtk-*.json")))
    if images:
        print()
        print("Images: VTK's 8-bit RGBA frame against oit-lab's linear EXR rounded to 8 bits (linear, no sRGB). "
              "flip-y: VTK drew upside down so that edges on pixel centres fall as in oit-lab (vtk_peer.py --flip-y).")
        print()
        print("| scene | flip-y | VTK mode | against | max diff (8-bit codes) | mean diff | identical px | px differing by > 1 |")
        print("|---|---|---|---|---|---|---|---|")
        for path in images:
            with open(path) as f:
                v = json.load(f)
            for r in v["results"]:
                for c in r.get("compare", []):
                    flip = "yes" if v.get("flip_y") else "no"
                    if "error" in c:
                        print(f"| {v['scene']} | {flip} | {r['mode']} | {c['label']} | {c['error']} | | | |")
                        continue
                    print(f"| {v['scene']} | {flip} | {r['mode']} | {c['label']} | {c['max_abs']} | {c['mean_abs']:.3f} | "
                          f"{100 * c['identical_pixels']:.1f} % | {c['pixels_over_1']} of {c['pixels']} |")


if __name__ == "__main__":
    main()
