//! Structure-aware generators: valid scenes and valid glTF assets from a seed. Starting from
//! valid documents lets mutations reach validation, flattening, accessor reading and image
//! decoding instead of stopping at the first syntax error. Sizes stay small (a few hundred
//! triangles, images of a few texels) so a run tests thousands of inputs per second.

use serde_json::{Map, Value, json};

use oit_scene::SplitMix64;

/// The fuzzer's random source: the crate's SplitMix64, so a seed gives the same input in every
/// version of the dependencies.
pub(super) struct Rng(SplitMix64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(SplitMix64::new(seed))
    }

    pub fn u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: u64) -> u64 {
        if n == 0 { 0 } else { self.u64() % n }
    }

    pub fn index(&mut self, n: usize) -> usize {
        self.below(n as u64) as usize
    }

    pub fn chance(&mut self, p: f32) -> bool {
        self.0.next_f32() < p
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        self.0.range(lo, hi)
    }

    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.index(items.len())]
    }

    /// A number in `[lo, hi]` rounded to 3 decimals, so corpus files stay readable.
    pub fn num(&mut self, lo: f32, hi: f32) -> Value {
        json!(round(self.range(lo, hi)))
    }

    pub fn vec(&mut self, n: usize, lo: f32, hi: f32) -> Value {
        Value::Array((0..n).map(|_| self.num(lo, hi)).collect())
    }
}

fn round(x: f32) -> f64 {
    (f64::from(x) * 1000.0).round() / 1000.0
}

/// Glues optional members: each `(name, value)` is kept with probability `p`.
fn maybe(r: &mut Rng, map: &mut Map<String, Value>, p: f32, name: &str, value: Value) {
    if r.chance(p) {
        map.insert(name.to_string(), value);
    }
}

// ---- JSON scenes ----

/// glTF assets a generated scene may place (written next to it by [`super::Fixtures`]).
pub(super) const FIXTURE_FILES: [&str; 3] = ["fixture.glb", "fixture.gltf", "no-triangles.gltf"];

const KINDS: [&str; 9] = [
    "quad",
    "box",
    "uv-sphere",
    "torus",
    "cylinder",
    "layers",
    "soup",
    "billboards",
    "gltf",
];

/// A valid scene: camera, lighting and up to five objects of every kind, each optional field
/// present about half the time so defaults are exercised too.
pub(super) fn scene(r: &mut Rng) -> Value {
    let mut s = Map::new();
    let name = *r.pick(&["fuzz", "", "ünïcode ✓", "a b"]);
    s.insert("name".into(), json!(name));
    let description = json!("generated");
    maybe(r, &mut s, 0.3, "description", description);
    let resolution = json!([1 + r.below(160), 1 + r.below(160)]);
    maybe(r, &mut s, 0.6, "resolution", resolution);
    s.insert("camera".into(), camera(r));
    let background = r.vec(3, 0.0, 2.0);
    maybe(r, &mut s, 0.4, "background", background);
    let reverse_z = json!(r.chance(0.5));
    maybe(r, &mut s, 0.4, "reverse_z", reverse_z);
    if r.chance(0.4) {
        let lighting = if r.chance(0.3) {
            json!("unlit")
        } else {
            let mut d = Map::new();
            // z < 0 keeps the direction away from zero.
            d.insert(
                "direction".into(),
                json!([round(r.range(-1.0, 1.0)), round(r.range(-1.0, 1.0)), -1]),
            );
            let color = r.vec(3, 0.0, 2.0);
            maybe(r, &mut d, 0.5, "color", color);
            let ambient = r.vec(3, 0.0, 0.5);
            maybe(r, &mut d, 0.5, "ambient", ambient);
            json!({"directional": d})
        };
        s.insert("lighting".into(), lighting);
    }
    let objects: Vec<Value> = (0..r.below(6)).map(|_| object(r)).collect();
    s.insert("objects".into(), Value::Array(objects));
    Value::Object(s)
}

