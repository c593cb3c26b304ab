//! Grouping items by a small integer key in two passes (a counting sort), order kept within
//! each key. The mesh stage (corners by welded position, corners by hash partition, edges by
//! vertex) and the tagging (triangles by piece) group this way: flat arrays instead of a list
//! per key, whose many small blocks cost a large model tens of MB of fresh pages.
//!
//! The caller walks its items twice, counting keys first and then placing items, in the same
//! order both times; the walks stay the caller's own loops so they inline in the hot paths.

/// First pass: how many items each key gets.
pub(crate) struct Counts(Vec<u32>);

impl Counts {
    /// Keys `0..keys`.
    pub(crate) fn new(keys: usize) -> Self {
        Counts(vec![0; keys + 1])
    }

    #[inline(always)]
    pub(crate) fn add(&mut self, key: usize) {
        self.0[key + 1] += 1;
    }

    /// Second pass: room for every counted item, `empty` until placed.
    pub(crate) fn placing<T: Clone>(mut self, empty: T) -> Placing<T> {
        let start = &mut self.0;
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let total = start[start.len() - 1] as usize;
        Placing {
            next: start.clone(),
            start: self.0,
            items: vec![empty; total],
        }
    }
}

pub(crate) struct Placing<T> {
    start: Vec<u32>,
    next: Vec<u32>,
    items: Vec<T>,
}

impl<T> Placing<T> {
    /// The next item of `key`; items must come in the counting pass's order.
    #[inline(always)]
    pub(crate) fn put(&mut self, key: usize, item: T) {
        let at = &mut self.next[key];
        self.items[*at as usize] = item;
        *at += 1;
    }

    pub(crate) fn finish(self) -> Grouped<T> {
        debug_assert!(
            self.next[..self.next.len() - 1] == self.start[1..],
            "items placed differ from those counted"
        );
        Grouped {
            start: self.start,
            items: self.items,
        }
    }
}

/// Key `k`'s items are `items[start[k]..start[k + 1]]`, in the order they were placed.
pub(crate) struct Grouped<T> {
    pub(crate) start: Vec<u32>,
    pub(crate) items: Vec<T>,
}

impl<T> Grouped<T> {
    pub(crate) fn range(&self, key: usize) -> std::ops::Range<usize> {
        self.start[key] as usize..self.start[key + 1] as usize
    }

    pub(crate) fn group(&self, key: usize) -> &[T] {
        &self.items[self.range(key)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_by_key_keeping_order_within_each() {
        let items = [(2, 'a'), (0, 'b'), (2, 'c'), (3, 'd'), (0, 'e'), (2, 'f')];
        let mut counts = Counts::new(5);
        for &(k, _) in &items {
            counts.add(k);
        }
        let mut placing = counts.placing(' ');
        for &(k, v) in &items {
            placing.put(k, v);
        }
        let g = placing.finish();
        assert_eq!(g.group(0), ['b', 'e']);
        assert_eq!(g.group(1), [] as [char; 0]);
        assert_eq!(g.group(2), ['a', 'c', 'f']);
        assert_eq!(g.group(3), ['d']);
        assert_eq!(g.group(4), [] as [char; 0]);
        assert_eq!(g.start, [0, 2, 2, 5, 6, 6]);
    }

    #[test]
    fn no_items_no_keys() {
        let g = Counts::new(0).placing(0u8).finish();
        assert_eq!((g.start, g.items), (vec![0], vec![]));
    }
}
