//! Broad phase over many bodies: which pairs of world boxes overlap, updated as a few bodies
//! move (the seed's USE list scaled to thousands of bodies). Two implementations behind one
//! trait, measured against each other by `robosim_report::collision`:
//!
//! * [`SweepAndPrune`] — boxes kept sorted by their lower x bound; a moved box is shifted to its
//!   new place by insertion (cheap when motion per step is small), and its partners are found by
//!   scanning neighbours along x.
//! * [`BvhBroadPhase`] — parry's dynamic BVH; a moved box is re-inserted with propagation up the
//!   tree, and its partners are found by a tree query.
//!
//! [`brute_force_pairs`] is the O(n²) reference the tests compare both against.
//!
//! Every query reports the unordered pairs `(i, j)`, `i < j`, of overlapping boxes (touching
//! counts) that involve at least one of the given bodies, sorted and without duplicates.

use parry3d_f64::bounding_volume::Aabb as PAabb;
use parry3d_f64::partitioning::Bvh;
use robosim_geometry::Aabb;

/// A broad phase over bodies numbered `0..n`.
pub trait BroadPhase {
    /// Inserts body `id` or moves it to box `b` (world frame).
    fn set(&mut self, id: u32, b: &Aabb);
    /// Overlapping pairs involving at least one body of `ids`, appended to `out` (sorted, unique).
    fn pairs_involving(&mut self, ids: &[u32], out: &mut Vec<(u32, u32)>);
    fn name(&self) -> &'static str;
}

#[inline]
fn overlap(a: &([f64; 3], [f64; 3]), b: &([f64; 3], [f64; 3])) -> bool {
    a.0[0] <= b.1[0]
        && b.0[0] <= a.1[0]
        && a.0[1] <= b.1[1]
        && b.0[1] <= a.1[1]
        && a.0[2] <= b.1[2]
        && b.0[2] <= a.1[2]
}

fn bounds(b: &Aabb) -> ([f64; 3], [f64; 3]) {
    let (lo, hi) = (b.mins(), b.maxs());
    ([lo.x, lo.y, lo.z], [hi.x, hi.y, hi.z])
}

fn finish(out: &mut Vec<(u32, u32)>, start: usize) {
    out[start..].sort_unstable();
    let mut tail = out.split_off(start);
    tail.dedup();
    out.extend(tail);
}

/// All overlapping pairs involving `ids`, by testing every body: the reference.
pub fn brute_force_pairs(boxes: &[Aabb], ids: &[u32], out: &mut Vec<(u32, u32)>) {
    let start = out.len();
    for &i in ids {
        let bi = bounds(&boxes[i as usize]);
        for (j, bj) in boxes.iter().enumerate() {
            if j as u32 != i && overlap(&bi, &bounds(bj)) {
                out.push((i.min(j as u32), i.max(j as u32)));
            }
        }
    }
    finish(out, start);
}

/// Sweep and prune along x (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct SweepAndPrune {
    boxes: Vec<([f64; 3], [f64; 3])>,
    present: Vec<bool>,
    /// Body ids sorted by lower x bound.
    order: Vec<u32>,
    /// `pos[id]` = index of `id` in `order`.
    pos: Vec<u32>,
    /// Largest x extent ever seen (never shrinks): bounds the leftward scan.
    max_width: f64,
}

impl SweepAndPrune {
    pub fn new() -> Self {
        Self::default()
    }

    /// Builds over `boxes` (ids = indices) with one sort instead of n insertions.
    pub fn from_boxes(boxes: &[Aabb]) -> Self {
        let b: Vec<([f64; 3], [f64; 3])> = boxes.iter().map(bounds).collect();
        let mut order: Vec<u32> = (0..b.len() as u32).collect();
        order.sort_unstable_by(|x, y| b[*x as usize].0[0].total_cmp(&b[*y as usize].0[0]));
        let mut pos = vec![0u32; b.len()];
        for (i, id) in order.iter().enumerate() {
            pos[*id as usize] = i as u32;
        }
        let max_width = b.iter().map(|x| x.1[0] - x.0[0]).fold(0.0, f64::max);
        SweepAndPrune {
            present: vec![true; b.len()],
            boxes: b,
            order,
            pos,
            max_width,
        }
    }

    fn swap(&mut self, a: usize, b: usize) {
        self.order.swap(a, b);
        self.pos[self.order[a] as usize] = a as u32;
        self.pos[self.order[b] as usize] = b as u32;
    }
}

