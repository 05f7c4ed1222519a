//! The configurations `oit recommend` considers when none are named: every technique at its
//! defaults, and a bounded sweep of the parameters that size what a technique keeps per pixel
//! (docs/recommend.md lists them). Bounded so that a recommendation over the bundled suite
//! stays under a thousand runs.

use oit_gpu::TechniqueSpec;

use crate::HarnessError;

/// The sweeps added to the defaults, each a `-t` sweep of `oit compare`.
pub const SWEEPS: &[&str] = &[
    "front-peel:layers=1,2,4,8,16",
    "dual-peel:passes=1,2,3,8,auto",
    "stochastic:spp=4,16",
    "a2c:samples=8",
    "mboit:moments=power4,power8",
    "linked-list:nodes-per-pixel=128,sort-max=128",
    "k-buffer:k=1,2,4,16,32",
];

/// Every technique at its defaults (registry order), then [`SWEEPS`]; each canonical spec once.
pub fn candidate_specs() -> Result<Vec<TechniqueSpec>, HarnessError> {
    let mut texts: Vec<String> = crate::registry()
        .iter()
        .map(|info| info.default_spec().canonical())
        .collect();
    texts.extend(SWEEPS.iter().map(|s| (*s).to_owned()));
    crate::resolve_specs(&texts)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every default is a candidate, every sweep value parses, and the set stays bounded.
    #[test]
    fn candidates_are_the_defaults_and_the_stated_sweeps() {
        let specs = candidate_specs().unwrap();
        let canonical: Vec<String> = specs.iter().map(TechniqueSpec::canonical).collect();
        for info in crate::registry() {
            assert!(
                canonical.contains(&info.default_spec().canonical()),
                "{}",
                info.name
            );
        }
        assert!(canonical.contains(&"k-buffer:k=32,tail=average".to_owned()));
        assert!(canonical.contains(&"stochastic:pattern=blue,seed=object,spp=16".to_owned()));
        let sweeps: usize = SWEEPS.iter().map(|s| crate::expand_sweep(s).len()).sum();
        assert_eq!(specs.len(), crate::registry().len() + sweeps);
        assert!(specs.len() <= 48, "{}", specs.len());
    }
}
