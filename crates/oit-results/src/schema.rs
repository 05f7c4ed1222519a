//! The `results.json` contract (schema `oit-lab/results/v1`, docs/results-schema.md). Fields may
//! be added; none may change meaning without a new schema version.

use std::path::Path;

use serde::{Deserialize, Serialize};

pub const SCHEMA: &str = "oit-lab/results/v1";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Results {
    pub schema: String,
    /// The build of oit that wrote the file (absent in older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool: Option<ToolJson>,
    /// False while a comparison is running and when it was interrupted: then some requested
    /// runs are missing (`oit compare --resume` finishes them). Absent (true) in older files.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub complete: bool,
    pub adapter: AdapterJson,
    pub runs: Vec<Run>,
    /// Per scene, the floor: one blended pass over its transparent draws with the cheapest
    /// fragment work (`oit_gpu::Floor`), timed like a run.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub floors: Vec<FloorJson>,
    /// Per scene: its size on the GPU and where its content came from.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub scenes: Vec<SceneJson>,
    /// The part of a comparison this file holds (`oit compare --shard K/N`; absent for a whole
    /// comparison and in files written before 2026-12-06).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<ShardJson>,
    /// The shards `oit merge` made this file from, each with its adapter (absent unless merged):
    /// timings, and so cost ratios, compare only within one shard.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub merged: Vec<ShardJson>,
}

/// One shard of a comparison split with `oit compare --shard K/N` (docs/sharding.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardJson {
    /// K: 1 ≤ K ≤ `count`.
    pub index: u32,
    /// N: how many shards the comparison was split into.
    pub count: u32,
    /// Runs of the whole comparison (every shard together): scene × technique pairs, each made
    /// once per target format (`oit compare --target-format`).
    pub runs: u64,
    /// A hash (FNV-1a, hex) of the whole comparison's plan: every (scene, technique) in order
    /// and the options that change a run. Shards of one comparison have the same plan.
    pub plan: String,
    /// Whether the shard finished its runs (only in a merged file's `merged`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub complete: Option<bool>,
    /// The adapter that ran the shard (only in a merged file's `merged`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adapter: Option<AdapterJson>,
}

fn yes() -> bool {
    true
}

fn is_true(b: &bool) -> bool {
    *b
}

/// Which build of oit made a results file: `--resume` reuses only runs of the same build, so a
/// code change never leaves stale numbers beside new ones.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ToolJson {
    pub name: String,
    /// The crate version (`CARGO_PKG_VERSION`).
    pub version: String,
    /// [`ToolJson::build_id`]: changes with any change to the code or its build.
    pub build: String,
}

impl ToolJson {
    pub fn current() -> Self {
        ToolJson {
            name: "oit-lab".to_owned(),
            version: env!("CARGO_PKG_VERSION").to_owned(),
            build: Self::build_id(),
        }
    }

    /// A hash (FNV-1a, 64 bit, hex) of the running executable's bytes: the same for one
    /// binary wherever it runs, different after any rebuild that changed code. Computed once
    /// per process; `unknown` where the executable cannot be read.
    pub fn build_id() -> String {
        static ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();
        ID.get_or_init(|| {
            std::env::current_exe().and_then(std::fs::read).map_or_else(
                |_| "unknown".to_owned(),
                |bytes| format!("{:016x}", crate::fnv1a64_wide(&bytes)),
            )
        })
        .clone()
    }
}

/// What one scene brought to the run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneJson {
    pub scene: String,
    pub scene_file: String,
    /// What the scene tests, from its file (absent in older files).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    pub triangles: u64,
    /// GPU bytes of the uploaded scene that every technique shares (vertices, material table,
    /// textures); a run's `memory_bytes` is the technique's own on top of it.
    pub scene_bytes: u64,
    /// Of `scene_bytes`, the textures (RGBA f32 texels).
    pub texture_bytes: u64,
    /// Who made the content (glTF `asset.copyright`); reports show it with the scene.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub credits: Vec<String>,
    /// What the loader read but does not model (e.g. glTF extensions), one line each.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ignored: Vec<String>,
    /// Peak resident memory of the comparison's process while this scene ran (reference,
    /// uploads, every run, motion), in bytes; absent off Linux and in older files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peak_memory_bytes: Option<u64>,
}

