//! Space management for the renderer's shared mesh buffers: every body's triangles (and edge
//! lines) live in one of a few large vertex buffers, at an offset this allocator hands out,
//! instead of in a GPU buffer of their own. The number of GPU resources then no longer grows
//! with the number of bodies, and neither does the per-submission work the graphics stack does
//! for each live resource (docs/display.md, *Packing meshes into shared buffers*).
//!
//! An [`Arena`] counts in elements (vertices). It hands out ranges first-fit from the holes
//! that freed ranges leave, else from the top; freeing merges a range with its neighbouring
//! holes, and a hole that reaches the top lowers the top. When neither a hole nor the room
//! above the top fits, the caller grows the buffer ([`Arena::grow`]: a bigger buffer, the old
//! contents copied on the GPU). The live data is drawn as the runs between holes
//! ([`Arena::runs`]), so a frame makes one draw per run, not one per body; when the holes
//! become many or large, [`Arena::compact`] slides the runs down over them and says where
//! every old offset went.
//!
//! Nothing here touches the GPU: the renderer applies what the arena decides, and the tests
//! below check the decisions.

use std::collections::BTreeMap;

/// A range of elements: `start .. start + len`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Span {
    pub start: u32,
    pub len: u32,
}

impl Span {
    pub fn end(&self) -> u32 {
        self.start + self.len
    }
}

/// Holes beyond which [`Arena::wants_compaction`] says yes: a frame draws at most this many
/// runs plus one per arena.
pub const MAX_HOLES: usize = 64;

/// Free-space bookkeeping of one shared buffer, in elements.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Arena {
    capacity: u32,
    /// End of the highest live range: everything at or above it is free.
    top: u32,
    /// Free ranges below `top`: start → length. Never empty, never adjacent to one another,
    /// never touching `top` (those merge).
    holes: BTreeMap<u32, u32>,
    /// Elements in live ranges.
    used: u32,
}

/// What [`Arena::compact`] did: the copies to make into a fresh buffer (old start, new start,
/// length: every live run, in increasing order, each destination at or below its source) and
/// where each old offset went.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Compaction {
    pub copies: Vec<(u32, u32, u32)>,
    /// The holes as they were (start, length), sorted, with the total length of the holes
    /// before each one.
    holes: Vec<(u32, u32, u32)>,
}

impl Compaction {
    /// The new start of a live range that started at `old`.
    pub fn moved(&self, old: u32) -> u32 {
        // Holes wholly below `old`: every one that starts below it (a live range never starts
        // inside a hole).
        let k = self.holes.partition_point(|h| h.0 < old);
        match k {
            0 => old,
            _ => {
                let (_, len, before) = self.holes[k - 1];
                old - (before + len)
            }
        }
    }
}

impl Arena {
    pub fn new(capacity: u32) -> Arena {
        Arena {
            capacity,
            top: 0,
            holes: BTreeMap::new(),
            used: 0,
        }
    }

    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// End of the highest live range.
    pub fn top(&self) -> u32 {
        self.top
    }

    /// Elements in live ranges.
    pub fn used(&self) -> u32 {
        self.used
    }

    /// Free ranges between live ones.
    pub fn holes(&self) -> usize {
        self.holes.len()
    }

    /// Elements in the holes.
    pub fn hole_elements(&self) -> u32 {
        self.top - self.used
    }

    /// A range of `len` (> 0) elements: the first hole that fits, else above the top; `None`
    /// when neither has room (grow first).
    pub fn alloc(&mut self, len: u32) -> Option<u32> {
        if len == 0 {
            return None;
        }
        if let Some((&s, &l)) = self.holes.iter().find(|(_, l)| **l >= len) {
            self.holes.remove(&s);
            if l > len {
                self.holes.insert(s + len, l - len);
            }
            self.used += len;
            return Some(s);
        }
        if self.capacity - self.top >= len {
            let s = self.top;
            self.top += len;
            self.used += len;
            return Some(s);
        }
        None
    }

    /// The capacity a growth must reach for `len` more elements above the top.
    pub fn needed_for(&self, len: u32) -> u64 {
        self.top as u64 + len as u64
    }

    /// Returns a live range to the free space, merging it with the holes beside it.
    pub fn free(&mut self, span: Span) {
        debug_assert!(
            span.end() <= self.top,
            "{span:?} above the top {}",
            self.top
        );
        self.used -= span.len;
        let (mut s, mut l) = (span.start, span.len);
        if let Some((&ps, &pl)) = self.holes.range(..s).next_back()
            && ps + pl == s
        {
            self.holes.remove(&ps);
            s = ps;
            l += pl;
        }
        if let Some(nl) = self.holes.remove(&(s + l)) {
            l += nl;
        }
        if s + l == self.top {
            self.top = s;
        } else {
            self.holes.insert(s, l);
        }
    }

