//! Files: atomic writes, multi-layer linear EXR, sRGB8 PNG previews.

use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, ImageAttributes, IntegerBounds, Layer,
    LayerAttributes, ReadChannels, ReadLayers, SmallVec, Text, Vec2, WritableImage,
};
use image::ImageEncoder;
use oit_scene::LinearImage;

use crate::MetricsError;
use crate::metrics::check_image;
use crate::tonemap::{Srgb8Image, preview_srgb8};

/// Makes temporary names unique within the process (the pid makes them unique across).
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Removes the temporary file unless the rename happened: error returns and panics alike.
#[derive(Debug)]
struct TempGuard {
    path: PathBuf,
    armed: bool,
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        if self.armed {
            let _ = fs::remove_file(&self.path);
        }
    }
}

fn write_error(path: &Path) -> impl FnOnce(std::io::Error) -> MetricsError + '_ {
    move |source| MetricsError::Write {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `path` atomically: `write` fills a temporary file `.NAME.PID-N.tmp` in the same
/// directory (same file system, so the rename is atomic), which is flushed, synced to disk and
/// renamed over `path`. If `write` fails or panics, or any step fails, the temporary file is
/// removed and `path` is untouched: a reader never sees a truncated file under `path`. (A
/// process killed mid-write can leave only the hidden `.tmp` file behind.)
///
/// The writer is seekable because EXR encoders need to patch offset tables.
pub fn write_atomic<F>(path: &Path, write: F) -> Result<(), MetricsError>
where
    F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
{
    let mut file = AtomicFile::create(path)?;
    write(&mut file.writer).map_err(write_error(path))?;
    file.commit()
}

/// A file written over time and published atomically, as [`write_atomic`] publishes one written
/// at once: the bytes go to a hidden temporary beside `path`, [`AtomicFile::commit`] syncs it and
/// renames it over `path`, and a file dropped without `commit` is removed. For outputs made
/// while a long computation streams (an animation's frames), which must not all be held in
/// memory first.
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    writer: BufWriter<File>,
    guard: TempGuard,
}

impl AtomicFile {
    /// Creates the temporary for `path` (refused when `path` exists and is not a regular file).
    pub fn create(path: &Path) -> Result<AtomicFile, MetricsError> {
        let Some(name) = path.file_name() else {
            return Err(MetricsError::InvalidOutput {
                path: path.to_path_buf(),
                what: "the output path names no file".into(),
            });
        };
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let tmp_name = format!(
            ".{}.{}-{}.tmp",
            name.to_string_lossy(),
            std::process::id(),
            TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
        );
        refuse_non_regular(path)?;
        let tmp = dir.join(tmp_name);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(write_error(path))?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            writer: BufWriter::new(file),
            guard: TempGuard {
                path: tmp,
                armed: true,
            },
        })
    }

    /// Flushes, syncs and renames the temporary over the destination.
    pub fn commit(mut self) -> Result<(), MetricsError> {
        let path = self.path.clone();
        self.writer.flush().map_err(write_error(&path))?;
        self.writer
            .get_ref()
            .sync_all()
            .map_err(write_error(&path))?;
        // Again just before the rename: the target may have been replaced meanwhile.
        refuse_non_regular(&path)?;
        fs::rename(&self.guard.path, &path).map_err(write_error(&path))?;
        self.guard.armed = false;
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.writer.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }
}

/// Only a regular file (or nothing) may be replaced: a rename over `/dev/null`, a FIFO, a socket
/// or a symbolic link would silently turn it into a regular file (or detach the link).
fn refuse_non_regular(path: &Path) -> Result<(), MetricsError> {
    match fs::symlink_metadata(path) {
        Ok(meta) if !meta.file_type().is_file() => Err(MetricsError::InvalidOutput {
            path: path.to_path_buf(),
            what: format!(
                "exists and is {}, not a regular file; refusing to replace it (give a file path)",
                describe_file_type(&meta.file_type())
            ),
        }),
        _ => Ok(()),
    }
}

