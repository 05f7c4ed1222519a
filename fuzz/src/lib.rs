//! Structure-aware fuzzing of the scene loader ([`oit_scene::parse`]) and the glTF loader
//! ([`oit_scene::parse_gltf`]) on stable Rust, with no libFuzzer.
//!
//! Each input is made from a seed: a valid JSON scene or glTF asset (glTF JSON or GLB) is
//! built from the format's structure (objects of every mesh kind, materials, cameras, lighting,
//! instancing; node trees, accessors in several encodings, PNG textures, samplers, extensions),
//! then mutated: type swaps, boundary numbers, deletions, duplications, unknown fields,
//! positional arrays, byte flips, truncation, GLB length fields. [`check`] loads it and tests
//! the invariants the loader documents: no panic, errors on one line that name the path and
//! what is allowed in JSON's words (never a Rust type), and accepted scenes within the caps
//! (triangles, resolution, texels) with finite values in their ranges.
//!
//! [`run`] fuzzes for a number of inputs or a time budget on several threads; the test suite
//! runs a bounded batch and replays `fuzz-corpus/`, and `cargo xtask fuzz` runs long batches
//! (the `fuzz` example), saving every finding to that corpus.

mod check;
mod generate;
mod mutate;

use std::cell::RefCell;
use std::collections::HashSet;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, Once};
use std::time::{Duration, Instant};

pub use check::rust_type_words;
use generate::Rng;

use oit_scene::LoadOptions;

/// Which loader an input is for (and its file extension in the corpus).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// The JSON scene format, loaded with [`oit_scene::parse`].
    Scene,
    /// glTF JSON, loaded with [`oit_scene::parse_gltf`].
    Gltf,
    /// A GLB container, loaded with [`oit_scene::parse_gltf`].
    Glb,
}

impl Format {
    fn extension(self) -> &'static str {
        match self {
            Format::Scene => "json",
            Format::Gltf => "gltf",
            Format::Glb => "glb",
        }
    }
}

/// One fuzz input: the bytes of a file and how to load them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Input {
    pub format: Format,
    /// glTF only: `LoadOptions::camera`.
    pub camera: Option<usize>,
    pub bytes: Vec<u8>,
}

impl Input {
    /// Input `seed`: a generated document, in 7 cases out of 8 mutated 1 to 3 times (the same
    /// seed gives the same input as long as the generator is unchanged).
    pub fn generate(seed: u64) -> Input {
        Input::make(seed, true)
    }

    /// The generated document of `seed` without mutations: a valid scene or asset.
    pub fn valid(seed: u64) -> Input {
        Input::make(seed, false)
    }

    fn make(seed: u64, mutate: bool) -> Input {
        let mut r = Rng::new(seed);
        let format = match r.below(10) {
            0..=5 => Format::Scene,
            6 | 7 => Format::Glb,
            _ => Format::Gltf,
        };
        let mut doc = match format {
            Format::Scene => generate::scene(&mut r),
            _ => {
                let g = generate::gltf(&mut r);
                if format == Format::Glb {
                    let doc = generate::glb_json(&g);
                    return Input::finish_glb(&mut r, doc, &g.bin, mutate);
                }
                generate::gltf_json(&g)
            }
        };
        let mutations = if mutate { r.below(8) } else { 0 };
        for _ in 0..mutations.min(3) {
            mutate::structure(&mut r, &mut doc);
        }
        let mut bytes = doc.to_string().into_bytes();
        if mutations > 0 && r.chance(0.35) {
            for _ in 0..1 + r.below(3) {
                mutate::bytes(&mut r, &mut bytes);
            }
        }
        let camera =
            (format != Format::Scene && mutations > 0 && r.chance(0.15)).then(|| r.index(3));
        Input {
            format,
            camera,
            bytes,
        }
    }

    fn finish_glb(r: &mut Rng, mut doc: serde_json::Value, bin: &[u8], mutate: bool) -> Input {
        let mutations = if mutate { r.below(8) } else { 0 };
        for _ in 0..mutations.min(3) {
            mutate::structure(r, &mut doc);
        }
        let mut bytes = generate::glb(doc.to_string().as_bytes(), bin);
        if mutations > 0 && r.chance(0.35) {
            for _ in 0..1 + r.below(3) {
                if r.chance(0.5) {
                    mutate::glb(r, &mut bytes);
                } else {
                    mutate::bytes(r, &mut bytes);
                }
            }
        }
        let camera = (mutations > 0 && r.chance(0.15)).then(|| r.index(3));
        Input {
            format: Format::Glb,
            camera,
            bytes,
        }
    }

