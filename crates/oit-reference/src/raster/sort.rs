//! Sorting a pixel's fragments by key: a natural merge sort stable on ties, and the permutation
//! it applies.

/// Marks an entry of a permutation as moved while [`permute`] follows its cycles.
pub(super) const MOVED: u32 = 1 << 31;

/// Reorders one pixel's slots in place so that slot `k` holds what slot `perm[k]` held (keys,
/// colours and, where the scene has them, transmittances together), following the
/// permutation's cycles: no buffer beyond `perm`, which is left as it was. Lists are shorter
/// than 2^31 (slot indices are u32 and a slice's slots fit it).
pub(super) fn permute(
    perm: &mut [u32],
    keys: &mut [u64],
    colors: &mut [[f32; 4]],
    transmittance: &mut [[f64; 3]],
) {
    for start in 0..perm.len() {
        if perm[start] & MOVED != 0 || perm[start] as usize == start {
            continue;
        }
        let (key, color) = (keys[start], colors[start]);
        let t = transmittance.get(start).copied();
        let mut j = start;
        loop {
            let k = perm[j] as usize;
            perm[j] |= MOVED;
            if k == start {
                keys[j] = key;
                colors[j] = color;
                if let Some(t) = t {
                    transmittance[j] = t;
                }
                break;
            }
            keys[j] = keys[k];
            colors[j] = colors[k];
            if t.is_some() {
                transmittance[j] = transmittance[k];
            }
            j = k;
        }
    }
    for i in perm.iter_mut() {
        *i &= !MOVED;
    }
}

/// Whether `keys[perm[0]] < keys[perm[1]] < …` (`perm` indexes `keys`). Branch-free over the
/// list: the answer is almost always yes, so an early exit would not pay.
pub(super) fn strictly_ascending(perm: &[u32], keys: &[u64]) -> bool {
    let Some((&first, rest)) = perm.split_first() else {
        return true;
    };
    let mut previous = keys[first as usize];
    let mut ascending = true;
    for &i in rest {
        let key = keys[i as usize];
        ascending &= previous < key;
        previous = key;
    }
    ascending
}

/// Lists up to this long are sorted by insertion, longer ones by merging runs.
pub(super) const SHORT_LIST: usize = 12;

/// Sorts one pixel's list (indices of its fragments) by key; keys are unique: they contain the
/// triangle rank.
///
/// Fragments arrive in triangle-rank order, one per triangle, so a pixel's list is usually a
/// few monotone runs (each object's layers in order, one way or the other). This is a natural
/// merge sort: find the runs (reversing descending ones), then merge neighbours pairwise
/// through `buffer` until one run is left: O(n) for one or two runs, O(n log n) at worst, and
/// no allocation once the tile's scratch has grown. Short lists use insertion sort.
pub(super) fn sort_by_key(
    list: &mut [u32],
    key: impl Fn(u32) -> u64,
    buffer: &mut Vec<u32>,
    runs: &mut Vec<usize>,
) {
    let n = list.len();
    if n <= SHORT_LIST {
        // Insertion sort on a local copy of the keys (no indirect loads while shifting).
        let mut keys = [0u64; SHORT_LIST];
        for (k, &i) in keys.iter_mut().zip(list.iter()) {
            *k = key(i);
        }
        for i in 1..n {
            let (f, fk) = (list[i], keys[i]);
            let mut j = i;
            while j > 0 && keys[j - 1] > fk {
                list[j] = list[j - 1];
                keys[j] = keys[j - 1];
                j -= 1;
            }
            list[j] = f;
            keys[j] = fk;
        }
        return;
    }
    runs.clear();
    runs.push(0);
    let mut i = 0;
    while i < n {
        let mut j = i + 1;
        if j < n && key(list[j]) < key(list[j - 1]) {
            while j < n && key(list[j]) < key(list[j - 1]) {
                j += 1;
            }
            list[i..j].reverse();
        } else {
            while j < n && key(list[j]) > key(list[j - 1]) {
                j += 1;
            }
        }
        runs.push(j);
        i = j;
    }
    if runs.len() == 2 {
        return;
    }
    buffer.clear();
    buffer.extend_from_slice(list);
    // Ping-pong between `list` and `buffer`; `in_list` says where the current runs live.
    let mut in_list = true;
    while runs.len() > 2 {
        let (src, dst): (&[u32], &mut [u32]) = if in_list {
            (&*list, &mut buffer[..])
        } else {
            (&buffer[..], &mut *list)
        };
        let mut merged = 1;
        let mut r = 0;
        while r + 1 < runs.len() {
            let lo = runs[r];
            if r + 2 < runs.len() {
                let (mid, hi) = (runs[r + 1], runs[r + 2]);
                merge(&src[lo..mid], &src[mid..hi], &mut dst[lo..hi], &key);
                runs[merged] = hi;
                r += 2;
            } else {
                let hi = runs[r + 1];
                dst[lo..hi].copy_from_slice(&src[lo..hi]);
                runs[merged] = hi;
                r += 1;
            }
            merged += 1;
        }
        runs.truncate(merged);
        in_list = !in_list;
    }
    if !in_list {
        list.copy_from_slice(buffer);
    }
}

/// Merges two runs ascending by key into `out` (`out.len() == a.len() + b.len()`).
pub(super) fn merge(a: &[u32], b: &[u32], out: &mut [u32], key: &impl Fn(u32) -> u64) {
    let (mut i, mut j) = (0, 0);
    for slot in out.iter_mut() {
        let take_a = j >= b.len() || (i < a.len() && key(a[i]) < key(b[j]));
        if take_a {
            *slot = a[i];
            i += 1;
        } else {
            *slot = b[j];
            j += 1;
        }
    }
}