fn camera(r: &mut Rng) -> Value {
    let mut c = Map::new();
    // The eye is in front of (z >= 2) the target (z <= 1), and up has no z: never parallel.
    c.insert(
        "eye".into(),
        json!([
            round(r.range(-3.0, 3.0)),
            round(r.range(-3.0, 3.0)),
            round(r.range(2.0, 10.0))
        ]),
    );
    c.insert("target".into(), r.vec(3, -1.0, 1.0));
    let up = json!([round(r.range(-0.3, 0.3)), 1, 0]);
    maybe(r, &mut c, 0.3, "up", up);
    let orthographic = r.chance(0.3);
    let near = if orthographic {
        r.range(-2.0, 1.0)
    } else {
        r.range(0.01, 1.0)
    };
    if orthographic {
        c.insert("orthographic".into(), json!({"height": r.num(0.5, 10.0)}));
    } else {
        let fov = r.num(10.0, 120.0);
        maybe(r, &mut c, 0.6, "fov_y", fov);
    }
    // Absent near and far are 0.1 and 100, which also suit every eye above.
    if r.chance(0.7) {
        c.insert("near".into(), json!(round(near)));
        c.insert("far".into(), json!(round(near + r.range(0.5, 100.0))));
    }
    Value::Object(c)
}

fn object(r: &mut Rng) -> Value {
    let kind = *r.pick(&KINDS);
    let mut o = Map::new();
    o.insert("mesh".into(), mesh(r, kind));
    if r.chance(0.5) {
        let mut t = Map::new();
        let translate = r.vec(3, -2.0, 2.0);
        maybe(r, &mut t, 0.6, "translate", translate);
        let rotate = r.vec(3, -180.0, 180.0);
        maybe(r, &mut t, 0.6, "rotate", rotate);
        let scale = r.vec(3, 0.2, 2.0);
        maybe(r, &mut t, 0.6, "scale", scale);
        o.insert("transform".into(), Value::Object(t));
    }
    let mut transparent = false;
    if kind != "gltf" && r.chance(0.7) {
        let mut m = material(r);
        transparent = matches!(
            m.get("mode").and_then(Value::as_str),
            Some("blend" | "mask-blend")
        );
        if transparent {
            blending(r, &mut m);
        }
        o.insert("material".into(), m);
    }
    ordering(r, &mut o, kind, transparent);
    if r.chance(0.2) {
        let counts = json!([1 + r.below(3), 1 + r.below(3), 1 + r.below(3)]);
        let spacing = r.vec(3, -1.0, 1.0);
        o.insert(
            "instances".into(),
            json!({"counts": counts, "spacing": spacing}),
        );
    }
    Value::Object(o)
}

/// The blending fields of a transparent material (an object of `material`).
fn blending(r: &mut Rng, m: &mut Value) {
    let Some(m) = m.as_object_mut() else {
        return;
    };
    let operator = json!(r.pick(&["over", "add", "subtract", "multiply"]));
    maybe(r, m, 0.3, "operator", operator);
    let depth_write = json!(r.chance(0.5));
    maybe(r, m, 0.3, "depth_write", depth_write);
}

/// Where the object goes in engines' draw orders. Valid documents keep every opaque or mask
/// object at or below every transparent one in (render group, queue): opaque and mask objects
/// (and glTF objects, whose modes come from the asset) stay in group 0, the first at queues up
/// to 2400 (the others at their derived queue), transparent ones at 2600 and above.
fn ordering(r: &mut Rng, o: &mut Map<String, Value>, kind: &str, transparent: bool) {
    if transparent {
        let group = json!(r.below(4));
        maybe(r, o, 0.2, "render_group", group);
        let queue = json!(r.pick(&[2600, 3000, 3500, 4000]));
        maybe(r, o, 0.2, "render_queue", queue);
    } else if kind != "gltf" {
        let queue = json!(r.pick(&[1000, 1500, 2000, 2400]));
        maybe(r, o, 0.15, "render_queue", queue);
    }
    let index = json!(r.below(7) as i64 - 3);
    let key = if r.chance(0.5) {
        "alpha_index"
    } else {
        "render_order"
    };
    maybe(r, o, 0.2, key, index);
    let method = json!(r.pick(&["opaque", "stochastic", "blended", "weighted"]));
    maybe(r, o, 0.15, "method", method);
}

