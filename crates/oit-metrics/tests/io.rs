//! EXR, PNG and atomic writes, read back with independent decoders (the `exr` and `image`
//! crates directly), so a bug in our own readers cannot hide a bug in our writers.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use exr::prelude::{ReadChannels, ReadLayers};
use oit_metrics::{
    AtomicFile, ExrLayer, LinearImage, MetricsError, heatmap, preview_srgb8, read_exr_channel,
    read_exr_rgba, write_atomic, write_atomic_bytes, write_exr, write_png_preview, write_png_srgb8,
};

/// A fresh, empty directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("oit-metrics")
        .join(name);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

/// Values that stress a bit-exact round trip: NaN with a payload, ±0, ±∞, subnormals, HDR.
fn awkward(width: u32, height: u32, seed: u32) -> LinearImage {
    let specials = [
        f32::from_bits(0x7fc0_1234),
        -0.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::from_bits(1),
        f32::MIN_POSITIVE,
        65504.0,
        1.0e30,
    ];
    let mut image = LinearImage::new(width, height, [0.0; 4]);
    let mut state = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
    for (i, p) in image.pixels.iter_mut().enumerate() {
        for (c, v) in p.iter_mut().enumerate() {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            *v = if (i + c) % 97 == 0 {
                specials[(i / 97 + c) % specials.len()]
            } else {
                (state >> 8) as f32 / (1u32 << 20) as f32 - 2.0
            };
        }
    }
    image
}

fn bits(image: &LinearImage) -> Vec<[u32; 4]> {
    image.pixels.iter().map(|p| p.map(f32::to_bits)).collect()
}

type Layers = Vec<(Option<String>, (usize, usize), Vec<(String, Vec<u32>)>)>;

/// Decodes an EXR with the `exr` crate alone: per layer, its name, size and channels as bits.
fn decode_with_exr_crate(path: &Path) -> Layers {
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .unwrap();
    image
        .layer_data
        .iter()
        .map(|layer| {
            let channels = layer
                .channel_data
                .list
                .iter()
                .map(|c| {
                    let exr::prelude::FlatSamples::F32(v) = &c.sample_data else {
                        panic!("channel {} is not f32", c.name);
                    };
                    (c.name.to_string(), v.iter().map(|x| x.to_bits()).collect())
                })
                .collect();
            (
                layer
                    .attributes
                    .layer_name
                    .as_ref()
                    .map(ToString::to_string),
                (layer.size.0, layer.size.1),
                channels,
            )
        })
        .collect()
}

fn plane(image: &LinearImage, c: usize) -> Vec<u32> {
    image.pixels.iter().map(|p| p[c].to_bits()).collect()
}

