//! Technique specs `name[:key=value[,key=value…]]`, validated against a registry.

use crate::technique::Technique;
use std::collections::BTreeMap;

/// What values a parameter accepts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Allowed {
    /// One of these words.
    Values(&'static [&'static str]),
    /// An integer in `min..=max` (written without sign or leading zeros in the canonical
    /// form), or one of the `words` (e.g. `auto`).
    Integer {
        min: u64,
        max: u64,
        words: &'static [&'static str],
    },
}

impl std::fmt::Display for Allowed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Allowed::Values(v) => f.write_str(&v.join(", ")),
            Allowed::Integer { min, max, words } => {
                write!(f, "an integer {min}..={max}")?;
                for w in *words {
                    write!(f, ", {w}")?;
                }
                Ok(())
            }
        }
    }
}

impl Allowed {
    /// The canonical spelling of `value`, or `None` when it is not allowed.
    fn canonical(&self, value: &str) -> Option<String> {
        match self {
            Allowed::Values(v) => v.contains(&value).then(|| value.to_owned()),
            Allowed::Integer { min, max, words } => {
                if words.contains(&value) {
                    return Some(value.to_owned());
                }
                if value.is_empty() || !value.bytes().all(|b| b.is_ascii_digit()) {
                    return None;
                }
                let n: u64 = value.parse().ok()?;
                (*min..=*max).contains(&n).then(|| n.to_string())
            }
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParamInfo {
    pub key: &'static str,
    pub description: &'static str,
    /// Must itself be allowed (checked by [`TechniqueInfo::validate`]).
    pub default: &'static str,
    pub allowed: Allowed,
}

/// One registry entry. Each technique crate exposes `pub fn techniques() -> Vec<TechniqueInfo>`;
/// the harness concatenates them.
#[derive(Clone)]
pub struct TechniqueInfo {
    pub name: &'static str,
    pub description: &'static str,
    pub params: Vec<ParamInfo>,
    /// Builds the technique from a spec. A technique value always holds a valid
    /// configuration: a spec that does not describe one (hand-built, or of another name) is an
    /// error here, never a technique that fails later.
    pub build: fn(&TechniqueSpec) -> Result<Box<dyn Technique>, SpecError>,
}

impl std::fmt::Debug for TechniqueInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TechniqueInfo")
            .field("name", &self.name)
            .field("description", &self.description)
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

impl TechniqueInfo {
    /// The spec with every default.
    pub fn default_spec(&self) -> TechniqueSpec {
        TechniqueSpec {
            name: self.name.to_owned(),
            params: self
                .params
                .iter()
                .map(|p| (p.key.to_owned(), p.default.to_owned()))
                .collect(),
        }
    }

    /// Registry sanity: defaults allowed, keys unique (for the technique crates' own tests).
    pub fn validate(&self) -> Result<(), String> {
        for (i, p) in self.params.iter().enumerate() {
            if p.allowed.canonical(p.default).as_deref() != Some(p.default) {
                return Err(format!(
                    "{}: default {}={} is not allowed ({})",
                    self.name, p.key, p.default, p.allowed
                ));
            }
            if self.params[..i].iter().any(|q| q.key == p.key) {
                return Err(format!("{}: parameter {} declared twice", self.name, p.key));
            }
        }
        Ok(())
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SpecError {
    #[error("technique spec {spec:?}: empty; allowed: name[:key=value,...], names: {names}")]
    Empty { spec: String, names: String },
    #[error("technique spec {spec:?}: unknown technique {name:?}; allowed: {names}")]
    UnknownName {
        spec: String,
        name: String,
        names: String,
    },
    #[error("technique spec {spec:?}: {name} has no parameter {key:?}; allowed: {keys}")]
    UnknownKey {
        spec: String,
        name: String,
        key: String,
        keys: String,
    },
    #[error("technique spec {spec:?}: {key}={value:?} is not allowed; allowed: {allowed}")]
    BadValue {
        spec: String,
        key: String,
        value: String,
        allowed: String,
    },
    #[error("technique spec {spec:?}: {name} needs parameter {key}; allowed: {allowed}")]
    Missing {
        spec: String,
        name: String,
        key: String,
        allowed: String,
    },
    #[error("technique spec {spec:?}: not a {expected} spec")]
    WrongTechnique { spec: String, expected: String },
    #[error("technique spec {spec:?}: {key} given twice")]
    DuplicateKey { spec: String, key: String },
    #[error(
        "technique spec {spec:?}: malformed parameter {item:?}; allowed: key=value separated by commas, keys: {keys}"
    )]
    Malformed {
        spec: String,
        item: String,
        keys: String,
    },
}

/// A validated technique configuration: name and every parameter (defaults filled in).
/// `Display` is the canonical string: `name` alone without parameters, else
/// `name:k1=v1,k2=v2` with keys sorted.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TechniqueSpec {
    pub name: String,
    pub params: BTreeMap<String, String>,
}

fn names(registry: &[TechniqueInfo]) -> String {
    registry
        .iter()
        .map(|t| t.name)
        .collect::<Vec<_>>()
        .join(", ")
}

fn keys(info: &TechniqueInfo) -> String {
    if info.params.is_empty() {
        "(none)".to_owned()
    } else {
        info.params
            .iter()
            .map(|p| p.key)
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl TechniqueSpec {
    pub fn parse(text: &str, registry: &[TechniqueInfo]) -> Result<TechniqueSpec, SpecError> {
        let spec = text.to_owned();
        let trimmed = text.trim();
        let (name, rest) = match trimmed.split_once(':') {
            Some((n, r)) => (n, Some(r)),
            None => (trimmed, None),
        };
        if name.is_empty() {
            return Err(SpecError::Empty {
                spec,
                names: names(registry),
            });
        }
        let info =
            registry
                .iter()
                .find(|t| t.name == name)
                .ok_or_else(|| SpecError::UnknownName {
                    spec: spec.clone(),
                    name: name.to_owned(),
                    names: names(registry),
                })?;
        let mut given = BTreeMap::new();
        if let Some(rest) = rest {
            for item in rest.split(',') {
                let (key, value) = item.split_once('=').ok_or_else(|| SpecError::Malformed {
                    spec: spec.clone(),
                    item: item.to_owned(),
                    keys: keys(info),
                })?;
                let param = info.params.iter().find(|p| p.key == key).ok_or_else(|| {
                    SpecError::UnknownKey {
                        spec: spec.clone(),
                        name: info.name.to_owned(),
                        key: key.to_owned(),
                        keys: keys(info),
                    }
                })?;
                let canonical =
                    param
                        .allowed
                        .canonical(value)
                        .ok_or_else(|| SpecError::BadValue {
                            spec: spec.clone(),
                            key: key.to_owned(),
                            value: value.to_owned(),
                            allowed: param.allowed.to_string(),
                        })?;
                if given.insert(key.to_owned(), canonical).is_some() {
                    return Err(SpecError::DuplicateKey {
                        spec,
                        key: key.to_owned(),
                    });
                }
            }
        }
        let mut out = info.default_spec();
        out.params.extend(given);
        Ok(out)
    }

    /// The registry entry for this spec's name.
    pub fn info<'r>(&self, registry: &'r [TechniqueInfo]) -> Option<&'r TechniqueInfo> {
        registry.iter().find(|t| t.name == self.name)
    }

    /// Parses and builds in one step.
    pub fn build(text: &str, registry: &[TechniqueInfo]) -> Result<Box<dyn Technique>, SpecError> {
        let spec = Self::parse(text, registry)?;
        let info = spec.info(registry).ok_or_else(|| SpecError::UnknownName {
            spec: text.to_owned(),
            name: spec.name.clone(),
            names: names(registry),
        })?;
        (info.build)(&spec)
    }

    /// A parameter's value (always present for a parsed spec).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.params.get(key).map(String::as_str)
    }

    /// `Ok` when this is a spec of technique `name` (the first check of every `from_spec`).
    pub fn expect_name(&self, name: &str) -> Result<(), SpecError> {
        if self.name == name {
            Ok(())
        } else {
            Err(SpecError::WrongTechnique {
                spec: self.to_string(),
                expected: name.to_owned(),
            })
        }
    }

    /// The value of `key` turned into a `T` by `parse`; `allowed` describes the accepted values
    /// in the error when the key is missing or `parse` refuses it.
    pub fn value<T>(
        &self,
        key: &str,
        allowed: &str,
        parse: impl FnOnce(&str) -> Option<T>,
    ) -> Result<T, SpecError> {
        let value = self.get(key).ok_or_else(|| SpecError::Missing {
            spec: self.to_string(),
            name: self.name.clone(),
            key: key.to_owned(),
            allowed: allowed.to_owned(),
        })?;
        parse(value).ok_or_else(|| SpecError::BadValue {
            spec: self.to_string(),
            key: key.to_owned(),
            value: value.to_owned(),
            allowed: allowed.to_owned(),
        })
    }

    /// One of the words `names`, turned into a `T` by `parse`.
    pub fn word<T>(
        &self,
        key: &str,
        names: &[&str],
        parse: impl FnOnce(&str) -> Option<T>,
    ) -> Result<T, SpecError> {
        self.value(key, &names.join(", "), |v| {
            names.contains(&v).then_some(v).and_then(parse)
        })
    }

    /// An integer in `min..=max` written in canonical form (no sign, no leading zeros).
    pub fn integer(&self, key: &str, min: u64, max: u64) -> Result<u64, SpecError> {
        self.value(key, &format!("an integer {min}..={max}"), |v| {
            Allowed::Integer {
                min,
                max,
                words: &[],
            }
            .canonical(v)
            .filter(|c| c == v)
            .and_then(|c| c.parse().ok())
        })
    }

    pub fn canonical(&self) -> String {
        self.to_string()
    }
}

impl std::fmt::Display for TechniqueSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name)?;
        for (i, (k, v)) in self.params.iter().enumerate() {
            write!(f, "{}{k}={v}", if i == 0 { ':' } else { ',' })?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Caps, Context, GpuError, GpuScene, GpuTimer, RenderStats, Targets, Unsupported};

    #[derive(Debug)]
    struct Dummy(TechniqueSpec);

    impl Technique for Dummy {
        fn spec(&self) -> TechniqueSpec {
            self.0.clone()
        }
        fn check(&self, _: &Caps) -> Result<(), Unsupported> {
            Ok(())
        }
        fn render(
            &mut self,
            _: &Context,
            _: &GpuScene,
            _: &Targets,
            _: &mut GpuTimer,
        ) -> Result<RenderStats, GpuError> {
            Ok(RenderStats::default())
        }
        fn memory_bytes(&self) -> u64 {
            0
        }
        fn transmission(&self, _caps: &Caps) -> crate::TransmissionSupport {
            crate::TransmissionSupport::Unsupported("draws no transparent geometry")
        }
    }

    fn registry() -> Vec<TechniqueInfo> {
        vec![
            TechniqueInfo {
                name: "plain",
                description: "no parameters",
                params: vec![],
                build: |s| Ok(Box::new(Dummy(s.clone()))),
            },
            TechniqueInfo {
                name: "peel",
                description: "two parameters",
                params: vec![
                    ParamInfo {
                        key: "passes",
                        description: "",
                        default: "auto",
                        allowed: Allowed::Integer {
                            min: 1,
                            max: 64,
                            words: &["auto"],
                        },
                    },
                    ParamInfo {
                        key: "depth",
                        description: "",
                        default: "r32f",
                        allowed: Allowed::Values(&["r32f", "rg32f"]),
                    },
                ],
                build: |s| Ok(Box::new(Dummy(s.clone()))),
            },
        ]
    }

    fn parse(s: &str) -> Result<String, SpecError> {
        TechniqueSpec::parse(s, &registry()).map(|s| s.to_string())
    }

    #[test]
    fn canonical_strings() {
        assert_eq!(parse("plain").unwrap(), "plain");
        assert_eq!(parse(" plain ").unwrap(), "plain");
        assert_eq!(parse("peel").unwrap(), "peel:depth=r32f,passes=auto");
        assert_eq!(
            parse("peel:passes=07,depth=rg32f").unwrap(),
            "peel:depth=rg32f,passes=7"
        );
        assert_eq!(
            parse("peel:passes=64").unwrap(),
            "peel:depth=r32f,passes=64"
        );
        // The canonical string parses to itself.
        let c = parse("peel:depth=rg32f").unwrap();
        assert_eq!(parse(&c).unwrap(), c);
        for info in registry() {
            info.validate().unwrap();
        }
    }

    #[test]
    fn build_uses_the_canonical_spec() {
        let t = TechniqueSpec::build("peel:passes=3", &registry()).unwrap();
        assert_eq!(t.spec().to_string(), "peel:depth=r32f,passes=3");
        assert_eq!(t.spec().get("passes"), Some("3"));
    }

    #[test]
    fn errors_list_what_is_valid() {
        let e = parse("").unwrap_err();
        assert!(matches!(e, SpecError::Empty { .. }), "{e}");
        let e = parse("nope").unwrap_err();
        assert!(
            matches!(e, SpecError::UnknownName { .. }) && e.to_string().contains("plain, peel"),
            "{e}"
        );
        let e = parse("plain:x=1").unwrap_err();
        assert!(
            matches!(e, SpecError::UnknownKey { .. }) && e.to_string().contains("(none)"),
            "{e}"
        );
        let e = parse("plain:").unwrap_err();
        assert!(matches!(e, SpecError::Malformed { .. }), "{e}");
        let e = parse("peel:layers=3").unwrap_err();
        assert!(
            matches!(e, SpecError::UnknownKey { .. }) && e.to_string().contains("passes, depth"),
            "{e}"
        );
        for bad in ["0", "65", "-1", "+3", "auto2", "", "1.5"] {
            let e = parse(&format!("peel:passes={bad}")).unwrap_err();
            assert!(
                matches!(e, SpecError::BadValue { .. }) && e.to_string().contains("1..=64, auto"),
                "{bad}: {e}"
            );
        }
        let e = parse("peel:depth=R32F").unwrap_err();
        assert!(e.to_string().contains("r32f, rg32f"), "{e}");
        let e = parse("peel:passes=2,passes=3").unwrap_err();
        assert!(matches!(e, SpecError::DuplicateKey { .. }), "{e}");
        let e = parse("peel:passes").unwrap_err();
        assert!(matches!(e, SpecError::Malformed { .. }), "{e}");
        let e = parse("peel:passes=2,").unwrap_err();
        assert!(matches!(e, SpecError::Malformed { .. }), "{e}");
    }

    #[test]
    fn invalid_registry_defaults_are_caught() {
        let mut r = registry();
        r[1].params[1].default = "r16f";
        assert!(r[1].validate().is_err());
        r[1].params[1].default = "r32f";
        let dup = r[1].params[0].clone();
        r[1].params.push(dup);
        assert!(r[1].validate().is_err());
    }

    #[test]
    fn typed_accessors_name_the_key_and_what_is_allowed() {
        let spec = TechniqueSpec::parse("peel:passes=12", &registry()).unwrap();
        assert!(spec.expect_name("peel").is_ok());
        let e = spec.expect_name("plain").unwrap_err();
        assert!(matches!(e, SpecError::WrongTechnique { .. }), "{e}");
        assert_eq!(spec.integer("passes", 1, 64), Ok(12));
        let e = spec.integer("passes", 1, 8).unwrap_err();
        assert!(
            e.to_string().contains("1..=8") && e.to_string().contains("\"12\""),
            "{e}"
        );
        let e = spec.integer("layers", 1, 8).unwrap_err();
        assert!(
            matches!(e, SpecError::Missing { .. }) && e.to_string().contains("layers"),
            "{e}"
        );
        let depth = spec.word("depth", &["r32f", "rg32f"], |v| Some(v.len()));
        assert_eq!(depth, Ok(4));
        let e = spec
            .word("depth", &["rg32f"], |v| Some(v.len()))
            .unwrap_err();
        assert!(
            matches!(e, SpecError::BadValue { .. }) && e.to_string().contains("rg32f"),
            "{e}"
        );
        // A hand-built spec with a non-canonical integer is refused, not reinterpreted.
        let mut odd = spec.clone();
        odd.params.insert("passes".into(), "012".into());
        assert!(odd.integer("passes", 1, 64).is_err());
    }
}