fn material(r: &mut Rng) -> Value {
    let mut m = Map::new();
    let base = r.vec(3, 0.0, 1.5);
    maybe(r, &mut m, 0.5, "base_color", base);
    let alpha = r.num(0.0, 1.0);
    maybe(r, &mut m, 0.6, "alpha", alpha);
    let mode = json!(r.pick(&["opaque", "mask", "blend", "mask-blend"]));
    maybe(r, &mut m, 0.7, "mode", mode);
    let cutoff = r.num(0.0, 1.0);
    maybe(r, &mut m, 0.3, "cutoff", cutoff);
    let double_sided = json!(r.chance(0.5));
    maybe(r, &mut m, 0.3, "double_sided", double_sided);
    let premultiplied = json!(r.chance(0.5));
    maybe(r, &mut m, 0.2, "premultiplied", premultiplied);
    let intensity = r.num(0.0, 5.0);
    maybe(r, &mut m, 0.2, "intensity", intensity);
    Value::Object(m)
}

fn mesh(r: &mut Rng, kind: &str) -> Value {
    let mut m = Map::new();
    m.insert("kind".into(), json!(kind));
    let p = 0.5;
    match kind {
        "quad" => {
            let size = r.vec(2, 0.1, 2.0);
            maybe(r, &mut m, p, "size", size);
            let corners = r.vec(4, 0.0, 1.0);
            maybe(r, &mut m, p, "corner_alpha", corners);
        }
        "box" => {
            let size = r.vec(3, 0.1, 2.0);
            maybe(r, &mut m, p, "size", size);
        }
        "uv-sphere" => {
            let radius = r.num(0.1, 2.0);
            maybe(r, &mut m, p, "radius", radius);
            let segments = json!(3 + r.below(14));
            maybe(r, &mut m, p, "segments", segments);
            let rings = json!(2 + r.below(9));
            maybe(r, &mut m, p, "rings", rings);
        }
        "torus" => {
            if r.chance(0.6) {
                let major = r.range(0.3, 1.0);
                m.insert("major_radius".into(), json!(round(major)));
                m.insert(
                    "minor_radius".into(),
                    json!(round(major * r.range(0.1, 0.8))),
                );
            }
            let segments = json!(3 + r.below(14));
            maybe(r, &mut m, p, "segments", segments);
            let tube = json!(3 + r.below(8));
            maybe(r, &mut m, p, "tube_segments", tube);
        }
        "cylinder" => {
            let radius = r.num(0.1, 1.0);
            maybe(r, &mut m, p, "radius", radius);
            let height = r.num(0.1, 2.0);
            maybe(r, &mut m, p, "height", height);
            let segments = json!(3 + r.below(14));
            maybe(r, &mut m, p, "segments", segments);
            let capped = json!(r.chance(0.5));
            maybe(r, &mut m, p, "capped", capped);
        }
        "layers" => {
            m.insert("count".into(), json!(1 + r.below(8)));
            let spacing = r.num(0.0, 0.3);
            maybe(r, &mut m, p, "spacing", spacing);
            let size = r.vec(2, 0.1, 3.0);
            maybe(r, &mut m, p, "size", size);
            let from = r.vec(3, 0.0, 1.0);
            maybe(r, &mut m, p, "color_from", from);
            let to = r.vec(3, 0.0, 1.0);
            maybe(r, &mut m, p, "color_to", to);
            let a = r.num(0.0, 1.0);
            maybe(r, &mut m, p, "alpha_from", a);
            let b = r.num(0.0, 1.0);
            maybe(r, &mut m, p, "alpha_to", b);
        }
        "soup" | "billboards" => {
            m.insert("seed".into(), json!(r.below(1000)));
            m.insert("count".into(), json!(1 + r.below(40)));
            // min <= 0 <= max in every component, colour and alpha ranges likewise.
            let (min, max) = (r.vec(3, -2.0, 0.0), r.vec(3, 0.0, 2.0));
            m.insert("bounds".into(), json!({"min": min, "max": max}));
            let size = r.num(0.01, 0.3);
            maybe(r, &mut m, p, "size", size);
            let cmin = r.vec(3, 0.0, 0.5);
            maybe(r, &mut m, p, "color_min", cmin);
            let cmax = r.vec(3, 0.5, 2.0);
            maybe(r, &mut m, p, "color_max", cmax);
            let amin = r.num(0.0, 0.5);
            maybe(r, &mut m, p, "alpha_min", amin);
            let amax = r.num(0.5, 1.0);
            maybe(r, &mut m, p, "alpha_max", amax);
        }
        _ => {
            m.insert("file".into(), json!(r.pick(&FIXTURE_FILES)));
            maybe(r, &mut m, 0.3, "scene", json!(0));
        }
    }
    Value::Object(m)
}

