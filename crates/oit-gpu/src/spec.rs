//! Technique specs `name[:key=value[,key=value…]]`, validated against a registry, and the one
//! typed declaration of each technique parameter ([`Param`]) from which parsing, the canonical
//! spec string and `oit techniques` all come.
//!
//! A parameter's values are a [`ParamValue`] type: a word enum declared with [`words!`] (each
//! variant and its word written once), a [`Bounded`] integer, or a type of the technique's own.
//! A configuration holds such types, so it cannot hold a value its spec could not say.

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
    pub fn canonical(&self, value: &str) -> Option<String> {
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

/// What `oit techniques` and the parser know of a parameter: made by [`Param::info`] from the
/// parameter's one declaration.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParamInfo {
    pub key: &'static str,
    pub description: &'static str,
    /// Must itself be allowed (checked by [`TechniqueInfo::validate`]).
    pub default: String,
    pub allowed: Allowed,
}

/// A type a technique parameter takes: the values that exist and how each is written.
pub trait ParamValue: Copy + PartialEq + std::fmt::Debug + 'static {
    /// The values, as parsing errors and `oit techniques` list them.
    fn allowed() -> Allowed;
    /// The value a word in canonical form stands for; `None` for any other text.
    fn from_word(word: &str) -> Option<Self>;
    /// The canonical word of the value.
    fn word(self) -> String;
}

/// One technique parameter, declared once: its key, its default and what it means. Its values
/// are its type's ([`ParamValue`]).
#[derive(Debug, Clone, Copy)]
pub struct Param<T: ParamValue> {
    pub key: &'static str,
    pub default: T,
    pub doc: &'static str,
}

impl<T: ParamValue> Param<T> {
    pub const fn new(key: &'static str, default: T, doc: &'static str) -> Self {
        Param { key, default, doc }
    }

    /// What the registry lists for it.
    pub fn info(&self) -> ParamInfo {
        ParamInfo {
            key: self.key,
            description: self.doc,
            default: self.default.word(),
            allowed: T::allowed(),
        }
    }

    /// Its value in `spec` (a parsed spec always has one), or an error naming the key and what
    /// is allowed.
    pub fn read(&self, spec: &TechniqueSpec) -> Result<T, SpecError> {
        let allowed = T::allowed().to_string();
        let value = spec.get(self.key).ok_or_else(|| SpecError::Missing {
            spec: spec.to_string(),
            name: spec.name.clone(),
            key: self.key.to_owned(),
            allowed: allowed.clone(),
        })?;
        T::from_word(value).ok_or_else(|| SpecError::BadValue {
            spec: spec.to_string(),
            key: self.key.to_owned(),
            value: value.to_owned(),
            allowed,
        })
    }
}

/// An integer parameter in `MIN..=MAX`: a value outside cannot be made ([`Bounded::new`]
/// refuses it), so a configuration holding one is in range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Bounded<const MIN: u32, const MAX: u32>(u32);

impl<const MIN: u32, const MAX: u32> Bounded<MIN, MAX> {
    /// `n`, or `None` outside `MIN..=MAX`.
    pub const fn new(n: u32) -> Option<Self> {
        if n >= MIN && n <= MAX {
            Some(Bounded(n))
        } else {
            None
        }
    }

    /// `n` for a constant known to be in range: a compile-time error in a `const`, a panic
    /// otherwise (for literals in code, never for input).
    pub const fn of(n: u32) -> Self {
        match Self::new(n) {
            Some(b) => b,
            None => panic!("Bounded::of: value out of range"),
        }
    }

    pub const fn get(self) -> u32 {
        self.0
    }
}

impl<const MIN: u32, const MAX: u32> ParamValue for Bounded<MIN, MAX> {
    fn allowed() -> Allowed {
        Allowed::Integer {
            min: u64::from(MIN),
            max: u64::from(MAX),
            words: &[],
        }
    }
    fn from_word(word: &str) -> Option<Self> {
        let canonical = Self::allowed().canonical(word)?;
        if canonical != word {
            return None;
        }
        Self::new(canonical.parse().ok()?)
    }
    fn word(self) -> String {
        self.0.to_string()
    }
}