impl SceneJson {
    /// The lines a report prints under the scene's heading.
    pub fn report_lines(&self) -> Vec<String> {
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        let mut out = vec![if self.texture_bytes > 0 {
            format!(
                "Scene: {} triangles, {:.1} MiB on the GPU shared by every technique ({:.1} MiB of textures)",
                self.triangles,
                mib(self.scene_bytes),
                mib(self.texture_bytes)
            )
        } else {
            format!(
                "Scene: {} triangles, {:.2} MiB on the GPU shared by every technique",
                self.triangles,
                mib(self.scene_bytes)
            )
        }];
        if let Some(peak) = self.peak_memory_bytes {
            out.push(format!(
                "Peak memory: {:.0} MiB resident while this scene ran (reference, uploads and every run)",
                mib(peak)
            ));
        }
        out.extend(note_lines(&self.credits, &self.ignored));
        out
    }
}

/// A scene's credit lines and what its loader read but does not model, as every command that
/// renders prints them (`Credits: …`, `Not modelled: …`).
pub fn note_lines(credits: &[String], ignored: &[String]) -> Vec<String> {
    (credits.iter())
        .map(|c| format!("Credits: {}", c.trim_end_matches('.')))
        .chain(ignored.iter().map(|i| format!("Not modelled: {i}")))
        .collect()
}

/// The floor of one scene in this run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FloorJson {
    pub scene: String,
    pub resolution: [u32; 2],
    /// The whole frame (opaque pass + floor pass), like every run's `gpu_ms`.
    pub gpu_ms: GpuMs,
    /// Per-pass medians (`opaque`, `floor`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub passes: Vec<PassMs>,
    /// The shard (K of `--shard K/N`) that timed this floor (absent when not sharded). A scene
    /// whose runs fell in two shards has a floor from each.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<u32>,
    /// The final colour target the floor was timed into (absent: `rgba16float`); a scene
    /// compared at several formats has a floor per format.
    #[serde(default, skip_serializing_if = "TargetFormat::is_default")]
    pub target_format: TargetFormat,
}

/// The format of the final colour target a run composited into (`oit compare
/// --target-format`): absent in results.json for the default, `rgba16float`, so files of
/// comparisons at the default read as before the field existed (2026-12-07).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TargetFormat {
    /// Linear 8-bit UNORM: clamps to [0, 1] and rounds to 1/255 at every blend.
    Rgba8Unorm,
    /// Half float, the default.
    #[default]
    Rgba16Float,
    /// Full float.
    Rgba32Float,
}

impl TargetFormat {
    /// Every format, in the order the command line lists them.
    pub const ALL: [TargetFormat; 3] = [
        TargetFormat::Rgba8Unorm,
        TargetFormat::Rgba16Float,
        TargetFormat::Rgba32Float,
    ];

    /// As on the command line and in results.json.
    pub fn name(self) -> &'static str {
        match self {
            TargetFormat::Rgba8Unorm => "rgba8unorm",
            TargetFormat::Rgba16Float => "rgba16float",
            TargetFormat::Rgba32Float => "rgba32float",
        }
    }

    /// The format named `text` (case-insensitive), or a message listing the allowed names.
    pub fn parse(text: &str) -> Result<TargetFormat, String> {
        let wanted = text.trim().to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .find(|f| f.name() == wanted)
            .ok_or_else(|| {
                format!(
                    "`{}` is not a target format; allowed: {}",
                    crate::report::printable(text),
                    Self::ALL.map(TargetFormat::name).join(", ")
                )
            })
    }

    pub fn is_default(&self) -> bool {
        *self == TargetFormat::default()
    }

    /// What output file stems get for this format: nothing for the default (file names as
    /// before the parameter existed), else `@NAME` (`sorted@rgba8unorm.exr`). `@` is never
    /// in a [`crate::file_stem`], so two formats, or a format and a technique, never share a
    /// file.
    pub fn file_suffix(self) -> String {
        if self.is_default() {
            String::new()
        } else {
            format!("@{}", self.name())
        }
    }
}

