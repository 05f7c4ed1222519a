//! The fuzzer in the test suite: its generator builds valid inputs, its checks catch what they
//! must, a bounded run finds nothing, and every file of the crash corpus (fuzz-corpus/) loads
//! without a panic or a broken invariant, so fixed defects stay fixed.

use std::path::Path;
use std::time::Duration;

use oit_fuzz::{self as fuzz, Event, Fixtures, Format, Input, Options, Outcome};

fn corpus() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/corpus"))
}

#[test]
fn generated_inputs_without_mutations_are_accepted() {
    // Mutations start from valid documents, so they reach validation and flattening.
    let fixtures = Fixtures::new().unwrap();
    let mut formats = std::collections::HashSet::new();
    for seed in 0..400 {
        let input = Input::valid(seed);
        formats.insert(input.format);
        match fuzz::check(&input, &fixtures) {
            Ok(Outcome::Accepted) => {}
            other => panic!(
                "seed {seed}: {other:?}\n{}",
                String::from_utf8_lossy(&input.bytes)
            ),
        }
    }
    assert_eq!(formats.len(), 3, "{formats:?}");
}

#[test]
fn inputs_are_reproducible_from_their_seed_and_file_name() {
    let dir = std::env::temp_dir().join(format!("oit-fuzz-names-{}", std::process::id()));
    for seed in 0..50 {
        let input = Input::generate(seed);
        assert_eq!(input, Input::generate(seed));
        let path = fuzz::save(&input, &dir).unwrap();
        assert_eq!(Input::read(&path).unwrap(), input, "{}", path.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn checks_catch_rust_words_and_ignore_quoted_input() {
    assert_eq!(
        fuzz::rust_type_words("x.json: camera: invalid type: sequence; allowed: struct RawCamera"),
        ["sequence", "struct", "RawCamera"]
    );
    assert_eq!(
        fuzz::rust_type_words("x.json: a: invalid value: integer `-1`; allowed: u32"),
        ["u32"]
    );
    // Input repeated in quotes or backticks is the author's, not Rust's.
    assert!(
        fuzz::rust_type_words(
            "x.json: objects[0].map: unknown field `map`; allowed: `mesh`, string \"enum\""
        )
        .iter()
        .all(|w| w == "map"),
    );
}

#[test]
fn checks_read_rust_words_in_the_problem_not_in_the_path() {
    // Found by a long run: a key `u8` (a mutated `up`) named in the path is the author's word.
    let fixtures = Fixtures::new().unwrap();
    let text = r#"{"name": "k", "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "u8": 1}, "objects": []}"#;
    let input = Input {
        format: Format::Scene,
        camera: None,
        bytes: text.as_bytes().to_vec(),
    };
    assert_eq!(fuzz::check(&input, &fixtures).unwrap(), Outcome::Rejected);
}

#[test]
fn a_bounded_run_finds_nothing() {
    let fixtures = Fixtures::new().unwrap();
    let options = Options {
        seed: 0x5eed,
        inputs: Some(10_000),
        // A bound for slow machines; the count normally ends the run first.
        duration: Some(Duration::from_secs(60)),
        threads: 2,
        timeout: Duration::from_secs(30),
    };
    let report = fuzz::run(&options, &fixtures, &|event| {
        if let Event::Stuck(f) = event {
            // Its thread cannot be stopped, so the test could never end: fail the binary now.
            eprintln!("{} (seed {:?}): {}", f.signature, f.seed, f.detail);
            std::process::exit(101);
        }
    });
    let findings: Vec<String> = report
        .findings
        .iter()
        .map(|f| format!("{} (seed {:?}): {}", f.signature, f.seed, f.detail))
        .collect();
    assert!(
        findings.is_empty(),
        "{}\n(show an input with `cargo run -p oit-fuzz --bin fuzz -- --show SEED`)",
        findings.join("\n")
    );
    assert!(report.inputs >= 1000, "{report:?}");
    // Both sides of the loader are reached: mutations make errors, most valid inputs pass.
    assert!(report.accepted * 10 >= report.inputs, "{report:?}");
    assert!(report.rejected * 10 >= report.inputs, "{report:?}");
}

#[test]
fn the_crash_corpus_replays_without_findings() {
    // In a thread, so an input that hangs again fails the test instead of stalling it.
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let fixtures = Fixtures::new().unwrap();
        send.send(fuzz::replay(corpus(), &fixtures).unwrap())
    });
    let results = receive
        .recv_timeout(Duration::from_secs(120))
        .expect("the corpus did not replay within 120 s");
    assert!(results.len() >= 5, "corpus has {} inputs", results.len());
    let mut formats = std::collections::HashSet::new();
    for (path, result) in &results {
        formats.insert(Input::read(path).unwrap().format);
        if let Err(f) = result {
            panic!("{}: {}: {}", path.display(), f.signature, f.detail);
        }
    }
    assert_eq!(formats.len(), 3, "{formats:?}");
    assert!(formats.contains(&Format::Scene));
}
