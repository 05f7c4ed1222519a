//! Prints a scene file's flattened `Scene` as JSON, for tools outside Rust (benches/peer/).
//!
//! ```text
//! cargo run --release -p oit-tools --bin flatten -- scenes/many-layers-64.json \
//!     --resolution 256x256 > flat.json
//! ```
//!
//! Output: `name`, `resolution` `[w, h]`, `reverse_z`, `background` `[r, g, b]`,
//! `view_proj`, `view` and `proj` (16 floats each, column-major, wgpu clip space), the camera's
//! `eye`/`target`/`up`/`fov_y` (or `ortho_height`)/`near`/`far`,
//! and `draws` in draw order, each with its `material` (as in `Material`) and its non-indexed
//! triangle list as `positions` (`[x, y, z]` world space) and `colors` (`[r, g, b, a]` linear).

use std::path::Path;
use std::process::ExitCode;

use oit_scene::{AlphaMode, Projection, Resolution, Scene};
use serde_json::{Value, json};

fn main() -> ExitCode {
    match run() {
        Ok(text) => {
            println!("{text}");
            ExitCode::SUCCESS
        }
        Err(msg) => {
            eprintln!("flatten: {msg}");
            eprintln!("usage: flatten SCENE.json [--resolution WxH]");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<String, String> {
    let mut args = std::env::args().skip(1);
    let mut path = None;
    let mut resolution = None;
    while let Some(arg) = args.next() {
        if arg == "--resolution" {
            let value = args.next().ok_or("--resolution needs a value")?;
            resolution = Some(parse_resolution(&value)?);
        } else if path.is_none() {
            path = Some(arg);
        } else {
            return Err(format!("unexpected argument {arg:?}"));
        }
    }
    let path = path.ok_or("no scene file given")?;
    let mut scene = oit_scene::load(Path::new(&path)).map_err(|e| e.to_string())?;
    if let Some(r) = resolution {
        scene = scene.with_resolution(r);
    }
    serde_json::to_string(&to_json(&scene)).map_err(|e| e.to_string())
}

fn parse_resolution(s: &str) -> Result<Resolution, String> {
    let bad = || format!("--resolution {s:?}: expected WxH, e.g. 256x256");
    let (w, h) = s.split_once('x').ok_or_else(bad)?;
    let width: u32 = w.parse().map_err(|_| bad())?;
    let height: u32 = h.parse().map_err(|_| bad())?;
    let ok = 1..=Resolution::MAX_DIMENSION;
    if !ok.contains(&width) || !ok.contains(&height) {
        return Err(format!(
            "{}; each side 1 to {}",
            bad(),
            Resolution::MAX_DIMENSION
        ));
    }
    Ok(Resolution { width, height })
}

fn mode_name(mode: AlphaMode) -> &'static str {
    match mode {
        AlphaMode::Opaque => "opaque",
        AlphaMode::Mask => "mask",
        AlphaMode::Blend => "blend",
        AlphaMode::MaskBlend => "mask-blend",
    }
}

fn to_json(scene: &Scene) -> Value {
    let cam = &scene.camera;
    let (fov_y, ortho_height) = match cam.projection {
        Projection::Perspective { fov_y_degrees } => (Some(fov_y_degrees), None),
        Projection::Orthographic { height } => (None, Some(height)),
    };
    let draws: Vec<Value> = scene
        .draws
        .iter()
        .map(|d| {
            let m = scene.material_of(d);
            let verts = &scene.vertices[d.vertex_range()];
            json!({
                "id": d.id,
                "name": d.name,
                "material": {
                    "base_color": m.base_color,
                    "alpha": m.alpha,
                    "mode": mode_name(m.mode),
                    "cutoff": m.cutoff,
                    "premultiplied": m.premultiplied,
                    "intensity": m.intensity,
                    "double_sided": m.double_sided,
                },
                "positions": verts.iter().map(|v| v.position).collect::<Vec<_>>(),
                "colors": verts.iter().map(|v| v.color).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "name": scene.name,
        "resolution": [scene.resolution.width, scene.resolution.height],
        "reverse_z": cam.reverse_z,
        "background": scene.background,
        "view_proj": cam.view_proj.to_cols_array(),
        "view": cam.view.to_cols_array(),
        "proj": cam.proj.to_cols_array(),
        "eye": cam.eye.to_array(),
        "target": cam.target.to_array(),
        "up": cam.up.to_array(),
        "fov_y": fov_y,
        "ortho_height": ortho_height,
        "near": cam.near,
        "far": cam.far,
        "draws": draws,
    })
}
