//! Scene-parameter sweeps (`oit compare --vary PATH=VALUES`): one scene file becomes one
//! derived scene per value, named `NAME[LABEL=VALUE]`, so a comparison measures how cost and
//! error grow with the work (a layer count, an α, the resolution).
//!
//! `PATH` is `resolution` or a JSON pointer (RFC 6901) to a number in a JSON scene file, e.g.
//! `/objects/0/mesh/count`; a pointer to a field the file leaves at its default may name it in
//! an existing object (`/objects/0/material/alpha`). `VALUES` is a comma-separated list of
//! numbers and ranges: `a..b` (whole numbers, step 1, inclusive), `a..b:+S` (step S) and
//! `a..b:xK` (times K, a > 0, K > 1); for `resolution` a value is `N` (N×N) or `WxH`. Every
//! derived scene is loaded by the normal scene loader before anything runs, so a bad value is
//! the loader's error naming the field.

use oit_results::{Run, Varied};
use oit_scene::Resolution;

use crate::{HarnessError, SceneEntry};

/// Most values one `--vary` may expand to: a typo such as `1..1000000` must be an error, not
/// a million scenes. (The runs of the whole comparison are bounded again by `--max-runs`.)
pub const MAX_SCENE_SWEEP_VALUES: u64 = 1024;

/// What a sweep sets.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Parameter {
    /// The scene's resolution (width and height).
    Resolution,
    /// A JSON pointer to a number in a JSON scene file.
    Pointer(String),
}

impl Parameter {
    /// As written on the command line and in results.json.
    pub fn text(&self) -> &str {
        match self {
            Parameter::Resolution => "resolution",
            Parameter::Pointer(p) => p,
        }
    }

    /// The short name in a derived scene's name: `resolution`, or the pointer's last
    /// segment (`count` for `/objects/0/mesh/count`).
    pub fn label(&self) -> String {
        match self {
            Parameter::Resolution => "resolution".to_owned(),
            Parameter::Pointer(p) => unescape(p.rsplit('/').next().unwrap_or(p)),
        }
    }
}

/// One `--vary`: the parameter and its values, expanded, in order, each once.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSweep {
    pub parameter: Parameter,
    /// The short name in derived scene names ([`Parameter::label`], or the whole pointer
    /// when two sweeps of a comparison would share it).
    pub label: String,
    pub values: Vec<SweepValue>,
}

/// One value of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub enum SweepValue {
    Number(f64),
    Resolution(Resolution),
}

impl SweepValue {
    /// As written in the derived scene's name and in results.json.
    pub fn text(&self) -> String {
        match self {
            SweepValue::Number(v) => number_text(*v),
            SweepValue::Resolution(r) => r.to_string(),
        }
    }

    /// The growth plots' x: the number, or a resolution's pixel count.
    pub fn x(&self) -> f64 {
        match self {
            SweepValue::Number(v) => *v,
            SweepValue::Resolution(r) => r.pixel_count() as f64,
        }
    }
}

/// Parses every `--vary`, validating and bounding each before expanding it; two sweeps whose
/// pointers end in the same name are labelled by their whole pointers.
pub fn parse_scene_sweeps(texts: &[String]) -> Result<Vec<SceneSweep>, HarnessError> {
    let mut sweeps = texts
        .iter()
        .map(|t| parse_scene_sweep(t))
        .collect::<Result<Vec<_>, _>>()?;
    let labels: Vec<(String, Parameter)> = sweeps
        .iter()
        .map(|s| (s.label.clone(), s.parameter.clone()))
        .collect();
    for sweep in &mut sweeps {
        if labels
            .iter()
            .any(|(l, p)| *l == sweep.label && *p != sweep.parameter)
        {
            sweep.label = sweep.parameter.text().to_owned();
        }
    }
    Ok(sweeps)
}

