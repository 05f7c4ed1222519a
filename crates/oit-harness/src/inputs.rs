//! Where outputs may go: never onto a file a scene was read from (the scene file, a glTF asset,
//! its buffers and images), and `compare`'s output folder never over or inside its inputs.
//!
//! Two paths name the same file when they resolve to the same file on disk (same device and
//! inode where both exist; otherwise the same canonical path, a missing file's folder resolved
//! and its name compared without regard to case, as case-folding file systems would).

use std::path::{Path, PathBuf};

use crate::HarnessError;

/// Refuses when any of `outputs` would replace one of `inputs` (files a scene was read from).
pub fn refuse_outputs_on_inputs(outputs: &[&Path], inputs: &[PathBuf]) -> Result<(), HarnessError> {
    for output in outputs {
        if let Some(input) = inputs.iter().find(|i| same_file(output, i)) {
            return Err(HarnessError::Invalid {
                path: output.to_path_buf(),
                message: format!(
                    "would replace {}, which the scene reads; choose another output",
                    input.display()
                ),
            });
        }
    }
    Ok(())
}

/// Refuses an output folder for `compare` that is one of the scene folders given, or that
/// holds (at any depth) a file a scene was read from: results.json, plots and per-scene
/// folders would land among the inputs, and a later `compare` of that folder would read
/// results.json as a scene.
pub fn refuse_out_dir_over_inputs(
    out: &Path,
    scene_dirs: &[PathBuf],
    inputs: &[PathBuf],
) -> Result<(), HarnessError> {
    let refuse = |what: String| {
        Err(HarnessError::Invalid {
            path: out.to_path_buf(),
            message: format!(
                "--out {what}: its results.json, plots and scene folders would land among the inputs; choose an output folder of its own"
            ),
        })
    };
    if let Some(dir) = scene_dirs.iter().find(|d| same_file(out, d)) {
        return refuse(format!("is the scene folder {}", dir.display()));
    }
    if let Some(input) = inputs.iter().find(|i| is_within(i, out)) {
        return refuse(format!("holds {}, which a scene reads", input.display()));
    }
    Ok(())
}

/// Whether `a` and `b` name the same file (see the module docs).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    match (resolve(a), resolve(b)) {
        (Some(a), Some(b)) => {
            a == b
                || (a.parent() == b.parent()
                    && a.file_name().map(|n| n.to_string_lossy().to_lowercase())
                        == b.file_name().map(|n| n.to_string_lossy().to_lowercase()))
        }
        _ => false,
    }
}

/// Whether `path` lies inside folder `dir` (at any depth), after resolving both.
pub fn is_within(path: &Path, dir: &Path) -> bool {
    match (resolve(path), resolve(dir)) {
        (Some(p), Some(d)) => p != d && p.starts_with(&d),
        _ => false,
    }
}

/// The canonical form of `path`; for a path that does not exist (yet), its nearest existing
/// ancestor canonicalized with the rest appended.
fn resolve(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().ok()?.join(path)
    };
    let mut rest = Vec::new();
    let mut at = absolute.as_path();
    loop {
        if let Ok(base) = at.canonicalize() {
            let mut out = base;
            for part in rest.iter().rev() {
                out.push(part);
            }
            return Some(out);
        }
        rest.push(at.file_name()?.to_os_string());
        at = at.parent()?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("oit-inputs-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Any spelling of an input's path is refused: relative, through `..`, a hard link, or
    /// not yet resolvable parts; another name in the same folder is allowed.
    #[test]
    fn outputs_on_any_spelling_of_an_input_are_refused() {
        let dir = temp("spell");
        let texture = dir.join("base.png");
        std::fs::write(&texture, b"png").unwrap();
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let inputs = vec![texture.clone()];
        for output in [
            texture.clone(),
            dir.join("sub/../base.png"),
            dir.join("./base.png"),
        ] {
            let err = refuse_outputs_on_inputs(&[output.as_path()], &inputs)
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("would replace") && err.contains("base.png"),
                "{err}"
            );
        }
        let link = dir.join("link.png");
        std::fs::hard_link(&texture, &link).unwrap();
        assert!(refuse_outputs_on_inputs(&[link.as_path()], &inputs).is_err());
        assert!(refuse_outputs_on_inputs(&[dir.join("base.exr").as_path()], &inputs).is_ok());
        assert!(refuse_outputs_on_inputs(&[dir.join("new/base.png").as_path()], &inputs).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_out_dir_over_or_around_inputs_is_refused() {
        let dir = temp("outdir");
        let scenes = dir.join("scenes");
        std::fs::create_dir_all(scenes.join("assets")).unwrap();
        let scene = scenes.join("a.json");
        let asset = scenes.join("assets/m.glb");
        std::fs::write(&scene, b"{}").unwrap();
        std::fs::write(&asset, b"glb").unwrap();
        let inputs = vec![scene.clone(), asset.clone()];
        let err = refuse_out_dir_over_inputs(&scenes, std::slice::from_ref(&scenes), &inputs)
            .unwrap_err()
            .to_string();
        assert!(err.contains("is the scene folder"), "{err}");
        let err = refuse_out_dir_over_inputs(&dir, &[], &inputs)
            .unwrap_err()
            .to_string();
        assert!(err.contains("holds") && err.contains("a.json"), "{err}");
        let err = refuse_out_dir_over_inputs(&scenes.join("assets"), &[], &inputs)
            .unwrap_err()
            .to_string();
        assert!(err.contains("m.glb"), "{err}");
        // A sibling folder, or one not yet made, is fine.
        assert!(
            refuse_out_dir_over_inputs(&dir.join("out"), std::slice::from_ref(&scenes), &inputs)
                .is_ok()
        );
        assert!(
            refuse_out_dir_over_inputs(
                &dir.join("out/deeper"),
                std::slice::from_ref(&scenes),
                &inputs
            )
            .is_ok()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