#[test]
fn exr_layers_round_trip_bit_exact() {
    let dir = scratch("exr_layers");
    let path = dir.join("run.exr");
    let (w, h) = (37, 23);
    let render = awkward(w, h, 1);
    let reference = awkward(w, h, 2);
    let diff = awkward(w, h, 3);
    let counts: Vec<f32> = (0..w * h).map(|i| (i % 70) as f32).collect();
    let layers = [
        ExrLayer::new("render", &render),
        ExrLayer::new("reference", &reference).with_channel("layers", &counts),
        ExrLayer::new("diff", &diff),
    ];
    write_exr(&path, &layers).unwrap();
    assert_eq!(entries(&dir), ["run.exr"], "no temporary file may remain");

    let decoded = decode_with_exr_crate(&path);
    let names: Vec<Option<String>> = decoded.iter().map(|l| l.0.clone()).collect();
    assert_eq!(
        names,
        [
            Some("render".to_string()),
            Some("reference".into()),
            Some("diff".into())
        ],
        "parts keep their order"
    );
    for ((_, size, channels), image, extra) in [
        (&decoded[0], &render, None),
        (&decoded[1], &reference, Some(&counts)),
        (&decoded[2], &diff, None),
    ]
    .map(|(d, i, e)| (d.clone(), i, e))
    {
        assert_eq!(size, (w as usize, h as usize));
        let find = |name: &str| {
            channels
                .iter()
                .find(|(n, _)| n == name)
                .unwrap_or_else(|| panic!("no {name}"))
                .1
                .clone()
        };
        for (c, name) in ["R", "G", "B", "A"].iter().enumerate() {
            assert_eq!(find(name), plane(image, c), "channel {name}");
        }
        match extra {
            Some(counts) => {
                assert_eq!(channels.len(), 5);
                assert_eq!(
                    find("layers"),
                    counts.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                );
            }
            None => assert_eq!(channels.len(), 4),
        }
    }

    // Our own readers agree, bit for bit.
    assert_eq!(bits(&read_exr_rgba(&path, None).unwrap()), bits(&render));
    assert_eq!(
        bits(&read_exr_rgba(&path, Some("diff")).unwrap()),
        bits(&diff)
    );
    let layer_counts = read_exr_channel(&path, Some("reference"), "layers").unwrap();
    assert_eq!((layer_counts.width, layer_counts.height), (w, h));
    assert_eq!(layer_counts.samples, counts);

    match read_exr_rgba(&path, Some("nope")).unwrap_err() {
        MetricsError::MissingLayer {
            path: p,
            layer,
            available,
        } => {
            assert_eq!((p, layer.as_str()), (path.clone(), "nope"));
            assert_eq!(available, ["render", "reference", "diff"]);
        }
        other => panic!("expected MissingLayer, got {other}"),
    }
    let err = read_exr_channel(&path, Some("render"), "layers").unwrap_err();
    assert!(matches!(err, MetricsError::MissingChannel { .. }), "{err}");
    assert!(err.to_string().contains("run.exr"), "{err}");
}

#[test]
fn single_unnamed_layer_is_a_plain_rgba_file() {
    let dir = scratch("exr_single");
    let path = dir.join("reference.exr");
    let image = awkward(16, 9, 7);
    let counts: Vec<f32> = (0..16 * 9).map(|i| i as f32).collect();
    write_exr(
        &path,
        &[ExrLayer::new("", &image).with_channel("layers", &counts)],
    )
    .unwrap();
    let decoded = decode_with_exr_crate(&path);
    assert_eq!(decoded.len(), 1);
    assert_eq!(decoded[0].0, None);
    let names: Vec<&str> = decoded[0].2.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["A", "B", "G", "R", "layers"]);
    assert_eq!(bits(&read_exr_rgba(&path, None).unwrap()), bits(&image));
    assert_eq!(
        read_exr_channel(&path, None, "layers").unwrap().samples,
        counts
    );
}

#[test]
fn bad_exr_requests_are_errors_and_leave_nothing() {
    let dir = scratch("exr_bad");
    let path = dir.join("bad.exr");
    let a = awkward(4, 4, 1);
    let b = awkward(4, 5, 2);
    let short = [0.0f32; 15];
    let cases: Vec<(&str, Vec<ExrLayer<'_>>)> = vec![
        ("at least one layer", vec![]),
        (
            "needs a name",
            vec![ExrLayer::new("", &a), ExrLayer::new("x", &a)],
        ),
        (
            "used twice",
            vec![ExrLayer::new("x", &a), ExrLayer::new("x", &a)],
        ),
        (
            "all layers must match",
            vec![ExrLayer::new("x", &a), ExrLayer::new("y", &b)],
        ),
        (
            "has 15 samples",
            vec![ExrLayer::new("x", &a).with_channel("layers", &short)],
        ),
        (
            "R, G, B, A are taken",
            vec![ExrLayer::new("x", &a).with_channel("G", &short)],
        ),
        ("printable ASCII", vec![ExrLayer::new("r\u{e9}nder", &a)]),
    ];
    for (needle, layers) in cases {
        let err = write_exr(&path, &layers).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains(needle) && text.contains("bad.exr"),
            "{needle}: {text}"
        );
    }
    assert!(entries(&dir).is_empty());
    let err = read_exr_rgba(&dir.join("missing.exr"), None).unwrap_err();
    assert!(err.to_string().contains("missing.exr"), "{err}");
}