/// Parses one `--vary PATH=VALUES` ([module documentation](self)).
pub fn parse_scene_sweep(text: &str) -> Result<SceneSweep, HarnessError> {
    let bad = |why: String| HarnessError::Options(format!("--vary `{text}`: {why}"));
    let (path, list) = text.split_once('=').ok_or_else(|| {
        bad(
            "expected PATH=VALUES, e.g. `/objects/0/mesh/count=1..256:x2` or `resolution=128,256`"
                .into(),
        )
    })?;
    let path = path.trim();
    let parameter = if path == "resolution" {
        Parameter::Resolution
    } else if path.starts_with('/') && path.len() > 1 {
        Parameter::Pointer(path.to_owned())
    } else {
        return Err(bad(format!(
            "`{path}` is neither `resolution` nor a JSON pointer into the scene file (it starts with `/`, e.g. `/objects/0/mesh/count`)"
        )));
    };
    let items: Vec<&str> = list.split(',').map(str::trim).collect();
    // Bounded before anything is expanded.
    let mut count: u64 = 0;
    for item in &items {
        count = count.saturating_add(item_count(item, &parameter).map_err(&bad)?);
    }
    if count > MAX_SCENE_SWEEP_VALUES {
        return Err(bad(format!(
            "expands to {count} values; at most {MAX_SCENE_SWEEP_VALUES} per sweep (narrow the ranges)"
        )));
    }
    let mut values: Vec<SweepValue> = Vec::new();
    for item in &items {
        for value in expand_item(item, &parameter).map_err(&bad)? {
            if !values.contains(&value) {
                values.push(value);
            }
        }
    }
    Ok(SceneSweep {
        label: parameter.label(),
        parameter,
        values,
    })
}

/// A range's parts: start, end and step.
enum Step {
    /// `a..b`: whole numbers.
    One,
    /// `a..b:+S`.
    Add(f64),
    /// `a..b:xK`.
    Times(f64),
}

fn parse_range(item: &str) -> Result<Option<(f64, f64, Step)>, String> {
    let Some((a, rest)) = item.split_once("..") else {
        return Ok(None);
    };
    let (b, step) = match rest.split_once(':') {
        None => (rest, Step::One),
        Some((b, s)) => {
            let step = if let Some(k) = s.strip_prefix(['x', 'X', '*']) {
                Step::Times(number(k, "factor")?)
            } else if let Some(d) = s.strip_prefix('+') {
                Step::Add(number(d, "step")?)
            } else {
                return Err(format!(
                    "`{item}`: a range's step is `:+STEP` or `:xFACTOR` (e.g. `1..256:x2`)"
                ));
            };
            (b, step)
        }
    };
    let (a, b) = (number(a, "range start")?, number(b, "range end")?);
    if a > b {
        return Err(format!("`{item}`: the range ends before it starts"));
    }
    match step {
        Step::One if a.fract() != 0.0 || b.fract() != 0.0 => Err(format!(
            "`{item}`: a range without a step takes whole numbers; add `:+STEP` or `:xFACTOR`"
        )),
        Step::Add(s) if s <= 0.0 => Err(format!("`{item}`: the step must be positive")),
        Step::Times(k) if k <= 1.0 => Err(format!("`{item}`: the factor must be above 1")),
        Step::Times(_) if a <= 0.0 => Err(format!("`{item}`: a range of factors starts above 0")),
        step => Ok(Some((a, b, step))),
    }
}

fn number(text: &str, what: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("{what} `{text}` is not a finite number")),
    }
}

/// How many values `item` expands to, without expanding it.
fn item_count(item: &str, parameter: &Parameter) -> Result<u64, String> {
    let Some((a, b, step)) = parse_range(item)? else {
        return Ok(1);
    };
    let n = match step {
        Step::One => b - a + 1.0,
        Step::Add(s) => ((b - a) / s + 1e-9).floor() + 1.0,
        Step::Times(k) => ((b / a).ln() / k.ln() + 1e-9).floor() + 1.0,
    };
    if *parameter == Parameter::Resolution && (a.fract() != 0.0 || a < 1.0) {
        return Err(format!(
            "`{item}`: a resolution is a whole number of pixels"
        ));
    }
    Ok(if n.is_finite() && n < 1e18 {
        n as u64
    } else {
        u64::MAX
    })
}

fn expand_item(item: &str, parameter: &Parameter) -> Result<Vec<SweepValue>, String> {
    let numbers: Vec<f64> = match parse_range(item)? {
        None if *parameter == Parameter::Resolution && item.contains(['x', 'X']) => {
            return Ok(vec![SweepValue::Resolution(resolution(item)?)]);
        }
        None => vec![number(item, "value")?],
        Some((a, b, step)) => {
            let mut out = Vec::new();
            let mut i = 0.0;
            loop {
                let v = match step {
                    Step::One => a + i,
                    Step::Add(s) => a + i * s,
                    Step::Times(k) => a * k.powf(i),
                };
                if v > b * (1.0 + 1e-9) + 1e-12 {
                    break;
                }
                out.push(round_12(v));
                i += 1.0;
            }
            out
        }
    };
    match parameter {
        Parameter::Pointer(_) => Ok(numbers.into_iter().map(SweepValue::Number).collect()),
        Parameter::Resolution => numbers
            .into_iter()
            .map(|n| {
                let text = number_text(n);
                resolution(&format!("{text}x{text}")).map(SweepValue::Resolution)
            })
            .collect(),
    }
}

