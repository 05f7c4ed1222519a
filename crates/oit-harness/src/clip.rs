//! What a person watches: a technique's path as an animated PNG that browsers play
//! (`SCENE/TECHNIQUE-motion.png`, APNG; viewers without APNG show the first frame), each frame
//! render | reference | error heat map side by side in the colours of `-diff.png`. Frames are
//! encoded as they arrive (one frame in memory) and the file is published atomically when the
//! path ends; a path that stops early leaves no file.

use std::cell::RefCell;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use oit_metrics::{AtomicFile, Srgb8Image};
use oit_scene::LinearImage;

use crate::{HarnessError, file_stem};

/// Most frames in one clip: longer paths show every k-th frame (k the smallest that fits),
/// each held k times as long, so a clip stays a few MB whatever the path's length.
pub const MAX_CLIP_FRAMES: usize = 240;
/// Panels taller than this are shown at 1/⌈height / this⌉ of their size (nearest pixel).
pub const MAX_PANEL_HEIGHT: u32 = 256;

/// The clip's file name for a technique.
pub fn file_name(canonical: &str, format: oit_results::TargetFormat) -> String {
    format!(
        "{}{}-motion.png",
        file_stem(canonical),
        format.file_suffix()
    )
}

/// Which of a path's `frames` go into the clip: every `step`th, `step` the smallest that keeps
/// the clip within [`MAX_CLIP_FRAMES`].
pub fn step(frames: usize) -> usize {
    frames.div_ceil(MAX_CLIP_FRAMES).max(1)
}

/// The file under the encoder, shared so that it can be committed once the encoder is done
/// (the encoder owns its writer and gives it back to no one).
#[derive(Clone)]
struct Shared(Rc<RefCell<AtomicFile>>);

impl Write for Shared {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.borrow_mut().flush()
    }
}

/// One technique's clip, open while its path streams.
pub struct Clip {
    path: PathBuf,
    file: Shared,
    encoder: png::Writer<Shared>,
    /// Panel size after shrinking, and the shrink factor.
    width: u32,
    height: u32,
    shrink: u32,
    /// Frames announced in the header, and written so far.
    frames: usize,
    written: usize,
}

impl std::fmt::Debug for Clip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Clip")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

fn encoding(path: &Path) -> impl Fn(png::EncodingError) -> HarnessError + '_ {
    move |e| HarnessError::io(path, std::io::Error::other(e.to_string()))
}

