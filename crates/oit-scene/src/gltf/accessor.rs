//! Bounds-checked accessor reading. The crate's reader slices buffers without checking that an
//! accessor fits its bufferView or the bufferView its buffer (and can panic on malformed
//! input), so every range is checked here, in u64, before a byte is read. Sparse accessors are
//! supported; an accessor without a bufferView reads as zeros (glTF 2.0, 3.6.2.1).

use gltf::accessor::{DataType, Dimensions};

use super::{Cx, Result};
use crate::error::Problem;
use crate::format::MAX_TRIANGLES;

/// Largest element count read from one accessor: three vertices per triangle of the scene cap.
/// Bounds what an accessor without a bufferView (zeros, no bytes behind it) can allocate.
const MAX_ELEMENTS: u64 = 3 * MAX_TRIANGLES;

fn component_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn dims_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

fn type_name(t: DataType, normalized: bool) -> String {
    let base = match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    };
    if normalized {
        format!("normalized {base}")
    } else {
        base.to_string()
    }
}

/// One component as f64: floats as is, normalized integers mapped to [0, 1] or [-1, 1]
/// (glTF 2.0, 3.11), other integers as their value.
fn component(bytes: &[u8], t: DataType, normalized: bool) -> f64 {
    let b = |k: usize| bytes.get(k).copied().unwrap_or(0);
    match t {
        DataType::I8 => {
            let v = f64::from(b(0) as i8);
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        DataType::U8 => {
            let v = f64::from(b(0));
            if normalized { v / 255.0 } else { v }
        }
        DataType::I16 => {
            let v = f64::from(i16::from_le_bytes([b(0), b(1)]));
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = f64::from(u16::from_le_bytes([b(0), b(1)]));
            if normalized { v / 65535.0 } else { v }
        }
        DataType::U32 => f64::from(u32::from_le_bytes([b(0), b(1), b(2), b(3)])),
        DataType::F32 => f64::from(f32::from_le_bytes([b(0), b(1), b(2), b(3)])),
    }
}

/// What an attribute accepts: the dimensions and (component type, normalized) pairs.
pub(super) struct Spec {
    pub dims: &'static [Dimensions],
    pub types: &'static [(DataType, bool)],
    /// For messages, e.g. "VEC3 FLOAT".
    pub allowed: &'static str,
}

/// Reads accessor `a` as `count` elements of up to 4 components each (f64, missing ones 0),
/// after checking its format against `spec` (reported at `pointer`) and every byte range.
pub(super) fn read(
    cx: &Cx,
    buffers: &[gltf::buffer::Data],
    a: &gltf::Accessor,
    spec: &Spec,
    pointer: &str,
) -> Result<Vec<[f64; 4]>> {
    let ap = format!("/accessors/{}", a.index());
    let (t, normalized, dims) = (a.data_type(), a.normalized(), a.dimensions());
    if !spec.dims.contains(&dims) || !spec.types.contains(&(t, normalized)) {
        return Err(cx.err(
            pointer,
            Problem::AccessorFormat {
                found: format!(
                    "accessor {} is {} {}",
                    a.index(),
                    dims_name(dims),
                    type_name(t, normalized)
                ),
                expected: spec.allowed.to_string(),
            },
        ));
    }
    let n = dims.multiplicity();
    let csize = component_size(t);
    let elem = n * csize;
    let count = a.count();
    if count as u64 > MAX_ELEMENTS {
        return Err(cx.err(
            format!("{ap}/count"),
            Problem::AccessorOutOfBounds {
                message: format!("count {count} exceeds {MAX_ELEMENTS} elements"),
            },
        ));
    }
    let mut out = vec![[0.0f64; 4]; count];
    if let Some(view) = a.view() {
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(cx.err(
                format!("/bufferViews/{}/byteStride", view.index()),
                Problem::AccessorOutOfBounds {
                    message: format!("byteStride {stride} is below the element size {elem}"),
                },
            ));
        }
        let bytes = view_bytes(cx, buffers, &view)?;
        let start = a.offset() as u64;
        let needed = if count == 0 {
            start
        } else {
            start + (count as u64 - 1) * stride as u64 + elem as u64
        };
        if needed > bytes.len() as u64 {
            return Err(cx.err(
                &ap,
                Problem::AccessorOutOfBounds {
                    message: format!(
                        "byteOffset {start} + {count} elements of {elem} bytes at stride {stride} need {needed} bytes; bufferView {} has {}",
                        view.index(),
                        bytes.len()
                    ),
                },
            ));
        }
        for (i, slot) in out.iter_mut().enumerate() {
            let at = a.offset() + i * stride;
            for (k, c) in slot.iter_mut().take(n).enumerate() {
                let s = at + k * csize;
                *c = component(bytes.get(s..s + csize).unwrap_or(&[]), t, normalized);
            }
        }
    }
    if let Some(sparse) = a.sparse() {
        let sp = format!("{ap}/sparse");
        let m = sparse.count();
        let idx = sparse.indices();
        let it = match idx.index_type() {
            gltf::accessor::sparse::IndexType::U8 => DataType::U8,
            gltf::accessor::sparse::IndexType::U16 => DataType::U16,
            gltf::accessor::sparse::IndexType::U32 => DataType::U32,
        };
        let isize = component_size(it);
        let ib = view_bytes(cx, buffers, &idx.view())?;
        let vb = view_bytes(cx, buffers, &sparse.values().view())?;
        let inside = |bytes: &[u8], offset: usize, size: usize| {
            (offset as u64).saturating_add((m as u64).saturating_mul(size as u64))
                <= bytes.len() as u64
        };
        if m as u64 > count as u64
            || !inside(ib, idx.offset(), isize)
            || !inside(vb, sparse.values().offset(), elem)
        {
            return Err(cx.err(
                &sp,
                Problem::AccessorOutOfBounds {
                    message: format!(
                        "{m} sparse entries do not fit the accessor ({count} elements) or their bufferViews"
                    ),
                },
            ));
        }
        for j in 0..m {
            let s = idx.offset() + j * isize;
            let target = component(ib.get(s..s + isize).unwrap_or(&[]), it, false) as u64;
            let Some(slot) = out
                .get_mut(target as usize)
                .filter(|_| target < count as u64)
            else {
                return Err(cx.err(
                    format!("{sp}/indices"),
                    Problem::IndexOutOfRange {
                        index: target,
                        count: count as u64,
                    },
                ));
            };
            let at = sparse.values().offset() + j * elem;
            for (k, c) in slot.iter_mut().take(n).enumerate() {
                let s = at + k * csize;
                *c = component(vb.get(s..s + csize).unwrap_or(&[]), t, normalized);
            }
        }
    }
    Ok(out)
}