    /// A bigger capacity (the caller has made the bigger buffer and copied `0..top` into it).
    pub fn grow(&mut self, capacity: u32) {
        debug_assert!(capacity >= self.capacity);
        self.capacity = capacity;
    }

    /// A new capacity at or above the top (after [`Arena::compact`], for a buffer made to fit
    /// what is live).
    pub fn set_capacity(&mut self, capacity: u32) {
        debug_assert!(capacity >= self.top);
        self.capacity = capacity.max(self.top);
    }

    /// The live runs, in order: `0..top` without the holes. What a frame draws.
    pub fn runs(&self) -> impl Iterator<Item = Span> + '_ {
        let mut at = 0;
        let mut holes = self.holes.iter();
        std::iter::from_fn(move || {
            loop {
                if at >= self.top {
                    return None;
                }
                match holes.next() {
                    Some((&hs, &hl)) => {
                        let run = Span {
                            start: at,
                            len: hs - at,
                        };
                        at = hs + hl;
                        if run.len > 0 {
                            return Some(run);
                        }
                    }
                    None => {
                        let run = Span {
                            start: at,
                            len: self.top - at,
                        };
                        at = self.top;
                        return Some(run);
                    }
                }
            }
        })
    }

    /// Many holes (more draws per frame) or more elements in holes than in use (the buffer
    /// twice the size it needs): time to [`Arena::compact`].
    pub fn wants_compaction(&self) -> bool {
        self.holes.len() > MAX_HOLES || (self.hole_elements() > self.used.max(1 << 12))
    }

    /// Slides every live run down over the holes below it; afterwards there are no holes and
    /// the top is [`Arena::used`]. Returns the copies to make on the GPU and the mapping of
    /// old starts to new ones.
    pub fn compact(&mut self) -> Compaction {
        let runs: Vec<Span> = self.runs().collect();
        let mut holes = Vec::with_capacity(self.holes.len());
        let mut before = 0;
        for (&s, &l) in &self.holes {
            holes.push((s, l, before));
            before += l;
        }
        let mut copies = Vec::with_capacity(runs.len());
        let mut dst = 0;
        for r in runs {
            copies.push((r.start, dst, r.len));
            dst += r.len;
        }
        self.holes.clear();
        self.top = self.used;
        Compaction { copies, holes }
    }

    /// The invariants, for tests: holes non-empty, disjoint, not adjacent, below the top and
    /// not touching it; used + holes = top ≤ capacity.
    pub fn check(&self) -> Result<(), String> {
        let mut prev_end: Option<u32> = None;
        let mut sum = 0u64;
        for (&s, &l) in &self.holes {
            if l == 0 {
                return Err(format!("empty hole at {s}"));
            }
            if let Some(pe) = prev_end
                && s <= pe
            {
                return Err(format!(
                    "hole at {s} touches or overlaps the one ending at {pe}"
                ));
            }
            if s + l >= self.top {
                return Err(format!("hole {s}..{} reaches the top {}", s + l, self.top));
            }
            prev_end = Some(s + l);
            sum += l as u64;
        }
        if self.used as u64 + sum != self.top as u64 {
            return Err(format!(
                "used {} + holes {sum} ≠ top {}",
                self.used, self.top
            ));
        }
        if self.top > self.capacity {
            return Err(format!("top {} above capacity {}", self.top, self.capacity));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(start: u32, len: u32) -> Span {
        Span { start, len }
    }

    #[test]
    fn frees_merge_and_holes_are_reused_first_fit() {
        let mut a = Arena::new(100);
        let x = a.alloc(10).expect("room");
        let y = a.alloc(20).expect("room");
        let z = a.alloc(5).expect("room");
        assert_eq!((x, y, z), (0, 10, 30));
        assert_eq!(a.top(), 35);
        a.free(span(y, 20));
        a.check().expect("invariants");
        assert_eq!(a.holes(), 1);
        assert_eq!(a.runs().collect::<Vec<_>>(), vec![span(0, 10), span(30, 5)]);
        // A smaller range goes into the hole; the rest of the hole stays free.
        assert_eq!(a.alloc(8), Some(10));
        assert_eq!(a.runs().collect::<Vec<_>>(), vec![span(0, 18), span(30, 5)]);
        // Too big for the hole (12 left): above the top.
        assert_eq!(a.alloc(13), Some(35));
        a.check().expect("invariants");
        // Freeing the top range lowers the top; freeing the range under it merges with the
        // hole, which then reaches the top and goes too.
        a.free(span(35, 13));
        assert_eq!(a.top(), 35);
        a.free(span(30, 5));
        assert_eq!(a.top(), 18);
        assert_eq!(a.holes(), 0);
        a.check().expect("invariants");
        // Freeing between two holes merges all three.
        let b = a.alloc(10).expect("room");
        let c = a.alloc(10).expect("room");
        let d = a.alloc(10).expect("room");
        let _e = a.alloc(1).expect("room");
        a.free(span(b, 10));
        a.free(span(d, 10));
        assert_eq!(a.holes(), 2);
        a.free(span(c, 10));
        assert_eq!(a.holes(), 1);
        assert_eq!(a.hole_elements(), 30);
        a.check().expect("invariants");
    }

    #[test]
    fn a_full_arena_refuses_until_grown() {
        let mut a = Arena::new(16);
        assert_eq!(a.alloc(0), None, "nothing to place");
        assert_eq!(a.alloc(16), Some(0));
        assert_eq!(a.alloc(1), None);
        assert_eq!(a.needed_for(1), 17);
        a.grow(32);
        assert_eq!(a.alloc(1), Some(16));
        a.check().expect("invariants");
    }

    #[test]
    fn compaction_slides_runs_down_and_maps_every_offset() {
        let mut a = Arena::new(1000);
        let spans: Vec<Span> = [5, 7, 3, 11, 2, 9]
            .iter()
            .map(|&n| span(a.alloc(n).expect("room"), n))
            .collect();
        // Free the 2nd and 4th and 5th: holes at 5..12 and 15..28.
        for k in [1, 3, 4] {
            a.free(spans[k]);
        }
        a.check().expect("invariants");
        let c = a.compact();
        a.check().expect("invariants");
        assert_eq!(a.holes(), 0);
        assert_eq!(a.top(), 5 + 3 + 9);
        assert_eq!(c.copies, vec![(0, 0, 5), (12, 5, 3), (28, 8, 9)]);
        assert_eq!(c.moved(spans[0].start), 0);
        assert_eq!(c.moved(spans[2].start), 5);
        assert_eq!(c.moved(spans[5].start), 8);
        assert_eq!(a.runs().collect::<Vec<_>>(), vec![span(0, 17)]);
    }

    /// Random allocations and frees against a model of every element's owner: no two live
    /// ranges overlap, the runs cover exactly the live elements, and compaction keeps each
    /// range's contents (simulated by copying owners) where the mapping says.
    #[test]
    fn random_churn_keeps_ranges_disjoint_and_runs_exact() {
        let mut rng = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let mut a = Arena::new(64);
        // The buffer's contents: which range owns each element.
        let mut mem: Vec<u32> = vec![u32::MAX; 64];
        let mut live: Vec<(u32, Span)> = Vec::new();
        for step in 0..5_000u32 {
            let r = next();
            if live.is_empty() || r % 3 != 0 {
                let len = 1 + (next() % 40) as u32;
                let start = match a.alloc(len) {
                    Some(s) => s,
                    None => {
                        let cap = (a.capacity() * 2).max(a.needed_for(len) as u32);
                        a.grow(cap);
                        mem.resize(cap as usize, u32::MAX);
                        a.alloc(len).expect("room after growth")
                    }
                };
                for e in &mut mem[start as usize..(start + len) as usize] {
                    assert_eq!(
                        *e,
                        u32::MAX,
                        "step {step}: {start}+{len} overlaps a live range"
                    );
                    *e = step;
                }
                live.push((step, span(start, len)));
            } else {
                let (_, s) = live.swap_remove((r / 3 % live.len() as u64) as usize);
                for e in &mut mem[s.start as usize..s.end() as usize] {
                    *e = u32::MAX;
                }
                a.free(s);
            }
            a.check().unwrap_or_else(|e| panic!("step {step}: {e}"));
            let in_runs: u32 = a.runs().map(|s| s.len).sum();
            assert_eq!(in_runs, a.used());
            for s in a.runs() {
                assert!(
                    mem[s.start as usize..s.end() as usize]
                        .iter()
                        .all(|e| *e != u32::MAX),
                    "step {step}: run {s:?} covers free elements"
                );
            }
            if a.wants_compaction() || step % 997 == 0 {
                let c = a.compact();
                // The copies into a fresh buffer, as the GPU makes them.
                let mut fresh = vec![u32::MAX; mem.len()];
                for &(src, dst, len) in &c.copies {
                    assert!(dst <= src);
                    fresh[dst as usize..(dst + len) as usize]
                        .copy_from_slice(&mem[src as usize..(src + len) as usize]);
                }
                for (owner, s) in &mut live {
                    let new = c.moved(s.start);
                    assert!(
                        fresh[new as usize..(new + s.len) as usize]
                            .iter()
                            .all(|e| *e == *owner),
                        "step {step}: range {s:?} of {owner} not found at {new} after compaction"
                    );
                    s.start = new;
                }
                assert_eq!(
                    fresh.iter().filter(|e| **e != u32::MAX).count() as u32,
                    a.used()
                );
                mem = fresh;
                a.check().expect("after compaction");
                assert_eq!(a.holes(), 0);
            }
        }
    }
}