fn describe_file_type(t: &fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else if t.is_symlink() {
        "a symbolic link"
    } else {
        "not a regular file"
    }
}

/// Removes the temporary files [`write_atomic`] leaves in `dir` when its process was killed
/// mid-write (`.NAME.PID-N.tmp` whose PID is not running, or, where that cannot be checked,
/// older than a day). Returns how many were removed; a directory that cannot be read removes
/// nothing.
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let Ok(entries) = fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = temporary_pid(&name.to_string_lossy()) else {
            continue;
        };
        if pid == std::process::id() || !is_stale(pid, &entry) {
            continue;
        }
        if entry.file_type().is_ok_and(|t| t.is_file()) && fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// The PID in a temporary name `.NAME.PID-N.tmp`.
fn temporary_pid(name: &str) -> Option<u32> {
    let inner = name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (_, tail) = inner.rsplit_once('.')?;
    let (pid, n) = tail.split_once('-')?;
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

fn is_stale(pid: u32, entry: &fs::DirEntry) -> bool {
    let proc_dir = Path::new("/proc");
    if proc_dir.join("self").exists() {
        return !proc_dir.join(pid.to_string()).exists();
    }
    entry
        .metadata()
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age.as_secs() > 24 * 3600)
}

/// [`write_atomic`] of a byte slice.
pub fn write_atomic_bytes(path: &Path, bytes: &[u8]) -> Result<(), MetricsError> {
    write_atomic(path, |w| w.write_all(bytes))
}

/// One extra single-channel f32 image stored beside R, G, B, A in an [`ExrLayer`], e.g. the
/// reference's per-pixel `layers` count (f32 holds counts exactly up to 2²⁴).
#[derive(Debug, Clone, Copy)]
pub struct ExrChannel<'a> {
    pub name: &'a str,
    /// Row-major from the top-left, `width*height` samples.
    pub samples: &'a [f32],
}

/// One layer of an EXR file: linear f32 `R`, `G`, `B`, `A` from `image`, plus `extra` channels.
/// Each layer is one part of the file (OpenEXR 2 multi-part) named `name`; a file with a single
/// layer may leave the name empty and is then a plain single-part RGBA file.
#[derive(Debug, Clone)]
pub struct ExrLayer<'a> {
    pub name: &'a str,
    pub image: &'a LinearImage,
    pub extra: Vec<ExrChannel<'a>>,
}

impl<'a> ExrLayer<'a> {
    /// A layer with R, G, B, A only.
    pub fn new(name: &'a str, image: &'a LinearImage) -> Self {
        Self {
            name,
            image,
            extra: Vec::new(),
        }
    }

    /// Adds one extra single-channel image.
    pub fn with_channel(mut self, name: &'a str, samples: &'a [f32]) -> Self {
        self.extra.push(ExrChannel { name, samples });
        self
    }
}

const RGBA: [&str; 4] = ["R", "G", "B", "A"];

/// EXR names are byte strings; printable ASCII keeps every reader (and Python's str) happy.
fn exr_text(path: &Path, what: &str, name: &str) -> Result<Text, MetricsError> {
    let ok =
        !name.is_empty() && name.len() <= 255 && name.bytes().all(|b| (0x20..0x7f).contains(&b));
    match Text::new_or_none(name) {
        Some(text) if ok => Ok(text),
        _ => Err(MetricsError::InvalidOutput {
            path: path.to_path_buf(),
            what: format!("{what} {name:?} must be 1 to 255 printable ASCII characters"),
        }),
    }
}

fn invalid(path: &Path, what: String) -> MetricsError {
    MetricsError::InvalidOutput {
        path: path.to_path_buf(),
        what,
    }
}

