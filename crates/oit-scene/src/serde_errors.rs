//! Scene-file errors in the words of the file: serde's messages and paths translated into the
//! JSON path of the offending value (`objects[3].material.alpha`) and one of the [`Problem`]
//! classes, so a user can fix a scene without reading code.

use crate::error::{Problem, SceneError};
use crate::load::Ctx;

/// Renders a serde_path_to_error path as `objects[3].material.alpha`, prefixed by `prefix`.
pub(crate) fn json_path(prefix: &str, path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = prefix.to_string();
    for seg in path {
        match seg {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } | Segment::Enum { variant: key } => push_key(&mut out, key),
            // Where serde cannot tell (e.g. inside a syntax error), the line and column say it.
            Segment::Unknown => {}
        }
    }
    if out.is_empty() {
        "(root)".to_string()
    } else {
        out
    }
}

/// Appends a member to a path: `.key`, or `["key"]` (a JSON string) for a key that is empty or
/// has characters other than letters, digits, `_` and `-`, so the path stays unambiguous and on
/// one line.
fn push_key(path: &mut String, key: &str) {
    let plain = !key.is_empty()
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if plain {
        if !path.is_empty() {
            path.push('.');
        }
        path.push_str(key);
    } else {
        path.push('[');
        path.push_str(&serde_json::Value::from(key).to_string());
        path.push(']');
    }
}

/// Appends the member `field` unless the path already ends with it.
fn with_field(path: &str, field: &str) -> String {
    let mut full = if path == "(root)" {
        String::new()
    } else {
        path.to_string()
    };
    let before = full.len();
    push_key(&mut full, field);
    let member = &full[before..];
    let already = (member.starts_with(['.', '[']) && path.ends_with(member))
        || path == member.trim_start_matches('.');
    if already { path.to_string() } else { full }
}

/// The text between the first pair of backticks in `s`, and what follows it.
fn backticked(s: &str) -> Option<(&str, &str)> {
    let start = s.find('`')? + 1;
    let len = s[start..].find('`')?;
    Some((&s[start..start + len], &s[start + len + 1..]))
}

impl Ctx<'_> {
    /// The number-like token of the source around a serde_json error position.
    fn token_at(&self, line: usize, column: usize) -> Option<String> {
        let text = self.json.lines().nth(line.checked_sub(1)?)?;
        let chars: Vec<char> = text.chars().collect();
        let is_tok = |c: char| c.is_ascii_alphanumeric() || matches!(c, '.' | '+' | '-');
        let mut i = column.saturating_sub(1).min(chars.len().checked_sub(1)?);
        if !is_tok(chars[i]) && i > 0 && is_tok(chars[i - 1]) {
            i -= 1;
        }
        if !is_tok(chars[i]) {
            return None;
        }
        let (mut a, mut b) = (i, i);
        while a > 0 && is_tok(chars[a - 1]) {
            a -= 1;
        }
        while b + 1 < chars.len() && is_tok(chars[b + 1]) {
            b += 1;
        }
        Some(chars[a..=b].iter().collect())
    }

    /// Maps a serde_json error to one of our problem classes, keeping the JSON path.
    pub(crate) fn serde_error(&self, path: &str, e: &serde_json::Error) -> SceneError {
        let full = e.to_string();
        let msg = if e.line() > 0 {
            full.strip_suffix(&format!(" at line {} column {}", e.line(), e.column()))
                .unwrap_or(&full)
        } else {
            &full
        };
        if msg.starts_with("number out of range") {
            let value = self
                .token_at(e.line(), e.column())
                .unwrap_or_else(|| "number".into());
            return self.err(path, Problem::NonFinite { value });
        }
        if msg == "trailing characters" && path != "(root)" {
            // serde_json's wording when a fixed-size array gets more elements than it holds.
            let found = "array has too many elements".to_string();
            let expected =
                "exactly the number of elements documented in docs/scene-format.md".to_string();
            return self.err(path, Problem::WrongType { found, expected });
        }
        if e.is_syntax() || e.is_eof() {
            // NaN and Infinity are not JSON; say so instead of "expected value".
            if let Some(tok) = self.token_at(e.line(), e.column()) {
                let t = tok.trim_start_matches(['-', '+']).to_ascii_lowercase();
                if t.starts_with("nan") || t.starts_with("inf") {
                    return self.err(path, Problem::NonFinite { value: tok });
                }
            }
            let problem = Problem::Syntax {
                line: e.line(),
                column: e.column(),
                message: msg.to_string(),
            };
            return self.err(path, problem);
        }
        if let Some(rest) = msg.strip_prefix("unknown field ")
            && let Some((field, tail)) = backticked(rest)
        {
            let expected = tail
                .trim_start_matches(", ")
                .trim_start_matches("expected one of ")
                .trim_start_matches("expected ")
                .to_string();
            let expected = if expected.is_empty() {
                "no fields here".to_string()
            } else {
                expected
            };
            return self.err(
                with_field(path, field),
                Problem::UnknownField {
                    field: field.to_string(),
                    expected,
                },
            );
        }
        if let Some(rest) = msg.strip_prefix("unknown variant ")
            && let Some((value, tail)) = backticked(rest)
        {
            let expected = tail
                .trim_start_matches(", ")
                .trim_start_matches("expected one of ")
                .trim_start_matches("expected ")
                .to_string();
            return self.err(
                path,
                Problem::UnknownVariant {
                    value: value.to_string(),
                    expected,
                },
            );
        }
        if msg.starts_with("duplicate field ") {
            let expected = "each field at most once".to_string();
            let found = msg.to_string();
            return self.err(path, Problem::WrongType { found, expected });
        }
        if let Some(rest) = msg.strip_prefix("missing field ")
            && let Some((field, _)) = backticked(rest)
        {
            return self.err(
                with_field(path, field),
                Problem::MissingField {
                    field: field.into(),
                },
            );
        }
        let (found, expected) = match msg.split_once(", expected ") {
            Some((f, x)) => (json_found(f), json_expected(x, path)),
            None => (msg.to_string(), "see docs/scene-format.md".to_string()),
        };
        self.err(path, Problem::WrongType { found, expected })
    }
}

