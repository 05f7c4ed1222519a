//! Hand-built glTF assets for tests: binary data with its bufferViews and accessors, glTF
//! JSON with a base64 buffer, GLB containers and uncompressed PNG images.

use serde_json::{Value, json};

pub fn base64(bytes: &[u8]) -> String {
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

/// Binary data plus the bufferViews/accessors that describe it.
#[derive(Default)]
pub struct Data {
    pub bytes: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
}

impl Data {
    /// Appends `bytes` as a new bufferView (e.g. an image); returns the view index.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": bytes.len()}));
        self.bytes.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// Appends `bytes` as a new bufferView and an accessor over it; returns the accessor index.
    pub fn add(
        &mut self,
        bytes: &[u8],
        component: u32,
        ty: &str,
        count: usize,
        normalized: bool,
    ) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": bytes.len()}));
        self.bytes.extend_from_slice(bytes);
        let mut a = json!({"bufferView": self.views.len() - 1, "componentType": component, "type": ty, "count": count});
        if normalized {
            a["normalized"] = json!(true);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }
    pub fn f32s(&mut self, v: &[f32], ty: &str) -> usize {
        let n = match ty {
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 1,
        };
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let a = self.add(&bytes, 5126, ty, v.len() / n, false);
        if ty == "VEC3" {
            // POSITION accessors must carry min and max (glTF 2.0, 3.7.2.1).
            let fold = |f: fn(f32, f32) -> f32, init: f32| -> Vec<f32> {
                (0..3)
                    .map(|k| v.iter().skip(k).step_by(3).fold(init, |m, &x| f(m, x)))
                    .collect()
            };
            self.accessors[a]["min"] = json!(fold(f32::min, f32::INFINITY));
            self.accessors[a]["max"] = json!(fold(f32::max, f32::NEG_INFINITY));
        }
        a
    }
    pub fn u16s(&mut self, v: &[u16], ty: &str, count: usize, normalized: bool) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.add(&bytes, 5123, ty, count, normalized)
    }

    /// A complete glTF JSON document: `doc` plus asset, buffers (as a data URI), views and
    /// accessors.
    pub fn gltf(&self, mut doc: Value) -> String {
        doc["asset"] = json!({"version": "2.0"});
        doc["buffers"] = json!([{"byteLength": self.bytes.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64(&self.bytes))}]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        doc.to_string()
    }
}

/// One triangle in the z = 0 plane, counter-clockwise seen from +Z.
pub const TRI: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

pub fn single_mesh(positions_accessor: usize, extra: Value) -> Value {
    let mut prim = json!({"attributes": {"POSITION": positions_accessor}});
    if let Value::Object(m) = extra {
        for (k, v) in m {
            prim[k] = v;
        }
    }
    json!({"meshes": [{"primitives": [prim]}], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]})
}

pub fn glb(json: &str, bin: Option<&[u8]>) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(0u32.to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(&j);
    if let Some(b) = bin {
        out.extend((b.len() as u32).to_le_bytes());
        out.extend(0x004E_4942u32.to_le_bytes());
        out.extend(b);
    }
    let len = out.len() as u32;
    out[8..12].copy_from_slice(&len.to_le_bytes());
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

/// A PNG of `width`×`height` with colour type `color_type` (0 grey, 2 RGB, 4 grey+alpha,
/// 6 RGBA) and `depth` bits per sample; `samples` are the rows' raw bytes (16-bit samples
/// big-endian, as PNG stores them). Compressed with stored deflate blocks.
pub fn png(width: u32, height: u32, color_type: u8, depth: u8, samples: &[u8]) -> Vec<u8> {
    let row = samples.len() / height as usize;
    let mut raw = Vec::new();
    for r in samples.chunks(row) {
        raw.push(0); // filter: none
        raw.extend_from_slice(r);
    }
    let mut z = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = raw.chunks(65_535).collect();
    for (i, b) in blocks.iter().enumerate() {
        z.push(u8::from(i + 1 == blocks.len()));
        z.extend((b.len() as u16).to_le_bytes());
        z.extend((!(b.len() as u16)).to_le_bytes());
        z.extend_from_slice(b);
    }
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
