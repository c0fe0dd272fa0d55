//! A list shared between snapshots in groups of [`GROUP`] elements: a copy is one reference
//! count, and changing one element of a copy copies that element's group and the list of groups
//! — O(len / GROUP + GROUP) — where a `Vec` copies every element. A snapshot's per-chunk lists
//! (object chunks, geometry tables, pose chunks) are kept so: a reader following a one-chunk
//! change at 10⁵ objects (391 chunks) touches 13 group handles and one group, not 391 chunks.

use std::rc::Rc;

/// Elements per group.
const GROUP: usize = 32;

/// Every group holds [`GROUP`] elements but the last, which holds 1..=GROUP; no group is
/// empty.
pub(super) struct Groups<T> {
    groups: Rc<Vec<Rc<Vec<T>>>>,
    len: usize,
}

impl<T> Clone for Groups<T> {
    fn clone(&self) -> Self {
        Groups {
            groups: Rc::clone(&self.groups),
            len: self.len,
        }
    }
}

impl<T> Default for Groups<T> {
    fn default() -> Self {
        Groups {
            groups: Rc::default(),
            len: 0,
        }
    }
}

impl<T: Clone> Groups<T> {
    pub(super) fn from_vec(v: Vec<T>) -> Self {
        let len = v.len();
        let mut groups = Vec::with_capacity(len.div_ceil(GROUP));
        let mut it = v.into_iter().peekable();
        while it.peek().is_some() {
            groups.push(Rc::new(it.by_ref().take(GROUP).collect()));
        }
        Groups {
            groups: Rc::new(groups),
            len,
        }
    }

    pub(super) fn len(&self) -> usize {
        self.len
    }

    pub(super) fn get(&self, k: usize) -> Option<&T> {
        self.groups.get(k / GROUP)?.get(k % GROUP)
    }

    pub(super) fn first(&self) -> Option<&T> {
        self.get(0)
    }

    pub(super) fn iter(&self) -> impl Iterator<Item = &T> {
        self.groups.iter().flat_map(|g| g.iter())
    }

    /// Replaces element `k`; `false` (nothing changed) when `k` is out of range.
    pub(super) fn set(&mut self, k: usize, v: T) -> bool {
        if k >= self.len {
            return false;
        }
        let groups = Rc::make_mut(&mut self.groups);
        match groups
            .get_mut(k / GROUP)
            .and_then(|g| Rc::make_mut(g).get_mut(k % GROUP))
        {
            Some(slot) => {
                *slot = v;
                true
            }
            None => false,
        }
    }

    pub(super) fn push(&mut self, v: T) {
        let groups = Rc::make_mut(&mut self.groups);
        match groups.last_mut() {
            Some(g) if g.len() < GROUP => Rc::make_mut(g).push(v),
            _ => groups.push(Rc::new(vec![v])),
        }
        self.len += 1;
    }

    /// Element `k` replaced, or pushed when `k` is the length; `false` (nothing changed) when
    /// `k` is beyond the length.
    pub(super) fn set_or_push(&mut self, k: usize, v: T) -> bool {
        if k == self.len {
            self.push(v);
            true
        } else {
            self.set(k, v)
        }
    }

    /// Keeps the first `len` elements.
    pub(super) fn truncate(&mut self, len: usize) {
        if len >= self.len {
            return;
        }
        let groups = Rc::make_mut(&mut self.groups);
        groups.truncate(len.div_ceil(GROUP));
        let rest = len % GROUP;
        if rest != 0
            && let Some(g) = groups.last_mut()
            && g.len() > rest
        {
            Rc::make_mut(g).truncate(rest);
        }
        self.len = len;
    }

    /// The number of leading elements for which `pred` holds (it must hold for a prefix and
    /// fail after it, as for [`slice::partition_point`]).
    pub(super) fn partition_point(&self, mut pred: impl FnMut(&T) -> bool) -> usize {
        // The group where it turns, by its first element, then within it.
        let g = self
            .groups
            .partition_point(|g| g.first().is_some_and(&mut pred));
        match g.checked_sub(1).and_then(|i| self.groups.get(i)) {
            None => 0,
            Some(group) => (g - 1) * GROUP + group.partition_point(pred),
        }
    }
}

impl<T: Clone> std::ops::Index<usize> for Groups<T> {
    type Output = T;
    /// Panics when `k` is out of range, like a slice.
    fn index(&self, k: usize) -> &T {
        match self.get(k) {
            Some(v) => v,
            None => panic!("index {k} out of range for {} elements", self.len),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(g: &Groups<u32>) -> Vec<u32> {
        g.iter().copied().collect()
    }

    #[test]
    fn a_copy_changed_leaves_the_original_as_it_was() {
        let v: Vec<u32> = (0..100).collect();
        let a = Groups::from_vec(v.clone());
        assert_eq!(all(&a), v);
        let mut b = a.clone();
        assert!(b.set(40, 1000));
        assert!(!b.set(100, 1));
        assert_eq!(all(&a), v, "the original");
        let mut want = v.clone();
        want[40] = 1000;
        assert_eq!(all(&b), want);
        // Only the changed group was copied: the others are the same memory.
        assert!(Rc::ptr_eq(&a.groups[0], &b.groups[0]));
        assert!(!Rc::ptr_eq(&a.groups[1], &b.groups[1]));
        assert_eq!(b[40], 1000);
        assert_eq!(b.get(99), Some(&99));
        assert_eq!(b.get(100), None);
    }

    #[test]
    fn push_and_truncate_keep_every_group_but_the_last_full() {
        let mut g = Groups::default();
        let mut v = Vec::new();
        for i in 0..(3 * GROUP as u32 + 5) {
            let before = g.clone();
            g.push(i);
            v.push(i);
            assert_eq!(before.len() + 1, g.len());
            assert_eq!(all(&g), v);
        }
        assert_eq!(g.groups.len(), 4);
        let kept = g.clone();
        for len in [3 * GROUP + 5, 3 * GROUP + 1, 3 * GROUP, 2 * GROUP - 1, 1, 0] {
            let mut t = kept.clone();
            t.truncate(len);
            assert_eq!(t.len(), len);
            assert_eq!(all(&t), v[..len]);
            assert_eq!(t.groups.len(), len.div_ceil(GROUP));
            // pushing after a truncate fills the last group first
            t.push(7);
            let mut w = v[..len].to_vec();
            w.push(7);
            assert_eq!(all(&t), w);
            assert_eq!(t.groups.len(), (len + 1).div_ceil(GROUP));
        }
        assert_eq!(all(&kept), v, "truncating copies leaves the original");
        assert!(g.set_or_push(g.len(), 9));
        assert!(g.set_or_push(0, 8));
        assert!(!g.set_or_push(g.len() + 1, 1));
        assert_eq!((g[0], g[g.len() - 1]), (8, 9));
    }

    #[test]
    fn partition_point_agrees_with_the_slice() {
        for n in [0usize, 1, 31, 32, 33, 100] {
            let v: Vec<u32> = (0..n as u32).map(|i| i * 2).collect();
            let g = Groups::from_vec(v.clone());
            for x in 0..(2 * n as u32 + 2) {
                assert_eq!(
                    g.partition_point(|&e| e <= x),
                    v.partition_point(|&e| e <= x),
                    "n {n} x {x}"
                );
            }
        }
    }
}
