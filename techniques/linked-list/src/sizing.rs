//! `auto` sizes: `k-buffer:k=auto` and `linked-list:nodes-per-pixel=auto,sort-max=auto` take
//! their size from a GPU count of the fragments to hold ([`oit_gpu::LayerCounter`]), counted
//! every frame before the storage is sized, so nothing is dropped or averaged. A size over the
//! parameter's range or the memory cap is refused with the numbers, never clamped.

use oit_gpu::{Allowed, Bounded, Caps, GpuError, LayerCount, ParamValue, Unsupported, mib};

/// The most bytes one `auto`-sized storage (the k-buffer's slots, the list's node pool) may
/// take, whatever the adapter allows: 1 GiB. The adapter's own limit on one storage binding
/// applies too (lavapipe: 128 MiB), and the smaller decides.
pub const AUTO_MEMORY_CAP: u64 = 1 << 30;

/// A size the spec gives, or `auto`: counted every frame on the GPU before the storage is
/// sized (the engines' count → size → build).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sizing<T> {
    Fixed(T),
    Auto,
}

impl<const MIN: u32, const MAX: u32> ParamValue for Sizing<Bounded<MIN, MAX>> {
    fn allowed() -> Allowed {
        Allowed::Integer {
            min: u64::from(MIN),
            max: u64::from(MAX),
            words: &["auto"],
        }
    }
    fn from_word(word: &str) -> Option<Self> {
        if word == "auto" {
            return Some(Sizing::Auto);
        }
        Bounded::from_word(word).map(Sizing::Fixed)
    }
    fn word(self) -> String {
        match self {
            Sizing::Fixed(n) => n.word(),
            Sizing::Auto => "auto".to_owned(),
        }
    }
}

impl<const MIN: u32, const MAX: u32> std::fmt::Display for Sizing<Bounded<MIN, MAX>> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.word())
    }
}

impl<const MIN: u32, const MAX: u32> Sizing<Bounded<MIN, MAX>> {
    /// The fixed value, or `None` for `auto`.
    pub fn fixed(self) -> Option<u32> {
        match self {
            Sizing::Fixed(n) => Some(n.get()),
            Sizing::Auto => None,
        }
    }

    /// The value for a frame: the fixed one, or the deepest pixel's fragment count (at least
    /// `MIN`); refused when that is over `MAX` (`why` says what sets the maximum).
    pub(crate) fn per_pixel(
        self,
        spec_key: &str,
        count: Option<LayerCount>,
        why: &str,
    ) -> Result<Bounded<MIN, MAX>, GpuError> {
        let (Sizing::Auto, Some(count)) = (self, count) else {
            return match self {
                Sizing::Fixed(n) => Ok(n),
                Sizing::Auto => Err(GpuError::Mismatch(format!(
                    "{spec_key}=auto sized without a count"
                ))),
            };
        };
        let depth = count.max_per_pixel.max(MIN);
        Bounded::new(depth).ok_or_else(|| {
            Unsupported::new(format!(
                "{spec_key}=auto: the deepest pixel holds {} transparent fragments in front of the opaque surface, more than {spec_key} allows ({MIN}–{MAX}: {why}); nothing is clamped, so this configuration is refused on this scene",
                count.max_per_pixel
            ))
            .into()
        })
    }
}

/// Refuses `bytes` of storage sized by `auto` (`what` names it) over the adapter's storage
/// binding or [`AUTO_MEMORY_CAP`], with both in MiB.
pub(crate) fn check_auto_bytes(what: &str, bytes: u64, caps: &Caps) -> Result<(), GpuError> {
    let binding = caps
        .max_storage_buffer_binding_size
        .min(caps.max_buffer_size);
    let (cap, cap_name) = if binding < AUTO_MEMORY_CAP {
        (
            binding,
            format!(
                "the adapter's largest storage binding (auto's own cap, AUTO_MEMORY_CAP, is {})",
                mib(AUTO_MEMORY_CAP)
            ),
        )
    } else {
        (
            AUTO_MEMORY_CAP,
            format!(
                "AUTO_MEMORY_CAP, the cap on storage sized by auto (the adapter binds up to {})",
                mib(binding)
            ),
        )
    };
    if bytes > cap {
        return Err(GpuError::OverMemoryCap {
            what: what.to_owned(),
            needed: bytes,
            cap,
            cap_name,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    type Small = Sizing<Bounded<1, 32>>;

    #[test]
    fn auto_is_a_word_beside_the_range() {
        assert_eq!(Small::from_word("auto"), Some(Sizing::Auto));
        assert_eq!(Small::from_word("7"), Some(Sizing::Fixed(Bounded::of(7))));
        for bad in ["0", "33", "Auto", "07", ""] {
            assert_eq!(Small::from_word(bad), None, "{bad}");
        }
        assert_eq!(Sizing::<Bounded<1, 32>>::Auto.word(), "auto");
        assert_eq!(Small::allowed().to_string(), "an integer 1..=32, auto");
        assert_eq!(Small::Auto.fixed(), None);
        assert_eq!(Sizing::Fixed(Bounded::<1, 32>::of(5)).fixed(), Some(5));
    }

    #[test]
    fn auto_takes_the_deepest_pixel_and_refuses_past_the_range() {
        let count = |max| {
            Some(LayerCount {
                fragments: 100,
                max_per_pixel: max,
            })
        };
        assert_eq!(Small::Auto.per_pixel("k", count(9), "x").unwrap().get(), 9);
        // No fragment at all still needs one slot.
        assert_eq!(Small::Auto.per_pixel("k", count(0), "x").unwrap().get(), 1);
        let e = Small::Auto
            .per_pixel("k", count(40), "slots walked per fragment")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("40") && e.contains("1–32") && e.contains("slots walked"),
            "{e}"
        );
        let fixed = Sizing::Fixed(Bounded::<1, 32>::of(3));
        assert_eq!(fixed.per_pixel("k", count(40), "x").unwrap().get(), 3);
        assert!(Small::Auto.per_pixel("k", None, "x").is_err());
    }
}
