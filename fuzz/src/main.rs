//! Long fuzz runs of the scene and glTF loaders (`cargo xtask fuzz` builds and runs this in
//! release). Every finding's input is written to the crash corpus, which the test suite
//! replays.
//!
//! `fuzz [--inputs N] [--minutes M] [--seed S] [--threads T] [--timeout SECONDS] [--corpus DIR]`:
//! stops after N inputs or M minutes, whichever comes first (default: 1 minute); an input
//! running longer than the timeout (default 60 s) is a finding too; exits 1 on any finding.
//! `fuzz --show S` prints input S (its file name, text and what the checks say) instead.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use oit_fuzz::{self as fuzz, Event, Fixtures, Options};

fn main() -> ExitCode {
    match run() {
        Ok(clean) if clean => ExitCode::SUCCESS,
        Ok(_) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("fuzz: error: {e}");
            ExitCode::from(2)
        }
    }
}

fn run() -> Result<bool, String> {
    let mut options = Options {
        seed: 0,
        inputs: None,
        duration: None,
        threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        // Far above the slowest valid input (a few seconds near the triangle cap).
        timeout: Duration::from_secs(60),
    };
    let mut corpus = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/corpus"));
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or_else(|| format!("`{flag}` needs a value"));
        // Integers also as `1e6`; seconds as any non-negative number that fits a Duration.
        let integer = |v: String| {
            v.parse::<u64>()
                .ok()
                .or_else(|| {
                    let x = v.parse::<f64>().ok()?;
                    (x >= 0.0 && x.fract() == 0.0 && x < 1.8e19).then_some(x as u64)
                })
                .ok_or_else(|| format!("`{flag} {v}`: expected a non-negative integer"))
        };
        let seconds = |v: String, scale: f64| {
            v.parse::<f64>()
                .ok()
                .and_then(|x| Duration::try_from_secs_f64(x * scale).ok())
                .ok_or_else(|| format!("`{flag} {v}`: expected a non-negative number"))
        };
        match flag.as_str() {
            "--inputs" => options.inputs = Some(integer(value()?)?),
            "--minutes" => options.duration = Some(seconds(value()?, 60.0)?),
            "--seed" => options.seed = integer(value()?)?,
            "--threads" => options.threads = (integer(value()?)? as usize).max(1),
            "--timeout" => options.timeout = seconds(value()?, 1.0)?,
            "--corpus" => corpus = PathBuf::from(value()?),
            "--show" => return show(integer(value()?)?),
            other => {
                return Err(format!(
                    "unknown argument `{other}`; allowed: --inputs N, --minutes M, --seed S, --threads T, --timeout SECONDS, --corpus DIR, --show S"
                ));
            }
        }
    }
    if options.inputs.is_none() && options.duration.is_none() {
        options.duration = Some(Duration::from_secs(60));
    }
    println!(
        "fuzz: seed {}, {} threads, up to {} inputs / {} s; findings go to {}",
        options.seed,
        options.threads,
        options.inputs.map_or("unlimited".into(), |n| n.to_string()),
        options
            .duration
            .map_or("unlimited".into(), |d| format!("{:.0}", d.as_secs_f64())),
        corpus.display()
    );
    let fixtures = Fixtures::new().map_err(|e| format!("cannot write the fixtures: {e}"))?;
    let started = std::time::Instant::now();
    let report = fuzz::run(&options, &fixtures, &|event| match event {
        Event::Progress { inputs } => {
            let rate = inputs as f64 / started.elapsed().as_secs_f64().max(1e-9);
            eprint!("\rfuzz: {inputs} inputs, {rate:.0}/s   ");
        }
        Event::Stuck(f) => {
            // The stuck thread cannot be stopped: save the input and end the run here.
            let saved = fuzz::save(&f.input, &corpus)
                .map_or_else(|e| format!("not saved: {e}"), |p| p.display().to_string());
            println!(
                "\nfinding: {} ({}), saved as {saved}",
                f.signature, f.detail
            );
            std::process::exit(1);
        }
    });
    eprintln!();
    println!(
        "fuzz: {} inputs in {:.1} s ({:.0} inputs/s): {} accepted, {} rejected, {} failed; slowest {:.1} ms (seed {})",
        report.inputs,
        report.elapsed.as_secs_f64(),
        report.inputs_per_second(),
        report.accepted,
        report.rejected,
        report.failed,
        report.slowest.0.as_secs_f64() * 1e3,
        report.slowest.1
    );
    for f in &report.findings {
        let path = fuzz::save(&f.input, &corpus)
            .map_err(|e| format!("cannot write to {}: {e}", corpus.display()))?;
        println!(
            "finding: {} (seed {}): {}\n  saved as {}",
            f.signature,
            f.seed.unwrap_or_default(),
            f.detail,
            path.display()
        );
    }
    if report.findings.is_empty() {
        println!("fuzz: no findings");
    }
    Ok(report.findings.is_empty())
}

/// Prints input `seed` and what [`fuzz::check`] says of it.
fn show(seed: u64) -> Result<bool, String> {
    let input = fuzz::Input::generate(seed);
    let fixtures = Fixtures::new().map_err(|e| format!("cannot write the fixtures: {e}"))?;
    let started = std::time::Instant::now();
    let result = fuzz::check(&input, &fixtures);
    println!("{} ({} bytes)", input.file_name(), input.bytes.len());
    println!("{}", String::from_utf8_lossy(&input.bytes));
    println!(
        "{:.1} ms: {result:?}",
        started.elapsed().as_secs_f64() * 1e3
    );
    Ok(result.is_ok())
}
