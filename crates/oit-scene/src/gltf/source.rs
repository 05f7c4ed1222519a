//! Reading a glTF asset's bytes: the GLB container (checked here, before the crate sees it, so
//! a malformed header gets a precise message and cannot reach the crate's unchecked length
//! arithmetic), the JSON document (parsed and schema-validated by the `gltf` crate) and the
//! buffers (`data:` URIs, files relative to the asset, the GLB BIN chunk).

use std::path::Path;

use gltf::Document;

use super::{Cx, Result, SUPPORTED_REQUIRED};
use crate::error::{Problem, SceneError};
use crate::serde_errors::{json_expected, json_found};
use crate::strict::Strict;

/// The JSON chunk and the optional BIN chunk of a GLB, or the whole file for glTF JSON.
pub(super) struct Container<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB into its chunks, or passes glTF JSON through. A file is taken as GLB when it
/// starts with the magic `glTF`, or when its name ends in `.glb` (then a wrong magic is an error,
/// not a JSON parse error).
pub(super) fn container<'a>(cx: &Cx, bytes: &'a [u8], is_glb_name: bool) -> Result<Container<'a>> {
    if !bytes.starts_with(GLB_MAGIC) {
        if is_glb_name {
            let head: Vec<String> = bytes.iter().take(4).map(|b| format!("{b:02x}")).collect();
            let message = format!("magic bytes [{}] are not `glTF`", head.join(" "));
            return Err(cx.err("(glb header)", Problem::GlbStructure { message }));
        }
        return Ok(Container {
            json: bytes,
            bin: None,
        });
    }
    let header = |message: String| cx.err("(glb header)", Problem::GlbStructure { message });
    let (Some(version), Some(length)) = (u32_at(bytes, 4), u32_at(bytes, 8)) else {
        return Err(header(format!(
            "file is {} bytes, shorter than the 12-byte header",
            bytes.len()
        )));
    };
    if version != 2 {
        return Err(header(format!("container version {version}, not 2")));
    }
    if length as usize != bytes.len() {
        return Err(header(format!(
            "header length {length} differs from the file size {}",
            bytes.len()
        )));
    }
    let mut chunks: Vec<(u32, &[u8])> = Vec::new();
    let mut at = 12usize;
    while at < bytes.len() {
        let k = chunks.len();
        let chunk = |message: String| {
            cx.err(
                format!("(glb chunk {k})"),
                Problem::GlbStructure { message },
            )
        };
        let (Some(len), Some(kind)) = (u32_at(bytes, at), u32_at(bytes, at + 4)) else {
            return Err(chunk(format!(
                "chunk header at byte {at} is cut off by the end of the file"
            )));
        };
        let start = at + 8;
        let end = start
            .checked_add(len as usize)
            .filter(|&e| e <= bytes.len());
        let Some(end) = end else {
            return Err(chunk(format!(
                "chunk length {len} at byte {at} runs past the end of the file ({} bytes)",
                bytes.len()
            )));
        };
        chunks.push((kind, &bytes[start..end]));
        // Chunks are 4-byte aligned; tolerate a missing final pad.
        at = end.next_multiple_of(4);
    }
    let Some(&(kind, json)) = chunks.first() else {
        return Err(cx.err(
            "(glb chunk 0)",
            Problem::GlbStructure {
                message: "no chunks after the header".into(),
            },
        ));
    };
    if kind != CHUNK_JSON {
        return Err(cx.err(
            "(glb chunk 0)",
            Problem::GlbStructure {
                message: format!("first chunk has type {kind:#010x}, not JSON (0x4e4f534a)"),
            },
        ));
    }
    let bin = match chunks.get(1) {
        Some(&(CHUNK_BIN, data)) => Some(data),
        // Unknown chunk types after the first must be ignored (glTF 2.0, 4.4.3).
        _ => None,
    };
    Ok(Container { json, bin })
}