/// serde's description of the value it got (`invalid type: sequence`), in JSON's words
/// (`invalid type: array`).
pub(crate) fn json_found(found: &str) -> String {
    if let Some(n) = found.strip_prefix("invalid length ") {
        let s = if n == "1" { "" } else { "s" };
        return format!("an array of {n} element{s}");
    }
    let Some((head, what)) = found.split_once(": ") else {
        return found.to_string();
    };
    let what = match what {
        "sequence" => "array".to_string(),
        "map" => "object".to_string(),
        "unit value" => "null".to_string(),
        "unit variant" => "a string".to_string(),
        "newtype variant" | "tuple variant" | "struct variant" => "an object".to_string(),
        other => match other.strip_prefix("floating point ") {
            Some(number) => format!("number {number}"),
            None => other.to_string(),
        },
    };
    format!("{head}: {what}")
}

/// serde's description of what it expected (Rust types like `u32`, `a sequence`), in words a
/// scene author knows. `path` names the enum variant for a variant given without its settings.
pub(crate) fn json_expected(expected: &str, path: &str) -> String {
    match expected {
        "u8" | "u16" | "u32" | "u64" | "u128" | "usize" => "a non-negative integer".into(),
        "i8" | "i16" | "i32" | "i64" | "i128" | "isize" => "an integer".into(),
        "f32" | "f64" => "a number".into(),
        "a boolean" => "true or false".into(),
        // serde_json::Value's wording when a fixed-size array gets more elements than it holds.
        "fewer elements in array" => {
            "exactly the number of elements documented in docs/scene-format.md".into()
        }
        "a sequence" => "an array".into(),
        "a map" => "an object".into(),
        "unit" | "unit variant" => "the value as a plain string, without settings".into(),
        "newtype variant" | "tuple variant" | "struct variant" => {
            let variant = path.rsplit('.').next().unwrap_or(path);
            format!("an object {{\"{variant}\": {{...}}}} with the settings of `{variant}`")
        }
        other => other.into(),
    }
}

pub(crate) fn json_kind(v: &serde_json::Value) -> &'static str {
    match v {
        serde_json::Value::Null => "null",
        serde_json::Value::Bool(_) => "boolean",
        serde_json::Value::Number(_) => "number",
        serde_json::Value::String(_) => "string",
        serde_json::Value::Array(_) => "array",
        serde_json::Value::Object(_) => "object",
    }
}