impl std::fmt::Display for TargetFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AdapterJson {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RunStatus {
    Ok,
    Skipped,
    Failed,
}

/// Median / min / max over the timed frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GpuMs {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    pub frames: u32,
    /// `timestamp` (GPU timestamp queries) or `wall-clock` (submit-and-wait; includes CPU work).
    pub source: String,
    /// The share of the machine's CPU time that was stolen or spent by other processes while
    /// the frames were timed (Linux only; absent elsewhere and in older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interference: Option<crate::interference::Interference>,
    /// Windows of frames timed, this one the quietest (`oit compare --retime`); 1 unless the
    /// first was noisy.
    #[serde(default = "one_attempt", skip_serializing_if = "is_one_attempt")]
    pub attempts: u32,
}

fn one_attempt() -> u32 {
    1
}

fn is_one_attempt(attempts: &u32) -> bool {
    *attempts == 1
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PassMs {
    pub name: String,
    pub median_ms: f64,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    pub geometry_passes: u32,
    pub layers_peeled: u64,
    pub pixels_with_dropped_layers: u64,
    /// Pixels where some layers were composited by an approximate tail rule (absent in
    /// results written before the field existed).
    #[serde(default)]
    pub pixels_with_approximated_layers: u64,
    /// The sizes `auto` parameters took from the technique's GPU count pass, and the bytes
    /// they use (absent for fixed sizes, and in files written before 2026-12-06).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub auto_sizes: Option<AutoSizes>,
    /// Wall-clock milliseconds of per-scene work done once before the frames (`ray-query`'s
    /// acceleration-structure build), not in `gpu_ms` (absent for other techniques).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub setup_ms: Option<f64>,
}

/// What `k-buffer:k=auto` and `linked-list:nodes-per-pixel=auto,sort-max=auto` counted and
/// chose (docs/results-schema.md, "auto_sizes"): the sizes of the run's last frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct AutoSizes {
    /// Transparent fragments in front of the opaque surface, all pixels together.
    pub fragments: u64,
    /// The deepest pixel's.
    pub max_per_pixel: u32,
    /// `k=auto`: slots per pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k: Option<u32>,
    /// `nodes-per-pixel=auto`: nodes in the pool.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pool_nodes: Option<u64>,
    /// `sort-max=auto`: fragments sorted per pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sort_max: Option<u32>,
    /// Bytes of the storage these sizes set: the k-buffer's slots, the list's node pool.
    pub sized_bytes: u64,
    /// Bytes the count pass keeps (4 per pixel and 48 more); part of `memory_bytes`.
    pub count_bytes: u64,
}

impl AutoSizes {
    /// One short phrase for tables, e.g. `k=5, slots 640.0 KiB`.
    pub fn summary(&self) -> String {
        let mut parts = Vec::new();
        if let Some(k) = self.k {
            parts.push(format!("k={k}"));
        }
        if let Some(nodes) = self.pool_nodes {
            parts.push(format!("nodes={nodes}"));
        }
        if let Some(sort) = self.sort_max {
            parts.push(format!("sort-max={sort}"));
        }
        let storage = if self.k.is_some() { "slots" } else { "pool" };
        parts.push(format!("{storage} {}", kib_or_mib(self.sized_bytes)));
        parts.join(", ")
    }
}

/// Bytes as KiB below 1 MiB, MiB above, one decimal.
fn kib_or_mib(bytes: u64) -> String {
    if bytes < 1 << 20 {
        format!("{:.1} KiB", bytes as f64 / 1024.0)
    } else {
        format!("{:.1} MiB", bytes as f64 / f64::from(1u32 << 20))
    }
}