// ---- glTF assets ----

/// A glTF document and its binary buffer (the GLB BIN chunk, or a `data:` URI in glTF JSON).
pub(super) struct Gltf {
    pub doc: Value,
    pub bin: Vec<u8>,
}

/// The binary buffer under construction with its bufferViews and accessors.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, data: &[u8], stride: Option<usize>) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len()});
        if let Some(s) = stride {
            v["byteStride"] = json!(s);
        }
        self.views.push(v);
        self.bytes.extend_from_slice(data);
        self.views.len() - 1
    }

    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// `count` elements of `n` f32 components each, in `[lo, hi]`.
    fn floats(&mut self, r: &mut Rng, count: usize, ty: &str, lo: f32, hi: f32) -> usize {
        let n = components(ty);
        let values: Vec<f32> = (0..count * n).map(|_| r.range(lo, hi)).collect();
        let bytes: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        self.accessor(
            json!({"bufferView": view, "componentType": 5126, "type": ty, "count": count}),
        )
    }

    /// `count` normalized unsigned elements (`component` 5121 or 5123) of type `ty`, padded to
    /// a 4-byte stride as glTF requires of vertex attributes.
    fn normalized(&mut self, r: &mut Rng, count: usize, ty: &str, component: u32) -> usize {
        let size = if component == 5121 { 1 } else { 2 };
        let element = components(ty) * size;
        let stride = element.next_multiple_of(4);
        let mut bytes = vec![0u8; count * stride];
        for e in 0..count {
            for b in 0..element {
                bytes[e * stride + b] = r.below(256) as u8;
            }
        }
        let view = self.view(&bytes, (stride != element).then_some(stride));
        self.accessor(
            json!({"bufferView": view, "componentType": component, "type": ty,
                             "count": count, "normalized": true}),
        )
    }
}

fn components(ty: &str) -> usize {
    match ty {
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        _ => 1,
    }
}