impl BroadPhase for SweepAndPrune {
    fn set(&mut self, id: u32, b: &Aabb) {
        let i = id as usize;
        if i >= self.boxes.len() {
            self.boxes.resize(i + 1, ([0.0; 3], [0.0; 3]));
            self.present.resize(i + 1, false);
            self.pos.resize(i + 1, 0);
        }
        self.boxes[i] = bounds(b);
        self.max_width = self.max_width.max(self.boxes[i].1[0] - self.boxes[i].0[0]);
        if !self.present[i] {
            self.present[i] = true;
            self.order.push(id);
            self.pos[i] = (self.order.len() - 1) as u32;
        }
        // Insertion step: shift the body to its sorted place.
        let mut p = self.pos[i] as usize;
        let key = self.boxes[i].0[0];
        while p > 0 && self.boxes[self.order[p - 1] as usize].0[0] > key {
            self.swap(p - 1, p);
            p -= 1;
        }
        while p + 1 < self.order.len() && self.boxes[self.order[p + 1] as usize].0[0] < key {
            self.swap(p, p + 1);
            p += 1;
        }
    }

    fn pairs_involving(&mut self, ids: &[u32], out: &mut Vec<(u32, u32)>) {
        let start = out.len();
        for &id in ids {
            let i = id as usize;
            if i >= self.present.len() || !self.present[i] {
                continue;
            }
            let b = self.boxes[i];
            let p = self.pos[i] as usize;
            for &o in &self.order[p + 1..] {
                let ob = &self.boxes[o as usize];
                if ob.0[0] > b.1[0] {
                    break;
                }
                if overlap(&b, ob) {
                    out.push((id.min(o), id.max(o)));
                }
            }
            let reach = b.0[0] - self.max_width;
            for &o in self.order[..p].iter().rev() {
                let ob = &self.boxes[o as usize];
                if ob.0[0] < reach {
                    break;
                }
                if overlap(&b, ob) {
                    out.push((id.min(o), id.max(o)));
                }
            }
        }
        finish(out, start);
    }

    fn name(&self) -> &'static str {
        "sweep-and-prune"
    }
}

/// parry's BVH as a broad phase (see the module docs).
#[derive(Default)]
pub struct BvhBroadPhase {
    bvh: Bvh,
}

impl BvhBroadPhase {
    pub fn new() -> Self {
        Self::default()
    }

    /// Builds the tree over `boxes` (ids = indices) in one pass (binned SAH build).
    pub fn from_boxes(boxes: &[Aabb]) -> Self {
        let leaves: Vec<PAabb> = boxes
            .iter()
            .map(|b| PAabb::new(b.mins(), b.maxs()))
            .collect();
        BvhBroadPhase {
            bvh: Bvh::from_leaves(parry3d_f64::partitioning::BvhBuildStrategy::Binned, &leaves),
        }
    }
}

impl BroadPhase for BvhBroadPhase {
    fn set(&mut self, id: u32, b: &Aabb) {
        self.bvh.insert(PAabb::new(b.mins(), b.maxs()), id);
    }

    fn pairs_involving(&mut self, ids: &[u32], out: &mut Vec<(u32, u32)>) {
        let start = out.len();
        for &id in ids {
            let Some(node) = self.bvh.leaf_node(id) else {
                continue;
            };
            let q = node.aabb();
            for o in self.bvh.intersect_aabb(&q) {
                if o != id {
                    out.push((id.min(o), id.max(o)));
                }
            }
        }
        finish(out, start);
    }

    fn name(&self) -> &'static str {
        "bvh"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_boxes(n: usize, rng: &mut ChaCha8Rng) -> Vec<Aabb> {
        (0..n)
            .map(|_| Aabb {
                center: Point3::new(
                    rng.random_range(0.0..10.0),
                    rng.random_range(0.0..10.0),
                    rng.random_range(0.0..10.0),
                ),
                half: Vector3::new(
                    rng.random_range(0.05..0.4),
                    rng.random_range(0.05..0.4),
                    rng.random_range(0.05..0.4),
                ),
            })
            .collect()
    }

    #[test]
    fn both_broad_phases_agree_with_brute_force_while_bodies_move() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut boxes = random_boxes(600, &mut rng);
        let mut sap = SweepAndPrune::new();
        for (i, b) in boxes.iter().enumerate().take(300) {
            sap.set(i as u32, b);
        }
        for (i, b) in boxes.iter().enumerate().skip(300) {
            sap.set(i as u32, b);
        }
        let mut sap2 = SweepAndPrune::from_boxes(&boxes);
        let mut bvh = BvhBroadPhase::from_boxes(&boxes);
        for _step in 0..20 {
            let moved: Vec<u32> = (0..12).map(|_| rng.random_range(0..600u32)).collect();
            for &m in &moved {
                let b = &mut boxes[m as usize];
                b.center += Vector3::new(
                    rng.random_range(-0.3..0.3),
                    rng.random_range(-0.3..0.3),
                    rng.random_range(-0.3..0.3),
                );
                sap.set(m, b);
                sap2.set(m, b);
                bvh.set(m, b);
            }
            let (mut r, mut s, mut t, mut u) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            brute_force_pairs(&boxes, &moved, &mut r);
            sap.pairs_involving(&moved, &mut s);
            sap2.pairs_involving(&moved, &mut u);
            assert_eq!(r, u);
            bvh.pairs_involving(&moved, &mut t);
            assert!(!r.is_empty());
            assert_eq!(r, s);
            assert_eq!(r, t);
        }
    }
}
