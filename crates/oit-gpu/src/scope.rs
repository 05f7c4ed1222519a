//! Keeping one failure to itself: wgpu reports validation, out-of-memory and internal errors
//! to the device's uncaptured-error handler, whose default panics and ends the process. Work
//! run through [`Context::contain`] has them captured by error scopes instead and returned as
//! [`GpuError::Device`], and a panic inside it is returned the same way, so a comparison fails
//! one run or one scene and goes on with the next.

use std::panic::AssertUnwindSafe;

use crate::context::Context;
use crate::error::GpuError;

impl Context {
    /// Runs `work` inside error scopes for validation, out-of-memory and internal errors, and
    /// catches a panic in it. The first error wgpu reported while it ran (or the panic's
    /// message) is returned as [`GpuError::Device`], saying that `what` (e.g. "the run")
    /// stopped; otherwise `work`'s own result. The scopes are per thread: work `work` hands to other threads is not covered.
    pub fn contain<T, E>(
        &self,
        what: &str,
        work: impl FnOnce() -> Result<T, E>,
    ) -> Result<T, ContainedError<E>> {
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let outcome = std::panic::catch_unwind(AssertUnwindSafe(work));
        // Popped in the reverse order of pushing; the first error found is the cause.
        let captured = [internal.pop(), memory.pop(), validation.pop()]
            .into_iter()
            .filter_map(pollster::block_on)
            .map(|e| e.to_string())
            .next();
        match (outcome, captured) {
            (_, Some(error)) => Err(ContainedError::Device(GpuError::Device(format!(
                "{what} stopped: the GPU reported {}",
                one_line(&error)
            )))),
            (Err(panic), None) => Err(ContainedError::Device(GpuError::Device(format!(
                "{what} stopped: it panicked: {}",
                panic_message(panic.as_ref())
            )))),
            (Ok(Err(e)), None) => Err(ContainedError::Work(e)),
            (Ok(Ok(value)), None) => Ok(value),
        }
    }
}

/// What [`Context::contain`] returns on failure: the work's own error, or one the device
/// reported (or a panic).
#[derive(Debug)]
pub enum ContainedError<E> {
    Work(E),
    Device(GpuError),
}

impl<E: From<GpuError>> ContainedError<E> {
    /// Either as the work's error type.
    pub fn into_inner(self) -> E {
        match self {
            ContainedError::Work(e) => e,
            ContainedError::Device(e) => e.into(),
        }
    }
}

/// wgpu's messages run over many lines (the error, then its sources indented); the
/// reports keep one line.
fn one_line(text: &str) -> String {
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    lines.join(" ")
}

fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = panic.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = panic.downcast_ref::<String>() {
        s.clone()
    } else {
        "(no message)".to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_are_kept_on_one_line() {
        assert_eq!(
            one_line("Validation Error\n\nCaused by:\n    In a draw\n      bad"),
            "Validation Error Caused by: In a draw bad"
        );
        let boxed: Box<dyn std::any::Any + Send> = Box::new(String::from("index 9 of 3"));
        assert_eq!(panic_message(boxed.as_ref()), "index 9 of 3");
        let boxed: Box<dyn std::any::Any + Send> = Box::new("static text");
        assert_eq!(panic_message(boxed.as_ref()), "static text");
        let boxed: Box<dyn std::any::Any + Send> = Box::new(7u8);
        assert_eq!(panic_message(boxed.as_ref()), "(no message)");
    }
}
