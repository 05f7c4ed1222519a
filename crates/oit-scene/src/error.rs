//! Scene loading errors. Every error names the file, the JSON path of the offending value and
//! what would have been accepted, on one line, so a user can fix a scene without reading code.

use crate::format::MAX_TRIANGLES;
use crate::scene::Resolution;

/// A scene file could not be read, parsed or validated.
///
/// Display is one line: `<file>: <json path>: <problem>; allowed: <what is allowed>`.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file or directory could not be read.
    #[error("{}", one_line(format_args!("{file}: cannot read: {source}; allowed: a readable UTF-8 JSON file")))]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// The file was read but a value in it is not acceptable.
    #[error("{}", one_line(format_args!("{file}: {path}: {problem}")))]
    Invalid {
        file: String,
        /// JSON path like `objects[3].material.alpha` (`(root)` for the whole document).
        path: String,
        problem: Problem,
    },
}

/// `text` with control characters written as JSON escapes (`\n`, `\u0000`): messages quote
/// field names, values and URIs from the file, and must stay one line.
fn one_line(text: std::fmt::Arguments) -> String {
    let text = text.to_string();
    if !text.chars().any(char::is_control) {
        return text;
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if c.is_control() => out.push_str(&format!("\\u{:04x}", u32::from(c))),
            c => out.push(c),
        }
    }
    out
}

impl SceneError {
    /// The JSON path of the offending value (`None` for I/O errors).
    pub fn path(&self) -> Option<&str> {
        match self {
            SceneError::Io { .. } => None,
            SceneError::Invalid { path, .. } => Some(path),
        }
    }

    /// What is wrong with the value (`None` for I/O errors).
    pub fn problem(&self) -> Option<&Problem> {
        match self {
            SceneError::Io { .. } => None,
            SceneError::Invalid { problem, .. } => Some(problem),
        }
    }

    /// The same error, its path marked as a value of frame `t` derived from `source` (the
    /// keyframes, a glTF animation): the frame's own values are nowhere in the file.
    pub fn at_frame(self, t: u32, source: &str) -> SceneError {
        match self {
            SceneError::Invalid {
                file,
                path,
                problem,
            } => SceneError::Invalid {
                file,
                path: format!("{path} (at frame {t}, from {source})"),
                problem,
            },
            other => other,
        }
    }

    /// The file name the error refers to.
    pub fn file(&self) -> &str {
        match self {
            SceneError::Io { file, .. } | SceneError::Invalid { file, .. } => file,
        }
    }
}