/// A valid glTF 2.0 asset: a node tree (TRS and matrices, a mirroring scale now and then) with
/// 1 to 3 meshes of indexed and non-indexed triangle lists, strips and fans; normals,
/// texcoords and colours in float and normalized forms; strided and sparse accessors;
/// materials with every alpha mode, emission, tiny PNG textures (in a bufferView or a `data:`
/// URI), samplers, KHR_texture_transform and unmodelled extensions; cameras of both kinds.
/// Node 0 is a root with a mesh, so every asset has triangles to frame.
pub(super) fn gltf(r: &mut Rng) -> Gltf {
    let mut bin = Bin::default();
    let mut doc = Map::new();
    doc.insert("asset".into(), json!({"version": "2.0"}));
    if r.chance(0.2) {
        doc["asset"]["copyright"] = json!("fuzz");
    }

    let images: Vec<Value> = (0..r.below(3)).map(|_| image(r, &mut bin)).collect();
    let samplers: Vec<Value> = (0..r.below(3))
        .map(|_| {
            let mut s = Map::new();
            let wraps = [33071, 33648, 10497];
            let ws = json!(r.pick(&wraps));
            maybe(r, &mut s, 0.7, "wrapS", ws);
            let wt = json!(r.pick(&wraps));
            maybe(r, &mut s, 0.7, "wrapT", wt);
            Value::Object(s)
        })
        .collect();
    let textures: Vec<Value> = if images.is_empty() {
        Vec::new()
    } else {
        (0..1 + r.below(2))
            .map(|_| {
                let mut t = Map::new();
                t.insert("source".into(), json!(r.index(images.len())));
                if !samplers.is_empty() && r.chance(0.6) {
                    t.insert("sampler".into(), json!(r.index(samplers.len())));
                }
                Value::Object(t)
            })
            .collect()
    };
    let mut used = Vec::new();
    let materials: Vec<Value> = (0..r.below(4))
        .map(|_| gltf_material(r, textures.len(), &mut used))
        .collect();
    let meshes: Vec<Value> = (0..1 + r.below(3))
        .map(|_| {
            let primitives: Vec<Value> = (0..1 + r.below(3))
                .map(|_| primitive(r, &mut bin, materials.len()))
                .collect();
            json!({"primitives": primitives})
        })
        .collect();
    let cameras: Vec<Value> = (0..r.below(3)).map(|_| camera_gltf(r)).collect();

    // Nodes form a forest: each later node hangs under an earlier one or is a root.
    let count = 1 + r.index(5);
    let mut nodes: Vec<Map<String, Value>> = Vec::new();
    let mut roots = vec![0usize];
    for i in 0..count {
        let mut n = Map::new();
        if i == 0 || r.chance(0.6) {
            n.insert("mesh".into(), json!(r.index(meshes.len())));
        }
        if !cameras.is_empty() && r.chance(0.3) {
            n.insert("camera".into(), json!(r.index(cameras.len())));
        }
        node_transform(r, &mut n);
        if i > 0 {
            if r.chance(0.6) {
                let parent = r.index(i);
                let children = nodes[parent].entry("children").or_insert_with(|| json!([]));
                if let Value::Array(c) = children {
                    c.push(json!(i));
                }
            } else {
                roots.push(i);
            }
        }
        nodes.push(n);
    }
    let nodes: Vec<Value> = nodes.into_iter().map(Value::Object).collect();

    if r.chance(0.9) {
        let mut scenes = vec![json!({"nodes": roots})];
        if r.chance(0.2) {
            scenes.push(json!({"nodes": [0]}));
        }
        doc.insert("scenes".into(), Value::Array(scenes));
        let default = json!(0);
        maybe(r, &mut doc, 0.5, "scene", default);
    }
    doc.insert("nodes".into(), Value::Array(nodes));
    doc.insert("meshes".into(), Value::Array(meshes));
    for (name, list) in [
        ("materials", materials),
        ("textures", textures),
        ("images", images),
        ("samplers", samplers),
        ("cameras", cameras),
    ] {
        if !list.is_empty() {
            doc.insert(name.into(), Value::Array(list));
        }
    }
    if !used.is_empty() {
        used.sort();
        used.dedup();
        doc.insert("extensionsUsed".into(), json!(used));
        if used.contains(&"KHR_texture_transform") && r.chance(0.3) {
            doc.insert(
                "extensionsRequired".into(),
                json!(["KHR_texture_transform"]),
            );
        }
    }
    doc.insert("bufferViews".into(), Value::Array(bin.views));
    doc.insert("accessors".into(), Value::Array(bin.accessors));
    Gltf {
        doc: Value::Object(doc),
        bin: bin.bytes,
    }
}

fn node_transform(r: &mut Rng, n: &mut Map<String, Value>) {
    if r.chance(0.2) {
        // Uniform scale and a translation, column-major.
        let s = round(r.range(0.3, 2.0));
        let t: Vec<f64> = (0..3).map(|_| round(r.range(-2.0, 2.0))).collect();
        n.insert(
            "matrix".into(),
            json!([s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0, t[0], t[1], t[2], 1]),
        );
        return;
    }
    let translation = r.vec(3, -2.0, 2.0);
    maybe(r, n, 0.5, "translation", translation);
    if r.chance(0.5) {
        let q: Vec<f32> = (0..4).map(|_| r.range(-1.0, 1.0)).collect();
        let len = q.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-3);
        // Unit length to glTF's tolerance; rounding the components would break it.
        let q: Vec<f32> = if len > 0.1 {
            q.iter().map(|x| x / len).collect()
        } else {
            vec![0.0, 0.0, 0.0, 1.0]
        };
        n.insert("rotation".into(), json!(q));
    }
    if r.chance(0.4) {
        let mut s: Vec<f64> = (0..3).map(|_| round(r.range(0.3, 2.0))).collect();
        if r.chance(0.2) {
            s[0] = -s[0]; // mirroring
        }
        n.insert("scale".into(), json!(s));
    }
}