/// Writes a linear f32 EXR (ZIP-compressed scan lines, lossless) with one part per layer, in
/// the given order; every channel round-trips bit for bit. All layers must have the same,
/// non-zero size; with more than one layer every name must be non-empty and unique; extra
/// channel names must be unique within their layer and not R, G, B or A.
pub fn write_exr(path: &Path, layers: &[ExrLayer<'_>]) -> Result<(), MetricsError> {
    let Some(first) = layers.first() else {
        return Err(invalid(path, "an EXR file needs at least one layer".into()));
    };
    let (width, height) = (first.image.width, first.image.height);
    if width == 0 || height == 0 {
        return Err(invalid(
            path,
            format!("layer {:?} is empty ({width}x{height})", first.name),
        ));
    }
    let pixel_count = width as usize * height as usize;
    let size = Vec2(width as usize, height as usize);

    let mut parts = Vec::with_capacity(layers.len());
    let mut seen_layers: Vec<&str> = Vec::new();
    for layer in layers {
        check_image(layer.image, "EXR layer")?;
        if (layer.image.width, layer.image.height) != (width, height) {
            return Err(invalid(
                path,
                format!(
                    "layer {:?} is {}x{} but layer {:?} is {width}x{height}; all layers must match",
                    layer.name, layer.image.width, layer.image.height, first.name
                ),
            ));
        }
        let attributes = if layer.name.is_empty() {
            if layers.len() > 1 {
                return Err(invalid(
                    path,
                    "every layer of a multi-layer EXR needs a name".into(),
                ));
            }
            LayerAttributes::default()
        } else {
            LayerAttributes::named(exr_text(path, "layer name", layer.name)?)
        };
        if seen_layers.contains(&layer.name) {
            return Err(invalid(
                path,
                format!("layer name {:?} is used twice", layer.name),
            ));
        }
        seen_layers.push(layer.name);

        let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
        for (c, name) in RGBA.iter().enumerate() {
            let samples = layer.image.pixels.iter().map(|p| p[c]).collect();
            channels.push(AnyChannel::new(*name, FlatSamples::F32(samples)));
        }
        let mut seen_extra: Vec<&str> = Vec::new();
        for extra in &layer.extra {
            let text = exr_text(path, "channel name", extra.name)?;
            if RGBA.contains(&extra.name) || seen_extra.contains(&extra.name) {
                return Err(invalid(
                    path,
                    format!(
                        "channel {:?} of layer {:?} is used twice (R, G, B, A are taken)",
                        extra.name, layer.name
                    ),
                ));
            }
            seen_extra.push(extra.name);
            if extra.samples.len() != pixel_count {
                return Err(invalid(
                    path,
                    format!(
                        "channel {:?} of layer {:?} has {} samples, the layer has {width}x{height} = {pixel_count} pixels",
                        extra.name,
                        layer.name,
                        extra.samples.len()
                    ),
                ));
            }
            channels.push(AnyChannel::new(
                text,
                FlatSamples::F32(extra.samples.to_vec()),
            ));
        }
        parts.push(Layer::new(
            size,
            attributes,
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels),
        ));
    }

    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions(size)),
        parts,
    );
    write_atomic(path, |w| {
        image.write().to_buffered(w).map_err(std::io::Error::other)
    })
}

/// The decoded layers of an EXR file, every channel converted to f32.
type FlatExr = Image<exr::image::Layers<AnyChannels<FlatSamples>>>;

fn read_flat(path: &Path) -> Result<FlatExr, MetricsError> {
    exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|source| MetricsError::ReadExr {
            path: path.to_path_buf(),
            source,
        })
}

fn layer_name(layer: &Layer<AnyChannels<FlatSamples>>) -> String {
    layer
        .attributes
        .layer_name
        .as_ref()
        .map(ToString::to_string)
        .unwrap_or_default()
}

