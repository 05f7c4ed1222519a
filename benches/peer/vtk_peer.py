#!/usr/bin/env python3
"""Peer timing: draw an oit-lab scene with VTK and time its translucency modes per frame.

Input is the flattened scene that `cargo run --release -p oit-tools --bin flatten` prints
(see README.md beside this file), so VTK rasterizes exactly oit-lab's world-space triangles,
colours and camera. Each oit-lab draw becomes one vtkActor (in draw order), unlit:

  - colour = vertex colour x base_color x intensity, alpha = vertex alpha x material alpha
    (`Material::shade`, as pygfx_peer.py bakes it). A draw whose every vertex has the same
    colour gets it as the actor's property colour and opacity (kept in float, so nothing is
    rounded before blending); any other draw gets per-vertex RGBA scalars, which VTK always
    maps to 8 bits per channel (`--colors` picks one way for every draw);
  - back faces culled unless the material is double-sided;
  - camera: oit-lab's view (as position, focal point and view-up) and projection matrices, the
    projection given to VTK as an explicit projection matrix with its z row rewritten for
    OpenGL's [-1, 1] clip depth (reverse-Z made forward-Z). x, y and w are unchanged, so the same
    pixels are covered; the script prints how far VTK's matrices are from oit-lab's (0 here).
    GL counts window rows bottom up and Vulkan top down, so an edge that lands exactly on a pixel
    centre (after the rasterizer's 1/256-pixel snapping) is filled on the other side; --flip-y
    draws upside down to make those ties fall as in oit-lab (for image comparisons).

VTK modes (vtkRenderer settings):

  peel   SetUseDepthPeeling(1), SetMaximumNumberOfPeels(--max-peels), SetOcclusionRatio(0):
         VTK's dual depth peeling (vtkDualDepthPeelingPass) where the driver supports it, else
         the single-layer vtkDepthPeelingPass; exact up to 8-bit colour targets. Peeling stops
         when a peel's occlusion query counts no written pixel.
  oit    SetUseOIT(1): vtkOrderIndependentTranslucentPass, McGuire-Bavoil weighted blended OIT
         with weight 1 (RGBA16F accumulation of (C*a, prod(1-a)), R16F sum of a).
  blend  neither: plain OVER blending (src-alpha, one-minus-src-alpha) of the translucent
         actors in the order they were added (oit-lab's draw order), no sorting.

Per mode, after warm-up frames, each timed frame is

    t0; renderWindow.Render(); t1; renderWindow.WaitForCompletion(); t2

`Render()` is VTK's whole frame on the CPU and the GL commands it issues: pipeline update
checks, the renderer's passes (clear to the background, the opaque and translucent passes of
the mode, dual depth peeling's per-peel occlusion query waits), and the copy of VTK's internal
render framebuffer to the window's framebuffer. `WaitForCompletion()` is `glFinish()`. `wall_ms`
is t2 - t0 (what the issue compares); `render_call_ms` is t1 - t0 (on EGL with llvmpipe,
Render() itself already waits for the rendering: it is within about 0.01 ms of wall_ms). With
`--readback` a read of the pixels (glReadPixels through GetRGBACharPixelData) replaces
WaitForCompletion(). Nothing is uploaded in a timed frame: the geometry does not change.
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

# Offscreen OpenGL without an X display: EGL (Mesa's llvmpipe) is the default here. The PyPI VTK
# wheels pick the window class at run time from this variable (read when the window is made).
WINDOWS = {
    "egl": "vtkEGLRenderWindow",
    "osmesa": "vtkOSOpenGLRenderWindow",
    "x": "vtkXOpenGLRenderWindow",
}


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", required=True, help="flattened scene JSON (oit-tools flatten)")
    p.add_argument("--frames", type=int, default=50, help="timed frames per mode (default 50)")
    p.add_argument("--warmup", type=int, default=5,
                   help="untimed frames per mode, after a first frame that builds shaders and buffers (default 5)")
    p.add_argument("--modes", default="peel,oit,blend", help="comma-separated VTK modes: peel, oit, blend (default all three)")
    p.add_argument("--window", choices=sorted(WINDOWS), default=None,
                   help="offscreen window: egl (default unless VTK_DEFAULT_OPENGL_WINDOW is set), osmesa (needs libOSMesa), x")
    p.add_argument("--max-peels", type=int, default=100000,
                   help="renderer.SetMaximumNumberOfPeels (default 100000: peeling ends on the occlusion query, "
                        "not this; 0 would stop dual depth peeling at once, although VTK documents 0 as 'no limit')")
    p.add_argument("--colors", choices=["auto", "vertex", "property"], default="auto",
                   help="auto: property colour for draws of one colour, per-vertex RGBA8 otherwise (default); "
                        "vertex: per-vertex RGBA8 scalars everywhere; property: every draw must be of one colour")
    p.add_argument("--flip-y", action="store_true",
                   help="draw upside down (clip y negated, front faces culled instead of back faces, rows read "
                        "top-down), so that GL's window rows run as Vulkan's and edges snapped onto a pixel "
                        "centre fall on the same side as in oit-lab; for image comparison (the cost is the same)")
    p.add_argument("--readback", action="store_true",
                   help="end each timed frame with a pixel read-back instead of WaitForCompletion()")
    p.add_argument("--no-count", action="store_true",
                   help="skip the extra (untimed) frame per mode that counts actor renders (peels)")
    p.add_argument("--json", help="write the results here")
    p.add_argument("--png-dir", help="save one frame per mode as MODE.png (8-bit linear RGB, as VTK stores it)")
    p.add_argument("--compare-exr", action="append", default=[], metavar="MODE=FILE.exr",
                   help="compare that mode's frame with an oit-lab EXR (linear RGBA, rounded to 8 bit linear); repeatable")
    p.add_argument("--compare-results", metavar="DIR",
                   help="an `oit compare` output folder: compare each mode with its counterparts' EXRs "
                        "and the reference, found through DIR/results.json")
    args = p.parse_args(argv)
    args.modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    for m in args.modes:
        if m not in MODES:
            p.error(f"--modes: unknown mode {m!r}; allowed: {', '.join(MODES)}")
    if args.frames < 1 or args.warmup < 0 or args.max_peels < 1:
        p.error("--frames and --max-peels must be >= 1, --warmup >= 0")
    compares = []
    for item in args.compare_exr:
        mode, sep, path = item.partition("=")
        if not sep or mode not in args.modes:
            p.error(f"--compare-exr {item!r}: expected MODE=FILE.exr with MODE one of --modes")
        compares.append((mode, path))
    args.compare_exr = compares
    return args


# VTK mode -> what it sets, and the oit-lab technique specs it stands next to (the first is the
# one the issue compares; any key=value not given is the technique's default).
MODES = {
    "peel": {"vtk": "SetUseDepthPeeling(1), OcclusionRatio 0", "oit_lab": ["dual-peel:passes=auto,depth=rg32f,accum=auto",
                                                                         "dual-peel:passes=auto,depth=rg32f,accum=rgba8"]},
    "oit": {"vtk": "SetUseOIT(1)", "oit_lab": ["wboit:weight=const"]},
    "blend": {"vtk": "no peeling, no OIT", "oit_lab": ["unsorted", "sorted-object"]},
}


def load_flat_scene(path):
    try:
        with open(path) as f:
            flat = json.load(f)
        for key in ("name", "resolution", "view", "proj", "view_proj", "reverse_z", "background", "draws"):
            flat[key]  # noqa: B018 (presence check)
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"{path}: not a flattened oit-lab scene ({type(e).__name__}: {e}); "
                 "make one with `cargo run --release -p oit-tools --bin flatten -- SCENE.json`")
    return flat


def col_major(m):
    """16 column-major floats -> numpy 4x4 (row-major indexing, m[row, col])."""
    return np.array(m, dtype=np.float64).reshape(4, 4).T


def gl_projection(flat, flip_y=False):
    """oit-lab's projection (wgpu clip space, depth 0..w, maybe reverse-Z) as an OpenGL one
    (depth -w..w, forward-Z): only the z row changes (and y's sign with flip_y)."""
    proj = col_major(flat["proj"]).copy()
    if flat["reverse_z"]:
        proj[2] = proj[3] - proj[2]  # z' = w - z: forward, still 0..w
    proj[2] = 2.0 * proj[2] - proj[3]  # 0..w -> -w..w
    if flip_y:
        proj[1] = -proj[1]
    return proj


def bake_colors(draw):
    """Material::shade's colour and coverage per vertex: rgb * base * intensity, a * alpha."""
    m = draw["material"]
    c = np.asarray(draw["colors"], dtype=np.float32).reshape(-1, 4).copy()
    c[:, :3] *= np.asarray(m["base_color"], dtype=np.float32) * np.float32(m["intensity"])
    c[:, 3] *= np.float32(m["alpha"])
    return c


def srgb8_from_linear(x):
    x = np.clip(np.nan_to_num(x), 0.0, 1.0).astype(np.float64)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.floor(s * 255 + 0.5).astype(np.int32)


def unorm8_from_linear(x):
    """What an 8-bit UNORM target stores for x: round to nearest."""
    return np.floor(np.clip(np.nan_to_num(x), 0.0, 1.0).astype(np.float64) * 255 + 0.5).astype(np.int32)


def read_exr_rgb(path):
    try:
        import OpenEXR
    except ImportError:
        sys.exit("comparing with EXRs needs the OpenEXR package: pip install OpenEXR")
    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGBA" in ch:
            return np.asarray(ch["RGBA"].pixels)[..., :3]
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels)
        return np.stack([np.asarray(ch[c].pixels) for c in "RGB"], axis=-1)


