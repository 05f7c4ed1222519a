//! `cargo xtask mutants`: mutation testing with cargo-mutants, crate by crate, in place (the
//! workspace's own build cache makes each mutant an incremental build), and a score table.
//!
//! A whole run is long (about 7 000 mutants at 10–30 s each on a 2-core machine); `--shard K/N`
//! runs the K-th of N consecutive slices of each crate's mutants (cargo-mutants' default slice
//! sharding): a deterministic sample, weighted towards the top of the crate's files.

use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};

/// The crates whose score the project tracks (CONTRIBUTING.md): the instrument and the CPU
/// side of every technique crate.
pub const CRATES: &[&str] = &[
    "oit-reference",
    "oit-scene",
    "oit-metrics",
    "oit-harness",
    "oit-report",
    "oit-sorted",
    "oit-peel",
    "oit-wboit",
    "oit-stochastic",
    "oit-mboit",
    "oit-linked-list",
    "oit-opaque-copy",
];

/// One crate's outcome counts (cargo-mutants' `outcomes.json`).
#[derive(Debug, Default, Clone, Copy)]
pub struct Score {
    pub total: u64,
    pub caught: u64,
    pub missed: u64,
    pub timeout: u64,
    pub unviable: u64,
}

impl Score {
    /// Caught over viable mutants (a timeout counts as caught: the mutant made the tests hang).
    pub fn percent(&self) -> f64 {
        let viable = self.caught + self.missed + self.timeout;
        if viable == 0 {
            return 100.0;
        }
        100.0 * (self.caught + self.timeout) as f64 / viable as f64
    }
}

pub fn mutants(args: &[String]) -> Result<()> {
    let mut crates: Vec<String> = Vec::new();
    let mut shard = "0/1".to_owned();
    let mut timeout = "300".to_owned();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--package" | "-p" => {
                crates.push(it.next().context("--package needs a crate")?.clone())
            }
            "--shard" => shard = it.next().context("--shard needs K/N")?.clone(),
            "--timeout" => timeout = it.next().context("--timeout needs seconds")?.clone(),
            other => bail!(
                "unknown argument `{other}`; usage: cargo xtask mutants [--package CRATE]... [--shard K/N] [--timeout SECS]"
            ),
        }
    }
    if crates.is_empty() {
        crates = CRATES.iter().map(|s| s.to_string()).collect();
    }
    // In place: a mutant lives in the source tree while its tests run, so the tree must be
    // clean before (and cargo-mutants restores every file after each mutant).
    let status = Command::new("git")
        .args(["status", "--porcelain", "--untracked-files=no"])
        .output()
        .context("running git status")?;
    if !status.stdout.is_empty() {
        bail!(
            "cargo xtask mutants mutates the source tree in place: commit or stash changes first"
        );
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_owned());
    let mut table = String::from(
        "| crate | mutants (shard) | caught | missed | timeout | unviable | score |\n|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for name in &crates {
        let out = Path::new("target/mutants").join(name);
        std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
        println!("xtask mutants: {name}, shard {shard}");
        let status = Command::new(&cargo)
            .args(["mutants", "--in-place", "--no-shuffle", "--package"])
            .arg(name)
            .arg("--test-package")
            .arg(name)
            .args(["--shard", &shard, "--timeout", &timeout, "--output"])
            .arg(&out)
            .status()
            .context("running cargo mutants (install it: cargo install cargo-mutants --locked)")?;
        // cargo-mutants exits 2 when mutants were missed: that is a result, not a failure.
        if !matches!(status.code(), Some(0) | Some(2) | Some(3)) {
            bail!("cargo mutants failed on {name}: {status}");
        }
        let score = read_score(&out.join("mutants.out/outcomes.json"))?;
        table += &format!(
            "| {name} | {} | {} | {} | {} | {} | {:.0} % |\n",
            score.total,
            score.caught,
            score.missed,
            score.timeout,
            score.unviable,
            score.percent()
        );
        println!(
            "xtask mutants: {name}: missed mutants in {}",
            out.join("mutants.out/missed.txt").display()
        );
    }
    print!("\n{table}");
    std::fs::write("target/mutants/summary.md", &table).context("writing the summary")?;
    Ok(())
}

fn read_score(path: &Path) -> Result<Score> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let n = |k: &str| v.get(k).and_then(serde_json::Value::as_u64).unwrap_or(0);
    Ok(Score {
        total: n("total_mutants"),
        caught: n("caught"),
        missed: n("missed"),
        timeout: n("timeout"),
        unviable: n("unviable"),
    })
}