/// Parses and validates the JSON document. Required extensions are checked before the crate's
/// validation, which rejects some of them with a less specific message.
///
/// Objects of the glTF schema are read from JSON objects only ([`Strict`]), and a value of the
/// wrong type is reported at its JSON pointer. A UTF-8 byte order mark is skipped.
pub(super) fn document(cx: &Cx, json: &[u8]) -> Result<Document> {
    let json = json.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(json);
    let mut de = serde_json::Deserializer::from_slice(json);
    let root: gltf::json::Root = serde_path_to_error::deserialize(Strict(&mut de))
        .map_err(|e| json_error(cx, Some(e.path()), e.inner()))?;
    de.end().map_err(|e| json_error(cx, None, &e))?;
    let unsupported: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !SUPPORTED_REQUIRED.contains(e))
        .collect();
    if !unsupported.is_empty() {
        return Err(cx.err(
            "/extensionsRequired",
            Problem::UnsupportedExtension {
                names: unsupported.join(", "),
                supported: SUPPORTED_REQUIRED.join(", "),
            },
        ));
    }
    // gltf-json's own validation indexes `accessors` with the POSITION index before checking
    // it (mesh.rs, `primitive_validate_hook`), so out-of-range attribute indices are caught here.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for index in prim.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(cx.err(
                        format!("/meshes/{m}/primitives/{p}/attributes"),
                        Problem::GltfInvalid {
                            message: format!(
                                "accessor index {} out of range ({} accessors)",
                                index.value(),
                                root.accessors.len()
                            ),
                        },
                    ));
                }
            }
        }
    }
    // The crate's accessors unwrap these after validation without their being validated.
    let invalid = |path: String, message: &str| {
        cx.err(
            path,
            Problem::GltfInvalid {
                message: message.to_string(),
            },
        )
    };
    for (i, image) in root.images.iter().enumerate() {
        match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => {
                return Err(invalid(
                    format!("/images/{i}"),
                    "neither `uri` nor `bufferView`",
                ));
            }
            (Some(_), Some(_), _) => {
                return Err(invalid(
                    format!("/images/{i}"),
                    "both `uri` and `bufferView`",
                ));
            }
            (None, Some(_), None) => {
                return Err(invalid(
                    format!("/images/{i}/mimeType"),
                    "required value missing (an image in a bufferView needs a mimeType)",
                ));
            }
            _ => {}
        }
    }
    for (i, camera) in root.cameras.iter().enumerate() {
        use gltf::json::camera::Type;
        use gltf::json::validation::Checked;
        let ok = match camera.type_ {
            Checked::Valid(Type::Perspective) => camera.perspective.is_some(),
            Checked::Valid(Type::Orthographic) => camera.orthographic.is_some(),
            Checked::Invalid => true, // reported by the validation below
        };
        if !ok {
            return Err(invalid(
                format!("/cameras/{i}"),
                "the object its `type` names is missing",
            ));
        }
    }
    Document::from_json(root).map_err(|e| match e {
        gltf::Error::Validation(errors) => {
            let count = errors.len();
            let Some((path, kind)) = errors.into_iter().next() else {
                return cx.err(
                    "(root)",
                    Problem::GltfInvalid {
                        message: "validation failed".into(),
                    },
                );
            };
            let (pointer, value) = js_path_to_pointer(path.as_str());
            let mut message = match kind {
                gltf::json::validation::Error::IndexOutOfBounds => "index out of range".to_string(),
                gltf::json::validation::Error::Invalid => "invalid value".to_string(),
                gltf::json::validation::Error::Missing => "required value missing".to_string(),
                gltf::json::validation::Error::Oversize => "value too large".to_string(),
                gltf::json::validation::Error::Unsupported => "unsupported value".to_string(),
            };
            if let Some(v) = value {
                message.push_str(&format!(" ({v})"));
            }
            if count > 1 {
                message.push_str(&format!(" (and {} more problems)", count - 1));
            }
            cx.err(pointer, Problem::GltfInvalid { message })
        }
        other => cx.err(
            "(root)",
            Problem::GltfInvalid {
                message: other.to_string(),
            },
        ),
    })
}

