//! Where each cloth of a batch lives in the shared buffers: per buffer, a
//! first-fit allocator of element ranges. A removed cloth's ranges are
//! freed and reused by a later cloth that fits in them; a cloth that fits
//! nowhere goes at the end, and the buffer grows to hold it.

use std::ops::Range;

/// The shared buffers of a batch, each indexed by its own element (a
/// particle's `vec4`, a `vec4` of words, a `u32` word; see [`Region::ALL`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Region {
    /// `x`, `v` and `vertex_normals`: a `vec4` per particle.
    Particles,
    /// `model`: spring records, topology and dense filters, `vec4`s of
    /// `u32` words.
    Model,
    /// `work`: per-particle and per-spring sections and partials, `vec4`s.
    Work,
    /// `status`: `u32` words.
    Status,
    /// The index buffer: `u32` triangle indices.
    Indices,
}

/// Number of [`Region`]s.
pub(crate) const REGIONS: usize = 5;

impl Region {
    /// Every region, in the order of [`Extents`]' arrays.
    pub(crate) const ALL: [Region; REGIONS] = [
        Region::Particles,
        Region::Model,
        Region::Work,
        Region::Status,
        Region::Indices,
    ];

    /// Its index in [`Region::ALL`].
    pub(crate) fn index(self) -> usize {
        self as usize
    }
}

/// A length or a start per [`Region`], in that region's elements.
pub(crate) type Extents = [u64; REGIONS];

/// The ranges in use in one buffer, in elements.
#[derive(Clone, Debug, Default, PartialEq)]
struct Ranges {
    /// In use: sorted by start, disjoint, none empty.
    used: Vec<Range<u64>>,
}

impl Ranges {
    /// Where `len` elements go: the start of the first gap that holds
    /// them, else the end of the last range in use. Zero elements go at 0
    /// (nothing is reserved for them).
    fn place(&self, len: u64) -> u64 {
        if len == 0 {
            return 0;
        }
        let mut at = 0;
        for r in &self.used {
            if r.start - at >= len {
                return at;
            }
            at = r.end;
        }
        at
    }

    /// Reserves `len` elements where [`Ranges::place`] puts them and
    /// returns their start.
    fn reserve(&mut self, len: u64) -> u64 {
        let start = self.place(len);
        if len > 0 {
            let k = self.used.partition_point(|r| r.start < start);
            self.used.insert(k, start..start + len);
        }
        start
    }

    /// Frees the `len` elements reserved at `start` (nothing for zero: a
    /// zero-length range was never reserved, and another may start there).
    fn free(&mut self, start: u64, len: u64) {
        if len > 0 {
            self.used.retain(|r| *r != (start..start + len));
        }
    }

    /// The end of the last range in use: the elements the buffer must hold.
    fn end(&self) -> u64 {
        self.used.last().map_or(0, |r| r.end)
    }
}

/// The ranges in use in every shared buffer of a batch.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Layout {
    ranges: [Ranges; REGIONS],
}

impl Layout {
    /// Reserves `lens` elements in each buffer and returns their starts.
    pub(crate) fn reserve(&mut self, lens: &Extents) -> Extents {
        let mut starts = [0; REGIONS];
        for (k, r) in self.ranges.iter_mut().enumerate() {
            starts[k] = r.reserve(lens[k]);
        }
        starts
    }

    /// Frees the ranges of `lens` elements a cloth reserved at `starts`.
    pub(crate) fn free(&mut self, starts: &Extents, lens: &Extents) {
        for (k, r) in self.ranges.iter_mut().enumerate() {
            r.free(starts[k], lens[k]);
        }
    }

    /// Elements each buffer must hold for the ranges in use.
    pub(crate) fn ends(&self) -> Extents {
        self.ranges.each_ref().map(Ranges::end)
    }
}

/// The elements to allocate for a buffer that must hold `needed` and holds
/// `capacity`: unchanged when it fits, else at least twice as many, so
/// adding cloths one by one copies each buffer O(log n) times.
pub(crate) fn grown(capacity: u64, needed: u64) -> u64 {
    if needed <= capacity {
        capacity
    } else {
        needed.max(capacity.saturating_mul(2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lens(particles: u64, words: u64) -> Extents {
        let mut l = [words; REGIONS];
        l[Region::Particles.index()] = particles;
        l
    }

    #[test]
    fn cloths_are_placed_one_after_another() {
        let mut layout = Layout::default();
        let a = layout.reserve(&lens(10, 4));
        let b = layout.reserve(&lens(20, 5));
        assert_eq!(a, [0; REGIONS]);
        assert_eq!(b[Region::Particles.index()], 10);
        assert_eq!(b[Region::Model.index()], 4);
        assert_eq!(layout.ends()[Region::Particles.index()], 30);
        assert_eq!(layout.ends()[Region::Indices.index()], 9);
    }

    #[test]
    fn a_freed_range_is_reused_by_a_cloth_that_fits_and_skipped_by_one_that_does_not() {
        let mut layout = Layout::default();
        let a = layout.reserve(&lens(10, 4));
        let _b = layout.reserve(&lens(20, 5));
        layout.free(&a, &lens(10, 4));
        // Too large for the holes: at the ends.
        let c = layout.reserve(&lens(11, 5));
        assert_eq!(c[Region::Particles.index()], 30);
        assert_eq!(c[Region::Model.index()], 9);
        // Fits: in the hole, and the buffers need not grow.
        let before = layout.ends();
        let d = layout.reserve(&lens(10, 3));
        assert_eq!(d[Region::Particles.index()], 0);
        assert_eq!(d[Region::Model.index()], 0);
        assert_eq!(layout.ends(), before);
        // The hole's rest (one word) takes a one-word range.
        let e = layout.reserve(&lens(0, 1));
        assert_eq!(e[Region::Model.index()], 3);
    }

    #[test]
    fn ranges_in_use_never_overlap() {
        let mut layout = Layout::default();
        let mut live: Vec<(Extents, Extents)> = Vec::new();
        // A fixed sequence of adds and removes of assorted sizes.
        for step in 0u64..60 {
            if step % 3 == 2 {
                let (starts, l) = live.remove((step as usize * 7) % live.len());
                layout.free(&starts, &l);
            } else {
                let l = lens(1 + step * 13 % 17, step * 5 % 11);
                live.push((layout.reserve(&l), l));
            }
            for (k, (sa, la)) in live.iter().enumerate() {
                for (sb, lb) in &live[k + 1..] {
                    for r in 0..REGIONS {
                        let disjoint = sa[r] + la[r] <= sb[r] || sb[r] + lb[r] <= sa[r];
                        assert!(
                            disjoint || la[r] == 0 || lb[r] == 0,
                            "region {r}: {}+{} overlaps {}+{}",
                            sa[r],
                            la[r],
                            sb[r],
                            lb[r]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_buffer_grows_at_least_twofold_and_only_when_needed() {
        assert_eq!(grown(100, 80), 100);
        assert_eq!(grown(100, 101), 200);
        assert_eq!(grown(100, 500), 500);
        assert_eq!(grown(0, 7), 7);
    }
}