    /// `scene-<hash>.json`, `glb-cam1-<hash>.glb`, ...: the format, the camera option and a
    /// hash of the bytes, so saving the same input twice writes one file.
    pub fn file_name(&self) -> String {
        // FNV-1a, 64 bit.
        let hash = self.bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
        });
        let kind = match self.format {
            Format::Scene => "scene",
            Format::Gltf => "gltf",
            Format::Glb => "glb",
        };
        let camera = self.camera.map_or(String::new(), |c| format!("-cam{c}"));
        format!("{kind}{camera}-{hash:016x}.{}", self.format.extension())
    }

    /// Reads a corpus file written by [`Input::file_name`]'s scheme (the extension gives the
    /// format, a `-camN` part the camera option).
    pub fn read(path: &Path) -> std::io::Result<Input> {
        let bytes = std::fs::read(path)?;
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let format = match path.extension().and_then(|e| e.to_str()) {
            Some("json") => Format::Scene,
            Some("gltf") => Format::Gltf,
            Some("glb") => Format::Glb,
            _ => {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("{name}: not a .json, .gltf or .glb fuzz input"),
                ));
            }
        };
        let camera = name
            .split('-')
            .find_map(|part| part.strip_prefix("cam")?.parse().ok());
        Ok(Input {
            format,
            camera,
            bytes,
        })
    }
}

/// A directory with the glTF assets generated scenes place, and the name inputs are loaded
/// under: `fixture.glb` and `fixture.gltf` (one asset with 16 triangles in 6 primitives, 4
/// materials and 2 textures) and `no-triangles.gltf` (a primitive with 2 vertices, so an object
/// placing it adds nothing however many instances it has). Removed on drop.
#[derive(Debug)]
pub struct Fixtures {
    dir: PathBuf,
}

impl Fixtures {
    /// Writes the fixtures into a fresh directory under the system's temporary directory.
    pub fn new() -> std::io::Result<Fixtures> {
        static COUNT: AtomicU64 = AtomicU64::new(0);
        let dir = std::env::temp_dir().join(format!(
            "oit-scene-fuzz-{}-{}",
            std::process::id(),
            COUNT.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&dir)?;
        let fixtures = Fixtures { dir };
        let g = generate::gltf(&mut Rng::new(FIXTURE_SEED));
        let glb = generate::glb(generate::glb_json(&g).to_string().as_bytes(), &g.bin);
        std::fs::write(fixtures.dir.join(generate::FIXTURE_FILES[0]), glb)?;
        let json = generate::gltf_json(&g).to_string();
        std::fs::write(fixtures.dir.join(generate::FIXTURE_FILES[1]), json)?;
        let empty = generate::gltf_json(&generate::gltf_without_triangles()).to_string();
        std::fs::write(fixtures.dir.join(generate::FIXTURE_FILES[2]), empty)?;
        Ok(fixtures)
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

impl Drop for Fixtures {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The seed of the fixture asset.
const FIXTURE_SEED: u64 = 5;

/// An input that panicked or broke an invariant.
#[derive(Debug, Clone)]
pub struct Finding {
    /// Short and fixed per kind of defect (`panic at src/load.rs:120:5`,
    /// `Rust type words in error`): findings with the same signature are one defect.
    pub signature: String,
    /// The panic message, the error line or the value out of range.
    pub detail: String,
    /// The seed [`Input::generate`] made it from, when it came from [`run`].
    pub seed: Option<u64>,
    pub input: Input,
}

/// What a loader did with an input that broke no invariant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    Accepted,
    Rejected,
}

thread_local! {
    /// Set while [`check`] runs a loader on this thread: the panic hook records into it
    /// instead of printing.
    static CAPTURE: RefCell<Option<Option<(String, String)>>> = const { RefCell::new(None) };
}

/// Installs (once) a panic hook that records panics on threads inside [`check`] and hands
/// every other panic to the previous hook, so tests running beside the fuzzer still report.
fn install_panic_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let captured = CAPTURE.with(|c| {
                let mut c = c.borrow_mut();
                match c.as_mut() {
                    Some(slot) => {
                        let message = info
                            .payload()
                            .downcast_ref::<&str>()
                            .map(|s| s.to_string())
                            .or_else(|| info.payload().downcast_ref::<String>().cloned())
                            .unwrap_or_else(|| "(non-string panic payload)".into());
                        let location = info
                            .location()
                            .map_or("(unknown location)".into(), |l| l.to_string());
                        *slot = Some((location, message));
                        true
                    }
                    None => false,
                }
            });
            if !captured {
                previous(info);
            }
        }));
    });
}

