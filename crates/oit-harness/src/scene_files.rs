//! Which files of a scene folder are scenes. A folder of downloaded content holds JSON files
//! that are not scenes beside the model (`metadata.json` of the Khronos sample assets, say):
//! those are skipped with a note, decided by content, while a file meant as a scene that is
//! malformed still fails with the loader's message.

use std::path::{Path, PathBuf};

use crate::HarnessError;

/// Top-level keys only a JSON scene has (docs/scene-format.md: `camera` and `objects` are
/// required). A JSON object with neither is some other file.
pub const SCENE_KEYS: &[&str] = &["camera", "objects"];

/// A file of a scene folder that is not a scene.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedFile {
    pub path: PathBuf,
    /// Why it is not taken for a scene.
    pub reason: String,
}

impl SkippedFile {
    /// The note commands print: `skipped: not a scene: FILE (REASON)`.
    pub fn note(&self) -> String {
        format!(
            "skipped: not a scene: {} ({})",
            self.path.display(),
            self.reason
        )
    }
}

/// The scene files of `dir` (`*.json`, `*.gltf`, `*.glb`, not recursive, sorted by file
/// name), and the JSON files in it that are not scenes.
pub fn scene_files(dir: &Path) -> Result<(Vec<PathBuf>, Vec<SkippedFile>), HarnessError> {
    let mut scenes = Vec::new();
    let mut skipped = Vec::new();
    for path in oit_scene::scene_files(dir)? {
        match not_a_scene(&path) {
            Some(reason) => skipped.push(SkippedFile { path, reason }),
            None => scenes.push(path),
        }
    }
    Ok((scenes, skipped))
}

/// Why `path` is not a scene, or `None` when it is taken for one: a glTF file always is, and
/// so is a JSON file that cannot be read or parsed (the loader then says what is wrong with
/// it), or a JSON object with any of [`SCENE_KEYS`].
pub fn not_a_scene(path: &Path) -> Option<String> {
    if oit_scene::is_gltf_path(path) {
        return None;
    }
    let text = std::fs::read_to_string(path).ok()?;
    let value: serde_json::Value =
        serde_json::from_str(text.trim_start_matches('\u{feff}')).ok()?;
    not_a_scene_value(&value)
}

/// [`not_a_scene`] of parsed JSON.
fn not_a_scene_value(value: &serde_json::Value) -> Option<String> {
    let keys = || SCENE_KEYS.join("\", \"");
    match value {
        serde_json::Value::Object(map) => {
            if SCENE_KEYS.iter().any(|k| map.contains_key(*k)) {
                None
            } else {
                Some(format!(
                    "a JSON object without any of the scene keys \"{}\"",
                    keys()
                ))
            }
        }
        other => Some(format!(
            "JSON {}, where a scene is an object with \"{}\"",
            json_kind(other),
            keys()
        )),
    }
}

fn json_kind(value: &serde_json::Value) -> &'static str {
    match value {
        serde_json::Value::Null => "null",
        serde_json::Value::Bool(_) => "boolean",
        serde_json::Value::Number(_) => "number",
        serde_json::Value::String(_) => "string",
        serde_json::Value::Array(_) => "array",
        serde_json::Value::Object(_) => "object",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(files: &[(&str, &str)]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("oit-scene-files-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for (name, text) in files {
            std::fs::write(dir.join(name), text).unwrap();
        }
        dir
    }

    #[test]
    fn metadata_beside_a_model_is_skipped_and_scenes_are_kept() {
        let dir = folder(&[
            (
                "metadata.json",
                r#"{"version": 2, "legal": [{"license": "CC-BY 4.0"}], "name": "Vase"}"#,
            ),
            ("list.json", "[1, 2]"),
            (
                "a-scene.json",
                r#"{"name": "a", "camera": {}, "objects": []}"#,
            ),
            // Meant as a scene (it has objects) but malformed: kept, so loading fails on it.
            ("broken.json", r#"{"name": "b", "objects": 3}"#),
            // Not JSON at all: kept, the loader names the syntax error.
            ("truncated.json", r#"{"name": "c", "camera": "#),
            ("model.gltf", "not even JSON"),
            ("notes.txt", "ignored: not a scene extension"),
        ]);
        let (scenes, skipped) = scene_files(&dir).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let names: Vec<String> = scenes
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "a-scene.json",
                "broken.json",
                "model.gltf",
                "truncated.json"
            ]
        );
        let skipped_names: Vec<String> = skipped
            .iter()
            .map(|s| s.path.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(skipped_names, ["list.json", "metadata.json"]);
        assert!(
            skipped[0].reason.contains("JSON array"),
            "{}",
            skipped[0].reason
        );
        let note = skipped[1].note();
        assert!(note.starts_with("skipped: not a scene: "), "{note}");
        assert!(note.contains("metadata.json"), "{note}");
        assert!(note.contains("\"camera\", \"objects\""), "{note}");
    }

    #[test]
    fn every_bundled_scene_is_taken_for_a_scene() {
        let scenes_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        let listed = oit_scene::scene_files(&scenes_dir).unwrap();
        assert!(!listed.is_empty());
        let (scenes, skipped) = scene_files(&scenes_dir).unwrap();
        assert_eq!(skipped, Vec::new());
        assert_eq!(scenes, listed);
    }
}