fn camera_gltf(r: &mut Rng) -> Value {
    if r.chance(0.6) {
        let mut p = Map::new();
        p.insert("yfov".into(), r.num(0.2, 2.5));
        let near = r.range(0.01, 1.0);
        p.insert("znear".into(), json!(round(near)));
        let far = json!(round(near + r.range(1.0, 100.0)));
        maybe(r, &mut p, 0.6, "zfar", far);
        let aspect = r.num(0.5, 2.0);
        maybe(r, &mut p, 0.3, "aspectRatio", aspect);
        json!({"type": "perspective", "perspective": p})
    } else {
        let near = r.range(0.0, 1.0);
        json!({"type": "orthographic", "orthographic": {
            "xmag": r.num(0.5, 5.0), "ymag": r.num(0.5, 5.0),
            "znear": round(near), "zfar": round(near + r.range(1.0, 100.0))}})
    }
}

/// One material; extensions it uses are added to `used`.
fn gltf_material(r: &mut Rng, textures: usize, used: &mut Vec<&'static str>) -> Value {
    let mut m = Map::new();
    let mut pbr = Map::new();
    let factor = r.vec(4, 0.0, 1.0);
    maybe(r, &mut pbr, 0.6, "baseColorFactor", factor);
    let texture_info = |r: &mut Rng, used: &mut Vec<&'static str>| {
        let mut info = Map::new();
        info.insert("index".into(), json!(r.index(textures)));
        let set = json!(r.below(2));
        maybe(r, &mut info, 0.1, "texCoord", set);
        if r.chance(0.3) {
            used.push("KHR_texture_transform");
            let mut t = Map::new();
            let offset = r.vec(2, -1.0, 1.0);
            maybe(r, &mut t, 0.6, "offset", offset);
            let rotation = r.num(-3.2, 3.2);
            maybe(r, &mut t, 0.6, "rotation", rotation);
            let scale = r.vec(2, 0.1, 2.0);
            maybe(r, &mut t, 0.6, "scale", scale);
            info.insert(
                "extensions".into(),
                json!({"KHR_texture_transform": Value::Object(t)}),
            );
        }
        Value::Object(info)
    };
    if textures > 0 && r.chance(0.6) {
        pbr.insert("baseColorTexture".into(), texture_info(r, used));
    }
    if textures > 0 && r.chance(0.2) {
        m.insert("emissiveTexture".into(), texture_info(r, used));
    }
    if !pbr.is_empty() || r.chance(0.5) {
        m.insert("pbrMetallicRoughness".into(), Value::Object(pbr));
    }
    let mode = json!(r.pick(&["OPAQUE", "MASK", "BLEND"]));
    maybe(r, &mut m, 0.7, "alphaMode", mode);
    let cutoff = r.num(0.0, 1.2);
    maybe(r, &mut m, 0.3, "alphaCutoff", cutoff);
    let double_sided = json!(r.chance(0.5));
    maybe(r, &mut m, 0.4, "doubleSided", double_sided);
    let emissive = r.vec(3, 0.0, 1.0);
    maybe(r, &mut m, 0.3, "emissiveFactor", emissive);
    let mut ext = Map::new();
    if r.chance(0.2) {
        used.push("KHR_materials_emissive_strength");
        ext.insert(
            "KHR_materials_emissive_strength".into(),
            json!({"emissiveStrength": r.num(0.0, 5.0)}),
        );
    }
    if r.chance(0.1) {
        used.push("KHR_materials_transmission");
        ext.insert(
            "KHR_materials_transmission".into(),
            json!({"transmissionFactor": r.num(0.0, 1.0)}),
        );
    }
    if !ext.is_empty() {
        m.insert("extensions".into(), Value::Object(ext));
    }
    let name = json!("m");
    maybe(r, &mut m, 0.2, "name", name);
    Value::Object(m)
}