/// Loads `input` (scenes as `<fixtures>/input.json`, so they can place the fixture assets;
/// glTF as `<fixtures>/input.gltf` or `.glb`) and checks every invariant.
pub fn check(input: &Input, fixtures: &Fixtures) -> Result<Outcome, Finding> {
    install_panic_hook();
    let finding = |signature: String, detail: String| Finding {
        signature,
        detail,
        seed: None,
        input: input.clone(),
    };
    let origin = fixtures
        .dir
        .join(format!("input.{}", input.format.extension()));
    let origin = origin.to_string_lossy();
    let options = LoadOptions {
        camera: input.camera,
        ..Default::default()
    };
    CAPTURE.with(|c| *c.borrow_mut() = Some(None));
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| match input.format {
        Format::Scene => oit_scene::parse(&String::from_utf8_lossy(&input.bytes), &origin),
        Format::Gltf | Format::Glb => oit_scene::parse_gltf(&input.bytes, &origin, &options),
    }));
    let panic = CAPTURE.with(|c| c.borrow_mut().take()).flatten();
    let violations = match result {
        Err(_) => {
            let (location, message) =
                panic.unwrap_or_else(|| ("(unknown location)".into(), String::new()));
            return Err(finding(format!("panic at {location}"), message));
        }
        Ok(Ok(scene)) => (check::scene(&scene), Outcome::Accepted),
        Ok(Err(e)) => (check::error(&e), Outcome::Rejected),
    };
    match violations {
        (v, outcome) if v.is_empty() => Ok(outcome),
        (v, _) => {
            let (name, detail) = &v[0];
            Err(finding(name.to_string(), detail.clone()))
        }
    }
}

/// How long [`run`] fuzzes.
#[derive(Debug, Clone)]
pub struct Options {
    /// Input `i` is made from the seed `seed + i`.
    pub seed: u64,
    /// Stop after this many inputs...
    pub inputs: Option<u64>,
    /// ...or after this long, whichever comes first (at least one of the two is needed).
    pub duration: Option<Duration>,
    /// Worker threads.
    pub threads: usize,
    /// An input still running after this long is a finding ([`Event::Stuck`]).
    pub timeout: Duration,
}

/// What [`run`] reports while it runs.
#[derive(Debug)]
pub enum Event<'a> {
    /// About once a second: inputs started so far.
    Progress { inputs: u64 },
    /// An input has run longer than [`Options::timeout`] (a hang or a pathological cost). Its
    /// thread cannot be stopped, so the run cannot finish: the handler should save the input
    /// and end the process.
    Stuck(&'a Finding),
}

/// Totals of a [`run`].
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub inputs: u64,
    /// Inputs the loader accepted (the scene met every invariant).
    pub accepted: u64,
    /// Inputs the loader rejected with a well-formed error.
    pub rejected: u64,
    /// Inputs that panicked or broke an invariant (`findings` keeps one per signature).
    pub failed: u64,
    pub elapsed: Duration,
    /// The slowest input and its seed.
    pub slowest: (Duration, u64),
    /// The first finding of each signature, in the order found.
    pub findings: Vec<Finding>,
}