#[test]
fn png_preview_has_the_image_size_and_the_tone_mapped_values() {
    let dir = scratch("png");
    let path = dir.join("render.png");
    let image = awkward(37, 19, 5);
    write_png_preview(&path, &image).unwrap();
    let decoded = image::load_from_memory(&fs::read(&path).unwrap()).unwrap();
    assert_eq!((decoded.width(), decoded.height()), (37, 19));
    assert_eq!(decoded.color(), image::ColorType::Rgb8);
    assert_eq!(
        decoded.into_rgb8().into_raw(),
        preview_srgb8(&image).unwrap().as_bytes()
    );

    let heat = heatmap(&image, &awkward(37, 19, 6)).unwrap();
    let heat_path = dir.join("diff.png");
    write_png_srgb8(&heat_path, &heat).unwrap();
    let decoded = image::load_from_memory(&fs::read(&heat_path).unwrap()).unwrap();
    assert_eq!(decoded.into_rgb8().into_raw(), heat.as_bytes());
    assert_eq!(entries(&dir), ["diff.png", "render.png"]);

    let empty = LinearImage::new(0, 3, [0.0; 4]);
    let err = write_png_preview(&dir.join("empty.png"), &empty).unwrap_err();
    assert!(err.to_string().contains("empty.png"), "{err}");
    assert_eq!(entries(&dir), ["diff.png", "render.png"]);
}

#[test]
fn failing_writer_leaves_no_file_and_no_temporary() {
    let dir = scratch("atomic_fail");
    let path = dir.join("out.bin");
    let err = write_atomic(&path, |w| {
        w.write_all(&[7u8; 100_000])?;
        Err(std::io::Error::other("disk on fire"))
    })
    .unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("out.bin") && text.contains("disk on fire"),
        "{text}"
    );
    assert!(entries(&dir).is_empty(), "left behind: {:?}", entries(&dir));
}

#[test]
fn failing_writer_keeps_the_previous_file_intact() {
    let dir = scratch("atomic_keep");
    let path = dir.join("results.json");
    write_atomic_bytes(&path, b"old complete contents").unwrap();
    let result = write_atomic(&path, |w| {
        w.write_all(b"new but trunc")?;
        Err(std::io::Error::other("interrupted"))
    });
    assert!(result.is_err());
    assert_eq!(fs::read(&path).unwrap(), b"old complete contents");
    assert_eq!(entries(&dir), ["results.json"]);
    write_atomic_bytes(&path, b"new").unwrap();
    assert_eq!(fs::read(&path).unwrap(), b"new");
    assert_eq!(entries(&dir), ["results.json"]);
}

#[test]
fn panicking_writer_leaves_no_temporary() {
    let dir = scratch("atomic_panic");
    let path = dir.join("out.bin");
    let caught = std::panic::catch_unwind(|| {
        let _ = write_atomic(&path, |w| {
            w.write_all(b"partial")?;
            panic!("writer bug");
        });
    });
    assert!(caught.is_err());
    assert!(entries(&dir).is_empty(), "left behind: {:?}", entries(&dir));
}

#[test]
fn unwritable_targets_are_errors_naming_the_path() {
    let dir = scratch("atomic_bad_target");
    // The target is a directory: the rename fails and the temporary goes away.
    let sub = dir.join("taken");
    fs::create_dir(&sub).unwrap();
    let err = write_atomic_bytes(&sub, b"x").unwrap_err();
    assert!(err.to_string().contains("taken"), "{err}");
    assert_eq!(entries(&dir), ["taken"]);
    // The directory does not exist.
    let err = write_atomic_bytes(&dir.join("no/such/dir/f.png"), b"x").unwrap_err();
    assert!(err.to_string().contains("f.png"), "{err}");
}

/// A FIFO, a symbolic link or a directory at the target is refused before anything is written:
/// a rename would turn it into a regular file (as `-o /dev/null` once did to the device node).
#[cfg(unix)]
#[test]
fn only_a_regular_file_is_ever_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let dir = scratch("atomic_non_regular");
    let fifo = dir.join("pipe.exr");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo runs");
    assert!(made.success());
    let err = write_atomic_bytes(&fifo, b"x").unwrap_err().to_string();
    assert!(err.contains("pipe.exr") && err.contains("a FIFO"), "{err}");
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());

    let target = dir.join("target.bin");
    write_atomic_bytes(&target, b"kept").unwrap();
    let link = dir.join("link.bin");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let err = write_atomic_bytes(&link, b"new").unwrap_err().to_string();
    assert!(err.contains("symbolic link"), "{err}");
    assert!(
        fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(fs::read(&target).unwrap(), b"kept");
    assert_eq!(entries(&dir), ["link.bin", "pipe.exr", "target.bin"]);
}