/// One class of invalid input. Each class has its own variant so tests (and tools) can tell them
/// apart; the Display text is `<problem>; allowed: <what is allowed>`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Problem {
    #[error(
        "invalid JSON at line {line}, column {column}: {message}; allowed: standard JSON (no comments, no trailing commas, no NaN or Infinity)"
    )]
    Syntax {
        line: usize,
        column: usize,
        message: String,
    },
    #[error("unknown field `{field}`; allowed: {expected}")]
    UnknownField { field: String, expected: String },
    #[error("unknown value `{value}`; allowed: {expected}")]
    UnknownVariant { value: String, expected: String },
    #[error(
        "missing required field `{field}`; allowed: see docs/scene-format.md for required fields"
    )]
    MissingField { field: String },
    #[error("{found}; allowed: {expected}")]
    WrongType { found: String, expected: String },
    #[error(
        "{value} is not a finite number; allowed: finite numbers that fit in f32 (|x| < 3.4e38, no NaN, no infinity)"
    )]
    NonFinite { value: String },
    #[error(
        "{what} is not finite after applying it; allowed: transforms and values whose results fit in f32"
    )]
    DerivedNonFinite { what: String },
    #[error("{value} is outside [0, 1]; allowed: alpha in [0, 1]")]
    AlphaOutOfRange { value: f32 },
    #[error("{value} is outside [0, 1]; allowed: cutoff in [0, 1]")]
    CutoffOutOfRange { value: f32 },
    #[error("{value} is negative; allowed: intensity >= 0")]
    NegativeIntensity { value: f32 },
    #[error("{value} is negative; allowed: linear RGB components >= 0")]
    NegativeColor { value: f32 },
    #[error("{value} is not positive; allowed: sizes, radii, scales and heights > 0")]
    NotPositive { value: f32 },
    #[error("{value} is negative; allowed: spacing >= 0")]
    NegativeSpacing { value: f32 },
    #[error("{value} segments; allowed: at least {min}")]
    TooFewSegments { value: u32, min: u32 },
    #[error("{what} is 0, which makes an empty mesh; allowed: at least 1")]
    EmptyMesh { what: &'static str },
    #[error("minimum {min} is greater than maximum {max}; allowed: min <= max in every component")]
    EmptyRange { min: f32, max: f32 },
    #[error(
        "minor radius {minor} is not below major radius {major}; allowed: 0 < minor_radius < major_radius"
    )]
    TorusRadii { minor: f32, major: f32 },
    #[error("near {near} is not positive; allowed: near > 0 for a perspective camera")]
    NearNotPositive { near: f32 },
    #[error("near {near} is not before far {far}; allowed: near < far")]
    NearNotBeforeFar { near: f32, far: f32 },
    #[error(
        "{value} is outside (0, 180); allowed: vertical field of view in degrees, 0 < fov_y < 180"
    )]
    FovOutOfRange { value: f32 },
    #[error(
        "both `fov_y` and `orthographic` are given; allowed: one of them (perspective or orthographic)"
    )]
    ProjectionConflict,
    #[error("{value} is outside 1..={max}; allowed: width and height from 1 to {max} pixels", max = Resolution::MAX_DIMENSION)]
    ResolutionOutOfRange { value: u64 },
    #[error("up vector has zero length; allowed: a non-zero vector not parallel to target - eye")]
    ZeroUp,
    #[error(
        "up vector is parallel to the view direction; allowed: a vector not parallel to target - eye"
    )]
    UpParallel,
    #[error("eye equals target, so there is no view direction; allowed: eye != target")]
    EyeAtTarget,
    #[error("zero-length vector; allowed: a non-zero direction")]
    ZeroVector,
    #[error("{count} triangles in total; allowed: at most {MAX_TRIANGLES} triangles per scene")]
    TooManyTriangles { count: u64 },

    // ---- glTF 2.0 (paths are JSON pointers into the asset, e.g. `/meshes/0/primitives/1`) ----
    #[error(
        "{message}; allowed: a GLB file (12-byte header `glTF`, version 2, a JSON chunk, an optional BIN chunk, lengths within the file) or glTF JSON"
    )]
    GlbStructure { message: String },
    #[error(
        "{message}; allowed: a glTF 2.0 document that passes the glTF schema (indices in range, required fields present)"
    )]
    GltfInvalid { message: String },
    #[error(
        "extension(s) {names} required but not modelled; allowed: required extensions among {supported}"
    )]
    UnsupportedExtension { names: String, supported: String },
    #[error("primitive mode {mode}; allowed: TRIANGLES (4), TRIANGLE_STRIP (5), TRIANGLE_FAN (6)")]
    UnsupportedPrimitiveMode { mode: String },
    #[error(
        "cannot read `{uri}`: {message}; allowed: a readable file relative to the asset, or a base64 `data:` URI"
    )]
    ExternalData { uri: String, message: String },
    #[error(
        "{actual} bytes of data, fewer than byteLength {expected}; allowed: at least byteLength bytes"
    )]
    BufferTooShort { expected: u64, actual: u64 },
    #[error(
        "{message}; allowed: accessor and bufferView ranges inside their buffer (byteOffset + (count-1)·stride + element size <= length)"
    )]
    AccessorOutOfBounds { message: String },
    #[error("{found}; allowed: {expected}")]
    AccessorFormat { found: String, expected: String },
    #[error(
        "image format {found}; allowed: PNG (`image/png`, .png) or JPEG (`image/jpeg`, .jpg, .jpeg)"
    )]
    UnsupportedImage { found: String },
    #[error(
        "cannot decode image: {message}; allowed: a valid PNG or JPEG with 1 to 4 channels of 8, 16 or 32-bit float samples"
    )]
    ImageDecode { message: String },
    #[error("{width}x{height} texels; allowed: 1 to {max} texels per side", max = crate::texture::MAX_TEXTURE_DIMENSION)]
    TextureTooLarge { width: u32, height: u32 },
    #[error("{texels} texels of decoded textures in total; allowed: at most {max} level-0 texels per scene (1 GiB of 8-bit RGBA codes)", max = crate::gltf::MAX_TEXELS)]
    TooManyTexels { texels: u64 },
    #[error(
        "index {index} is not below the vertex count {count}; allowed: indices < the POSITION accessor's count"
    )]
    IndexOutOfRange { index: u64, count: u64 },
    #[error("{what} {value}; allowed: {allowed}")]
    BadValue {
        what: String,
        value: String,
        allowed: String,
    },
    #[error("index {index}, but there are {count}; allowed: 0..{count}")]
    NoSuchItem { index: usize, count: usize },
    #[error(
        "node {node} is reached twice from the scene's roots; allowed: nodes forming strict trees (one parent each, no cycles)"
    )]
    NodeNotTree { node: usize },
    #[error("`{field}` is given for a glTF object; allowed: {allowed}")]
    GltfObjectField { field: String, allowed: String },
}