def summary(values):
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def spec_matches(technique, spec):
    """Whether a canonical oit-lab technique string is the spec `name[:k=v,...]` (keys not in
    the spec may have any value)."""
    name, _, params = technique.partition(":")
    sname, _, sparams = spec.partition(":")
    if name != sname:
        return False
    have = dict(kv.split("=", 1) for kv in params.split(",") if "=" in kv)
    return all(have.get(k) == v for k, v in (kv.split("=", 1) for kv in sparams.split(",") if "=" in kv))


def counterpart_exrs(results_dir, scene, mode):
    """[(label, exr path)] for `mode`'s oit-lab counterparts and the reference in an
    `oit compare` output folder."""
    try:
        with open(os.path.join(results_dir, "results.json")) as f:
            res = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"--compare-results {results_dir}: {e}")
    out = []
    for spec in MODES[mode]["oit_lab"]:
        for run in res.get("runs", []):
            exr = (run.get("outputs") or {}).get("exr")
            if run.get("scene") == scene and exr and spec_matches(run["technique"], spec):
                out.append((run["technique"], os.path.join(results_dir, exr)))
                break
    ref = os.path.join(results_dir, scene, "reference.exr")
    if os.path.exists(ref):
        out.append(("reference", ref))
    return out


def compare_image(img_rgb8, exr_path):
    """Stats of VTK's 8-bit linear image against an oit-lab linear EXR rounded to 8 bits."""
    ref = unorm8_from_linear(read_exr_rgb(exr_path))
    if ref.shape != img_rgb8.shape:
        return {"exr": exr_path, "error": f"shape {ref.shape} vs VTK {img_rgb8.shape}"}
    diff = np.abs(img_rgb8.astype(np.int32) - ref)
    worst = diff.max(axis=-1)
    y, x = np.unravel_index(int(np.argmax(worst)), worst.shape)
    return {
        "exr": exr_path,
        "space": "8-bit linear (EXR rounded to nearest)",
        "max_abs": int(diff.max()),
        "mean_abs": float(diff.mean()),
        "identical_pixels": float(np.mean(worst == 0)),
        "pixels_over_1": int(np.count_nonzero(worst > 1)),
        "pixels": int(worst.size),
        "worst_pixel_xy": [int(x), int(y)],
        "worst_vtk": img_rgb8[y, x].tolist(),
        "worst_oit": ref[y, x].tolist(),
        "mean_vtk": [float(v) for v in img_rgb8.reshape(-1, 3).mean(axis=0)],
        "mean_oit": [float(v) for v in ref.reshape(-1, 3).mean(axis=0)],
    }


