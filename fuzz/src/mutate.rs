//! Mutations: on the JSON structure (type swaps, boundary numbers, deletions, duplications,
//! unknown fields, objects in serde's positional array form, splices) and on the bytes (flips,
//! truncation, cut and repeated ranges, inserted tokens, a byte order mark, GLB length fields).

use serde_json::{Value, json};

use super::generate::Rng;

/// Values that sit on or past a boundary some check draws, or have a surprising type.
fn nasty(r: &mut Rng) -> Value {
    let numbers = [
        json!(0),
        json!(-0.0),
        json!(-1),
        json!(1),
        json!(2),
        json!(3),
        json!(4),
        json!(5),
        json!(6),
        json!(0.5),
        json!(1.000_000_1),
        json!(1e-45),
        json!(1e-39),
        json!(3.4e38),
        json!(3.5e38),
        json!(-3.5e38),
        json!(1e300),
        json!(255),
        json!(256),
        json!(65_535),
        json!(65_536),
        json!(4_294_967_295u64),
        json!(4_294_967_296u64),
        json!(9_007_199_254_740_993u64),
        json!(u64::MAX),
        json!(i64::MIN),
        json!(180),
        json!(8192),
        json!(8193),
        json!(5121),
        json!(5123),
        json!(5125),
        json!(5126),
        json!(33_648),
    ];
    let strings = [
        "",
        "x",
        "blend",
        "mask-blend",
        "layers",
        "billboards",
        "gltf",
        "directional",
        "OPAQUE",
        "MASK",
        "BLEND",
        "SCALAR",
        "VEC3",
        "MAT4",
        "perspective",
        "orthographic",
        "image/png",
        "image/gif",
        "data:image/png;base64,iVBORw0KGgo=",
        "data:application/octet-stream;base64,AAAA",
        "data:;base64,%%%",
        "../fixture.glb",
        "/etc/hostname",
        "fixture.glb",
        "fixture.gltf",
        "missing.glb",
        "%zz.bin",
        "a\nb",
        "tab\there",
        "\u{0}",
        "ünï",
        "KHR_texture_transform",
        "KHR_materials_emissive_strength",
        "EXT_meshopt_compression",
    ];
    match r.below(4) {
        0 | 1 => r.pick(&numbers).clone(),
        2 => json!(r.pick(&strings)),
        _ => match r.below(9) {
            0 => json!(null),
            1 => json!(true),
            2 => json!([]),
            3 => json!({}),
            4 => json!([0, 0, 0]),
            5 => json!([1e39, 1, 1]),
            6 => json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
            7 => json!({"height": 0}),
            _ => json!({"directional": {"direction": [0, 0, 0]}}),
        },
    }
}

/// JSON pointers to every value in `v`, the root (`""`) included.
fn pointers(v: &Value, at: &mut String, out: &mut Vec<String>) {
    out.push(at.clone());
    let len = at.len();
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                at.push('/');
                at.push_str(&k.replace('~', "~0").replace('/', "~1"));
                pointers(x, at, out);
                at.truncate(len);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                at.push_str(&format!("/{i}"));
                pointers(x, at, out);
                at.truncate(len);
            }
        }
        _ => {}
    }
}

/// The parent pointer and the last token of `pointer` (which must not be the root).
fn split(pointer: &str) -> (&str, String) {
    let cut = pointer.rfind('/').unwrap_or(0);
    let token = pointer[cut + 1..].replace("~1", "/").replace("~0", "~");
    (&pointer[..cut], token)
}