/// The bytes of a bufferView, checked against its buffer's data.
fn view_bytes<'b>(
    cx: &Cx,
    buffers: &'b [gltf::buffer::Data],
    view: &gltf::buffer::View,
) -> Result<&'b [u8]> {
    let data = buffers
        .get(view.buffer().index())
        .map_or(&[][..], |d| &d.0[..]);
    let end = view.offset().checked_add(view.length());
    match end.and_then(|e| data.get(view.offset()..e)) {
        Some(b) => Ok(b),
        None => Err(cx.err(
            format!("/bufferViews/{}", view.index()),
            Problem::AccessorOutOfBounds {
                message: format!(
                    "byteOffset {} + byteLength {} exceeds buffer {}'s {} bytes",
                    view.offset(),
                    view.length(),
                    view.buffer().index(),
                    data.len()
                ),
            },
        )),
    }
}

use DataType::{F32, I8, I16, U8, U16, U32};
use Dimensions::{Scalar, Vec2, Vec3, Vec4};

pub(super) const POSITION: Spec = Spec {
    dims: &[Vec3],
    types: &[(F32, false)],
    allowed: "VEC3 FLOAT",
};
pub(super) const NORMAL: Spec = Spec {
    dims: &[Vec3],
    types: &[(F32, false)],
    allowed: "VEC3 FLOAT",
};
pub(super) const TEXCOORD: Spec = Spec {
    dims: &[Vec2],
    types: &[(F32, false), (U8, true), (U16, true)],
    allowed: "VEC2 FLOAT, normalized UNSIGNED_BYTE or normalized UNSIGNED_SHORT",
};
pub(super) const COLOR: Spec = Spec {
    dims: &[Vec3, Vec4],
    types: &[(F32, false), (U8, true), (U16, true)],
    allowed: "VEC3 or VEC4 of FLOAT, normalized UNSIGNED_BYTE or normalized UNSIGNED_SHORT",
};
pub(super) const INDICES: Spec = Spec {
    dims: &[Scalar],
    types: &[(U8, false), (U16, false), (U32, false)],
    allowed: "SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, not normalized",
};
pub(super) const TIMES: Spec = Spec {
    dims: &[Scalar],
    types: &[(F32, false)],
    allowed: "SCALAR FLOAT (key times in seconds)",
};
pub(super) const TRANSLATION_SCALE: Spec = Spec {
    dims: &[Vec3],
    types: &[(F32, false)],
    allowed: "VEC3 FLOAT (translation and scale outputs)",
};
pub(super) const ROTATION: Spec = Spec {
    dims: &[Vec4],
    types: &[
        (F32, false),
        (I8, true),
        (U8, true),
        (I16, true),
        (U16, true),
    ],
    allowed: "VEC4 FLOAT, normalized BYTE, UNSIGNED_BYTE, SHORT or UNSIGNED_SHORT (rotation quaternions)",
};