class counter:
    """A VTK observer callback that counts its calls."""

    def __init__(self):
        self.n = 0

    def __call__(self, _obj, _event):
        self.n += 1


def main(argv=None):
    args = parse_args(argv)
    if args.window:
        os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = WINDOWS[args.window]
    elif not os.environ.get("VTK_DEFAULT_OPENGL_WINDOW") and not os.environ.get("DISPLAY"):
        os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = WINDOWS["egl"]

    import vtkmodules
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401 (registers the OpenGL factories)
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
    from vtkmodules.vtkCommonCore import vtkCommand, vtkPoints, vtkUnsignedCharArray, vtkVersion
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
    from vtkmodules.vtkCommonMath import vtkMatrix4x4
    from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper, vtkRenderer, vtkRenderWindow

    flat = load_flat_scene(args.scene)
    width, height = flat["resolution"]

    # --- window and renderer -------------------------------------------------------------
    rw = vtkRenderWindow()
    rw.SetOffScreenRendering(1)
    rw.SetSize(width, height)
    rw.SetMultiSamples(0)  # oit-lab draws one sample per pixel; depth peeling wants none
    rw.SetAlphaBitPlanes(1)
    ren = vtkRenderer()
    rw.AddRenderer(ren)
    ren.SetBackground(*flat["background"])
    ren.SetBackgroundAlpha(1.0)
    ren.AutomaticLightCreationOff()
    ren.SetUseFXAA(False)

    # --- camera: oit-lab's view, its projection rewritten for OpenGL ----------------------
    view = col_major(flat["view"])
    inv = np.linalg.inv(view)
    eye = inv[:3, 3]
    forward = -inv[:3, 2]  # camera looks down its -z
    up = inv[:3, 1]
    cam = ren.GetActiveCamera()
    cam.SetPosition(*eye)
    cam.SetFocalPoint(*(eye + forward))
    cam.SetViewUp(*up)
    proj = gl_projection(flat, args.flip_y)
    m = vtkMatrix4x4()
    for r in range(4):
        for c in range(4):
            m.SetElement(r, c, float(proj[r, c]))
    cam.SetExplicitProjectionTransformMatrix(m)
    cam.SetUseExplicitProjectionTransformMatrix(True)
    # Check: VTK's view and composite (projection x view) against oit-lab's.
    vm = cam.GetModelViewTransformMatrix()
    vtk_view = np.array([[vm.GetElement(r, c) for c in range(4)] for r in range(4)])
    cm = cam.GetCompositeProjectionTransformMatrix(width / height, -1, 1)
    vtk_vp = np.array([[cm.GetElement(r, c) for c in range(4)] for r in range(4)])
    want_vp = col_major(flat["view_proj"])
    if args.flip_y:
        want_vp[1] = -want_vp[1]
    view_err = float(np.max(np.abs(vtk_view - view)))
    cam_err = float(np.max(np.abs(vtk_vp[[0, 1, 3]] - want_vp[[0, 1, 3]])))

    # --- geometry ---------------------------------------------------------------------------
    actors, warnings = [], []
    n_property = n_vertex = n_tris = 0
    for d in flat["draws"]:
        pos = np.ascontiguousarray(np.asarray(d["positions"], dtype=np.float32).reshape(-1, 3))
        if len(pos) == 0:
            continue
        mat = d["material"]
        mode = mat["mode"]
        if mode in ("mask", "mask-blend"):
            warnings.append(f"{d['name']}: alpha-mask material drawn without its cutoff (VTK has no alpha test here)")
        if mat["premultiplied"] and mode != "opaque":
            warnings.append(f"{d['name']}: premultiplied material drawn as straight alpha")
        n = len(pos)
        n_tris += n // 3
        pts = vtkPoints()
        pts.SetData(numpy_to_vtk(pos, deep=True))
        conn = numpy_to_vtkIdTypeArray(np.arange(n, dtype=np.int64), deep=True)
        offs = numpy_to_vtkIdTypeArray(np.arange(0, n + 1, 3, dtype=np.int64), deep=True)
        cells = vtkCellArray()
        cells.SetData(offs, conn)
        poly = vtkPolyData()
        poly.SetPoints(pts)
        poly.SetPolys(cells)
        colors = bake_colors(d)
        uniform = bool(np.all(colors == colors[0]))
        if args.colors == "property" and not uniform:
            sys.exit(f"--colors property: draw {d['name']} has more than one vertex colour")
        mapper = vtkPolyDataMapper()
        mapper.SetInputData(poly)
        actor = vtkActor()
        actor.SetMapper(mapper)
        prop = actor.GetProperty()
        prop.LightingOff()  # unlit: fragment colour = ambient*Ca + diffuse*Cd = the colour
        prop.SetAmbient(0.0)
        prop.SetDiffuse(1.0)
        prop.SetSpecular(0.0)
        prop.SetInterpolationToFlat()
        # The y flip mirrors the image, so it turns front faces' winding around.
        if args.flip_y:
            prop.SetFrontfaceCulling(not mat["double_sided"])
        else:
            prop.SetBackfaceCulling(not mat["double_sided"])
        if uniform and args.colors != "vertex":
            n_property += 1
            mapper.ScalarVisibilityOff()
            c = colors[0].astype(np.float64)
            prop.SetColor(*np.clip(c[:3], 0.0, 1.0))
            prop.SetOpacity(1.0 if mode in ("opaque", "mask") else float(np.clip(c[3], 0.0, 1.0)))
        else:
            n_vertex += 1
            rgba = unorm8_from_linear(colors).astype(np.uint8)
            if mode in ("opaque", "mask"):
                rgba[:, 3] = 255
            arr = numpy_to_vtk(np.ascontiguousarray(rgba), deep=True)  # uint8 -> vtkUnsignedCharArray
            arr.SetName("rgba")
            poly.GetPointData().SetScalars(arr)
            mapper.ScalarVisibilityOn()
            mapper.SetColorModeToDirectScalars()
            mapper.SetScalarModeToUsePointData()
            prop.SetOpacity(1.0)
            if any(float(v) > 1.0 for v in colors[:, :3].ravel()):
                warnings.append(f"{d['name']}: colours above 1 clamped to 8 bits")
        if mode in ("opaque", "mask"):
            actor.ForceOpaqueOn()
        ren.AddActor(actor)
        actors.append(actor)
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)

    # First frame: makes the GL context, compiles shaders, uploads buffers.
    rw.Render()
    rw.WaitForCompletion()
    caps = rw.ReportCapabilities() or ""
    gl = {}
    for line in caps.splitlines():
        for key, label in (("vendor", "OpenGL vendor string:"), ("renderer", "OpenGL renderer string:"),
                           ("version", "OpenGL version string:")):
            if line.startswith(label):
                gl[key] = line[len(label):].strip()
    dual_supported = bool(ren.IsDualDepthPeelingSupported())

    def read_rgb8():
        arr = vtkUnsignedCharArray()
        rw.GetRGBACharPixelData(0, 0, width - 1, height - 1, 0, arr)
        from vtkmodules.util.numpy_support import vtk_to_numpy
        img = vtk_to_numpy(arr).reshape(height, width, 4)
        # GL rows run bottom-up; drawn upside down they run as oit-lab's.
        return np.ascontiguousarray(img[:, :, :3] if args.flip_y else img[::-1, :, :3])

    def finish():
        rw.WaitForCompletion()

    if args.readback:
        def finish():  # noqa: F811
            arr = vtkUnsignedCharArray()
            rw.GetRGBACharPixelData(0, 0, width - 1, height - 1, 0, arr)

    wait_name = "GetRGBACharPixelData (glReadPixels)" if args.readback else "vtkRenderWindow.WaitForCompletion() (glFinish)"
    print(f"VTK {vtkVersion.GetVTKVersion()} ({vtkmodules.__file__.rsplit('/', 2)[-2]}), Python {platform.python_version()}")
    print(f"window: {rw.GetClassName()}; GL: {gl.get('renderer', '?')} / {gl.get('version', '?')} / {gl.get('vendor', '?')}")
    print(f"scene: {flat['name']} {width}x{height}, {len(flat['draws'])} draws -> {len(actors)} actors "
          f"({n_property} property colour, {n_vertex} per-vertex RGBA8), {n_tris} triangles")
    print(f"camera: |VTK view - oit view| = {view_err:.2e}, |VTK proj*view - oit view_proj| (x,y,w rows) = {cam_err:.2e}"
          + (" (y negated: --flip-y)" if args.flip_y else ""))
    print(f"dual depth peeling supported (vtkOpenGLRenderer.IsDualDepthPeelingSupported): {dual_supported}")
    print(f"timing: 1 build + {args.warmup} warm-up + {args.frames} timed frames per mode; "
          f"frame = Render() + {wait_name}")

    compares = {}
    for mode, path in args.compare_exr:
        compares.setdefault(mode, []).append((os.path.basename(path), path))
    if args.compare_results:
        for mode in args.modes:
            compares.setdefault(mode, []).extend(counterpart_exrs(args.compare_results, flat["name"], mode))

    results = []
    for mode in args.modes:
        ren.SetUseDepthPeeling(mode == "peel")
        ren.SetUseOIT(mode == "oit")
        if mode == "peel":
            ren.SetMaximumNumberOfPeels(args.max_peels)
            ren.SetOcclusionRatio(0.0)
        rw.Render()  # the mode's first frame (its pass objects and shaders are made here)
        finish()
        for _ in range(args.warmup):
            rw.Render()
            finish()
        wall, call = [], []
        for _ in range(args.frames):
            t0 = time.perf_counter()
            rw.Render()
            t1 = time.perf_counter()
            finish()
            t2 = time.perf_counter()
            wall.append((t2 - t0) * 1e3)
            call.append((t1 - t0) * 1e3)
        r = {
            "mode": mode,
            "vtk": MODES[mode]["vtk"],
            "oit_lab_counterparts": MODES[mode]["oit_lab"],
            "wall_ms": summary(wall),
            "render_call_ms": summary(call),
            "frames": args.frames,
            "warmup": args.warmup,
            "used_depth_peeling": bool(ren.GetLastRenderingUsedDepthPeeling()),
        }
        if mode == "peel":
            r["pass"] = "vtkDualDepthPeelingPass" if dual_supported else "vtkDepthPeelingPass"
            r["max_peels"] = args.max_peels
        if not args.no_count:
            # One more, untimed frame with an observer on every mapper: each actor render (one per
            # geometry pass that draws it) fires the mapper's StartEvent.
            renders = counter()
            tags = [(a.GetMapper(), a.GetMapper().AddObserver(vtkCommand.StartEvent, renders)) for a in actors]
            rw.Render()
            finish()
            for mp, tag in tags:
                mp.RemoveObserver(tag)
            r["actor_renders_per_frame"] = renders.n
            r["geometry_passes"] = renders.n / max(len(actors), 1)
            if mode == "peel" and dual_supported:
                # dual depth peeling: one depth-initialisation pass, then one pass per peel
                # (each peel takes the nearest and the farthest remaining layer).
                r["peels"] = r["geometry_passes"] - 1
        if args.png_dir or mode in compares:
            img = read_rgb8()
            if args.png_dir:
                import imageio.v3 as iio

                os.makedirs(args.png_dir, exist_ok=True)
                png = os.path.join(args.png_dir, f"{flat['name']}-{mode}.png")
                iio.imwrite(png, img)
                r["png"] = png
            if mode in compares:
                r["compare"] = [dict(compare_image(img, path), label=label) for label, path in compares[mode]]
        results.append(r)

    print(f"\n{'VTK mode':8} {'wall ms (med/min/max)':>24} {'Render() ms':>12} {'passes':>7}  notes")
    for r in results:
        w = r["wall_ms"]
        passes = f"{r['geometry_passes']:.0f}" if "geometry_passes" in r else "-"
        note = ""
        if r["mode"] == "peel":
            note = f"{r['pass']}, used depth peeling: {r['used_depth_peeling']}"
            if "peels" in r:
                note += f", {r['peels']:.0f} peels"
        print(f"{r['mode']:8} {w['median']:8.2f}/{w['min']:6.2f}/{w['max']:7.2f} {r['render_call_ms']['median']:12.2f} {passes:>7}  {note}")
        for c in r.get("compare", []):
            if "error" in c:
                print(f"  vs {c['label']}: {c['error']}")
                continue
            print(f"  vs {c['label']}: max |diff| {c['max_abs']} (8-bit linear), mean {c['mean_abs']:.3f}, "
                  f"{100 * c['identical_pixels']:.1f}% identical, {c['pixels_over_1']} of {c['pixels']} px differ by > 1; "
                  f"worst {c['worst_vtk']} vs {c['worst_oit']} at {c['worst_pixel_xy']}")

    if args.json:
        out = {
            "tool": "benches/peer/vtk_peer.py",
            "vtk": vtkVersion.GetVTKVersion(),
            "python": platform.python_version(),
            "window": rw.GetClassName(),
            "gl": gl,
            "scene": flat["name"],
            "resolution": [width, height],
            "draws": len(flat["draws"]),
            "actors": {"property_colour": n_property, "vertex_rgba8": n_vertex},
            "triangles": n_tris,
            "camera_view_max_abs_err": view_err,
            "camera_view_proj_max_abs_err": cam_err,
            "flip_y": args.flip_y,
            "dual_depth_peeling_supported": dual_supported,
            "frame": f"Render() + {wait_name}",
            "load_average": os.getloadavg(),
            "results": results,
        }
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
        print(f"\nwrote {args.json}")


if __name__ == "__main__":
    main()