/// Files written for one run, relative to the output directory.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Outputs {
    pub exr: String,
    pub render_png: String,
    pub diff_png: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Run {
    pub scene: String,
    pub scene_file: String,
    pub technique: String,
    pub resolution: [u32; 2],
    pub status: RunStatus,
    /// Why a run was skipped or failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_ms: Option<GpuMs>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub passes: Vec<PassMs>,
    /// CPU work per frame that the technique needs (e.g. sorting), median over timed frames.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cpu_ms: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub memory_bytes: Option<u64>,
    /// `memory_bytes` divided by the pixel count.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bytes_per_pixel: Option<f64>,
    /// Median GPU time divided by `unsorted`'s on the same scene in the same run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost_vs_unsorted: Option<f64>,
    /// Median GPU time divided by the scene's floor (`floors`) in the same run: how far the
    /// technique is from one blended pass with the cheapest fragment work.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost_vs_floor: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<oit_metrics::Errors>,
    /// Largest per-channel absolute difference between the render in draw order and the render
    /// with the draw order reversed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order_dependence: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stats: Option<Stats>,
    /// The frame's work in units every GPU shares (occlusion counts, stated bytes and
    /// atomics, triangles, full-screen passes), from a counted frame after the timed ones
    /// (absent in files written before 2026-12-06).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub counts: Option<crate::RunCounts>,
    /// Why this run's image is not the technique's exact answer, one short phrase each (e.g.
    /// `dropped layers on 1234 px`); empty when nothing was cut. Reports show it next to the
    /// numbers, never only in `stats`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inexact: Vec<String>,
    /// Pixels of the scene's reference holding a fragment whose α is within
    /// `oit_reference::CUTOFF_UNDECIDED_BOUND` of its cutoff: GPU interpolation rounding may
    /// decide them either way, and this run's error figures include them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub undecided_pixels: Option<u64>,
    /// Pixels of the scene's reference whose composite depends on two surfaces (or a surface
    /// and the far plane) within `oit_reference::PRECISION_TIE_ULPS` f32 ulps of window depth:
    /// rounding, not geometry, decides their order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub precision_tie_pixels: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outputs: Option<Outputs>,
    /// What the run was made from; `oit compare --resume` reuses a run only when these, the
    /// technique, the resolution and the adapter are all the same (absent in older files: such
    /// runs are never reused).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inputs: Option<RunInputs>,
    /// Taken from an earlier `oit compare` by `--resume` (its cost ratios were recomputed
    /// against this comparison's floor and baseline when the scene had new runs).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub resumed: bool,
    /// The run over every frame of an animated scene (absent for a still scene, and in files
    /// written before 2026-12-06).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temporal: Option<Temporal>,
    /// The shard (K of `--shard K/N`) that made this run (absent when not sharded): its cost
    /// ratios are against that shard's floor and `unsorted`, timed on the same machine.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<u32>,
    /// Whether the technique was predicted exact on the scene, and why, from its model of a
    /// pixel run on the reference's lists (`oit_gpu::predict`); absent where no prediction was
    /// made (`--no-predict`, runs not rendered, animated scenes, older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prediction: Option<PredictionRecord>,
    /// The scene parameter `oit compare --vary` set for this run's scene (absent otherwise,
    /// and in files written before 2026-12-06): runs of one sweep share `base_scene` and
    /// `parameter` and differ in `value`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub varied: Option<Varied>,
    /// The final colour target the technique composited into (`oit compare --target-format`;
    /// absent: `rgba16float`, the default, and in files written before 2026-12-07).
    #[serde(default, skip_serializing_if = "TargetFormat::is_default")]
    pub target_format: TargetFormat,
}

/// One value of a scene-parameter sweep (`oit compare --vary`, docs/results-schema.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Varied {
    /// The name of the scene the sweep derived this one from.
    pub base_scene: String,
    /// What was set: `resolution`, or a JSON pointer into the scene file
    /// (`/objects/0/mesh/count`).
    pub parameter: String,
    /// The parameter's short name, as in the derived scene's name (`base[count=16]`).
    pub label: String,
    /// The value as set in the derived scene (`16`, `0.5`, `256x256`).
    pub value: String,
    /// The value on the growth plots' x axis and in the fitted power law: the number set, or
    /// for `resolution` the pixel count (width × height).
    pub x: f64,
}

