//! What every command that renders prints about a scene's content: its credits and what the
//! loader read but does not model (the lines results.md and report.html carry under the
//! scene), so no command shows a model without saying what of it was lost.

use oit_scene::Scene;

/// The scene's `Credits: …` and `Not modelled: …` lines.
pub fn scene_lines(scene: &Scene) -> Vec<String> {
    oit_results::note_lines(&scene.credits, &scene.ignored)
}

/// Prints [`scene_lines`] to stdout, one a line.
pub fn print_scene(scene: &Scene) {
    for line in scene_lines(scene) {
        println!("{line}");
    }
}

/// Prints the notes of every scene of a comparison's results, each line after its scene's
/// name (`oit recommend`, which prints no per-scene table).
pub fn print_results(results: &oit_results::Results) {
    for s in &results.scenes {
        for line in oit_results::note_lines(&s.credits, &s.ignored) {
            println!("{}: {line}", s.scene);
        }
    }
}