impl Report {
    pub fn inputs_per_second(&self) -> f64 {
        self.inputs as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// Fuzzes inputs `seed`, `seed + 1`, ... on `options.threads` threads until the input count or
/// the time budget is reached, telling `events` the progress and any stuck input.
pub fn run(options: &Options, fixtures: &Fixtures, events: &(dyn Fn(Event) + Sync)) -> Report {
    assert!(
        options.inputs.is_some() || options.duration.is_some(),
        "fuzz::run needs an input count or a duration"
    );
    let started = Instant::now();
    let deadline = options.duration.map(|d| started + d);
    let limit = options.inputs.unwrap_or(u64::MAX);
    let next = AtomicU64::new(0);
    let accepted = AtomicU64::new(0);
    let rejected = AtomicU64::new(0);
    let failed = AtomicU64::new(0);
    let shared = Mutex::new((
        Vec::<Finding>::new(),
        HashSet::<String>::new(),
        (Duration::ZERO, 0u64),
    ));
    let threads = options.threads.max(1);
    // What each worker runs now (seed, since when), for the watchdog.
    let running: Vec<Mutex<Option<(u64, Instant)>>> =
        (0..threads).map(|_| Mutex::new(None)).collect();
    let working = AtomicU64::new(threads as u64);
    std::thread::scope(|s| {
        s.spawn(|| {
            let mut reported = HashSet::new();
            let mut last_progress = Instant::now();
            while working.load(Ordering::Relaxed) > 0 {
                std::thread::sleep(Duration::from_millis(100));
                let stuck = running.iter().find_map(|slot| {
                    let slot = slot.lock().unwrap_or_else(|e| e.into_inner());
                    slot.filter(|(seed, since)| {
                        since.elapsed() > options.timeout && !reported.contains(seed)
                    })
                });
                if let Some((seed, _)) = stuck {
                    reported.insert(seed);
                    let finding = Finding {
                        signature: format!("input running over {:?}", options.timeout),
                        detail: format!("seed {seed}"),
                        seed: Some(seed),
                        input: Input::generate(seed),
                    };
                    events(Event::Stuck(&finding));
                }
                if last_progress.elapsed() >= Duration::from_secs(1) {
                    last_progress = Instant::now();
                    let inputs = next.load(Ordering::Relaxed).min(limit);
                    events(Event::Progress { inputs });
                }
            }
        });
        for slot in &running {
            s.spawn(|| {
                let _done = Done(&working);
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= limit || deadline.is_some_and(|d| Instant::now() >= d) {
                        break;
                    }
                    let seed = options.seed.wrapping_add(i);
                    let input = Input::generate(seed);
                    let t = Instant::now();
                    *slot.lock().unwrap_or_else(|e| e.into_inner()) = Some((seed, t));
                    let result = check(&input, fixtures);
                    *slot.lock().unwrap_or_else(|e| e.into_inner()) = None;
                    let took = t.elapsed();
                    let mut guard = shared.lock().unwrap_or_else(|e| e.into_inner());
                    let (findings, seen, slowest) = &mut *guard;
                    if took > slowest.0 {
                        *slowest = (took, seed);
                    }
                    match result {
                        Ok(Outcome::Accepted) => accepted.fetch_add(1, Ordering::Relaxed),
                        Ok(Outcome::Rejected) => rejected.fetch_add(1, Ordering::Relaxed),
                        Err(mut f) => {
                            if seen.insert(f.signature.clone()) {
                                f.seed = Some(seed);
                                findings.push(f);
                            }
                            failed.fetch_add(1, Ordering::Relaxed)
                        }
                    };
                }
            });
        }
    });
    let (findings, _, slowest) = shared.into_inner().unwrap_or_else(|e| e.into_inner());
    let (accepted, rejected, failed) = (
        accepted.into_inner(),
        rejected.into_inner(),
        failed.into_inner(),
    );
    Report {
        inputs: accepted + rejected + failed,
        accepted,
        rejected,
        failed,
        elapsed: started.elapsed(),
        slowest,
        findings,
    }
}

/// Counts a worker out when it ends, even by a panic, so the watchdog stops.
struct Done<'a>(&'a AtomicU64);

impl Drop for Done<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

/// Writes a finding's input into `dir` (created if needed) as [`Input::file_name`]; returns
/// the path.
pub fn save(input: &Input, dir: &Path) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let path = dir.join(input.file_name());
    std::fs::write(&path, &input.bytes)?;
    Ok(path)
}

/// Every `.json`, `.gltf` and `.glb` file in `dir`, sorted by name, with what [`check`] says
/// of it.
pub fn replay(
    dir: &Path,
    fixtures: &Fixtures,
) -> std::io::Result<Vec<(PathBuf, Result<Outcome, Finding>)>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .is_some_and(|e| e == "json" || e == "gltf" || e == "glb")
        })
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let input = Input::read(&p)?;
            let result = check(&input, fixtures);
            Ok((p, result))
        })
        .collect()
}
