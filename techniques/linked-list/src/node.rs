//! The node formats and the tail rule, line-comparable with shaders/linked_list_node.wgsl: tests
//! predict the GPU's composite from these.

/// Largest rgb9e5 value ((511/512) · 2^16).
pub const RGB9E5_MAX: f32 = 65408.0;
const UNORM24_MAX: f32 = 16_777_215.0;

oit_gpu::words! {
    /// How a stored fragment is packed.
    pub enum NodeFormat {
        /// 16 B: the window depth's f32 bits, premultiplied colour and α as binary16.
        F32 = "f32",
        /// 12 B (Bevy's layout): unorm24 depth with unorm8 α in one word, rgb9e5 colour.
        Packed = "packed",
    }
}

impl NodeFormat {
    /// Bytes of one node in the pool (the `next` index included); `transmit`: nodes that store
    /// rgb opacity (scenes with coloured transmission), one word more.
    pub fn bytes(self, transmit: bool) -> u64 {
        let scalar = match self {
            NodeFormat::F32 => 16,
            NodeFormat::Packed => 12,
        };
        scalar + if transmit { 4 } else { 0 }
    }
}

/// A node in registers: `key` orders front to back (smaller is nearer), ties by `c0`, `c1`,
/// `c2`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Node {
    pub key: u32,
    pub c0: u32,
    pub c1: u32,
    pub c2: u32,
}

/// What a node decodes to: premultiplied colour and per-channel opacity `1 − t` (α in every
/// channel for scalar nodes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fragment {
    pub color: [f32; 3],
    pub opacity: [f32; 3],
}

fn ldexp(x: f32, e: i32) -> f32 {
    x * 2f32.powi(e)
}

/// Shared-exponent RGB with the exponent from the f32 bits (no log2 rounding).
pub fn pack_rgb9e5(c: [f32; 3]) -> u32 {
    let rc = c.map(|x| x.clamp(0.0, RGB9E5_MAX));
    let m = rc[0].max(rc[1].max(rc[2]));
    let e_floor = (((m.to_bits() >> 23) & 0xff) as i32 - 127).max(-16);
    let mut e_shared = e_floor + 16;
    let mut scale = ldexp(1.0, 24 - e_shared);
    if (m * scale + 0.5).floor() >= 512.0 {
        e_shared += 1;
        scale *= 0.5;
    }
    let q = rc.map(|x| (x * scale + 0.5).floor() as u32);
    q[0] | (q[1] << 9) | (q[2] << 18) | ((e_shared as u32) << 27)
}

pub fn unpack_rgb9e5(w: u32) -> [f32; 3] {
    let scale = ldexp(1.0, (w >> 27) as i32 - 24);
    [w & 511, (w >> 9) & 511, (w >> 18) & 511].map(|q| q as f32 * scale)
}

fn pack2x16float(a: f32, b: f32) -> u32 {
    u32::from(half::f16::from_f32(a).to_bits())
        | (u32::from(half::f16::from_f32(b).to_bits()) << 16)
}

fn unpack2x16float(w: u32) -> [f32; 2] {
    [
        half::f16::from_bits(w as u16).to_f32(),
        half::f16::from_bits((w >> 16) as u16).to_f32(),
    ]
}

const UNORM10_MAX: f32 = 1023.0;

fn unorm10(x: f32) -> u32 {
    (x.clamp(0.0, 1.0) * UNORM10_MAX + 0.5) as u32
}

/// Per-channel opacity as 3 × unorm10 (packed transmit nodes, the k-buffer's opacity slots).
pub fn pack_opacity(a: [f32; 3]) -> u32 {
    unorm10(a[0]) | (unorm10(a[1]) << 10) | (unorm10(a[2]) << 20)
}

pub fn unpack_opacity(w: u32) -> [f32; 3] {
    [w & 1023, (w >> 10) & 1023, (w >> 20) & 1023].map(|q| q as f32 / UNORM10_MAX)
}

/// Bit 31 of a packed transmit node's `c1` and of a k-buffer opacity slot's low word (unused
/// by the unorm10 opacities): the colour is negated. rgb9e5 holds no sign, so `subtract`'s colour
/// (−α·c in every channel) is stored as its magnitude and this bit.
pub const NEGATED: u32 = 0x8000_0000;

/// Whether a shaded colour is negative (`is_negated` of linked_list_node.wgsl): every channel
/// of a `subtract` fragment is ≤ 0, every other fragment's ≥ 0.
pub fn is_negated(c: [f32; 3]) -> bool {
    c[0] + c[1] + c[2] < 0.0
}

