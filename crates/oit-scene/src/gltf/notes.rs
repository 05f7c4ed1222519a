//! What a glTF material loses on the way to a [`crate::Material`], said in `Scene::ignored`:
//! one line per property and explanation, naming the file and every material it applies to,
//! so an asset of fifty materials with normal maps gets one line, not fifty.

use gltf::image::Data;

use crate::Scene;

/// Material-property lines collected while an asset's materials are converted.
#[derive(Debug, Default)]
pub(crate) struct MaterialNotes {
    /// (property, explanation, materials), in the order first seen.
    lines: Vec<(String, String, Vec<String>)>,
}

impl MaterialNotes {
    /// Records that `property` of `material` (its pointer and name) is not modelled or is
    /// approximated, as `explanation` says.
    pub(crate) fn add(
        &mut self,
        property: impl Into<String>,
        material: &str,
        explanation: impl Into<String>,
    ) {
        let (property, explanation) = (property.into(), explanation.into());
        match (self.lines.iter_mut()).find(|(p, e, _)| *p == property && *e == explanation) {
            Some((_, _, materials)) => {
                if !materials.iter().any(|m| m == material) {
                    materials.push(material.to_owned());
                }
            }
            None => self
                .lines
                .push((property, explanation, vec![material.to_owned()])),
        }
    }

    /// Appends the lines to `scene.ignored`: `<file>: <property> on <materials>: <explanation>`.
    pub(crate) fn finish(self, file: &str, scene: &mut Scene) {
        for (property, explanation, materials) in self.lines {
            scene.ignored.push(format!(
                "{file}: {property} on {}: {explanation}",
                materials.join(", ")
            ));
        }
    }
}

/// The blue channel (glTF's metalness) of a metallic-roughness image, as linear values in
/// [0, 1] from the stored code (8-bit c/255, 16-bit c/65535, float as is): (min, max, mean).
/// Grey images carry metalness in their one colour channel. `None` when the pixel data does
/// not match the format or a value is outside [0, 1] (a float image).
pub(crate) fn blue_channel_stats(data: &Data) -> Option<(f64, f64, f64)> {
    let (channels, bytes) = super::image::layout(data.format);
    let channel = if channels <= 2 { 0 } else { 2 };
    let pixel = channels * bytes;
    let count = data.width as usize * data.height as usize;
    if count == 0 || data.pixels.len() != count * pixel {
        return None;
    }
    let (mut lo, mut hi, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
    for px in data.pixels.chunks_exact(pixel) {
        let b = &px[channel * bytes..(channel + 1) * bytes];
        let v = match bytes {
            1 => f64::from(b[0]) / 255.0,
            2 => f64::from(u16::from_ne_bytes([b[0], b[1]])) / 65535.0,
            _ => f64::from(f32::from_ne_bytes([b[0], b[1], b[2], b[3]])),
        };
        if !(0.0..=1.0).contains(&v) {
            return None;
        }
        lo = lo.min(v);
        hi = hi.max(v);
        sum += v;
    }
    Some((lo, hi, sum / count as f64))
}

/// Notes the textures the loader does not sample: the shading has no per-texel metalness or
/// roughness and no normal perturbation (docs/scene-format.md, glTF 2.0).
/// `metallic_texture_read`: the metallic-roughness texture was read for transmission's
/// metalness.
pub(crate) fn unread_properties(
    m: &gltf::Material,
    label: &str,
    metallic_texture_read: bool,
    notes: &mut MaterialNotes,
) {
    if m.pbr_metallic_roughness()
        .metallic_roughness_texture()
        .is_some()
    {
        let why = if metallic_texture_read {
            "roughness and per-texel metalness not modelled (its mean metalness sets τ)"
        } else {
            "not modelled (metallicFactor and roughnessFactor light the material alone)"
        };
        notes.add("metallicRoughnessTexture", label, why);
    }
    if m.normal_texture().is_some() {
        notes.add(
            "normalTexture",
            label,
            "not modelled (geometric or vertex normals only)",
        );
    }
    if m.occlusion_texture().is_some() {
        notes.add("occlusionTexture", label, "not modelled");
    }
}