impl<const MIN: u32, const MAX: u32> std::fmt::Display for Bounded<MIN, MAX> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Declares a word enum for a technique parameter: every variant with its word, once. It gets
/// `ALL`, `WORDS` (in declaration order), `name()`, `parse()` and [`ParamValue`].
///
/// ```
/// oit_gpu::words! {
///     /// How far to look.
///     pub enum Reach {
///         /// The nearest layer only.
///         Near = "near",
///         Far = "far",
///     }
/// }
/// assert_eq!(Reach::WORDS, ["near", "far"]);
/// assert_eq!(Reach::Far.name(), "far");
/// ```
#[macro_export]
macro_rules! words {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $word:literal ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        $vis enum $name {
            $( $(#[$vmeta])* $variant ),+
        }

        impl $name {
            /// Every value, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];
            /// Every word, in declaration order.
            pub const WORDS: &'static [&'static str] = &[$($word),+];

            /// The value's word.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $word),+
                }
            }

            /// The value of a word, `None` for any other text.
            pub fn parse(word: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|v| v.name() == word)
            }
        }

        impl $crate::ParamValue for $name {
            fn allowed() -> $crate::Allowed {
                $crate::Allowed::Values(Self::WORDS)
            }
            fn from_word(word: &str) -> Option<Self> {
                Self::parse(word)
            }
            fn word(self) -> String {
                self.name().to_owned()
            }
        }
    };
}

/// One registry entry. Each technique crate exposes `pub fn techniques() -> Vec<TechniqueInfo>`;
/// the harness concatenates them.
#[derive(Clone)]
pub struct TechniqueInfo {
    pub name: &'static str,
    pub description: &'static str,
    pub params: Vec<ParamInfo>,
    /// What the technique does with coloured transmittance, in a sentence or two (the table
    /// of docs/coloured-transmission.md is generated from it; `Technique::transmission` says
    /// it per adapter at run time).
    pub transmission: &'static str,
    /// Builds the technique from a spec. A technique value always holds a valid
    /// configuration: a spec that does not describe one (hand-built, or of another name) is an
    /// error here, never a technique that fails later.
    pub build: fn(&TechniqueSpec) -> Result<Box<dyn Technique>, SpecError>,
}

