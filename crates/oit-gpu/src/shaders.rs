//! WGSL sources and the one include mechanism.
//!
//! Every crate keeps its WGSL beside its code, in its own `shaders/` folder, and embeds every
//! file of it in a [`Library`] (`SHADERS`, name → source): this crate's [`SHADERS`] holds the
//! modules every scene pass shares (common.wgsl, the scene pass interface scene_io/) and the
//! passes of the GPU spine; each technique crate's `SHADERS` holds its own. A pass pulls a
//! module in with a line of exactly this form:
//!
//! ```text
//! #include "common.wgsl"
//! ```
//!
//! [`compose_with`] replaces each such line with the module's text, looked up by [`resolve`]
//! in the given libraries and then in this crate's (recursively; a module included twice is
//! inserted once, so diamonds are harmless, and a cycle is an error). WGSL has no `#`, so an
//! unprocessed file fails to parse instead of silently missing code. [`Context::shader_with`]
//! and the validation test resolve the same way; the test also checks that every library
//! holds exactly the files of its folder.
//!
//! [`Context::shader_with`]: crate::Context::shader_with

use std::collections::HashSet;

/// A crate's WGSL files, by file name relative to its `shaders/` folder, embedded at build time.
pub type Library = &'static [(&'static str, &'static str)];

/// This crate's `shaders/` folder, for tests that hold [`SHADERS`] against the files.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// The scene pass interface common.wgsl includes: the material read per vertex, passed flat.
pub const SCENE_IO_VERTEX: &str = "scene_io/vertex.wgsl";
/// The same interface with the material read per draw from a uniform, which [`compose_per_draw`]
/// puts in place of [`SCENE_IO_VERTEX`] for textured materials.
pub const SCENE_IO_DRAW: &str = include_str!("../shaders/scene_io/draw.wgsl");
/// [`SCENE_IO_DRAW`] without texture coordinates, for untextured materials.
pub const SCENE_IO_DRAW_UNTEXTURED: &str = include_str!("../shaders/scene_io/draw_untextured.wgsl");
/// [`SCENE_IO_DRAW`] with the world position and normal, for lit materials (the two others
/// leave them out).
pub const SCENE_IO_DRAW_LIT: &str = include_str!("../shaders/scene_io/draw_lit.wgsl");
/// Per-pixel lighting, included by common.wgsl.
pub const LIGHTING: &str = include_str!("../shaders/lighting.wgsl");
/// The module every scene pass includes.
pub const COMMON: &str = include_str!("../shaders/common.wgsl");

/// Pass files of this crate.
pub const OPAQUE: &str = include_str!("../shaders/opaque.wgsl");
/// Premultiplied OVER blending (`fs_blend`) and a discard-honouring depth-only entry
/// (`fs_depth_only`), shared by the blended baselines.
pub const BLEND: &str = include_str!("../shaders/blend.wgsl");
pub const COUNT_FRAGMENTS: &str = include_str!("../shaders/count_fragments.wgsl");
/// The sizing count of the stored-fragment techniques ([`crate::LayerCounter`]).
pub const COUNT_LAYERS: &str = include_str!("../shaders/count_layers.wgsl");
/// The floor pass: vertex colour, premultiplied OVER ([`crate::Floor`]).
pub const FLOOR: &str = include_str!("../shaders/floor.wgsl");

/// Every WGSL file of this crate.
pub const SHADERS: Library = &[
    ("common.wgsl", COMMON),
    ("lighting.wgsl", LIGHTING),
    (
        SCENE_IO_VERTEX,
        include_str!("../shaders/scene_io/vertex.wgsl"),
    ),
    ("scene_io/draw.wgsl", SCENE_IO_DRAW),
    ("scene_io/draw_untextured.wgsl", SCENE_IO_DRAW_UNTEXTURED),
    ("scene_io/draw_lit.wgsl", SCENE_IO_DRAW_LIT),
    ("opaque.wgsl", OPAQUE),
    ("blend.wgsl", BLEND),
    ("count_fragments.wgsl", COUNT_FRAGMENTS),
    ("count_layers.wgsl", COUNT_LAYERS),
    ("floor.wgsl", FLOOR),
];

/// The source `#include "NAME"` means: `name` in the first of `libraries` that has it (a
/// crate's [`Library`], or a few sources it specialised at run time), else in this crate's
/// [`SHADERS`]. The one lookup every include goes through.
pub fn resolve<'a>(name: &str, libraries: &[&'a [(&'a str, &'a str)]]) -> Option<&'a str> {
    libraries
        .iter()
        .copied()
        .chain(std::iter::once(SHADERS))
        .flat_map(|l| l.iter())
        .find(|(n, _)| *n == name)
        .map(|(_, s)| *s)
}

/// [`compose`] with includes looked up by [`resolve`] in `libraries`.
pub fn compose_with(source: &str, libraries: &[&[(&str, &str)]]) -> Result<String, IncludeError> {
    compose(source, &|n| resolve(n, libraries).map(str::to_owned))
}

