#!/usr/bin/env python3
"""Writes FoliageCards.gltf: alpha-tested grass cards receding into the distance (oit-lab).

Standard library only; deterministic. Run from this folder: `python3 make.py`.
The texture is 256x256 RGBA8: thin grass blades with alpha 255 on about a third of the
texels and 0 between them, so its mipmaps' alpha falls below the 0.5 cutoff with distance.
"""
import base64, json, math, random, struct, zlib

SIZE = 256


def blades():
    rng = random.Random(7)
    alpha = [[0] * SIZE for _ in range(SIZE)]
    rgb = [[(0, 0, 0)] * SIZE for _ in range(SIZE)]
    for _ in range(30):
        base = rng.uniform(0, SIZE)
        lean = rng.uniform(-40, 40)
        height = rng.uniform(0.55, 0.98) * SIZE
        width = rng.uniform(3.0, 7.0)
        shade = rng.uniform(0.6, 1.0)
        for y in range(SIZE):
            t = (SIZE - 1 - y) / height  # 0 at the bottom, 1 at the tip
            if t > 1:
                continue
            centre = base + lean * t * t
            half = width * (1 - t) / 2 + 0.5
            for x in range(int(centre - half) - 1, int(centre + half) + 2):
                if abs(x + 0.5 - centre) <= half:
                    xx = x % SIZE  # the texture repeats
                    alpha[y][xx] = 255
                    g = int(255 * shade * (0.45 + 0.5 * t))
                    rgb[y][xx] = (int(g * 0.35), g, int(g * 0.2))
    return rgb, alpha


def png(rgb, alpha):
    raw = b"".join(
        b"\x00" + bytes(c for x in range(SIZE) for c in (*rgb[y][x], alpha[y][x]))
        for y in range(SIZE)
    )

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", SIZE, SIZE, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def cards(x):
    """Ten cards 2 wide and 1.2 tall, every 2.5 units from z = 0 to z = -22.5, at `x`."""
    pos, uv, idx = [], [], []
    for k in range(10):
        z = -2.5 * k
        n = len(pos)
        pos += [(x - 1, 0, z), (x + 1, 0, z), (x + 1, 1.2, z), (x - 1, 1.2, z)]
        uv += [(0, 1), (2, 1), (2, 0), (0, 0)]
        idx += [n, n + 1, n + 2, n, n + 2, n + 3]
    return pos, uv, idx


def main():
    rgb, alpha = blades()
    image = png(rgb, alpha)
    blob = b""
    views, accessors, prims = [], [], []

    def view(data, target):
        nonlocal blob
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        blob += data
        while len(blob) % 4:
            blob += b"\x00"
        return len(views) - 1

    for material, x in enumerate([-1.1, 1.1]):
        pos, uv, idx = cards(x)
        p = view(b"".join(struct.pack("<3f", *v) for v in pos), 34962)
        accessors.append({"bufferView": p, "componentType": 5126, "count": len(pos), "type": "VEC3",
                          "min": [min(v[k] for v in pos) for k in range(3)],
                          "max": [max(v[k] for v in pos) for k in range(3)]})
        t = view(b"".join(struct.pack("<2f", *v) for v in uv), 34962)
        accessors.append({"bufferView": t, "componentType": 5126, "count": len(uv), "type": "VEC2"})
        i = view(b"".join(struct.pack("<H", v) for v in idx), 34963)
        accessors.append({"bufferView": i, "componentType": 5123, "count": len(idx), "type": "SCALAR"})
        prims.append({"attributes": {"POSITION": len(accessors) - 3, "TEXCOORD_0": len(accessors) - 2},
                      "indices": len(accessors) - 1, "material": material})
    doc = {
        "asset": {"version": "2.0", "generator": "oit-lab assets/FoliageCards/make.py",
                  "copyright": "CC0 1.0: made for oit-lab"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "Cards"}],
        "meshes": [{"primitives": prims}],
        "materials": [
            {"name": "GrassTrilinear", "alphaMode": "MASK", "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
            {"name": "GrassNearestMip", "alphaMode": "MASK", "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
        ],
        # No sampler: LINEAR / LINEAR_MIPMAP_LINEAR. Sampler 0: NEAREST / NEAREST_MIPMAP_NEAREST.
        "textures": [{"source": 0}, {"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9728, "minFilter": 9984}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(image).decode()}],
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    with open("FoliageCards.gltf", "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