/// The `.tmp` a killed writer leaves is removed by the next run; a live writer's is kept.
#[test]
fn stale_temporaries_of_dead_writers_are_removed() {
    let dir = scratch("atomic_stale");
    // PIDs stop at 2^22 on Linux: 999999999 never runs.
    fs::write(dir.join(".ref.oitref.999999999-3.tmp"), b"partial").unwrap();
    let live = format!(".ref.oitref.{}-7.tmp", std::process::id());
    fs::write(dir.join(&live), b"in progress").unwrap();
    fs::write(dir.join("ref.oitref"), b"complete").unwrap();
    fs::write(dir.join(".hidden.tmp"), b"not ours").unwrap();
    assert_eq!(oit_metrics::remove_stale_temporaries(&dir), 1);
    assert_eq!(entries(&dir), [".hidden.tmp", live.as_str(), "ref.oitref"]);
}

/// A reader racing the writer only ever sees a complete file at the target: the old contents
/// or the new, never a prefix (a "write in place" or "copy instead of rename" would fail this).
#[test]
fn a_racing_reader_never_sees_a_partial_file() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let dir = scratch("atomic_race");
    let path = dir.join("results.json");
    let versions: Vec<Vec<u8>> = (0..8u8)
        .map(|v| vec![b'a' + v; 256 * 1024 + usize::from(v) * 4099])
        .collect();
    write_atomic_bytes(&path, &versions[0]).unwrap();
    let done = AtomicBool::new(false);
    let reads = std::thread::scope(|s| {
        let reader = s.spawn(|| {
            let mut reads = 0u32;
            while !done.load(Ordering::Relaxed) || reads < 50 {
                let bytes = fs::read(&path).expect("the target always exists");
                let complete = versions.contains(&bytes);
                assert!(complete, "partial file: {} bytes", bytes.len());
                reads += 1;
            }
            reads
        });
        for round in 0..40 {
            let v = &versions[round % versions.len()];
            write_atomic(&path, |w| {
                // In pieces, so a non-atomic writer would expose prefixes.
                for chunk in v.chunks(8192) {
                    w.write_all(chunk)?;
                    w.flush()?;
                }
                Ok(())
            })
            .unwrap();
        }
        done.store(true, Ordering::Relaxed);
        reader.join().unwrap()
    });
    assert!(reads >= 50, "{reads}");
    assert_eq!(entries(&dir), ["results.json"]);
}

/// A file written over time appears only when committed, whole; dropped before, it leaves
/// nothing, and an earlier file of that name stays as it was.
#[test]
fn an_atomic_file_appears_only_when_committed() {
    let dir = scratch("atomic-file");
    let path = dir.join("clip.png");
    fs::write(&path, b"earlier").unwrap();
    {
        let mut file = AtomicFile::create(&path).unwrap();
        file.write_all(b"half of a frame").unwrap();
        assert_eq!(
            fs::read(&path).unwrap(),
            b"earlier",
            "not replaced before commit"
        );
    }
    assert_eq!(
        entries(&dir),
        ["clip.png"],
        "an abandoned file leaves no temporary"
    );
    assert_eq!(fs::read(&path).unwrap(), b"earlier");
    let mut file = AtomicFile::create(&path).unwrap();
    for frame in 0..3u8 {
        file.write_all(&[frame; 4]).unwrap();
    }
    file.commit().unwrap();
    assert_eq!(
        fs::read(&path).unwrap(),
        [0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2]
    );
    assert_eq!(entries(&dir), ["clip.png"]);
    let error = AtomicFile::create(&dir).expect_err("a directory is no file");
    assert!(
        matches!(error, MetricsError::InvalidOutput { .. }),
        "{error}"
    );
}
