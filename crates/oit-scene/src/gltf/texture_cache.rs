//! Decoding each glTF image once and making one texture per (image, sampler, encoding).

use super::*;

/// Decoded images and the textures made from them, so each (image, sampler, encoding) is one
/// texture.
#[derive(Default)]
pub(super) struct TextureCache {
    images: HashMap<usize, gltf::image::Data>,
    textures: HashMap<(usize, Sampler, Encoding), u32>,
}

impl TextureCache {
    /// Image `i` decoded (once per asset).
    pub(super) fn image(&mut self, asset: &Asset, i: usize) -> Result<&gltf::image::Data> {
        match self.images.entry(i) {
            std::collections::hash_map::Entry::Occupied(e) => Ok(e.into_mut()),
            std::collections::hash_map::Entry::Vacant(e) => {
                let Some(img) = asset.doc.images().nth(i) else {
                    return Err(asset.cx.err(
                        format!("/images/{i}"),
                        Problem::NoSuchItem {
                            index: i,
                            count: asset.doc.images().len(),
                        },
                    ));
                };
                let decoded = image::decode(&asset.cx, &img, &asset.base, &asset.buffers)?;
                Ok(e.insert(decoded))
            }
        }
    }

    pub(super) fn get(
        &mut self,
        asset: &Asset,
        key: (usize, Sampler, Encoding),
        scene: &mut Scene,
    ) -> Result<u32> {
        if let Some(&t) = self.textures.get(&key) {
            return Ok(t);
        }
        let (i, sampler, encoding) = key;
        let data = self.image(asset, i)?;
        let used: u64 = (scene.textures.iter())
            .map(|t| u64::from(t.width()) * u64::from(t.height()))
            .sum();
        let total = used + u64::from(data.width) * u64::from(data.height);
        if total > MAX_TEXELS {
            return Err(asset.cx.err(
                format!("/images/{i}"),
                Problem::TooManyTexels { texels: total },
            ));
        }
        let (codes, quantised) = image::codes(&asset.cx, i, data)?;
        let name = format!("{} /images/{i}", asset.name);
        let note = match quantised {
            image::Quantised::Exact => None,
            image::Quantised::From16Bit => {
                Some("16-bit image stored as 8-bit codes (rounded to nearest, as engines store it)")
            }
            image::Quantised::FromFloat => Some(
                "float image stored as 8-bit codes (nearest sRGB code for colour, UNORM for alpha; clamped to [0, 1])",
            ),
        };
        if let Some(note) = note {
            let line = format!("{name}: {note}");
            if !scene.ignored.contains(&line) {
                scene.ignored.push(line);
            }
        }
        let texture = Texture::new(name, data.width, data.height, codes, encoding, sampler)
            .map_err(|message| {
                asset
                    .cx
                    .err(format!("/images/{i}"), Problem::ImageDecode { message })
            })?;
        scene.textures.push(texture);
        let t = scene.textures.len() as u32 - 1;
        self.textures.insert(key, t);
        Ok(t)
    }
}