impl Clip {
    /// Opens the clip of `canonical` in `scene_dir` for `frames` frames of `width`×`height`
    /// images, each shown for `seconds_per_frame` (rounded to 1/1000 s).
    pub fn create(
        scene_dir: &Path,
        canonical: &str,
        format: oit_results::TargetFormat,
        (width, height): (u32, u32),
        frames: usize,
        seconds_per_frame: f64,
    ) -> Result<Clip, HarnessError> {
        let path = scene_dir.join(file_name(canonical, format));
        let shrink = height.div_ceil(MAX_PANEL_HEIGHT).max(1);
        let (w, h) = ((width / shrink).max(1), (height / shrink).max(1));
        let file = Shared(Rc::new(RefCell::new(AtomicFile::create(&path)?)));
        let mut encoder = png::Encoder::new(file.clone(), 3 * w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let encoder = {
            let fail = encoding(&path);
            encoder.set_animated(frames as u32, 0).map_err(&fail)?;
            let millis = (seconds_per_frame * 1000.0).round().clamp(1.0, 65_535.0) as u16;
            encoder.set_frame_delay(millis, 1000).map_err(&fail)?;
            encoder.write_header().map_err(&fail)?
        };
        Ok(Clip {
            path,
            file,
            encoder,
            width: w,
            height: h,
            shrink,
            frames,
            written: 0,
        })
    }

    /// Appends one frame: `render` | `reference` | their error heat map.
    pub fn push(
        &mut self,
        render: &LinearImage,
        reference: &LinearImage,
    ) -> Result<(), HarnessError> {
        let panels = [
            oit_metrics::preview_srgb8(render)?,
            oit_metrics::preview_srgb8(reference)?,
            oit_metrics::heatmap(render, reference)?,
        ];
        let (w, h, k) = (
            self.width as usize,
            self.height as usize,
            self.shrink as usize,
        );
        let mut rgb = Vec::with_capacity(3 * w * h * 3);
        for y in 0..h {
            for panel in &panels {
                for x in 0..w {
                    rgb.extend_from_slice(&pixel(panel, x * k, y * k));
                }
            }
        }
        self.encoder
            .write_image_data(&rgb)
            .map_err(encoding(&self.path))?;
        self.written += 1;
        Ok(())
    }

    /// Ends the clip and publishes it; an error if fewer frames came than were announced.
    pub fn finish(self) -> Result<PathBuf, HarnessError> {
        let Clip {
            path,
            file,
            encoder,
            frames,
            written,
            ..
        } = self;
        if written != frames {
            // Dropping the file removes its temporary.
            return Err(HarnessError::io(
                &path,
                std::io::Error::other(format!("{written} of the clip's {frames} frames came")),
            ));
        }
        encoder.finish().map_err(encoding(&path))?;
        let file = Rc::try_unwrap(file.0)
            .map_err(|_| {
                HarnessError::io(&path, std::io::Error::other("the clip is still shared"))
            })?
            .into_inner();
        file.commit()?;
        Ok(path)
    }
}

fn pixel(image: &Srgb8Image, x: usize, y: usize) -> [u8; 3] {
    let x = x.min(image.width as usize - 1);
    let y = y.min(image.height as usize - 1);
    image.pixels[y * image.width as usize + x]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: u32, height: u32, value: f32) -> LinearImage {
        LinearImage::new(width, height, [value, value * 0.5, 0.0, 1.0])
    }

    #[test]
    fn a_clip_is_an_animated_png_of_every_frame_side_by_side() {
        let dir = std::env::temp_dir().join(format!("oit-clip-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        let mut clip = Clip::create(
            &dir,
            "stochastic:spp=1",
            Default::default(),
            (20, 10),
            3,
            1.0 / 24.0,
        )
        .expect("clip");
        for t in 0..3 {
            clip.push(&image(20, 10, 0.1 * t as f32), &image(20, 10, 0.2))
                .expect("frame");
        }
        let path = clip.finish().expect("finish");
        let decoder = png::Decoder::new(std::io::BufReader::new(
            std::fs::File::open(&path).expect("file"),
        ));
        let reader = decoder.read_info().expect("png");
        let info = reader.info();
        assert_eq!(
            (info.width, info.height),
            (60, 10),
            "three panels side by side"
        );
        let control = info.animation_control().expect("an animated PNG");
        assert_eq!(control.num_frames, 3);
        let names: Vec<String> = std::fs::read_dir(&dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [file_name("stochastic:spp=1", Default::default())],
            "no temporary left"
        );

        // A path that stops early publishes nothing.
        let mut early =
            Clip::create(&dir, "unsorted", Default::default(), (20, 10), 3, 0.04).expect("clip");
        early
            .push(&image(20, 10, 0.3), &image(20, 10, 0.3))
            .expect("frame");
        assert!(early.finish().is_err(), "two frames short");
        assert!(!dir.join(file_name("unsorted", Default::default())).exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn long_paths_are_subsampled_and_tall_panels_shrunk() {
        assert_eq!(step(48), 1);
        assert_eq!(step(MAX_CLIP_FRAMES), 1);
        assert_eq!(step(MAX_CLIP_FRAMES + 1), 2);
        assert_eq!(step(10_000), 42);
        assert!(10_000usize.div_ceil(step(10_000)) <= MAX_CLIP_FRAMES);
    }
}