/// A serde_json error as a problem: a value of the wrong type at its JSON pointer, anything
/// else as a syntax error at `(json)` with line and column.
fn json_error(
    cx: &Cx,
    path: Option<&serde_path_to_error::Path>,
    inner: &serde_json::Error,
) -> SceneError {
    let full = inner.to_string();
    let suffix = format!(" at line {} column {}", inner.line(), inner.column());
    let message = full.strip_suffix(&suffix).unwrap_or(&full).to_string();
    let mut pointer = String::new();
    for segment in path.into_iter().flatten() {
        use serde_path_to_error::Segment;
        match segment {
            Segment::Seq { index } => pointer.push_str(&format!("/{index}")),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                pointer.push('/');
                pointer.push_str(&key.replace('~', "~0").replace('/', "~1"));
            }
            Segment::Unknown => {}
        }
    }
    if message == "trailing characters" && !pointer.is_empty() {
        // serde_json's wording when a fixed-size array gets more elements than it holds.
        let problem = Problem::WrongType {
            found: "array has too many elements".into(),
            expected: "exactly the number of elements the glTF schema gives".into(),
        };
        return cx.err(pointer, problem);
    }
    if !inner.is_data() {
        let at = if inner.line() > 0 { "(json)" } else { "(root)" };
        let (line, column) = (inner.line(), inner.column());
        let problem = Problem::Syntax {
            line,
            column,
            message,
        };
        return cx.err(at, problem);
    }
    if let Some(field) = message
        .strip_prefix("missing field `")
        .and_then(|rest| rest.strip_suffix('`'))
    {
        let field = field.to_string();
        return cx.err(
            format!("{pointer}/{field}"),
            Problem::MissingField { field },
        );
    }
    if pointer.is_empty() {
        pointer.push_str("(root)");
    }
    let problem = match message.split_once(", expected ") {
        Some((found, expected)) => {
            // gltf-json's wording for an index (`"mesh": "x"`).
            let expected = if expected.starts_with("index into ") {
                "a non-negative integer index".to_string()
            } else {
                json_expected(expected, &pointer)
            };
            Problem::WrongType {
                found: json_found(found),
                expected,
            }
        }
        None => Problem::GltfInvalid { message },
    };
    cx.err(pointer, problem)
}

/// `materials[0].alphaCutoff` → `/materials/0/alphaCutoff`; `a["k"]` → `/a/k`; a trailing
/// ` = "value"` (the crate's way of naming a bad value) is returned separately.
pub(crate) fn js_path_to_pointer(path: &str) -> (String, Option<String>) {
    let (path, value) = match path.split_once(" = ") {
        Some((p, v)) => (p, Some(v.trim_matches('"').to_string())),
        None => (path, None),
    };
    let mut out = String::new();
    let mut token = String::new();
    let mut chars = path.chars().peekable();
    let flush = |out: &mut String, token: &mut String| {
        if !token.is_empty() {
            out.push('/');
            // RFC 6901 escapes.
            out.push_str(&token.replace('~', "~0").replace('/', "~1"));
            token.clear();
        }
    };
    while let Some(c) = chars.next() {
        match c {
            '.' | '[' | ']' => flush(&mut out, &mut token),
            '"' => {
                // A quoted key: everything up to the closing quote.
                for q in chars.by_ref() {
                    if q == '"' {
                        break;
                    }
                    token.push(q);
                }
            }
            c => token.push(c),
        }
    }
    flush(&mut out, &mut token);
    if out.is_empty() {
        out.push_str("(root)");
    }
    (out, value)
}

