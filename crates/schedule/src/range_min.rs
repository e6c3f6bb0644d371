//! Offline range-minimum updates, then every slot's minimum: `N` independent minima per
//! slot, O(log n) per update and O(n) for all the slots, so every use over a path stays
//! n·log n.

/// Slots 0..n, each holding N values that only go down (start: +∞).
pub(crate) struct RangeMin<const N: usize> {
    n: usize,
    tree: Vec<[f64; N]>,
}

impl<const N: usize> RangeMin<N> {
    pub(crate) fn new(n: usize) -> Self {
        RangeMin {
            n,
            tree: vec![[f64::INFINITY; N]; 2 * n],
        }
    }

    /// Lowers slots `lo..hi` to at most `value` (elementwise).
    pub(crate) fn lower(&mut self, lo: usize, hi: usize, value: [f64; N]) {
        let (mut l, mut r) = (lo.min(self.n) + self.n, hi.min(self.n) + self.n);
        while l < r {
            if l & 1 == 1 {
                min_into(&mut self.tree[l], &value);
                l += 1;
            }
            if r & 1 == 1 {
                r -= 1;
                min_into(&mut self.tree[r], &value);
            }
            l >>= 1;
            r >>= 1;
        }
    }

    /// The values of every slot (what [`RangeMin::get`] gives each, bit for bit), in
    /// O(n): each node's minimum pushed down to its children, parents first, so a
    /// leaf ends with the minimum over itself and every ancestor, the set `get` takes
    /// (a minimum is one of its arguments, so the order it is taken in does not
    /// change it).
    pub(crate) fn into_minima(mut self) -> Vec<[f64; N]> {
        for i in 1..self.n {
            let value = self.tree[i];
            min_into(&mut self.tree[2 * i], &value);
            min_into(&mut self.tree[2 * i + 1], &value);
        }
        self.tree.drain(..self.n);
        self.tree
    }

    /// The values of slot `i`: the minimum of every update covering it.
    #[cfg(test)]
    pub(crate) fn get(&self, i: usize) -> [f64; N] {
        let mut at = i + self.n;
        let mut value = self.tree[at];
        while at > 1 {
            at >>= 1;
            min_into(&mut value, &self.tree[at]);
        }
        value
    }
}

fn min_into<const N: usize>(into: &mut [f64; N], value: &[f64; N]) {
    for (a, b) in into.iter_mut().zip(value) {
        *a = a.min(*b);
    }
}

#[cfg(test)]
mod tests {
    use super::RangeMin;

    #[test]
    fn matches_a_direct_minimum() {
        for n in [1usize, 2, 3, 7, 16, 33] {
            let mut tree = RangeMin::<1>::new(n);
            let mut direct = vec![f64::INFINITY; n];
            let mut seed = 12345u64;
            for _ in 0..50 {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let lo = (seed >> 33) as usize % n;
                let hi = lo + 1 + (seed >> 13) as usize % (n - lo);
                let value = (seed >> 40) as f64;
                tree.lower(lo, hi, [value]);
                for d in &mut direct[lo..hi] {
                    *d = d.min(value);
                }
            }
            for (i, d) in direct.iter().enumerate() {
                assert_eq!(tree.get(i)[0], *d, "n {n} slot {i}");
            }
            let minima = tree.into_minima();
            assert_eq!(minima.len(), n);
            for (i, d) in direct.iter().enumerate() {
                assert_eq!(minima[i][0].to_bits(), d.to_bits(), "n {n} slot {i}");
            }
        }
    }
}