/// `WxH`, each from 1 to [`Resolution::MAX_DIMENSION`], as `--resolution` reads it.
fn resolution(text: &str) -> Result<Resolution, String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{text}` is not WIDTHxHEIGHT"))?;
    let side = |v: &str| -> Result<u32, String> {
        match v.trim().parse::<u32>() {
            Ok(n) if (1..=Resolution::MAX_DIMENSION).contains(&n) => Ok(n),
            _ => Err(format!(
                "resolution `{text}`: `{v}` is not a whole number of pixels from 1 to {}",
                Resolution::MAX_DIMENSION
            )),
        }
    };
    Ok(Resolution {
        width: side(w)?,
        height: side(h)?,
    })
}

/// `v` to 12 significant digits: `0.1..0.5:+0.1` gives 0.3, not 0.30000000000000004.
fn round_12(v: f64) -> f64 {
    format!("{v:.11e}").parse().unwrap_or(v)
}

/// A number as the shortest text that reads back as it (whole numbers without `.0`).
fn number_text(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

/// A pointer segment's `~1` and `~0` as `/` and `~` (RFC 6901).
fn unescape(segment: &str) -> String {
    segment.replace("~1", "/").replace("~0", "~")
}

/// The scenes a comparison runs: `entries` unchanged when there are no sweeps; otherwise, for
/// each entry and each sweep, one derived scene per value (in that order), each loaded by the
/// normal scene loader, so every value is validated before anything runs.
pub fn vary_scenes(
    entries: Vec<SceneEntry>,
    sweeps: &[SceneSweep],
) -> Result<Vec<SceneEntry>, HarnessError> {
    if sweeps.is_empty() {
        return Ok(entries);
    }
    let mut out = Vec::new();
    for entry in &entries {
        let json = if oit_scene::is_gltf_path(&entry.path) {
            None
        } else {
            let text = std::fs::read_to_string(&entry.path)
                .map_err(|e| HarnessError::io(&entry.path, e))?;
            let text = text.strip_prefix('\u{feff}').unwrap_or(&text).to_owned();
            let value: serde_json::Value =
                serde_json::from_str(&text).map_err(|e| HarnessError::Invalid {
                    path: entry.path.clone(),
                    message: format!("not JSON: {e}"),
                })?;
            Some(value)
        };
        for sweep in sweeps {
            for value in &sweep.values {
                out.push(derive(entry, json.as_ref(), sweep, value)?);
            }
        }
    }
    Ok(out)
}

/// `entry` with `sweep`'s parameter set to `value`.
fn derive(
    entry: &SceneEntry,
    json: Option<&serde_json::Value>,
    sweep: &SceneSweep,
    value: &SweepValue,
) -> Result<SceneEntry, HarnessError> {
    let file = entry.path.display().to_string();
    let name = format!("{}[{}={}]", entry.scene.name, sweep.label, value.text());
    // The loader's messages name the file; the others get it here.
    let context = |why: String| {
        let why = if why.starts_with(file.as_str()) {
            why
        } else {
            format!("{file}: {why}")
        };
        HarnessError::Options(format!(
            "--vary {}={}: {why}",
            sweep.parameter.text(),
            value.text()
        ))
    };
    let varied = Varied {
        base_scene: entry.scene.name.clone(),
        parameter: sweep.parameter.text().to_owned(),
        label: sweep.label.clone(),
        value: value.text(),
        x: value.x(),
    };
    let Some(json) = json else {
        // A glTF file: only its resolution is a parameter here.
        let SweepValue::Resolution(r) = value else {
            return Err(context(
                "a glTF file has no scene-file fields to set; only `resolution` varies it (or wrap it in a JSON scene, docs/scene-format.md)".into(),
            ));
        };
        if entry.frames.is_some() {
            return Err(context(
                "an animated glTF file's resolution cannot vary (wrap it in a JSON scene, or use --resolution)".into(),
            ));
        }
        let mut scene = entry.scene.with_resolution(*r);
        scene.name = name;
        return Ok(SceneEntry {
            scene,
            varied: Some(varied),
            ..entry.clone()
        });
    };
    let mut json = json.clone();
    set(&mut json, sweep, value).map_err(context)?;
    if let Some(object) = json.as_object_mut() {
        object.insert("name".to_owned(), serde_json::Value::String(name));
    }
    let text = serde_json::to_string(&json).map_err(|e| context(e.to_string()))?;
    let frames = oit_scene::parse_frames(&text, &file).map_err(|e| context(e.to_string()))?;
    let scene = frames.frame(0).map_err(|e| context(e.to_string()))?;
    let frames = frames.animation().map(|_| std::rc::Rc::new(frames));
    Ok(SceneEntry {
        path: entry.path.clone(),
        scene,
        inputs: entry.inputs.clone(),
        frames,
        varied: Some(varied),
    })
}

/// Writes `value` at the sweep's place in the scene file's JSON: the pointer's number, or
/// `resolution` (added when the file leaves it at its default).
fn set(json: &mut serde_json::Value, sweep: &SceneSweep, value: &SweepValue) -> Result<(), String> {
    let (pointer, new) = match (&sweep.parameter, value) {
        (Parameter::Resolution, SweepValue::Resolution(r)) => {
            ("/resolution", serde_json::json!([r.width, r.height]))
        }
        (Parameter::Pointer(p), SweepValue::Number(v)) => (p.as_str(), json_number(*v)?),
        _ => return Err("the value does not fit the parameter".into()),
    };
    if let Some(target) = json.pointer_mut(pointer) {
        if !(target.is_number() || pointer == "/resolution") {
            return Err(format!(
                "`{pointer}` is {}, not a number: --vary sets numbers",
                kind(target)
            ));
        }
        *target = new;
        return Ok(());
    }
    // Not in the file: a field left at its default, named in an object that is.
    let (parent, key) = pointer.rsplit_once('/').unwrap_or(("", pointer));
    match json.pointer_mut(parent) {
        Some(serde_json::Value::Object(object)) => {
            object.insert(unescape(key), new);
            Ok(())
        }
        Some(other) => Err(format!(
            "`{pointer}` is not in the file, and `{}` is {}, not an object",
            if parent.is_empty() { "/" } else { parent },
            kind(other)
        )),
        None => Err(format!(
            "`{pointer}` is not in the file (nor is `{parent}`): a pointer names fields from the root, e.g. `/objects/0/mesh/count`"
        )),
    }
}

fn json_number(v: f64) -> Result<serde_json::Value, String> {
    if v.fract() == 0.0 && v.abs() < 9.0e15 {
        return Ok(serde_json::Value::from(v as i64));
    }
    serde_json::Number::from_f64(v)
        .map(serde_json::Value::Number)
        .ok_or_else(|| format!("{v} is not a finite number"))
}

fn kind(v: &serde_json::Value) -> &'static str {
    match v {
        serde_json::Value::Null => "null",
        serde_json::Value::Bool(_) => "a boolean",
        serde_json::Value::Number(_) => "a number",
        serde_json::Value::String(_) => "a string",
        serde_json::Value::Array(_) => "an array",
        serde_json::Value::Object(_) => "an object",
    }
}

/// Records the sweep value of `entry` (if any) in its runs.
pub fn tag(runs: &mut [Run], entry: &SceneEntry) {
    if let Some(varied) = &entry.varied {
        for run in runs {
            run.varied = Some(varied.clone());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numbers(text: &str) -> Vec<String> {
        parse_scene_sweep(text)
            .unwrap()
            .values
            .iter()
            .map(SweepValue::text)
            .collect()
    }

    fn error(text: &str) -> String {
        parse_scene_sweep(text).unwrap_err().to_string()
    }

    #[test]
    fn lists_and_ranges_expand_in_order_once_each() {
        assert_eq!(numbers("/a/count=1,2,4"), ["1", "2", "4"]);
        assert_eq!(numbers("/a/count=3..6"), ["3", "4", "5", "6"]);
        assert_eq!(
            numbers("/a/count=1..256:x2"),
            ["1", "2", "4", "8", "16", "32", "64", "128", "256"]
        );
        // The end need not be on the grid; duplicates between items are dropped.
        assert_eq!(numbers("/a/count=1..100:x4,4,1"), ["1", "4", "16", "64"]);
        assert_eq!(
            numbers("/a/alpha=0.1..0.5:+0.1"),
            ["0.1", "0.2", "0.3", "0.4", "0.5"]
        );
        assert_eq!(numbers("/a/alpha=0.25"), ["0.25"]);
        let sweep = parse_scene_sweep("/objects/0/mesh/count=1..8:x2").unwrap();
        assert_eq!(sweep.label, "count");
        assert_eq!(
            sweep.parameter,
            Parameter::Pointer("/objects/0/mesh/count".into())
        );
        assert_eq!(sweep.values[3].x(), 8.0);
    }

    #[test]
    fn resolutions_are_squares_or_width_by_height_and_x_is_the_pixel_count() {
        let sweep = parse_scene_sweep("resolution=128..512:x2,640x480").unwrap();
        let texts: Vec<String> = sweep.values.iter().map(SweepValue::text).collect();
        assert_eq!(texts, ["128x128", "256x256", "512x512", "640x480"]);
        assert_eq!(sweep.values[1].x(), 65536.0);
        assert_eq!(sweep.label, "resolution");
        assert!(
            error("resolution=0").contains("1 to 8192"),
            "{}",
            error("resolution=0")
        );
        assert!(error("resolution=9000x10").contains("`9000`"));
        assert!(error("resolution=1.5..4:x2").contains("whole number"));
    }

    #[test]
    fn bad_sweeps_are_named_errors() {
        for (text, says) in [
            ("count=1,2", "JSON pointer"),
            ("/a/count", "PATH=VALUES"),
            ("/a/count=1,x", "`x` is not a finite number"),
            ("/a/count=4..1", "ends before it starts"),
            ("/a/count=1..2:x1", "factor must be above 1"),
            ("/a/count=0..8:x2", "starts above 0"),
            ("/a/count=0..1:+0", "step must be positive"),
            ("/a/count=0.5..2", "whole numbers"),
            ("/a/count=1..2:y3", ":+STEP"),
            ("/a/count=inf", "finite"),
        ] {
            let e = error(text);
            assert!(e.contains(says) && e.contains(text), "{text}: {e}");
        }
    }

    /// A huge sweep is refused before it is expanded.
    #[test]
    fn sweeps_are_bounded_before_they_expand() {
        let start = std::time::Instant::now();
        let e = error("/a/count=1..100000000000");
        assert!(
            e.contains("100000000000") && e.contains("at most 1024"),
            "{e}"
        );
        let e = error("/a/alpha=0..1:+1e-12");
        assert!(e.contains("at most 1024"), "{e}");
        assert!(start.elapsed().as_secs() < 2);
        assert_eq!(numbers("/a/count=1..1024").len(), 1024);
    }

    #[test]
    fn two_sweeps_ending_in_one_name_are_labelled_by_their_pointers() {
        let sweeps = parse_scene_sweeps(&[
            "/objects/0/mesh/count=1,2".into(),
            "/objects/1/mesh/count=3".into(),
            "resolution=64".into(),
        ])
        .unwrap();
        let labels: Vec<&str> = sweeps.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(
            labels,
            [
                "/objects/0/mesh/count",
                "/objects/1/mesh/count",
                "resolution"
            ]
        );
    }

    fn entry(json: &str) -> (tempdir::Dir, SceneEntry) {
        let dir = tempdir::Dir::new();
        let path = dir.0.join("stack.json");
        std::fs::write(&path, json).unwrap();
        let entry = SceneEntry::load(&path, &oit_scene::LoadOptions::default()).unwrap();
        (dir, entry)
    }

    /// A one-object scene whose generated content the seed decides: the sweep must not
    /// depend on the scene's particulars.
    fn stack(seed: u64) -> String {
        let alpha = 0.1 + (seed % 7) as f64 * 0.1;
        format!(
            r#"{{"name": "stack-{seed}", "resolution": [32, 32],
               "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "fov_y": 45}},
               "objects": [{{"mesh": {{"kind": "layers", "count": {}, "size": [8, 8],
                             "alpha_from": {alpha}, "alpha_to": {alpha}}},
                             "material": {{"mode": "blend"}}}}]}}"#,
            1 + seed % 5
        )
    }

    #[test]
    fn each_value_makes_a_named_scene_with_the_parameter_set_and_recorded() {
        for seed in 0..4 {
            let (_dir, base) = entry(&stack(seed));
            let sweeps = parse_scene_sweeps(&[
                "/objects/0/mesh/count=1..8:x2".into(),
                "resolution=16,24x8".into(),
            ])
            .unwrap();
            let scenes = vary_scenes(vec![base.clone()], &sweeps).unwrap();
            let names: Vec<&str> = scenes.iter().map(|e| e.scene.name.as_str()).collect();
            let base_name = format!("stack-{seed}");
            assert_eq!(
                names,
                [
                    format!("{base_name}[count=1]"),
                    format!("{base_name}[count=2]"),
                    format!("{base_name}[count=4]"),
                    format!("{base_name}[count=8]"),
                    format!("{base_name}[resolution=16x16]"),
                    format!("{base_name}[resolution=24x8]"),
                ]
            );
            // One draw per layer: the count reached the mesh.
            let draws: Vec<usize> = scenes[..4].iter().map(|e| e.scene.draws.len()).collect();
            assert_eq!(draws, [1, 2, 4, 8]);
            assert_eq!(scenes[5].scene.resolution.to_string(), "24x8");
            assert_eq!(scenes[5].scene.draws.len(), base.scene.draws.len());
            let v = scenes[2].varied.as_ref().unwrap();
            assert_eq!(
                (
                    v.base_scene.as_str(),
                    v.parameter.as_str(),
                    v.label.as_str()
                ),
                (base_name.as_str(), "/objects/0/mesh/count", "count")
            );
            assert_eq!((v.value.as_str(), v.x), ("4", 4.0));
            assert_eq!(scenes[4].varied.as_ref().unwrap().x, 256.0);
            let mut runs = vec![Run::not_rendered(
                "s",
                "f",
                "unsorted",
                [1, 1],
                oit_results::RunStatus::Ok,
                String::new(),
            )];
            tag(&mut runs, &scenes[2]);
            assert_eq!(runs[0].varied.as_ref(), Some(v));
        }
    }

    #[test]
    fn a_field_left_at_its_default_can_be_set_and_a_bad_value_names_the_field() {
        let (_dir, base) = entry(&stack(1));
        let sweeps = parse_scene_sweeps(&["/objects/0/material/alpha=0.25,0.5".into()]).unwrap();
        let scenes = vary_scenes(vec![base.clone()], &sweeps).unwrap();
        assert_eq!(scenes[0].scene.name, "stack-1[alpha=0.25]");
        assert_ne!(
            scenes[0].scene.content_hash(),
            scenes[1].scene.content_hash()
        );

        let fail = |text: &str| {
            let sweeps = parse_scene_sweeps(&[text.into()]).unwrap();
            vary_scenes(vec![base.clone()], &sweeps)
                .unwrap_err()
                .to_string()
        };
        // The loader's own message names the field and what is allowed.
        let e = fail("/objects/0/mesh/count=0");
        assert!(
            e.contains("--vary /objects/0/mesh/count=0") && e.contains("count"),
            "{e}"
        );
        assert!(e.contains("stack.json"), "{e}");
        let e = fail("/objects/0/mesh/count=1.5");
        assert!(e.contains("count"), "{e}");
        let e = fail("/objects/0/mesh/kind=3");
        assert!(e.contains("is a string, not a number"), "{e}");
        let e = fail("/objects/0/mesh/layerz=3");
        assert!(e.contains("layerz"), "{e}");
        let e = fail("/objects/7/mesh/count=3");
        assert!(e.contains("not in the file"), "{e}");
    }

    /// Without sweeps the scenes are the ones read.
    #[test]
    fn no_sweep_keeps_the_scenes() {
        let (_dir, base) = entry(&stack(2));
        let scenes = vary_scenes(vec![base.clone()], &[]).unwrap();
        assert_eq!(scenes.len(), 1);
        assert_eq!(scenes[0].scene.name, "stack-2");
        assert!(scenes[0].varied.is_none());
    }

    /// A private temporary folder, removed on drop (no extra dependency).
    mod tempdir {
        pub struct Dir(pub std::path::PathBuf);

        impl Dir {
            pub fn new() -> Self {
                static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
                let n = N.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                let dir = std::env::temp_dir().join(format!("oit-vary-{}-{n}", std::process::id()));
                std::fs::create_dir_all(&dir).unwrap();
                Dir(dir)
            }
        }

        impl Drop for Dir {
            fn drop(&mut self) {
                let _ = std::fs::remove_dir_all(&self.0);
            }
        }
    }
}