fn primitive(r: &mut Rng, bin: &mut Bin, materials: usize) -> Value {
    let n = 3 + r.index(10);
    let mut attributes = Map::new();
    attributes.insert("POSITION".into(), json!(positions(r, bin, n)));
    if r.chance(0.4) {
        let normals = bin.floats(r, n, "VEC3", -1.0, 1.0);
        attributes.insert("NORMAL".into(), json!(normals));
    }
    if r.chance(0.5) {
        let uv = match r.below(3) {
            0 => bin.floats(r, n, "VEC2", -2.0, 2.0),
            1 => bin.normalized(r, n, "VEC2", 5121),
            _ => bin.normalized(r, n, "VEC2", 5123),
        };
        attributes.insert("TEXCOORD_0".into(), json!(uv));
    }
    if r.chance(0.4) {
        let color = match r.below(4) {
            0 => bin.floats(r, n, "VEC3", 0.0, 1.0),
            1 => bin.floats(r, n, "VEC4", 0.0, 1.0),
            2 => bin.normalized(r, n, "VEC4", 5121),
            _ => bin.normalized(r, n, "VEC3", 5123),
        };
        attributes.insert("COLOR_0".into(), json!(color));
    }
    let mut p = Map::new();
    p.insert("attributes".into(), Value::Object(attributes));
    let mode = *r.pick(&[4, 4, 4, 5, 6]);
    if mode != 4 || r.chance(0.3) {
        p.insert("mode".into(), json!(mode));
    }
    if r.chance(0.5) {
        let count = if mode == 4 {
            3 * (1 + r.index(5))
        } else {
            3 + r.index(8)
        };
        let component = *r.pick(&[5121u32, 5123, 5125]);
        let size = match component {
            5121 => 1,
            5123 => 2,
            _ => 4,
        };
        let mut bytes = Vec::new();
        for _ in 0..count {
            let i = r.below(n as u64);
            bytes.extend_from_slice(&i.to_le_bytes()[..size]);
        }
        let view = bin.view(&bytes, None);
        let a = bin.accessor(
            json!({"bufferView": view, "componentType": component, "type": "SCALAR", "count": count}),
        );
        p.insert("indices".into(), json!(a));
    }
    if materials > 0 && r.chance(0.7) {
        p.insert("material".into(), json!(r.index(materials)));
    }
    Value::Object(p)
}

/// A POSITION accessor of `n` vertices in [-1, 1]³ with the min and max glTF requires: tightly
/// packed, strided (16 bytes), or sparse (over data or over implicit zeros).
fn positions(r: &mut Rng, bin: &mut Bin, n: usize) -> usize {
    let points: Vec<[f32; 3]> = (0..n).map(|_| [0; 3].map(|_| r.range(-1.0, 1.0))).collect();
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    let mut extend = |p: &[f32; 3]| {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    };
    let form = r.below(10);
    let mut a = json!({"componentType": 5126, "type": "VEC3", "count": n});
    if form == 9 {
        // No bufferView: zeros, with one sparse element set.
        extend(&[0.0; 3]);
    } else {
        let stride = if form >= 7 { 16 } else { 12 };
        let mut bytes = vec![0u8; n * stride];
        for (i, p) in points.iter().enumerate() {
            extend(p);
            for k in 0..3 {
                bytes[i * stride + 4 * k..i * stride + 4 * k + 4]
                    .copy_from_slice(&p[k].to_le_bytes());
            }
        }
        a["bufferView"] = json!(bin.view(&bytes, (stride == 16).then_some(16)));
    }
    if form == 8 || form == 9 {
        let at = r.below(n as u64) as u32;
        let value = points[0];
        extend(&value);
        let indices = bin.view(&at.to_le_bytes(), None);
        let values: Vec<u8> = value.iter().flat_map(|x| x.to_le_bytes()).collect();
        let values = bin.view(&values, None);
        a["sparse"] = json!({"count": 1,
            "indices": {"bufferView": indices, "componentType": 5125},
            "values": {"bufferView": values}});
    }
    a["min"] = json!(lo);
    a["max"] = json!(hi);
    bin.accessor(a)
}