/// A technique family: one crate under `techniques/<folder>/` holding its techniques, their
/// shaders and a README. Each crate exports one `FAMILY`; the harness's list of them is the
/// registry, and the shader test validates every family's folder from it
/// (docs/adding-a-technique.md).
#[derive(Debug, Clone, Copy)]
pub struct Family {
    /// The folder under `techniques/`.
    pub folder: &'static str,
    /// The family's techniques, each with its parameters and builder.
    pub techniques: fn() -> Vec<TechniqueInfo>,
    /// The crate's `shaders/` folder.
    pub shader_dir: &'static str,
    /// The WGSL its passes include from: its own `SHADERS` (exactly the files of
    /// `shader_dir`) first, then any it borrows from another family.
    pub shaders: &'static [crate::shaders::Library],
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
                .map(|p| (p.key.to_owned(), p.default.clone()))
                .collect(),
        }
    }

    /// Registry sanity: defaults allowed, keys unique (for the technique crates' own tests).
    pub fn validate(&self) -> Result<(), String> {
        for (i, p) in self.params.iter().enumerate() {
            if p.allowed.canonical(&p.default).as_deref() != Some(p.default.as_str()) {
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
/// `name:k1=v1,k2=v2` with keys sorted. Made by [`TechniqueSpec::parse`] against a registry,
/// or by a technique from its typed configuration ([`TechniqueSpec::of`] and
/// [`TechniqueSpec::with`]), never field by field.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TechniqueSpec {
    name: String,
    params: BTreeMap<String, String>,
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

    /// The spec of technique `name` without parameters; [`TechniqueSpec::with`] adds them from
    /// a configuration's typed values.
    pub fn of(name: &str) -> TechniqueSpec {
        TechniqueSpec {
            name: name.to_owned(),
            params: BTreeMap::new(),
        }
    }

    /// This spec with `param` set to `value` (written in canonical form).
    pub fn with<T: ParamValue>(mut self, param: &Param<T>, value: T) -> TechniqueSpec {
        self.params.insert(param.key.to_owned(), value.word());
        self
    }

    /// The technique's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Every parameter, key to canonical value, keys sorted.
    pub fn params(&self) -> &BTreeMap<String, String> {
        &self.params
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
        fn predict(
            &self,
            _: &oit_scene::Scene,
            _: &crate::predict::PixelLists,
            _: &crate::Caps,
        ) -> crate::Prediction {
            crate::Prediction::unmodelled("a test technique")
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
        fn transmission(&self, _caps: &Caps) -> crate::Support {
            crate::Support::Unsupported("draws no transparent geometry")
        }
        fn operator(&self, _: oit_scene::BlendOperator, _caps: &Caps) -> crate::Support {
            crate::Support::Unsupported("draws no transparent geometry")
        }
    }

    fn registry() -> Vec<TechniqueInfo> {
        vec![
            TechniqueInfo {
                name: "plain",
                description: "no parameters",
                params: vec![],
                transmission: "none",
                build: |s| Ok(Box::new(Dummy(s.clone()))),
            },
            TechniqueInfo {
                name: "peel",
                description: "two parameters",
                transmission: "none",
                params: vec![
                    ParamInfo {
                        key: "passes",
                        description: "",
                        default: "auto".into(),
                        allowed: Allowed::Integer {
                            min: 1,
                            max: 64,
                            words: &["auto"],
                        },
                    },
                    ParamInfo {
                        key: "depth",
                        description: "",
                        default: "r32f".into(),
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
        r[1].params[1].default = "r16f".into();
        assert!(r[1].validate().is_err());
        r[1].params[1].default = "r32f".into();
        let dup = r[1].params[0].clone();
        r[1].params.push(dup);
        assert!(r[1].validate().is_err());
    }

    crate::words! {
        /// A test parameter's words.
        enum Depth {
            R32f = "r32f",
            Rg32f = "rg32f",
        }
    }

    const DEPTH: Param<Depth> = Param::new("depth", Depth::R32f, "test depth");
    const LAYERS: Param<Bounded<1, 64>> = Param::new("layers", Bounded::of(8), "test layers");

    /// A declared parameter reads its value from a spec, writes it back in canonical form, and
    /// names its key and what is allowed when it cannot.
    #[test]
    fn typed_parameters_read_write_and_explain() {
        let spec = TechniqueSpec::parse("peel:depth=rg32f", &registry()).unwrap();
        assert_eq!(DEPTH.read(&spec), Ok(Depth::Rg32f));
        assert_eq!(DEPTH.info().default, "r32f");
        assert_eq!(DEPTH.info().allowed, Allowed::Values(&["r32f", "rg32f"]));
        let e = LAYERS.read(&spec).unwrap_err();
        assert!(
            matches!(e, SpecError::Missing { .. }) && e.to_string().contains("1..=64"),
            "{e}"
        );
        let built = TechniqueSpec::of("peel")
            .with(&DEPTH, Depth::Rg32f)
            .with(&LAYERS, Bounded::of(12));
        assert_eq!(built.to_string(), "peel:depth=rg32f,layers=12");
        assert_eq!(LAYERS.read(&built), Ok(Bounded::of(12)));
        assert_eq!(LAYERS.info().default, "8");
    }

    /// A bounded integer cannot be made outside its range, and reads only canonical words.
    #[test]
    fn bounded_integers_hold_only_their_range() {
        type Spp = Bounded<1, 128>;
        assert_eq!(Spp::new(0), None);
        assert_eq!(Spp::new(129), None);
        assert_eq!(Spp::new(128).map(Bounded::get), Some(128));
        for bad in ["0", "129", "012", "+3", "-1", "", "x"] {
            assert_eq!(Spp::from_word(bad), None, "{bad}");
        }
        assert_eq!(Spp::from_word("12"), Some(Spp::of(12)));
        assert_eq!(Spp::of(7).word(), "7");
    }
}
