#!/usr/bin/env python3
"""Cross-check oit-metrics' float FLIP against NVIDIA's reference implementation.

Runs the `flip_pairs` example of oit-metrics (which writes test pairs and this crate's LDR- and
HDR-FLIP maps), evaluates the same pixels with `flip_evaluator` (PyPI `flip-evaluator`, NVlabs
FLIP >= 1.6: `pip install flip-evaluator`) and prints, per pair and mode, both means, |mean
difference| and the largest per-pixel difference; for HDR also both exposure ranges. If
scikit-image is installed, the SSIM of the green channels is compared with
`skimage.metrics.structural_similarity` (Gaussian window, sigma 1.5, population covariance).

    python3 xtask/flip-check/check.py [NAME=REF.exr,TEST.exr ...]

Extra arguments add pairs read from EXR files (passed through to the example). Exits non-zero
when an agreement bound is exceeded: |mean difference| <= 1e-5 and per-pixel <= 1e-3 (LDR and
HDR), exposure range within 1e-4 stops, SSIM within 1e-6.
"""

import json
import os
import subprocess
import sys
import tempfile

import numpy as np

try:
    import flip_evaluator as flip
except ImportError:
    sys.exit("flip_evaluator is missing: pip install flip-evaluator")

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MEAN_TOL, PIXEL_TOL, EXPOSURE_TOL, SSIM_TOL = 1e-5, 1e-3, 1e-4, 1e-6


def load(path, shape):
    return np.fromfile(path, dtype="<f4").reshape(shape)


def main():
    out = tempfile.mkdtemp(prefix="flip-check-")
    subprocess.run(
        ["cargo", "run", "--quiet", "--release", "-p", "oit-tools", "--bin", "flip_pairs", "--", out]
        + sys.argv[1:],
        cwd=REPO,
        check=True,
        stdout=subprocess.DEVNULL,
    )
    with open(os.path.join(out, "pairs.json")) as f:
        pairs = json.load(f)

    try:
        from skimage.metrics import structural_similarity
    except ImportError:
        structural_similarity = None
        print("(scikit-image not installed: SSIM not cross-checked)")

    from importlib.metadata import version

    print(f"flip-evaluator {version('flip-evaluator')}")
    header = f"{'pair':32} {'mode':4} {'ours':>10} {'NVIDIA':>10} {'|mean diff|':>11} {'max px diff':>11}"
    print(header)
    worst = {"LDR": [0.0, 0.0], "HDR": [0.0, 0.0]}
    failures = []
    for p in pairs:
        name, w, h = p["name"], p["width"], p["height"]
        ref = load(os.path.join(out, f"{name}.ref.f32"), (h, w, 3))
        test = load(os.path.join(out, f"{name}.test.f32"), (h, w, 3))
        params = {"ppd": p["ppd"]}
        for mode, key in (("LDR", "ldr"), ("HDR", "hdr")):
            ours = load(os.path.join(out, f"{name}.{key}.f32"), (h, w))
            theirs, _, used = flip.evaluate(ref, test, mode, inputsRGB=False, applyMagma=False, parameters=dict(params))
            theirs = np.asarray(theirs, dtype=np.float32).reshape(h, w)
            # Both means in f64 over the f32 maps (the tool's own mean sums in f32).
            ours_mean, their_mean = p[f"{key}_mean"], float(np.mean(theirs, dtype=np.float64))
            mean_diff = abs(ours_mean - their_mean)
            px_diff = float(np.max(np.abs(ours.astype(np.float64) - theirs.astype(np.float64))))
            worst[mode][0] = max(worst[mode][0], mean_diff)
            worst[mode][1] = max(worst[mode][1], px_diff)
            line = f"{name:32} {mode:4} {ours_mean:10.6f} {their_mean:10.6f} {mean_diff:11.2e} {px_diff:11.2e}"
            if mode == "HDR":
                ours_exp = (p["start_exposure"], p["stop_exposure"], p["num_exposures"])
                their_exp = (used["startExposure"], used["stopExposure"], used["numExposures"])
                line += f"  exposures ours {ours_exp[0]:.4f}..{ours_exp[1]:.4f} x{ours_exp[2]}"
                line += f", NVIDIA {their_exp[0]:.4f}..{their_exp[1]:.4f} x{their_exp[2]}"
                if (
                    abs(ours_exp[0] - their_exp[0]) > EXPOSURE_TOL
                    or abs(ours_exp[1] - their_exp[1]) > EXPOSURE_TOL
                    or ours_exp[2] != their_exp[2]
                ):
                    failures.append(f"{name}: exposures {ours_exp} vs {their_exp}")
            print(line)
            if mean_diff > MEAN_TOL or px_diff > PIXEL_TOL:
                failures.append(f"{name} {mode}: mean diff {mean_diff:.2e}, pixel diff {px_diff:.2e}")
        if structural_similarity is not None:
            g = lambda img: np.clip(img[:, :, 1], 0.0, 1.0).astype(np.float64)
            if min(w, h) >= 11:
                theirs_ssim = structural_similarity(
                    g(test), g(ref), gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=1.0
                )
                d = abs(theirs_ssim - p["ssim_green"])
                print(f"{name:32} SSIM {p['ssim_green']:10.6f} {theirs_ssim:10.6f} {d:11.2e}")
                if d > SSIM_TOL:
                    failures.append(f"{name}: SSIM {p['ssim_green']} vs {theirs_ssim}")

    for mode, (m, px) in worst.items():
        print(f"worst {mode}: |mean diff| {m:.2e}, per-pixel {px:.2e}")
    if failures:
        print("DISAGREEMENT:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("agreement within bounds")


if __name__ == "__main__":
    main()
