#!/usr/bin/env python3
"""Peer timing: draw an oit-lab scene with pygfx and time its transparency modes per frame.

Input is the flattened scene that `cargo run --release -p oit-tools --bin flatten` prints
(see README.md beside this file), so pygfx rasterizes exactly oit-lab's triangles, colours and
camera. Each draw becomes one pygfx Mesh (per-vertex colours with the material's colour,
intensity and alpha baked in, as `Material::shade` does), placed at its bounding-box centre so
that pygfx's per-object depth sort sees the same distances as oit-lab's `sorted-object`.

Per mode, after warm-up frames, each timed frame is:

    renderer.render(scene, camera)          # Python: flatten + sort scene, upload uniforms,
                                            # record and submit; then flush() records and
                                            # submits the copy into the offscreen target
    wait()                                  # block until the GPU (lavapipe) is done: the
                                            # queue's on_submitted_work_done_sync(), or where
                                            # that is broken (wgpu-py 0.32.0 with wgpu-native
                                            # 29: callback signature mismatch) a blocking
                                            # wgpuDevicePoll through device._poll_wait()

`wall_ms` is that whole span (what the issue compared). Where the adapter has timestamp
queries, `gpu_ms` is the time between timestamps written at the start and end of each command
encoder pygfx records in the frame (scene passes, weighted resolve, the output copy), summed;
`gpu_scene_ms` leaves out the output copy (the encoder recorded by flush()).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time

import numpy as np

os.environ.setdefault("XDG_RUNTIME_DIR", "/tmp")

import pygfx as gfx  # noqa: E402
import wgpu  # noqa: E402
from wgpu.backends.wgpu_native import extras as wgpu_extras  # noqa: E402

DEFAULT_MODES = ["blend", "weighted_blend", "dither", "bayer"]
# pygfx alpha modes usable for the scene's transparent draws, and the oit-lab technique each
# stands next to in README.md.
TRANSPARENT_MODES = {
    "blend": "sorted-object",
    "weighted_blend": "wboit:weight=alpha,reveal=r8",
    "dither": "stochastic:pattern=blue",
    "bayer": "stochastic:pattern=bayer",
}


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", required=True, help="flattened scene JSON (oit-scene example flatten)")
    p.add_argument("--frames", type=int, default=50, help="timed frames per mode (default 50)")
    p.add_argument("--warmup", type=int, default=5, help="untimed frames per mode (default 5)")
    p.add_argument(
        "--modes",
        default=",".join(DEFAULT_MODES),
        help=f"comma-separated pygfx alpha modes for transparent draws (default {','.join(DEFAULT_MODES)})",
    )
    p.add_argument("--adapter", default="llvmpipe", help="use the first Vulkan adapter whose name contains this (default llvmpipe)")
    p.add_argument("--no-timestamps", action="store_true", help="wall-clock only, no timestamp queries")
    p.add_argument("--json", help="write the results here")
    p.add_argument("--png-dir", help="save one frame per mode as MODE.png (sRGB8, as pygfx stores it)")
    p.add_argument(
        "--compare-exr",
        action="append",
        default=[],
        metavar="MODE=FILE.exr",
        help="compare that mode's frame with an oit-lab EXR (linear RGBA, sRGB-encoded to 8 bit "
        "for the comparison; needs the OpenEXR package); repeatable",
    )
    args = p.parse_args(argv)
    args.modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    for m in args.modes:
        if m not in TRANSPARENT_MODES:
            p.error(f"--modes: unknown mode {m!r}; allowed: {', '.join(TRANSPARENT_MODES)}")
    if args.frames < 1 or args.warmup < 0:
        p.error("--frames must be >= 1 and --warmup >= 0")
    compares = {}
    for item in args.compare_exr:
        mode, sep, path = item.partition("=")
        if not sep or mode not in args.modes:
            p.error(f"--compare-exr {item!r}: expected MODE=FILE.exr with MODE one of --modes")
        compares[mode] = path
    args.compare_exr = compares
    return args


def load_flat_scene(path):
    try:
        with open(path) as f:
            flat = json.load(f)
        for key in ("resolution", "view", "proj", "view_proj", "reverse_z", "background", "draws"):
            flat[key]  # noqa: B018 (presence check)
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"{path}: not a flattened oit-lab scene ({type(e).__name__}: {e}); "
                 "make one with `cargo run --release -p oit-tools --bin flatten -- SCENE.json`")
    return flat


def col_major(m):
    """16 column-major floats -> numpy 4x4 (row-major indexing, m[row, col])."""
    return np.array(m, dtype=np.float64).reshape(4, 4).T


class FixedCamera(gfx.Camera):
    """A camera whose view and projection are given matrices (oit-lab's, verbatim)."""

    def __init__(self, view, proj):
        super().__init__()
        self._proj = np.asarray(proj, dtype=np.float64)
        self._proj.flags.writeable = False
        self.local.matrix = np.linalg.inv(view)

    def _update_projection_matrix(self):
        return self._proj


def make_camera(flat):
    view, proj = col_major(flat["view"]), col_major(flat["proj"])
    if flat["reverse_z"]:
        # pygfx clears depth to 1 and tests "<": use the forward-Z projection (z' = w - z,
        # window depth 1 - d). x, y and w, and so every rasterized fragment, are unchanged.
        proj = proj.copy()
        proj[2] = proj[3] - proj[2]
    cam = FixedCamera(view, proj)
    # Check: the camera pygfx will use reproduces oit-lab's view_proj in x, y and w.
    got = np.asarray(cam.camera_matrix, dtype=np.float64)
    want = col_major(flat["view_proj"])
    err = float(np.max(np.abs(got[[0, 1, 3]] - want[[0, 1, 3]])))
    return cam, err


def bake_colors(draw):
    """Material::shade's colour and coverage per vertex: rgb * base * intensity, a * alpha."""
    m = draw["material"]
    c = np.asarray(draw["colors"], dtype=np.float32).reshape(-1, 4).copy()
    c[:, :3] *= np.asarray(m["base_color"], dtype=np.float32) * np.float32(m["intensity"])
    c[:, 3] *= np.float32(m["alpha"])
    return c


def build_scene(flat):
    scene = gfx.Scene()
    bg = gfx.Color.from_physical(*flat["background"])
    scene.add(gfx.Background(None, gfx.BackgroundMaterial(bg)))
    transparent, warnings = [], []
    for d in flat["draws"]:
        pos = np.asarray(d["positions"], dtype=np.float32).reshape(-1, 3)
        if len(pos) == 0:
            continue
        lo, hi = pos.min(axis=0), pos.max(axis=0)
        center = (lo + hi) * 0.5  # oit-lab's bounds_center
        # pygfx meshes are indexed; oit-lab's are plain triangle lists.
        indices = np.arange(len(pos), dtype=np.uint32).reshape(-1, 3)
        geo = gfx.Geometry(positions=pos - center, indices=indices, colors=bake_colors(d))
        m = d["material"]
        mode = m["mode"]
        mat = gfx.MeshBasicMaterial(
            color_mode="vertex",
            side="both" if m["double_sided"] else "front",
            alpha_mode="solid" if mode in ("opaque", "mask") else "blend",
        )
        if mode in ("mask", "mask-blend"):
            mat.alpha_test = m["cutoff"]
        if m["premultiplied"] and mode in ("blend", "mask-blend"):
            warnings.append(f"{d['name']}: premultiplied material drawn as straight alpha")
        mesh = gfx.Mesh(geo, mat)
        mesh.local.position = center
        scene.add(mesh)
        if mode in ("blend", "mask-blend"):
            transparent.append(mat)
    return scene, transparent, warnings


class TimestampedDevice:
    """Stands in for the renderer's device: every command encoder it hands out gets a timestamp
    written first and another just before finish(), so each submitted command buffer's GPU
    span can be read back. Everything else is the real device."""

    MAX = 64

    def __init__(self, device):
        self._device = device
        self.query_set = device.create_query_set(type="timestamp", count=self.MAX)
        self.resolve = device.create_buffer(size=8 * self.MAX, usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC)
        self.readback = device.create_buffer(size=8 * self.MAX, usage=wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.MAP_READ)
        self.used = 0
        period = getattr(device.queue, "get_timestamp_period", None)
        self.period_ns = float(period()) if callable(period) else 1.0

    def __getattr__(self, name):
        return getattr(self._device, name)

    def create_command_encoder(self, **kwargs):
        enc = self._device.create_command_encoder(**kwargs)
        if self.used + 2 > self.MAX:
            return enc
        start = self.used
        self.used += 2
        wgpu_extras.write_timestamp(enc, self.query_set, start)
        finish = enc.finish

        def finish_with_timestamp(**kw):
            wgpu_extras.write_timestamp(enc, self.query_set, start + 1)
            return finish(**kw)

        enc.finish = finish_with_timestamp
        return enc

    def collect(self):
        """Spans (ms) of the encoders since the last collect(), in creation order."""
        n = self.used
        self.used = 0
        if n == 0:
            return []
        enc = self._device.create_command_encoder()
        enc.resolve_query_set(self.query_set, 0, n, self.resolve, 0)
        enc.copy_buffer_to_buffer(self.resolve, 0, self.readback, 0, 8 * n)
        self._device.queue.submit([enc.finish()])
        self.readback.map_sync("read")
        try:
            ticks = np.frombuffer(self.readback.read_mapped(0, 8 * n), dtype=np.uint64).copy()
        finally:
            self.readback.unmap()
        return [float(ticks[i + 1] - ticks[i]) * self.period_ns / 1e6 for i in range(0, n, 2)]


def gpu_waiter(device):
    """A function that blocks until all submitted GPU work is done, and its name."""
    try:
        device.queue.on_submitted_work_done_sync()
        return device.queue.on_submitted_work_done_sync, "queue.on_submitted_work_done_sync()"
    except TypeError:
        # wgpu-py 0.32.0 builds the callback with the pre-29 signature and fails here.
        return device._poll_wait, "device._poll_wait() (wgpuDevicePoll, blocking)"


def pick_adapter(substring):
    for a in wgpu.gpu.enumerate_adapters_sync():
        if a.info["backend_type"] == "Vulkan" and substring.lower() in a.summary.lower():
            return a
    names = [a.summary for a in wgpu.gpu.enumerate_adapters_sync()]
    sys.exit(f"--adapter {substring!r}: no Vulkan adapter matches; found: {names}")


def summary(values):
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def srgb8_from_linear(x):
    x = np.clip(np.nan_to_num(x), 0.0, 1.0).astype(np.float64)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.floor(s * 255 + 0.5).astype(np.int32)


def read_exr_rgb(path):
    try:
        import OpenEXR
    except ImportError:
        sys.exit("--compare-exr needs the OpenEXR package: pip install OpenEXR")
    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGBA" in ch:
            return np.asarray(ch["RGBA"].pixels)[..., :3]
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels)
        return np.stack([np.asarray(ch[c].pixels) for c in "RGB"], axis=-1)