/// [`compose_per_draw`] with includes looked up by [`resolve`] in `libraries`.
pub fn compose_per_draw_with(
    source: &str,
    libraries: &[&[(&str, &str)]],
    textured: bool,
    lit: bool,
) -> Option<Result<String, IncludeError>> {
    compose_per_draw(
        source,
        &|n| resolve(n, libraries).map(str::to_owned),
        textured,
        lit,
    )
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum IncludeError {
    #[error("line {line}: malformed include {text:?}; allowed: #include \"name.wgsl\"")]
    Malformed { line: usize, text: String },
    #[error("line {line}: unknown module {name:?}; allowed: {available}")]
    Unknown {
        line: usize,
        name: String,
        available: String,
    },
    #[error("include cycle through {0:?}")]
    Cycle(String),
}

/// Expands `#include "name"` lines using `resolve` (name → source).
pub fn compose(
    source: &str,
    resolve: &dyn Fn(&str) -> Option<String>,
) -> Result<String, IncludeError> {
    let mut out = String::with_capacity(source.len());
    let mut done = HashSet::new();
    let mut stack = Vec::new();
    expand(source, resolve, &mut done, &mut stack, &mut out)?;
    Ok(out)
}

fn expand(
    source: &str,
    resolve: &dyn Fn(&str) -> Option<String>,
    done: &mut HashSet<String>,
    stack: &mut Vec<String>,
    out: &mut String,
) -> Result<(), IncludeError> {
    for (i, line) in source.lines().enumerate() {
        let trimmed = line.trim();
        let Some(rest) = trimmed.strip_prefix("#include") else {
            out.push_str(line);
            out.push('\n');
            continue;
        };
        let name = rest
            .trim()
            .strip_prefix('"')
            .and_then(|r| r.strip_suffix('"'))
            .filter(|n| !n.is_empty() && !n.contains('"'))
            .ok_or_else(|| IncludeError::Malformed {
                line: i + 1,
                text: trimmed.to_owned(),
            })?;
        if stack.iter().any(|s| s == name) {
            return Err(IncludeError::Cycle(name.to_owned()));
        }
        if done.contains(name) {
            continue;
        }
        let text = resolve(name).ok_or_else(|| IncludeError::Unknown {
            line: i + 1,
            name: name.to_owned(),
            available: SHADERS
                .iter()
                .map(|(n, _)| *n)
                .collect::<Vec<_>>()
                .join(", "),
        })?;
        stack.push(name.to_owned());
        expand(&text, resolve, done, stack, out)?;
        stack.pop();
        done.insert(name.to_owned());
    }
    Ok(())
}

/// [`compose`] with a per-draw form of the scene pass interface in place of
/// [`SCENE_IO_VERTEX`] ([`SCENE_IO_DRAW_LIT`] where `lit`, else [`SCENE_IO_DRAW`], or
/// [`SCENE_IO_DRAW_UNTEXTURED`] unless `textured`): the module a scene pass uses for draws whose
/// material is read per draw (`ScenePipelines`). `None` when `source` does not include the
/// scene pass interface.
pub fn compose_per_draw(
    source: &str,
    resolve: &dyn Fn(&str) -> Option<String>,
    textured: bool,
    lit: bool,
) -> Option<Result<String, IncludeError>> {
    let used = std::cell::Cell::new(false);
    let swapped = |name: &str| {
        if name == SCENE_IO_VERTEX {
            used.set(true);
            Some(
                match (lit, textured) {
                    (true, _) => SCENE_IO_DRAW_LIT,
                    (false, true) => SCENE_IO_DRAW,
                    (false, false) => SCENE_IO_DRAW_UNTEXTURED,
                }
                .to_owned(),
            )
        } else {
            resolve(name)
        }
    };
    let code = compose(source, &swapped);
    used.get().then_some(code)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(name: &str) -> Option<String> {
        match name {
            "a.wgsl" => Some("const A: u32 = 1u;".into()),
            "b.wgsl" => Some("#include \"a.wgsl\"\nconst B: u32 = A;".into()),
            "loop.wgsl" => Some("#include \"loop.wgsl\"".into()),
            _ => None,
        }
    }

    #[test]
    fn includes_once_and_in_order() {
        let s = compose(
            "#include \"b.wgsl\"\n#include \"a.wgsl\"\nfn f() {}",
            &table,
        )
        .unwrap();
        assert_eq!(s, "const A: u32 = 1u;\nconst B: u32 = A;\nfn f() {}\n");
    }

    #[test]
    fn errors() {
        assert!(matches!(
            compose("#include a.wgsl", &table),
            Err(IncludeError::Malformed { line: 1, .. })
        ));
        assert!(matches!(
            compose("\n#include \"zzz.wgsl\"", &table),
            Err(IncludeError::Unknown { line: 2, .. })
        ));
        assert_eq!(
            compose("#include \"loop.wgsl\"", &table),
            Err(IncludeError::Cycle("loop.wgsl".into()))
        );
    }
}