/// A run's prediction (docs/results-schema.md, "prediction").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PredictionRecord {
    /// `exact`, `inexact`, `borderline` (the model is within rounding of the bound, or
    /// rounding decides where it differs) or `unmodelled` (measured only).
    pub verdict: String,
    pub because: String,
    /// The model's largest difference from the exact composite, relative above 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modelled_error: Option<f64>,
    /// Whether the measured error agrees (`error.max_relative` against the exact bound);
    /// absent for borderline and unmodelled predictions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub agrees: Option<bool>,
}

/// A technique over the frames of an animated scene, each against the exact reference of that
/// frame (docs/results-schema.md, "temporal"; definitions in `oit_metrics::temporal`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Temporal {
    /// The frames rendered, in order (all of the animation unless a subset was asked for).
    pub frames: Vec<u32>,
    /// Per frame: RMSE of linear RGB, the headline ꟻLIP (`flip_name`) and the largest
    /// per-channel error.
    pub rmse: Vec<f64>,
    pub flip: Vec<f64>,
    pub flip_name: String,
    pub max_abs: Vec<f64>,
    /// Per frame after the first: mean |E_t − E_{t−1}| in display space.
    pub change: Vec<f64>,
    /// RMS of E_t − E_{t−1} over pixels, channels and consecutive frames.
    pub flicker: f64,
    /// Frames whose change exceeds `pop_multiple` × the median change and `pop_floor`.
    pub pop_events: Vec<u32>,
    pub pop_multiple: f64,
    pub pop_floor: f64,
    /// The frame with the largest headline ꟻLIP, and that value.
    pub worst_frame: u32,
    pub worst_flip: f64,
    pub mean_flip: f64,
    pub mean_rmse: f64,
    /// Largest order dependence over the frames (max |forward − reversed submission|).
    pub max_order_dependence: f64,
    /// Frames whose image holds dropped or approximated layers (the technique's own count).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inexact_frames: Vec<u32>,
    /// Frame 0 rendered `frames` times at its static camera with fresh per-frame noise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub static_camera: Option<StaticCamera>,
}

/// Bias and noise at a static camera, in the display space of ꟻLIP (`oit_metrics::temporal`):
/// `mse = bias_rmse² + noise_rms²`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StaticCamera {
    pub frames: u32,
    pub bias_rmse: f64,
    pub noise_rms: f64,
    pub mse: f64,
    /// RMSE of the exponential history (blend `history_blend`) after 1, 2, … frames.
    pub history_rmse: Vec<f64>,
    pub history_blend: f64,
    /// RMSE of the plain mean of the first 1, 2, … frames.
    pub mean_rmse: Vec<f64>,
}

/// The inputs of a run beyond its scene name, technique and resolution.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunInputs {
    /// `Scene::content_hash` of the scene as rendered (resolution applied), hex.
    pub scene_hash: String,
    pub frames: u32,
    pub warmup: u32,
    /// `--retime`: how many times a noisy window may be timed again (0 in older files).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub retime: u32,
    /// [`ToolJson::build_id`] of the build that made the run (empty in older files: such runs
    /// are never reused).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub build: String,
    /// An animated scene's motion measurement: the frames asked for, the static-camera
    /// renders and a hash of every selected frame's content (absent for a still scene), so a
    /// run is reused only for the same path.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<String>,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

/// What in a scene's reference rounding decides, one short phrase each; empty when nothing:
/// `undecided_pixels` hold a fragment on its cutoff's knife edge, `precision_tie_pixels` depend on
/// a precision tie. Shown once per scene in every report, beside the runs whose errors include
/// those pixels.
pub fn caveats(undecided_pixels: u64, precision_tie_pixels: u64) -> Vec<String> {
    let mut out = Vec::new();
    if undecided_pixels > 0 {
        out.push(format!(
            "{undecided_pixels} px hold a fragment on its cutoff's knife edge (|α − cutoff| ≤ 2^-16, wider where textured α moves with a rounded uv) or a nearest-filtered texel or mip level a rounded uv can change: rounding keeps or discards it, or picks its texel"
        ));
    }
    if precision_tie_pixels > 0 {
        out.push(format!(
            "{precision_tie_pixels} px depend on a precision tie (window depths within {} ulps): rounding orders them",
            oit_reference::PRECISION_TIE_ULPS
        ));
    }
    out
}