/// rgb9e5 of `|c|` and [`NEGATED`] or 0.
pub fn pack_signed_rgb9e5(c: [f32; 3]) -> (u32, u32) {
    if is_negated(c) {
        (pack_rgb9e5(c.map(|x| -x)), NEGATED)
    } else {
        (pack_rgb9e5(c), 0)
    }
}

/// The colour of an rgb9e5 word, negated where `flags` has [`NEGATED`].
pub fn unpack_signed_rgb9e5(w: u32, flags: u32) -> [f32; 3] {
    let c = unpack_rgb9e5(w);
    if flags & NEGATED != 0 {
        c.map(|x| -x)
    } else {
        c
    }
}

/// `opacity` (`1 − t` per channel) is stored only when `transmit`; scalar nodes store `alpha`.
pub fn pack_node(
    format: NodeFormat,
    transmit: bool,
    color: [f32; 3],
    alpha: f32,
    opacity: [f32; 3],
    z: f32,
    reverse_z: bool,
) -> Node {
    match format {
        NodeFormat::Packed => {
            // z = 1 rounds to 2^24 in f32: clamp to 24 bits (see linked_list_node.wgsl).
            let mut d = ((z.clamp(0.0, 1.0) * UNORM24_MAX + 0.5) as u32).min(16_777_215);
            if reverse_z {
                d = 16_777_215 - d;
            }
            // Only the 16-byte transmit layout has a spare bit for the sign.
            let (c0, c1) = if transmit {
                let (c0, sign) = pack_signed_rgb9e5(color);
                (c0, pack_opacity(opacity) | sign)
            } else {
                (pack_rgb9e5(color), 0)
            };
            Node {
                key: (d << 8) | (alpha.clamp(0.0, 1.0) * 255.0 + 0.5) as u32,
                c0,
                c1,
                c2: 0,
            }
        }
        NodeFormat::F32 => {
            // +0 for -0: the sign bit would sort it farthest.
            let mut bits = z.to_bits() & 0x7fff_ffff;
            if reverse_z {
                bits = !bits;
            }
            if transmit {
                Node {
                    key: bits,
                    c0: pack2x16float(color[0], color[1]),
                    c1: pack2x16float(color[2], opacity[0]),
                    c2: pack2x16float(opacity[1], opacity[2]),
                }
            } else {
                Node {
                    key: bits,
                    c0: pack2x16float(color[0], color[1]),
                    c1: pack2x16float(color[2], alpha),
                    c2: 0,
                }
            }
        }
    }
}

pub fn unpack_node(format: NodeFormat, transmit: bool, n: Node) -> Fragment {
    match format {
        NodeFormat::Packed => Fragment {
            color: unpack_signed_rgb9e5(n.c0, n.c1),
            opacity: if transmit {
                unpack_opacity(n.c1)
            } else {
                [(n.key & 255) as f32 / 255.0; 3]
            },
        },
        NodeFormat::F32 => {
            let rg = unpack2x16float(n.c0);
            let ba = unpack2x16float(n.c1);
            let gb = unpack2x16float(n.c2);
            Fragment {
                color: [rg[0], rg[1], ba[0]],
                opacity: if transmit {
                    [ba[1], gb[0], gb[1]]
                } else {
                    [ba[1]; 3]
                },
            }
        }
    }
}

/// Fragments behind the sort window, composited as one layer, per channel: coverage
/// 1 − Π(1 − a) exactly, colour the a-weighted average of their colours (a = the opacity, α
/// for scalar nodes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tail {
    pub color: [f32; 3],
    pub alpha_sum: [f32; 3],
    pub transmittance: [f32; 3],
    pub count: u32,
}

impl Tail {
    pub const EMPTY: Tail = Tail {
        color: [0.0; 3],
        alpha_sum: [0.0; 3],
        transmittance: [1.0; 3],
        count: 0,
    };

    pub fn with(self, f: Fragment) -> Tail {
        Tail {
            color: [0, 1, 2].map(|i| self.color[i] + f.color[i]),
            alpha_sum: [0, 1, 2].map(|i| self.alpha_sum[i] + f.opacity[i]),
            transmittance: [0, 1, 2].map(|i| self.transmittance[i] * (1.0 - f.opacity[i])),
            count: self.count + 1,
        }
    }

    pub fn resolve(self) -> Fragment {
        let opacity = self.transmittance.map(|t| 1.0 - t);
        let color = [0, 1, 2].map(|c| {
            if self.alpha_sum[c] > 0.0 {
                self.color[c] * (opacity[c] / self.alpha_sum[c])
            } else {
                0.0
            }
        });
        Fragment { color, opacity }
    }
}