/// Reads every buffer: the GLB BIN chunk, `data:` URIs (base64) and files relative to `base`.
pub(super) fn buffers(
    cx: &Cx,
    doc: &Document,
    base: &Path,
    mut bin: Option<&[u8]>,
) -> Result<Vec<gltf::buffer::Data>> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => match bin.take() {
                Some(b) => b.to_vec(),
                None => {
                    return Err(cx.err(
                        format!("/buffers/{i}"),
                        Problem::ExternalData {
                            uri: "(GLB BIN chunk)".into(),
                            message: "the buffer has no uri and the file has no BIN chunk (or another buffer took it)".into(),
                        },
                    ));
                }
            },
            gltf::buffer::Source::Uri(uri) => {
                read_uri(cx, base, uri, &format!("/buffers/{i}/uri"))?
            }
        };
        if data.len() < buffer.length() {
            return Err(cx.err(
                format!("/buffers/{i}/byteLength"),
                Problem::BufferTooShort {
                    expected: buffer.length() as u64,
                    actual: data.len() as u64,
                },
            ));
        }
        out.push(gltf::buffer::Data(data));
    }
    Ok(out)
}

/// The bytes a URI names: a base64 `data:` URI or a percent-encoded path relative to `base`.
pub(super) fn read_uri(cx: &Cx, base: &Path, uri: &str, pointer: &str) -> Result<Vec<u8>> {
    let fail = |message: String| {
        cx.err(
            pointer,
            Problem::ExternalData {
                uri: short(uri),
                message,
            },
        )
    };
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(fail("a data URI without `;base64,`".into()));
        };
        return base64_decode(payload).map_err(fail);
    }
    let relative = relative_path(uri).map_err(fail)?;
    let path = base.join(relative);
    let bytes = std::fs::read(&path).map_err(|e| fail(format!("{} ({e})", path.display())))?;
    cx.note_read(path);
    Ok(bytes)
}

/// A relative URI as a path: percent-decoded, no scheme, not absolute.
pub(super) fn relative_path(uri: &str) -> std::result::Result<String, String> {
    if uri.contains(':') {
        return Err("URI schemes other than `data:` are not read".into());
    }
    let decoded = percent_decode(uri)?;
    if decoded.starts_with('/') {
        return Err("absolute paths are not read".into());
    }
    Ok(decoded)
}

fn percent_decode(s: &str) -> std::result::Result<String, String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        match (bytes[i], bytes.get(i + 1), bytes.get(i + 2)) {
            (b'%', Some(&h), Some(&l)) if hex(h).is_some() && hex(l).is_some() => {
                out.push((hex(h).unwrap_or(0) * 16 + hex(l).unwrap_or(0)) as u8);
                i += 3;
            }
            (b, _, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8(out).map_err(|_| "percent-encoding decodes to invalid UTF-8".to_string())
}

fn base64_decode(s: &str) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for (i, c) in s.trim_end_matches('=').bytes().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return Err(format!("invalid base64 character at position {i}")),
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

/// A URI cut to a readable length for messages (data URIs can be megabytes).
fn short(uri: &str) -> String {
    if uri.chars().count() > 80 {
        let head: String = uri.chars().take(60).collect();
        format!("{head}…")
    } else {
        uri.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn js_paths_become_pointers() {
        assert_eq!(
            js_path_to_pointer("materials[0].alphaCutoff"),
            ("/materials/0/alphaCutoff".to_string(), None)
        );
        assert_eq!(
            js_path_to_pointer("meshes[2].primitives[0].attributes[\"TEXCOORD_0\"]").0,
            "/meshes/2/primitives/0/attributes/TEXCOORD_0"
        );
        assert_eq!(
            js_path_to_pointer("extensionsRequired[0] = \"KHR_x\""),
            (
                "/extensionsRequired/0".to_string(),
                Some("KHR_x".to_string())
            )
        );
    }

    #[test]
    fn base64_and_percent_decoding() {
        assert_eq!(
            base64_decode("AAECAw==").as_deref(),
            Ok(&[0u8, 1, 2, 3][..])
        );
        assert_eq!(base64_decode("aGk").as_deref(), Ok(&b"hi"[..]));
        assert!(base64_decode("a*b").is_err());
        assert_eq!(percent_decode("a%20b.png").as_deref(), Ok("a b.png"));
        assert!(percent_decode("%FF.png").is_err());
        assert_eq!(percent_decode("100%").as_deref(), Ok("100%"));
    }
}
