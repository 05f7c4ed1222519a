//! Writes seeded random scenes (`oit_scene::random`) as ordinary scene files, for running the
//! CLI or another tool on content nobody placed by hand:
//! `cargo run -p oit-tools --bin random_scene -- OUT_DIR FIRST_SEED COUNT`.

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(dir), Some(first), Some(count)) = (
        args.first(),
        args.get(1).and_then(|v| v.parse::<u64>().ok()),
        args.get(2).and_then(|v| v.parse::<u64>().ok()),
    ) else {
        eprintln!("usage: random_scene OUT_DIR FIRST_SEED COUNT");
        return ExitCode::from(2);
    };
    if let Err(e) = std::fs::create_dir_all(dir) {
        eprintln!("random_scene: {dir}: {e}");
        return ExitCode::FAILURE;
    }
    for seed in first..first + count {
        let (text, _) = oit_scene::random::random_scene_json(seed);
        let path = std::path::Path::new(dir).join(format!("random-{seed}.json"));
        if let Err(e) = std::fs::write(&path, text) {
            eprintln!("random_scene: {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    ExitCode::SUCCESS
}
