//! Decoding glTF images into the 8-bit codes [`crate::Texture`]s store. Images are decoded one at a time
//! (`gltf::import` fails the whole asset on one undecodable image and gives no index), with the
//! format checked first so an unsupported one is named with its pointer.

use std::path::Path;

use gltf::image::{Data, Format, Source};

use super::source::relative_path;
use super::{Cx, Result};
use crate::error::Problem;
use crate::texture::{MAX_TEXTURE_DIMENSION, linear_to_srgb_code, pack_rgba8};

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

/// How [`codes`] had to approximate an image, for `Scene::ignored`.
pub(super) enum Quantised {
    /// 8-bit codes: stored as they are.
    Exact,
    /// 16-bit codes rounded to the nearest 8-bit code, as engines store them.
    From16Bit,
    /// Float texels (taken as linear) rounded to the nearest 8-bit code: sRGB for colour,
    /// UNORM for alpha; values outside [0, 1] are clamped.
    FromFloat,
}

/// The image's pixels as packed 8-bit RGBA codes ([`crate::texture::pack_rgba8`]), row-major
/// from the top-left. Grey is replicated to rgb; grey+alpha keeps alpha in the second channel;
/// missing alpha is 255. 16-bit codes are rounded to 8 bits (`(c·255 + 32767) / 65535`); float
/// images must be finite and are re-encoded (see [`Quantised`]).
pub(super) fn codes(cx: &Cx, image_index: usize, data: &Data) -> Result<(Vec<u32>, Quantised)> {
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
    let (channels, bytes_per) = layout(data.format);
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
    let mut out = Vec::with_capacity(count);
    for (p, px) in data.pixels.chunks_exact(pixel).enumerate() {
        // Each present channel as an 8-bit code; `colour` says whether it is sRGB-encoded.
        let code = |k: usize, colour: bool| -> Result<u8> {
            let b = &px[k * bytes_per..(k + 1) * bytes_per];
            Ok(match bytes_per {
                1 => b[0],
                2 => {
                    let c = u32::from(u16::from_ne_bytes([b[0], b[1]]));
                    ((c * 255 + 32767) / 65535) as u8
                }
                _ => {
                    let f = f32::from_ne_bytes([b[0], b[1], b[2], b[3]]);
                    if !f.is_finite() {
                        return Err(cx.err(
                            &pointer,
                            Problem::BadValue {
                                what: format!("texel {p} has component"),
                                value: f.to_string(),
                                allowed: "finite float texels".into(),
                            },
                        ));
                    }
                    if colour {
                        linear_to_srgb_code(f64::from(f))
                    } else {
                        (f64::from(f).clamp(0.0, 1.0) * 255.0).round() as u8
                    }
                }
            })
        };
        let texel = match channels {
            1 => {
                let g = code(0, true)?;
                [g, g, g, 255]
            }
            2 => {
                let g = code(0, true)?;
                [g, g, g, code(1, false)?]
            }
            3 => [code(0, true)?, code(1, true)?, code(2, true)?, 255],
            _ => [
                code(0, true)?,
                code(1, true)?,
                code(2, true)?,
                code(3, false)?,
            ],
        };
        out.push(pack_rgba8(texel));
    }
    let quantised = match bytes_per {
        1 => Quantised::Exact,
        2 => Quantised::From16Bit,
        _ => Quantised::FromFloat,
    };
    Ok((out, quantised))
}

/// Channels per pixel and bytes per channel of a decoded glTF image format.
pub(crate) fn layout(format: Format) -> (usize, usize) {
    match format {
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
    }
}