/// The layer named `name`, or the first one (the file's first part) for `None`.
fn pick_layer<'i>(
    path: &Path,
    image: &'i FlatExr,
    name: Option<&str>,
) -> Result<&'i Layer<AnyChannels<FlatSamples>>, MetricsError> {
    let found = match name {
        None => image.layer_data.first(),
        Some(name) => image.layer_data.iter().find(|l| layer_name(l) == name),
    };
    found.ok_or_else(|| MetricsError::MissingLayer {
        path: path.to_path_buf(),
        layer: name.unwrap_or("<first>").to_string(),
        available: image.layer_data.iter().map(layer_name).collect(),
    })
}

fn channel_f32(layer: &Layer<AnyChannels<FlatSamples>>, name: &str) -> Option<Vec<f32>> {
    layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name == *name)
        .map(|c| c.sample_data.values_as_f32().collect())
}

fn missing_channel(
    path: &Path,
    layer: &Layer<AnyChannels<FlatSamples>>,
    channel: &str,
) -> MetricsError {
    MetricsError::MissingChannel {
        path: path.to_path_buf(),
        layer: layer_name(layer),
        channel: channel.to_string(),
        available: layer
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect(),
    }
}

/// Reads `R`, `G`, `B` (and `A`, 1.0 where absent) of one layer as a linear f32 image: the
/// layer named `layer`, or the file's first part for `None`. f16 and u32 channels convert to
/// f32; f32 channels are returned bit for bit.
pub fn read_exr_rgba(path: &Path, layer: Option<&str>) -> Result<LinearImage, MetricsError> {
    let image = read_flat(path)?;
    let layer = pick_layer(path, &image, layer)?;
    let mut planes = Vec::with_capacity(4);
    for name in &RGBA[..3] {
        planes.push(channel_f32(layer, name).ok_or_else(|| missing_channel(path, layer, name))?);
    }
    let alpha = channel_f32(layer, "A");
    let pixels = (0..planes[0].len())
        .map(|i| {
            [
                planes[0][i],
                planes[1][i],
                planes[2][i],
                alpha.as_ref().map_or(1.0, |a| a[i]),
            ]
        })
        .collect();
    Ok(LinearImage {
        width: layer.size.0 as u32,
        height: layer.size.1 as u32,
        pixels,
    })
}

/// One channel of an EXR layer (as written by [`ExrLayer::with_channel`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelImage {
    pub width: u32,
    pub height: u32,
    /// Row-major from the top-left.
    pub samples: Vec<f32>,
}

/// Reads the channel `channel` of the layer named `layer` (the first part for `None`).
pub fn read_exr_channel(
    path: &Path,
    layer: Option<&str>,
    channel: &str,
) -> Result<ChannelImage, MetricsError> {
    let image = read_flat(path)?;
    let layer = pick_layer(path, &image, layer)?;
    let samples =
        channel_f32(layer, channel).ok_or_else(|| missing_channel(path, layer, channel))?;
    Ok(ChannelImage {
        width: layer.size.0 as u32,
        height: layer.size.1 as u32,
        samples,
    })
}

/// Writes an 8-bit sRGB PNG (RGB, no alpha) atomically.
pub fn write_png_srgb8(path: &Path, image: &Srgb8Image) -> Result<(), MetricsError> {
    let expected = u64::from(image.width) * u64::from(image.height);
    if expected == 0 || image.pixels.len() as u64 != expected {
        return Err(invalid(
            path,
            format!(
                "PNG needs a non-empty image with width*height pixels; got {}x{} with {} pixels",
                image.width,
                image.height,
                image.pixels.len()
            ),
        ));
    }
    let bytes = image.as_bytes();
    write_atomic(path, |w| {
        image::codecs::png::PngEncoder::new(w)
            .write_image(
                &bytes,
                image.width,
                image.height,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(std::io::Error::other)
    })
}

/// Writes the PNG preview of a linear image: the crate's one tone map, the sRGB OETF, 8-bit.
pub fn write_png_preview(path: &Path, image: &LinearImage) -> Result<(), MetricsError> {
    let preview = preview_srgb8(image).map_err(|e| invalid(path, e.to_string()))?;
    write_png_srgb8(path, &preview)
}