/// The resolve of one pixel's fragments (`resolve_pixel`): the `sort_max` nearest composited
/// front to back, the rest by the tail rule (`None`: dropped). Returns premultiplied colour and
/// per-channel transmittance, and whether the tail was used.
pub fn resolve(
    format: NodeFormat,
    transmit: bool,
    nodes: &[Node],
    sort_max: usize,
    average_tail: bool,
) -> ([f32; 3], [f32; 3], bool) {
    let mut sorted = nodes.to_vec();
    sorted.sort();
    let (window, rest) = sorted.split_at(sort_max.min(sorted.len()));
    let mut c = [0.0f32; 3];
    let mut t = [1.0f32; 3];
    for n in window {
        let f = unpack_node(format, transmit, *n);
        c = [0, 1, 2].map(|i| c[i] + t[i] * f.color[i]);
        t = [0, 1, 2].map(|i| t[i] * (1.0 - f.opacity[i]));
    }
    if average_tail && !rest.is_empty() {
        let tail = rest.iter().fold(Tail::EMPTY, |acc, n| {
            acc.with(unpack_node(format, transmit, *n))
        });
        let f = tail.resolve();
        c = [0, 1, 2].map(|i| c[i] + t[i] * f.color[i]);
        t = [0, 1, 2].map(|i| t[i] * (1.0 - f.opacity[i]));
    }
    (c, t, !rest.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A scalar-alpha node.
    fn scalar(format: NodeFormat, color: [f32; 3], alpha: f32, z: f32, reverse_z: bool) -> Node {
        pack_node(format, false, color, alpha, [alpha; 3], z, reverse_z)
    }

    /// z = 1 (the reverse-Z near plane, the standard far plane) stays inside 24 bits: found by
    /// the GPU twin test, where it wrapped and sorted the nearest fragment farthest.
    #[test]
    fn packed_depth_at_one_stays_in_24_bits() {
        let near = scalar(NodeFormat::Packed, [1.0; 3], 1.0, 1.0, true);
        let next = scalar(NodeFormat::Packed, [1.0; 3], 1.0, 0.999, true);
        assert_eq!(near.key >> 8, 0);
        assert!(near.key < next.key);
        let far = scalar(NodeFormat::Packed, [1.0; 3], 0.0, 1.0, false);
        assert_eq!(far.key, 0xffff_ff00);
    }

    #[test]
    fn rgb9e5_known_values() {
        assert_eq!(unpack_rgb9e5(pack_rgb9e5([0.0; 3])), [0.0; 3]);
        assert_eq!(
            unpack_rgb9e5(pack_rgb9e5([1.0, 0.5, 0.25])),
            [1.0, 0.5, 0.25]
        );
        assert_eq!(unpack_rgb9e5(pack_rgb9e5([RGB9E5_MAX; 3])), [RGB9E5_MAX; 3]);
        // Above the largest value clamps; negative colour clamps to 0 (premultiplied colours of
        // the rendering model are never negative).
        assert_eq!(
            unpack_rgb9e5(pack_rgb9e5([1e9, -1.0, 0.0]))[..2],
            [RGB9E5_MAX, 0.0]
        );
        // 511.5/512 rounds up into the next exponent.
        let w = pack_rgb9e5([1.0 - 1.0 / 1024.0, 0.0, 0.0]);
        assert_eq!(unpack_rgb9e5(w)[0], 1.0);
    }

    proptest! {
        #[test]
        fn rgb9e5_error_is_bounded_by_half_a_step_of_the_largest_channel(
            r in 0.0f32..60000.0, g in 0.0f32..1.0, b in 0.0f32..4.0, scale in -20i32..0
        ) {
            let c = [r, g, b].map(|x| x * 2f32.powi(scale));
            let m = c[0].max(c[1]).max(c[2]);
            let d = unpack_rgb9e5(pack_rgb9e5(c));
            // One step is m / 256 at worst (the mantissa of the largest channel is ≥ 256);
            // below 2^-16 the smallest exponent's step 2^-24 applies.
            let step = (m / 256.0).max(2f32.powi(-24));
            for i in 0..3 {
                prop_assert!((d[i] - c[i]).abs() <= 0.5 * step * 1.0001, "{c:?} -> {d:?}");
            }
        }

        #[test]
        fn keys_order_nodes_as_depth_does(z1 in 0.0f32..=1.0, z2 in 0.0f32..=1.0, reverse in any::<bool>()) {
            for format in [NodeFormat::F32, NodeFormat::Packed] {
                let a = scalar(format, [0.5; 3], 0.5, z1, reverse);
                let b = scalar(format, [0.5; 3], 0.5, z2, reverse);
                let a_nearer = if reverse { z1 > z2 } else { z1 < z2 };
                if format == NodeFormat::F32 {
                    prop_assert_eq!(a.key < b.key, a_nearer);
                } else {
                    // 24-bit depth: nearer never sorts farther (equal keys may tie).
                    prop_assert!(!a_nearer || a.key <= b.key);
                }
            }
        }
    }

    #[test]
    fn negative_zero_sorts_as_zero() {
        let a = scalar(NodeFormat::F32, [0.0; 3], 0.5, -0.0, false);
        let b = scalar(NodeFormat::F32, [0.0; 3], 0.5, 1e-30, false);
        assert!(a.key < b.key);
    }

    #[test]
    fn resolve_composites_front_to_back_and_averages_the_tail() {
        let f = NodeFormat::F32;
        let near = scalar(f, [0.5, 0.0, 0.0], 0.5, 0.2, false);
        let mid = scalar(f, [0.0, 0.25, 0.0], 0.25, 0.5, false);
        let far = scalar(f, [0.0, 0.0, 0.75], 0.75, 0.8, false);
        // Any arrival order gives the same result.
        let (c, t, tail) = resolve(f, false, &[far, near, mid], 3, true);
        assert_eq!(resolve(f, false, &[mid, far, near], 3, true), (c, t, tail));
        assert!(!tail);
        assert_eq!(c, [0.5, 0.5 * 0.25, 0.5 * 0.75 * 0.75]);
        assert_eq!(t, [0.5 * 0.75 * 0.25; 3]);
        // Window of 1: the two far layers become one averaged layer with exact coverage.
        let (c1, t1, tail1) = resolve(f, false, &[far, near, mid], 1, true);
        assert!(tail1);
        assert_eq!(t1, t);
        let cov = 1.0 - 0.75 * 0.25;
        let expect = [0.5, 0.5 * 0.25 / 1.0 * cov, 0.5 * 0.75 / 1.0 * cov];
        for i in 0..3 {
            assert!((c1[i] - expect[i]).abs() < 1e-6, "{c1:?} vs {expect:?}");
        }
        // Dropped: only the nearest remains.
        let (c2, t2, _) = resolve(f, false, &[far, near, mid], 1, false);
        assert_eq!((c2, t2), ([0.5, 0.0, 0.0], [0.5; 3]));
    }

    proptest! {
        /// Transmit nodes keep the opacity to binary16 (f32 nodes: half a step, 2^-12 of it)
        /// or unorm10 (packed: 0.5 / 1023), independently per channel.
        #[test]
        fn transmit_nodes_keep_rgb_opacity(r in 0.0f32..=1.0, g in 0.0f32..=1.0, b in 0.0f32..=1.0) {
            let a = [r, g, b];
            for format in [NodeFormat::F32, NodeFormat::Packed] {
                let n = pack_node(format, true, [0.25, 0.5, 1.0], 0.3, a, 0.4, false);
                let f = unpack_node(format, true, n);
                for c in 0..3 {
                    let bound = match format {
                        NodeFormat::F32 => a[c] * 2f32.powi(-11) + 2f32.powi(-25),
                        NodeFormat::Packed => 0.5 / 1023.0 + 1e-7,
                    };
                    prop_assert!((f.opacity[c] - a[c]).abs() <= bound, "{format:?} {a:?} -> {:?}", f.opacity);
                }
            }
        }
    }

    /// Two complementary filters (red passes red, cyan passes green and blue) stack to black
    /// per channel, which no scalar α gives; the tail multiplies per channel exactly too.
    #[test]
    fn transmit_resolve_filters_per_channel() {
        for format in [NodeFormat::F32, NodeFormat::Packed] {
            let red = pack_node(format, true, [0.0; 3], 0.0, [0.0, 1.0, 1.0], 0.2, false);
            let cyan = pack_node(format, true, [0.0; 3], 0.0, [1.0, 0.0, 0.0], 0.6, false);
            let (c, t, _) = resolve(format, true, &[cyan, red], 2, true);
            assert_eq!((c, t), ([0.0; 3], [0.0; 3]), "{format:?}");
            let (_, t_red, _) = resolve(format, true, &[red], 2, true);
            assert_eq!(t_red, [1.0, 0.0, 0.0], "{format:?}");
            // Behind a window of 1 the cyan filter is the averaged tail: still exact coverage.
            let (_, t_tail, tail) = resolve(format, true, &[cyan, red], 1, true);
            assert!(tail);
            assert_eq!(t_tail, [0.0; 3], "{format:?}");
        }
    }
}
