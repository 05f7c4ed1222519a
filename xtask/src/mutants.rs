//! `cargo xtask mutants`: mutation testing with cargo-mutants, crate by crate, in place (the
//! workspace's own build cache makes each mutant an incremental build), and a score table.
//!
//! A whole run is long (about 7 000 mutants at 10–30 s each on a 2-core machine); `--shard K/N`
//! runs the K-th of N consecutive slices of each crate's mutants (cargo-mutants' default slice
//! sharding): a deterministic sample, weighted towards the top of the crate's files.

use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};

/// The crates whose score the project tracks (docs/testing.md): every library of the workspace
/// under `crates/` and `techniques/` — the instrument and every technique family — read from
/// `cargo metadata`, so a new technique crate is included without an edit here. The CLI binary
/// and the packages of tests, tools, the fuzzer, benches and xtask are not mutated.
pub fn tracked_crates() -> Result<Vec<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_owned());
    let out = Command::new(&cargo)
        .args(["metadata", "--no-deps", "--format-version", "1"])
        .output()
        .context("running cargo metadata")?;
    if !out.status.success() {
        bail!(
            "cargo metadata failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let meta: serde_json::Value =
        serde_json::from_slice(&out.stdout).context("parsing cargo metadata")?;
    Ok(library_crates(&meta))
}

/// The packages of `meta` (cargo metadata) with a library target whose manifest lives under
/// `crates/` or `techniques/`, in the workspace's order.
fn library_crates(meta: &serde_json::Value) -> Vec<String> {
    let root = meta["workspace_root"].as_str().unwrap_or_default();
    let mut names = Vec::new();
    for package in meta["packages"].as_array().into_iter().flatten() {
        let manifest = package["manifest_path"].as_str().unwrap_or_default();
        let relative = manifest
            .strip_prefix(root)
            .unwrap_or(manifest)
            .trim_start_matches('/');
        let has_lib = package["targets"]
            .as_array()
            .into_iter()
            .flatten()
            .any(|t| {
                t["kind"]
                    .as_array()
                    .is_some_and(|k| k.iter().any(|k| k == "lib"))
            });
        if has_lib
            && (relative.starts_with("crates/") || relative.starts_with("techniques/"))
            && let Some(name) = package["name"].as_str()
        {
            names.push(name.to_owned());
        }
    }
    names
}

/// The package that holds the GPU integration tests of every crate: each mutant runs its
/// crate's own tests and these.
const INTEGRATION_TESTS: &str = "oit-tests";

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
        crates = tracked_crates()?;
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
            .arg("--test-package")
            .arg(INTEGRATION_TESTS)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Libraries under crates/ and techniques/ are tracked, in order; binaries-only packages and
    /// packages elsewhere are not.
    #[test]
    fn tracked_crates_are_the_libraries_of_crates_and_techniques() {
        let meta = serde_json::json!({
            "workspace_root": "/w",
            "packages": [
                {"name": "oit-scene", "manifest_path": "/w/crates/oit-scene/Cargo.toml", "targets": [{"kind": ["lib"]}]},
                {"name": "oit-cli", "manifest_path": "/w/crates/oit-cli/Cargo.toml", "targets": [{"kind": ["bin"]}]},
                {"name": "oit-new", "manifest_path": "/w/techniques/new/Cargo.toml", "targets": [{"kind": ["lib"]}]},
                {"name": "oit-tests", "manifest_path": "/w/tests/Cargo.toml", "targets": [{"kind": ["lib"]}, {"kind": ["test"]}]},
                {"name": "xtask", "manifest_path": "/w/xtask/Cargo.toml", "targets": [{"kind": ["bin"]}]}
            ]
        });
        assert_eq!(library_crates(&meta), ["oit-scene", "oit-new"]);
    }

    /// The real workspace: every technique family and the instrument's libraries.
    #[test]
    fn the_workspace_tracks_every_technique_crate() {
        let crates = tracked_crates().unwrap();
        for name in [
            "oit-reference",
            "oit-scene",
            "oit-peel",
            "oit-opaque-copy",
            "oit-results",
        ] {
            assert!(crates.iter().any(|c| c == name), "{name} not in {crates:?}");
        }
        assert!(
            !crates.iter().any(|c| c == "oit-cli" || c == "oit-tests"),
            "{crates:?}"
        );
    }
}
