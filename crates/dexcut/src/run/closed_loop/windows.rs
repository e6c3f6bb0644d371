//! The sub-cell windows (MODEL.md §2.3): the run of items (servo periods,
//! or steps of the closed loop) a value is resolved over where an item
//! advances less than a grid cell, and the sums over such windows.

/// Per item (a servo period, or a step of the closed loop) with path advance
/// `advance(p)`, the window `(a, b)` of items its value is resolved over
/// (MODEL.md §2.3): an item of a run (`member[p]`; item p continues the run of
/// p − 1 where `joins(p)`) that advances less than one grid cell `cell_mm`
/// gets the shortest run of items centred on it, within its run, that covers
/// `window_mm` of path (or the whole run); every other item, itself. Each
/// item's window is given to `each` in item order, not held as a list (16 B
/// an item), nor is each item's run end (8 B: found by walking the run
/// once); item p advances `advance(p)` (made where it is read, not a list
/// beside the caller's: 8 B an item).
pub(crate) fn sub_cell_windows(
    advance: impl Fn(usize) -> f64,
    member: &[bool],
    joins: impl Fn(usize) -> bool,
    cell_mm: f64,
    window_mm: f64,
    mut each: impl FnMut(usize, (usize, usize)),
) {
    let n = member.len();
    let mut adv = vec![0.0; n + 1];
    for p in 0..n {
        adv[p + 1] = adv[p] + advance(p);
    }
    // The last item of the run the item last looked at lies in (items up to
    // it are members that join the item before).
    let mut known_end: Option<usize> = None;
    let mut run_start = 0;
    for p in 0..n {
        if !member[p] {
            run_start = p + 1;
            each(p, (p, p));
            continue;
        }
        if p > run_start && !joins(p) {
            run_start = p;
        }
        if advance(p) >= cell_mm {
            each(p, (p, p));
            continue;
        }
        let run_end = match known_end {
            Some(end) if p <= end => end,
            _ => {
                let mut end = p;
                while end + 1 < n && member[end + 1] && joins(end + 1) {
                    end += 1;
                }
                *known_end.insert(end)
            }
        };
        let window = |k: usize| (p.saturating_sub(k).max(run_start), (p + k).min(run_end));
        let covers = |k: usize| {
            let (a, b) = window(k);
            adv[b + 1] - adv[a] >= window_mm
        };
        // Smallest half-width that covers the window (or the whole run).
        // (So the windows these items are given start in order: a later
        // item q of the run is covered at p's half-width k plus q − p, a
        // window that holds p's, and one of a later run starts past p's.)
        let k_max = (p - run_start).max(run_end - p);
        let (mut lo, mut hi) = (0, k_max);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if covers(mid) {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        each(p, window(lo));
    }
}

/// Sums of a sequence's terms over windows of it, each the difference of two
/// running sums from the first term, `prefix[b + 1] − prefix[a]` a component:
/// the same numbers as from prefix sums held whole, made in one pass over the
/// terms in order that holds only the running sums from the start of the
/// window last asked for to the furthest end reached (the closed
/// loop's windows of sub-cell steps span a few steps of a million). Windows
/// are asked for in order of their starts; one that starts before the window
/// before sums again from the first term (the same numbers, at that cost).
pub(crate) struct WindowSums<const K: usize, T: Fn(usize) -> [f64; K]> {
    /// Term `j` of the sequence.
    pub(crate) term: T,
    /// The index of `held[0]` among the running sums (running sum `j`: the
    /// terms before `j`).
    pub(crate) first: usize,
    /// Running sums `first..first + held.len()`, never empty.
    pub(crate) held: std::collections::VecDeque<[f64; K]>,
}

impl<const K: usize, T: Fn(usize) -> [f64; K]> WindowSums<K, T> {
    /// Before any term is summed.
    pub(crate) fn new(term: T) -> Self {
        WindowSums {
            term,
            first: 0,
            held: std::collections::VecDeque::from([[0.0; K]]),
        }
    }

    /// The sums of terms `a..=b`.
    pub(crate) fn over(&mut self, a: usize, b: usize) -> [f64; K] {
        if a < self.first {
            self.first = 0;
            self.held.clear();
            self.held.push_back([0.0; K]);
        }
        loop {
            // Running sums before `a` are read no more (the last one made is
            // kept: the next is made from it).
            while self.first < a && self.held.len() > 1 {
                self.held.pop_front();
                self.first += 1;
            }
            let last = self.first + self.held.len() - 1;
            if last > b {
                break;
            }
            let sum = *self.held.back().expect("never empty");
            let term = (self.term)(last);
            self.held
                .push_back(std::array::from_fn(|c| sum[c] + term[c]));
        }
        let (lo, hi) = (self.held[a - self.first], self.held[b + 1 - self.first]);
        std::array::from_fn(|c| hi[c] - lo[c])
    }
}

/// A step's terms of the closed loop's window sums (`WindowSums`): its
/// weight `w` (its advance where the loop seeks its offset, else 0) times
/// its residual g − x, its offset x and g; `w`; and its advance.
pub(crate) fn residual_terms(w: f64, g: f64, x: f64, advance_mm: f64) -> [f64; 5] {
    [w * (g - x), w * x, w * g, w, advance_mm]
}

/// A sub-cell step's window's path-weighted mean residual |r̄| less the
/// grid's resolution of it, |ḡ|·grid/path, and mean offset |x̄| (MODEL.md
/// §5.1), from the window's sums of `residual_terms`; `None` where no step
/// of the window is weighed.
pub(crate) fn window_residual(sums: [f64; 5], grid_mm: f64) -> Option<(f64, f64)> {
    let [sum_r, sum_x, sum_g, w, path] = sums;
    (w > 0.0).then(|| {
        let resolution = (sum_g / w).abs() * grid_mm / path;
        let rw = ((sum_r / w).abs() - resolution).max(0.0);
        let xw = (sum_x / w).abs();
        (rw, xw)
    })
}
