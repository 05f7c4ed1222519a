//! Invariants: what every error and every accepted scene must satisfy, as the loader's
//! documentation promises (docs/scene-format.md).

use oit_scene::MAX_TEXELS;
use oit_scene::MAX_TRIANGLES;
use oit_scene::SceneError;
use oit_scene::{MAX_TEXTURE_DIMENSION, MAX_UV};
use oit_scene::{Projection, Resolution, Scene};

/// A broken invariant: a short fixed name (findings with the same one are the same defect)
/// and the details.
pub(super) type Violation = (&'static str, String);

/// Words of Rust's type system or serde's data model found in `message`, outside the quoted
/// (`"…"`) and backticked (`` `…` ``) parts that repeat the input. A scene author knows JSON,
/// not `struct RawObject`, `u32` or `sequence`.
pub fn rust_type_words(message: &str) -> Vec<String> {
    const WORDS: &[&str] = &[
        "struct", "enum", "usize", "isize", "u8", "u16", "u32", "u64", "u128", "i8", "i16", "i32",
        "i64", "i128", "f64", "sequence", "map", "Vec", "Option", "tuple", "newtype", "unit",
        "Some", "None",
    ];
    let mut plain = String::new();
    let mut quote = None;
    for c in message.chars() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == '"' || c == '`' => quote = Some(c),
            None => plain.push(c),
        }
    }
    plain
        .split(|c: char| !c.is_ascii_alphanumeric() && c != '_')
        .filter(|w| WORDS.contains(w) || (w.len() > 3 && w.starts_with("Raw")))
        .map(str::to_string)
        .collect()
}

/// What an error message must be: one line naming the file, the JSON path (or GLB part) and
/// what is allowed, in JSON's words.
pub(super) fn error(e: &SceneError) -> Vec<Violation> {
    let line = e.to_string();
    let mut out = Vec::new();
    if line.chars().any(char::is_control) {
        out.push(("control character in error", line.clone()));
    }
    if !line.contains("; allowed: ") {
        out.push(("error without `allowed`", line.clone()));
    }
    if e.file().is_empty() {
        out.push(("error without file", line.clone()));
    }
    if let SceneError::Invalid { path, .. } = e
        && path.is_empty()
    {
        out.push(("error without path", line.clone()));
    }
    // The file and the path repeat the input (a key may well be `u8`); the problem is ours.
    let ours = match e {
        SceneError::Io { source, .. } => source.to_string(),
        SceneError::Invalid { problem, .. } => problem.to_string(),
    };
    let words = rust_type_words(&ours);
    if !words.is_empty() {
        out.push(("Rust type words in error", format!("{words:?} in {line}")));
    }
    out
}

/// The documented caps and value ranges of an accepted scene.
pub(super) fn scene(s: &Scene) -> Vec<Violation> {
    let mut out = Vec::new();
    let mut ensure = |ok: bool, name: &'static str, detail: String| {
        if !ok {
            out.push((name, detail));
        }
    };
    let r = s.resolution;
    ensure(
        (1..=Resolution::MAX_DIMENSION).contains(&r.width)
            && (1..=Resolution::MAX_DIMENSION).contains(&r.height),
        "resolution out of range",
        format!("{}x{}", r.width, r.height),
    );
    ensure(
        s.triangle_count() as u64 <= MAX_TRIANGLES,
        "more triangles than MAX_TRIANGLES",
        s.triangle_count().to_string(),
    );
    ensure(
        s.background.iter().all(|c| c.is_finite() && *c >= 0.0),
        "background not finite or negative",
        format!("{:?}", s.background),
    );

    let c = &s.camera;
    ensure(
        c.view.is_finite() && c.proj.is_finite() && c.view_proj.is_finite(),
        "camera matrix not finite",
        format!("{c:?}"),
    );
    ensure(
        c.eye.is_finite() && c.target.is_finite() && c.up.is_finite(),
        "camera vectors not finite",
        format!("{c:?}"),
    );
    ensure(
        c.near.is_finite() && c.far.is_finite() && c.near < c.far,
        "near not before far",
        format!("{} {}", c.near, c.far),
    );
    match c.projection {
        Projection::Perspective { fov_y_degrees } => ensure(
            c.near > 0.0 && fov_y_degrees > 0.0 && fov_y_degrees < 180.0,
            "perspective near or fov out of range",
            format!("near {} fov {fov_y_degrees}", c.near),
        ),
        Projection::Orthographic { height } => ensure(
            height.is_finite() && height > 0.0,
            "orthographic height not positive",
            height.to_string(),
        ),
    }

    for (i, m) in s.materials.iter().enumerate() {
        let ok = m.base_color.iter().all(|c| c.is_finite() && *c >= 0.0)
            && (0.0..=1.0).contains(&m.alpha)
            && m.cutoff.is_finite()
            && m.cutoff >= 0.0
            && m.intensity.is_finite()
            && m.intensity >= 0.0
            && m.emissive.iter().all(|c| c.is_finite() && *c >= 0.0)
            && [m.base_texture, m.emissive_texture]
                .iter()
                .flatten()
                .all(|&t| (t as usize) < s.textures.len());
        ensure(
            ok,
            "material out of range",
            format!("materials[{i}]: {m:?}"),
        );
    }

    let mut texels = 0u64;
    for t in &s.textures {
        let level0 = u64::from(t.width()) * u64::from(t.height());
        texels += level0;
        let ok = (1..=MAX_TEXTURE_DIMENSION).contains(&t.width())
            && (1..=MAX_TEXTURE_DIMENSION).contains(&t.height())
            && t.is_consistent()
            && t.level_codes(0).len() as u64 == level0;
        ensure(
            ok,
            "texture out of range",
            format!("{} {}x{}", t.name, t.width(), t.height()),
        );
    }
    ensure(
        texels <= MAX_TEXELS,
        "more texels than MAX_TEXELS",
        texels.to_string(),
    );

    let mut covered = 0usize;
    for (i, d) in s.draws.iter().enumerate() {
        let end = d.first_vertex as usize + d.vertex_count as usize;
        let ok = d.id as usize == i
            && (d.material as usize) < s.materials.len()
            && d.vertex_count % 3 == 0
            && d.first_vertex as usize == covered
            && end <= s.vertices.len()
            && d.bounds_center.is_finite()
            && d.bounds_radius.is_finite()
            && d.bounds_radius >= 0.0;
        ensure(ok, "draw out of range", format!("draws[{i}]: {d:?}"));
        covered = end;
    }
    ensure(
        covered == s.vertices.len(),
        "vertices outside every draw",
        format!("{covered} of {}", s.vertices.len()),
    );
    if let Some((i, v)) = s.vertices.iter().enumerate().find(|(_, v)| {
        !(v.position.iter().all(|x| x.is_finite())
            && v.color.iter().all(|x| x.is_finite() && *x >= 0.0)
            && v.uv.iter().all(|x| x.is_finite() && x.abs() <= MAX_UV))
    }) {
        out.push(("vertex out of range", format!("vertices[{i}]: {v:?}")));
    }
    out
}