/// Applies one structural mutation to a random value of `doc`.
pub(super) fn structure(r: &mut Rng, doc: &mut Value) {
    let mut all = Vec::new();
    pointers(doc, &mut String::new(), &mut all);
    let pointer = r.pick(&all).clone();
    let op = r.below(9);
    // Deletion needs a parent; everything else works on the value itself.
    if op == 0 && !pointer.is_empty() {
        let (parent, token) = split(&pointer);
        match doc.pointer_mut(parent) {
            Some(Value::Object(m)) => {
                m.remove(&token);
            }
            Some(Value::Array(a)) => {
                if let Ok(i) = token.parse::<usize>()
                    && i < a.len()
                {
                    a.remove(i);
                }
            }
            _ => {}
        }
        return;
    }
    let donor = {
        let other = r.pick(&all).clone();
        doc.pointer(&other).cloned().unwrap_or(Value::Null)
    };
    let extra_key = *r.pick(&[
        "zz",
        "Kind",
        "alpah",
        "material",
        "kind",
        "extensions",
        "extras",
        "count",
        "",
    ]);
    let fresh = nasty(r);
    let Some(target) = doc.pointer_mut(&pointer) else {
        return;
    };
    match op {
        1 => {
            // Duplicate an element of an array (or the value itself into a pair).
            match target {
                Value::Array(a) if !a.is_empty() => {
                    let i = r.index(a.len());
                    let copy = a[i].clone();
                    a.insert(r.index(a.len() + 1), copy);
                }
                other => *other = json!([other.clone(), other.clone()]),
            }
        }
        2 => match target {
            Value::Object(m) => {
                m.insert(extra_key.to_string(), fresh);
            }
            other => *other = fresh,
        },
        3 => {
            // serde's positional form, and the reverse.
            *target = match &*target {
                Value::Object(m) => Value::Array(m.values().cloned().collect()),
                Value::Array(a) => Value::Object(
                    a.iter()
                        .enumerate()
                        .map(|(i, x)| (i.to_string(), x.clone()))
                        .collect(),
                ),
                other => json!([other.clone()]),
            }
        }
        4 => *target = donor,
        5 => {
            *target = match target.as_f64() {
                Some(x) => {
                    let tweaked = match r.below(6) {
                        0 => -x,
                        1 => x * 1e30,
                        2 => x + 1.0,
                        3 => x - 1.0,
                        4 => x * 0.5,
                        _ => x * 1e-30,
                    };
                    serde_json::Number::from_f64(tweaked).map_or(Value::Null, Value::Number)
                }
                None => fresh,
            }
        }
        6 => {
            *target = match &*target {
                Value::Array(a) if a.len() == 1 => a[0].clone(),
                other => json!([other.clone()]),
            }
        }
        _ => *target = fresh,
    }
}

/// Tokens inserted into the text.
const TOKENS: [&str; 16] = [
    "NaN", "Infinity", "-", "1e999", "-1e999", "\"", ",", "{", "}", "[", "]", "null", "\\u0000",
    "\\ud800", "0", "1e-999",
];

/// Bytes a flip writes: JSON's structural characters, digits and a few non-ASCII bytes.
const BYTES: &[u8] = b"{}[],:\"\\0123456789.eE+-ntfau \n\t\x00\x7f\x80\xc3\xff";

/// Applies one mutation to the bytes of a document (for a GLB: to the whole container).
pub(super) fn bytes(r: &mut Rng, b: &mut Vec<u8>) {
    if b.is_empty() {
        b.extend_from_slice(r.pick(&TOKENS).as_bytes());
        return;
    }
    let at = r.index(b.len());
    match r.below(7) {
        0 | 1 => b[at] = *r.pick(BYTES),
        2 => b.truncate(at),
        3 => {
            let end = (at + 1 + r.index(16)).min(b.len());
            b.drain(at..end);
        }
        4 => {
            let end = (at + 1 + r.index(64)).min(b.len());
            let copy = b[at..end].to_vec();
            let to = r.index(b.len() + 1);
            b.splice(to..to, copy);
        }
        5 => {
            let token = r.pick(&TOKENS).as_bytes();
            b.splice(at..at, token.iter().copied());
        }
        _ => {
            b.splice(0..0, *b"\xEF\xBB\xBF");
        }
    }
}

/// Rewrites a length or type field of a GLB container, or flips a byte of its BIN chunk.
pub(super) fn glb(r: &mut Rng, b: &mut [u8]) {
    let json_len = b
        .get(12..16)
        .map_or(0, |x| u32::from_le_bytes([x[0], x[1], x[2], x[3]]) as usize);
    let fields = [4, 8, 12, 16, 20 + json_len, 24 + json_len];
    if r.chance(0.7) {
        let at = *r.pick(&fields);
        let value = *r.pick(&[
            0u32,
            1,
            2,
            4,
            11,
            12,
            13,
            20,
            0x7fff_ffff,
            u32::MAX,
            0x004E_4942,
            0x4E4F_534A,
            b.len() as u32,
            b.len() as u32 + 4,
        ]);
        if let Some(slot) = b.get_mut(at..at + 4) {
            slot.copy_from_slice(&value.to_le_bytes());
        }
    } else {
        let start = (28 + json_len).min(b.len());
        if start < b.len() {
            let at = start + r.index(b.len() - start);
            b[at] = r.below(256) as u8;
        }
    }
}