/// A tiny PNG (1 to 3 texels per side, any colour type, 8 or 16 bits) in a bufferView or a
/// `data:` URI.
fn image(r: &mut Rng, bin: &mut Bin) -> Value {
    let (w, h) = (1 + r.below(3) as u32, 1 + r.below(3) as u32);
    let color_type = *r.pick(&[0u8, 2, 4, 6]);
    let depth = *r.pick(&[8u8, 16]);
    let channels = match color_type {
        0 => 1,
        2 => 3,
        4 => 2,
        _ => 4,
    };
    let len = (w * h) as usize * channels * usize::from(depth / 8);
    let samples: Vec<u8> = (0..len).map(|_| r.below(256) as u8).collect();
    let bytes = png(w, h, color_type, depth, &samples);
    if r.chance(0.5) {
        json!({"bufferView": bin.view(&bytes, None), "mimeType": "image/png"})
    } else {
        json!({"uri": format!("data:image/png;base64,{}", base64(&bytes))})
    }
}

/// A valid asset whose only primitive has two vertices: no complete triangle, no draw.
pub(super) fn gltf_without_triangles() -> Gltf {
    let mut bin = Bin::default();
    let points = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0];
    let bytes: Vec<u8> = points.iter().flat_map(|x| x.to_le_bytes()).collect();
    let view = bin.view(&bytes, None);
    let pos = bin.accessor(
        json!({"bufferView": view, "componentType": 5126, "type": "VEC3",
        "count": 2, "min": [0, 0, 0], "max": [1, 0, 0]}),
    );
    let doc = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
        "bufferViews": bin.views,
        "accessors": bin.accessors,
    });
    Gltf {
        doc,
        bin: bin.bytes,
    }
}

/// The document with its buffer as a `data:` URI (glTF JSON).
pub(super) fn gltf_json(g: &Gltf) -> Value {
    let mut doc = g.doc.clone();
    doc["buffers"] = json!([{"byteLength": g.bin.len(),
        "uri": format!("data:application/octet-stream;base64,{}", base64(&g.bin))}]);
    doc
}

/// The document for a GLB, whose buffer 0 is the BIN chunk.
pub(super) fn glb_json(g: &Gltf) -> Value {
    let mut doc = g.doc.clone();
    doc["buffers"] = json!([{"byteLength": g.bin.len()}]);
    doc
}

/// A GLB container: header, JSON chunk (space-padded), BIN chunk.
pub(super) fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut j = json.to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(0u32.to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(&j);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(0x004E_4942u32.to_le_bytes());
    out.extend(bin);
    let len = out.len() as u32;
    out[8..12].copy_from_slice(&len.to_le_bytes());
    out
}

pub(super) fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// A PNG with stored (uncompressed) deflate blocks; `samples` are the rows' raw bytes.
fn png(width: u32, height: u32, color_type: u8, depth: u8, samples: &[u8]) -> Vec<u8> {
    let row = samples.len() / height as usize;
    let mut raw = Vec::new();
    for r in samples.chunks(row) {
        raw.push(0); // filter: none
        raw.extend_from_slice(r);
    }
    let mut z = vec![0x78, 0x01];
    z.push(1);
    z.extend((raw.len() as u16).to_le_bytes());
    z.extend((!(raw.len() as u16)).to_le_bytes());
    z.extend_from_slice(&raw);
    let (mut a, mut b) = (1u32, 0u32);
    for &x in &raw {
        a = (a + u32::from(x)) % 65_521;
        b = (b + a) % 65_521;
    }
    z.extend(((b << 16) | a).to_be_bytes());
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        out.extend((data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        out.extend_from_slice(&body);
        out.extend(crc32(&body).to_be_bytes());
    };
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([depth, color_type, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &z);
    chunk(b"IEND", &[]);
    out
}