impl Stats {
    /// The `inexact` phrases these statistics imply.
    pub fn inexact(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.pixels_with_dropped_layers > 0 {
            out.push(format!(
                "dropped layers on {} px",
                self.pixels_with_dropped_layers
            ));
        }
        if self.pixels_with_approximated_layers > 0 {
            out.push(format!(
                "tail approximated on {} px",
                self.pixels_with_approximated_layers
            ));
        }
        out
    }
}

impl Run {
    /// [`caveats`] as recorded in this run.
    pub fn reference_caveats(&self) -> Vec<String> {
        caveats(
            self.undecided_pixels.unwrap_or(0),
            self.precision_tie_pixels.unwrap_or(0),
        )
    }

    /// A run that did not render, with the reason.
    pub fn not_rendered(
        scene: &str,
        scene_file: &str,
        technique: &str,
        resolution: [u32; 2],
        status: RunStatus,
        reason: String,
    ) -> Self {
        Run {
            scene: scene.to_owned(),
            scene_file: scene_file.to_owned(),
            technique: technique.to_owned(),
            resolution,
            status,
            reason: Some(reason),
            gpu_ms: None,
            passes: Vec::new(),
            cpu_ms: None,
            memory_bytes: None,
            bytes_per_pixel: None,
            cost_vs_unsorted: None,
            cost_vs_floor: None,
            error: None,
            order_dependence: None,
            stats: None,
            counts: None,
            inexact: Vec::new(),
            undecided_pixels: None,
            precision_tie_pixels: None,
            outputs: None,
            inputs: None,
            resumed: false,
            temporal: None,
            shard: None,
            prediction: None,
            varied: None,
            target_format: TargetFormat::default(),
        }
    }

    /// The run's technique as reports name it: the canonical spec, with ` @ FORMAT` when its
    /// target format is not the default, so runs of one technique at two formats are two
    /// rows (and two columns) of every table, like two parameter values.
    pub fn technique_label(&self) -> String {
        technique_label(&self.technique, self.target_format)
    }

    /// Whether this run is `technique` at `format`: within one scene and resolution, the
    /// pair names a run.
    pub fn is(&self, technique: &str, format: TargetFormat) -> bool {
        self.technique == technique && self.target_format == format
    }
}

/// [`Run::technique_label`] of `technique` at `format`.
pub fn technique_label(technique: &str, format: TargetFormat) -> String {
    if format.is_default() {
        technique.to_owned()
    } else {
        format!("{technique} @ {}", format.name())
    }
}

impl Results {
    /// Reads a results file. The schema is checked before anything else, so a file of
    /// another kind is named as such rather than by its first missing field.
    pub fn read(path: &Path) -> Result<Results, crate::ResultsError> {
        let invalid = |message: String| crate::ResultsError::Invalid {
            path: path.to_path_buf(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|source| crate::ResultsError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let value: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
            invalid(format!(
                "not JSON ({e}); a results file has schema `{SCHEMA}`"
            ))
        })?;
        match value.get("schema") {
            Some(serde_json::Value::String(s)) if s == SCHEMA => {}
            Some(serde_json::Value::String(s)) => {
                return Err(invalid(format!(
                    "schema is `{}`; this build reads `{SCHEMA}`",
                    crate::report::printable(s)
                )));
            }
            Some(_) => {
                return Err(invalid(format!(
                    "`schema` is not a string; this build reads `{SCHEMA}`"
                )));
            }
            None => {
                return Err(invalid(format!(
                    "no `schema` field: not an oit-lab results file (schema `{SCHEMA}`)"
                )));
            }
        }
        serde_json::from_value(value).map_err(|e| invalid(e.to_string()))
    }
}
