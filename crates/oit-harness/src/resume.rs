//! What `oit compare --resume` did with the earlier results, for the line that says so.

/// What `--resume` did, for the line that says so.
#[derive(Debug, Default)]
pub(crate) struct ResumeCount {
    /// Requested runs taken from the earlier comparison.
    pub(crate) reused: usize,
    /// Earlier runs of techniques not requested now, kept beside the new ones.
    pub(crate) kept_unrequested: usize,
    /// Earlier runs of scenes not in this comparison, kept.
    pub(crate) kept_other_scenes: usize,
    /// Earlier runs made by another build or from other inputs: not kept.
    pub(crate) dropped: usize,
    /// Requested runs made now.
    pub(crate) made: usize,
}

impl ResumeCount {
    pub(crate) fn describe(&self) -> Option<String> {
        let mut parts = vec![
            format!("{} runs made now", self.made),
            format!("{} taken from the earlier results", self.reused),
        ];
        if self.kept_unrequested > 0 {
            parts.push(format!(
                "{} of techniques not requested now kept beside them",
                self.kept_unrequested
            ));
        }
        if self.kept_other_scenes > 0 {
            parts.push(format!("{} of other scenes kept", self.kept_other_scenes));
        }
        if self.dropped > 0 {
            parts.push(format!(
                "{} earlier runs dropped (made by another build of oit, from other inputs, or failed)",
                self.dropped
            ));
        }
        Some(format!("--resume: {}", parts.join("; ")))
    }
}