def main(argv=None):
    args = parse_args(argv)
    flat = load_flat_scene(args.scene)
    width, height = flat["resolution"]

    adapter = pick_adapter(args.adapter)
    gfx.renderers.wgpu.select_adapter(adapter)
    timestamps = not args.no_timestamps and {"timestamp-query", "timestamp-query-inside-encoders"} <= set(adapter.features)
    if timestamps:
        gfx.renderers.wgpu.enable_wgpu_features("timestamp-query")
        # A native (non-WebGPU) feature: wgpu-py only takes it as a preferred feature.
        wgpu.preconfigure_default_device("pygfx-peer", preferred_features={"timestamp-query-inside-encoders"})

    scene, transparent, warnings = build_scene(flat)
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    camera, cam_err = make_camera(flat)

    target = gfx.Texture(dim=2, size=(width, height, 1), format=wgpu.TextureFormat.rgba8unorm_srgb, colorspace="physical")
    # pixel_scale=1: pygfx renders offscreen targets at 2x (SSAA) by default; oit-lab renders at
    # the target size. ppaa="none": no post-process anti-aliasing pass (oit-lab has none).
    renderer = gfx.WgpuRenderer(target, pixel_scale=1, ppaa="none", pixel_filter="nearest", enable_events=False)
    device = renderer.device
    ts = None
    if timestamps:
        ts = TimestampedDevice(device)
        renderer._device = ts  # the renderer records and submits every frame through this

    wait, wait_name = gpu_waiter(device)

    info = adapter.info
    adapter_name = f"{info['device']} ({info['backend_type']}, {info['adapter_type']}, {info['description']})"
    print(f"adapter: {adapter_name}")
    print(f"pygfx {gfx.__version__}, wgpu-py {wgpu.__version__}, wgpu-native {wgpu.backends.wgpu_native.__version__}")
    print(f"scene: {flat['name']} {width}x{height}, {len(flat['draws'])} draws, "
          f"{sum(len(d['positions']) for d in flat['draws']) // 3} triangles; camera |pygfx - oit view_proj| (x,y,w rows) = {cam_err:.2e}")
    print(f"timing: {args.warmup} warm-up + {args.frames} timed frames per mode; "
          f"GPU timestamps: {'yes' if timestamps else 'no'}; GPU wait: {wait_name}")

    results = []
    for mode in args.modes:
        for mat in transparent:
            mat.alpha_mode = mode
        for _ in range(args.warmup):
            renderer.render(scene, camera)
            wait()
        if ts:
            ts.collect()
        wall, cpu, gpu, gpu_scene = [], [], [], []
        for _ in range(args.frames):
            t0 = time.perf_counter()
            renderer.render(scene, camera)
            t1 = time.perf_counter()
            wait()
            t2 = time.perf_counter()
            wall.append((t2 - t0) * 1e3)
            cpu.append((t1 - t0) * 1e3)
            if ts:
                spans = ts.collect()
                gpu.append(sum(spans))
                gpu_scene.append(sum(spans[:-1]))  # the last encoder is flush()'s output copy
        r = {
            "mode": mode,
            "oit_lab_counterpart": TRANSPARENT_MODES[mode],
            "wall_ms": summary(wall),
            "cpu_submit_ms": summary(cpu),
            "frames": args.frames,
        }
        if ts:
            r["gpu_ms"] = summary(gpu)
            r["gpu_scene_ms"] = summary(gpu_scene)
        if args.png_dir or mode in args.compare_exr:
            img = renderer.snapshot()  # rgba8 sRGB bytes of the internal colour target
            if args.png_dir:
                import imageio.v3 as iio

                os.makedirs(args.png_dir, exist_ok=True)
                png = os.path.join(args.png_dir, f"{mode}.png")
                iio.imwrite(png, img[..., :3])
                r["png"] = png
            if mode in args.compare_exr:
                ref = srgb8_from_linear(read_exr_rgb(args.compare_exr[mode]))
                diff = np.abs(img[..., :3].astype(np.int32) - ref)
                r["compare"] = {
                    "exr": args.compare_exr[mode],
                    "max_abs_srgb8": int(diff.max()),
                    "mean_abs_srgb8": float(diff.mean()),
                    "identical_pixels": float(np.mean(np.all(diff == 0, axis=-1))),
                    # Dithered modes differ per pixel (other noise); compare their means.
                    "mean_srgb8_pygfx": [float(v) for v in img[..., :3].reshape(-1, 3).mean(axis=0)],
                    "mean_srgb8_oit": [float(v) for v in ref.reshape(-1, 3).mean(axis=0)],
                }
        results.append(r)

    hdr = f"{'pygfx mode':16} {'wall ms (med/min/max)':>24} {'CPU submit ms':>14}"
    if ts:
        hdr += f" {'GPU ms (med/min/max)':>24} {'GPU scene ms':>13}"
    print("\n" + hdr)
    for r in results:
        w = r["wall_ms"]
        line = f"{r['mode']:16} {w['median']:8.2f}/{w['min']:6.2f}/{w['max']:7.2f} {r['cpu_submit_ms']['median']:14.2f}"
        if ts:
            g = r["gpu_ms"]
            line += f" {g['median']:8.2f}/{g['min']:6.2f}/{g['max']:7.2f} {r['gpu_scene_ms']['median']:13.2f}"
        print(line)
        if "compare" in r:
            c = r["compare"]
            print(f"  vs {c['exr']}: max |diff| {c['max_abs_srgb8']} sRGB8 codes, mean {c['mean_abs_srgb8']:.3f}, "
                  f"{100 * c['identical_pixels']:.1f}% pixels identical; mean sRGB8 "
                  f"{np.round(c['mean_srgb8_pygfx'], 1).tolist()} vs {np.round(c['mean_srgb8_oit'], 1).tolist()}")

    if args.json:
        out = {
            "tool": "benches/peer/pygfx_peer.py",
            "pygfx": gfx.__version__,
            "wgpu_py": wgpu.__version__,
            "wgpu_native": wgpu.backends.wgpu_native.__version__,
            "python": platform.python_version(),
            "adapter": adapter_name,
            "scene": flat["name"],
            "resolution": [width, height],
            "camera_view_proj_max_abs_err": cam_err,
            "load_average": os.getloadavg(),
            "gpu_wait": wait_name,
            "gpu_timestamps": bool(timestamps),
            "results": results,
        }
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
        print(f"\nwrote {args.json}")


if __name__ == "__main__":
    main()
