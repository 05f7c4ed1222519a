//! Decoding glTF images into linear RGBA f32 [`Texture`]s. Images are decoded one at a time
//! (`gltf::import` fails the whole asset on one undecodable image and gives no index), with the
//! format checked first so an unsupported one is named with its pointer.

use std::path::Path;

use gltf::image::{Data, Format, Source};

use super::source::relative_path;
use super::{Cx, Result};
use crate::error::Problem;
use crate::texture::{MAX_TEXTURE_DIMENSION, srgb_to_linear};

/// Decodes image `image` of the document. Only PNG and JPEG are accepted (what the crate's
/// `image` dependency is built with); the mime type or file extension decides, as in glTF.
pub(super) fn decode(
    cx: &Cx,
    image: &gltf::Image,
    base: &Path,
    buffers: &[gltf::buffer::Data],
) -> Result<Data> {
    let i = image.index();
    let source = image.source();
    let unsupported = |pointer: String, found: &str| {
        cx.err(
            pointer,
            Problem::UnsupportedImage {
                found: format!("`{found}`"),
            },
        )
    };
    match source {
        Source::View { view, mime_type } => {
            if !matches!(mime_type, "image/png" | "image/jpeg") {
                return Err(unsupported(format!("/images/{i}/mimeType"), mime_type));
            }
            // The crate slices the buffer with these bounds unchecked.
            let data_len = buffers.get(view.buffer().index()).map_or(0, |b| b.0.len());
            let end = view.offset().checked_add(view.length());
            if end.is_none_or(|e| e > data_len) {
                return Err(cx.err(
                    format!("/bufferViews/{}", view.index()),
                    Problem::AccessorOutOfBounds {
                        message: format!(
                            "bufferView bytes {}..{} exceed its buffer's {data_len} bytes",
                            view.offset(),
                            end.map_or("overflow".to_string(), |e| e.to_string()),
                        ),
                    },
                ));
            }
        }
        Source::Uri { uri, mime_type } => {
            let pointer = format!("/images/{i}/uri");
            if let Some(m) = mime_type
                && !matches!(m, "image/png" | "image/jpeg")
            {
                return Err(unsupported(format!("/images/{i}/mimeType"), m));
            }
            if let Some(rest) = uri.strip_prefix("data:") {
                let media = rest.split([';', ',']).next().unwrap_or("");
                if !matches!(media, "image/png" | "image/jpeg") {
                    return Err(unsupported(pointer, &format!("data:{media}")));
                }
            } else {
                let path = relative_path(uri).map_err(|message| {
                    cx.err(
                        &pointer,
                        Problem::ExternalData {
                            uri: uri.to_string(),
                            message,
                        },
                    )
                })?;
                let ext = path.rsplit('.').next().unwrap_or("");
                if mime_type.is_none() && !matches!(ext, "png" | "jpg" | "jpeg") {
                    return Err(unsupported(
                        pointer,
                        &format!(".{ext} file without mimeType"),
                    ));
                }
                // Noted before decoding: a file that fails to decode was still an input.
                cx.note_read(base.join(&path));
            }
        }
    }
    Data::from_source(image.source(), Some(base), buffers).map_err(|e| {
        let pointer = match image.source() {
            Source::View { view, .. } => format!("/bufferViews/{}", view.index()),
            Source::Uri { .. } => format!("/images/{i}/uri"),
        };
        match e {
            gltf::Error::Io(io) => cx.err(
                pointer,
                Problem::ExternalData {
                    uri: match image.source() {
                        Source::Uri { uri, .. } => uri.chars().take(80).collect(),
                        Source::View { .. } => String::new(),
                    },
                    message: io.to_string(),
                },
            ),
            gltf::Error::UnsupportedImageEncoding | gltf::Error::UnsupportedScheme => cx.err(
                pointer,
                Problem::UnsupportedImage {
                    found: "unknown".into(),
                },
            ),
            other => cx.err(
                format!("/images/{i}"),
                Problem::ImageDecode {
                    message: other.to_string(),
                },
            ),
        }
    })
}

/// Decoded pixels as linear RGBA f32, row-major from the top-left. Colour channels of 8- and
/// 16-bit images are sRGB-decoded from their exact code value (c/255 or c/65535, in f64);
/// alpha is linear. Grey is replicated to rgb; grey+alpha keeps alpha in the second channel;
/// missing alpha is 1. Float images are taken as linear and must be finite.
pub(super) fn texels(cx: &Cx, image_index: usize, data: &Data) -> Result<Vec<[f32; 4]>> {
    let pointer = format!("/images/{image_index}");
    let (w, h) = (data.width, data.height);
    if w == 0 || h == 0 || w > MAX_TEXTURE_DIMENSION || h > MAX_TEXTURE_DIMENSION {
        return Err(cx.err(
            pointer,
            Problem::TextureTooLarge {
                width: w,
                height: h,
            },
        ));
    }
    let (channels, bytes_per) = match data.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let pixel = channels * bytes_per;
    let count = w as usize * h as usize;
    if data.pixels.len() != count * pixel {
        return Err(cx.err(
            pointer,
            Problem::ImageDecode {
                message: format!(
                    "{} bytes of pixels for {w}x{h} {:?}",
                    data.pixels.len(),
                    data.format
                ),
            },
        ));
    }
    // 8-bit codes are decoded through a table (same f64 arithmetic, once per code).
    let srgb8: Vec<f32> = (0..256).map(|c| srgb_to_linear(c as f64 / 255.0)).collect();
    let mut out = Vec::with_capacity(count);
    for (p, px) in data.pixels.chunks_exact(pixel).enumerate() {
        let raw: [f64; 4] = std::array::from_fn(|k| {
            if k >= channels {
                return 1.0;
            }
            let b = &px[k * bytes_per..(k + 1) * bytes_per];
            match bytes_per {
                1 => f64::from(b[0]),
                2 => f64::from(u16::from_ne_bytes([b[0], b[1]])),
                _ => f64::from(f32::from_ne_bytes([b[0], b[1], b[2], b[3]])),
            }
        });
        let texel = match (bytes_per, channels) {
            (4, _) => {
                let t = raw.map(|c| c as f32);
                if let Some(c) = t.iter().find(|c| !c.is_finite()) {
                    return Err(cx.err(
                        &pointer,
                        Problem::BadValue {
                            what: format!("texel {p} has component"),
                            value: c.to_string(),
                            allowed: "finite float texels".into(),
                        },
                    ));
                }
                t
            }
            (1, _) => {
                let colour = |c: f64| srgb8[c as usize & 0xff];
                let grey = channels <= 2;
                let (r, g, b) = if grey {
                    (raw[0], raw[0], raw[0])
                } else {
                    (raw[0], raw[1], raw[2])
                };
                let a = match channels {
                    2 => raw[1] / 255.0,
                    4 => raw[3] / 255.0,
                    _ => 1.0,
                };
                [colour(r), colour(g), colour(b), a as f32]
            }
            _ => {
                let colour = |c: f64| srgb_to_linear(c / 65535.0);
                let (r, g, b) = if channels <= 2 {
                    (raw[0], raw[0], raw[0])
                } else {
                    (raw[0], raw[1], raw[2])
                };
                let a = match channels {
                    2 => raw[1] / 65535.0,
                    4 => raw[3] / 65535.0,
                    _ => 1.0,
                };
                [colour(r), colour(g), colour(b), a as f32]
            }
        };
        out.push(texel);
    }
    Ok(out)
}
