//! Trajectory error: the largest distance of actual samples to the commanded path (S2).

type P3 = [f64; 3];

fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Squared distance from `p` to the segment `a`–`b` (a point when `a == b`).
pub fn dist2_point_segment(p: P3, a: P3, b: P3) -> f64 {
    let ab = sub(b, a);
    let ap = sub(p, a);
    let len2 = dot(ab, ab);
    // foot of the perpendicular, clamped to the segment: t = clamp(ap·ab / |ab|², 0, 1)
    let t = if len2 > 0.0 {
        (dot(ap, ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d = [ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]];
    dot(d, d)
}

/// Axis-aligned box.
#[derive(Clone, Copy)]
struct Aabb {
    lo: P3,
    hi: P3,
}

impl Aabb {
    fn of_segment(a: P3, b: P3) -> Aabb {
        Aabb {
            lo: [a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2])],
            hi: [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])],
        }
    }

    fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            lo: [
                self.lo[0].min(o.lo[0]),
                self.lo[1].min(o.lo[1]),
                self.lo[2].min(o.lo[2]),
            ],
            hi: [
                self.hi[0].max(o.hi[0]),
                self.hi[1].max(o.hi[1]),
                self.hi[2].max(o.hi[2]),
            ],
        }
    }

    /// Squared distance from `p` to the box (0 inside): a lower bound for anything inside.
    fn dist2(&self, p: P3) -> f64 {
        (0..3)
            .map(|i| (self.lo[i] - p[i]).max(p[i] - self.hi[i]).max(0.0).powi(2))
            .sum()
    }
}

/// Bounding boxes over runs of consecutive segments: `levels[0][j]` bounds segment j,
/// `levels[l][i]` bounds segments `i·2^l .. (i+1)·2^l`; the last level has one box.
struct SegmentTree<'a> {
    path: &'a [P3],
    levels: Vec<Vec<Aabb>>,
}

impl<'a> SegmentTree<'a> {
    fn new(path: &'a [P3]) -> SegmentTree<'a> {
        let mut levels = vec![(0..Self::segment_count(path))
            .map(|j| {
                let (a, b) = Self::segment_of(path, j);
                Aabb::of_segment(a, b)
            })
            .collect::<Vec<_>>()];
        while levels[levels.len() - 1].len() > 1 {
            let below = &levels[levels.len() - 1];
            let up = below
                .chunks(2)
                .map(|c| c.iter().skip(1).fold(c[0], |acc, b| acc.union(b)))
                .collect();
            levels.push(up);
        }
        SegmentTree { path, levels }
    }

    /// A single commanded point counts as one degenerate segment.
    fn segment_count(path: &[P3]) -> usize {
        path.len().saturating_sub(1).max(1)
    }

    fn segment_of(path: &[P3], j: usize) -> (P3, P3) {
        (path[j], path[(j + 1).min(path.len() - 1)])
    }

    fn dist2_to_segment(&self, p: P3, j: usize) -> f64 {
        let (a, b) = Self::segment_of(self.path, j);
        dist2_point_segment(p, a, b)
    }

    /// Exact nearest segment to `p` (squared distance, index), seeded with the segments at and
    /// after `hint` so that the box pruning cuts almost everything when the hint is good.
    fn nearest(&self, p: P3, hint: usize, stack: &mut Vec<(usize, usize)>) -> (f64, usize) {
        let segments = self.levels[0].len();
        let mut best = (f64::INFINITY, hint);
        for j in hint..(hint + 2).min(segments) {
            let d2 = self.dist2_to_segment(p, j);
            if d2 < best.0 {
                best = (d2, j);
            }
        }
        stack.clear();
        stack.push((self.levels.len() - 1, 0));
        while let Some((level, i)) = stack.pop() {
            if self.levels[level][i].dist2(p) >= best.0 {
                continue;
            }
            if level == 0 {
                let d2 = self.dist2_to_segment(p, i);
                if d2 < best.0 {
                    best = (d2, i);
                }
                continue;
            }
            let children = &self.levels[level - 1];
            let (left, right) = (2 * i, 2 * i + 1);
            if right < children.len() {
                // Visit the nearer child first (pushed last) to tighten the bound sooner.
                let (near, far) = if children[left].dist2(p) <= children[right].dist2(p) {
                    (left, right)
                } else {
                    (right, left)
                };
                stack.push((level - 1, far));
                stack.push((level - 1, near));
            } else {
                stack.push((level - 1, left));
            }
        }
        best
    }
}

/// Trajectory error: the largest distance in mm from an `actual` sample to the `commanded`
/// path taken as a polyline (true point-to-segment distance), and the index of that sample.
///
/// Exact for any input. Each sample is first measured against the segment nearest to the
/// previous sample and its successor (a moving window: actual positions follow the command),
/// which makes the bound tight; a hierarchy of boxes over consecutive segments then proves
/// that no other segment is nearer, visiting O(log n) boxes per sample on a path the actual
/// motion follows closely, so O(n log n) overall (O(n²) only for pathological inputs).
///
/// An empty `actual` gives `(0.0, 0)`.
///
/// # Panics
/// If `commanded` is empty while `actual` is not.
pub fn trajectory_error_mm(commanded: &[[f64; 3]], actual: &[[f64; 3]]) -> (f64, usize) {
    if actual.is_empty() {
        return (0.0, 0);
    }
    assert!(
        !commanded.is_empty(),
        "no commanded path to measure against"
    );
    // MODEL.md §7.2 (S2): trajectory error = max over actual samples of the distance to the path.
    let tree = SegmentTree::new(commanded);
    let mut stack = Vec::with_capacity(2 * tree.levels.len() + 2);
    let mut hint = 0;
    let mut worst = (0.0, 0);
    for (index, &p) in actual.iter().enumerate() {
        let (d2, segment) = tree.nearest(p, hint, &mut stack);
        hint = segment;
        if d2 > worst.0 {
            worst = (d2, index);
        }
    }
    (f64::sqrt(worst.0), worst.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute_force(commanded: &[P3], actual: &[P3]) -> (f64, usize) {
        let mut worst = (0.0, 0);
        for (index, &p) in actual.iter().enumerate() {
            let d2 = (0..SegmentTree::segment_count(commanded))
                .map(|j| {
                    let (a, b) = SegmentTree::segment_of(commanded, j);
                    dist2_point_segment(p, a, b)
                })
                .fold(f64::INFINITY, f64::min);
            if d2 > worst.0 {
                worst = (d2, index);
            }
        }
        (worst.0.sqrt(), worst.1)
    }

    #[test]
    fn exact_copy_is_zero() {
        let path: Vec<P3> = (0..1000)
            .map(|k| {
                let t = k as f64 * 0.01;
                [10.0 * t.cos(), 10.0 * t.sin(), t]
            })
            .collect();
        assert_eq!(trajectory_error_mm(&path, &path), (0.0, 0));
        assert_eq!(trajectory_error_mm(&path, &[]), (0.0, 0));
    }

    #[test]
    fn known_offset() {
        // A line along x, actual samples 0.01 mm off in y, one of them 0.03 mm off in z.
        let cmd: Vec<P3> = (0..100).map(|k| [k as f64, 0.0, 0.0]).collect();
        let mut act: Vec<P3> = (0..100).map(|k| [k as f64 + 0.5, 0.01, 0.0]).collect();
        act[99] = [99.0, 0.01, 0.0];
        let (e, _) = trajectory_error_mm(&cmd, &act);
        assert!((e - 0.01).abs() < 1e-15);
        act[40][2] = 0.03;
        let (e, i) = trajectory_error_mm(&cmd, &act);
        assert!((e - 0.01f64.hypot(0.03)).abs() < 1e-15 && i == 40);
        // Past the end of the path the distance is to the end point, not to the line.
        let (e, i) = trajectory_error_mm(&cmd, &[[102.0, 4.0, 0.0]]);
        assert!((e - 5.0).abs() < 1e-12 && i == 0);
        // A single commanded point.
        assert_eq!(
            trajectory_error_mm(&[[1.0, 1.0, 1.0]], &[[1.0, 1.0, 3.0]]),
            (2.0, 0)
        );
    }

    #[test]
    fn path_that_comes_back() {
        // A hairpin: the nearest segment for later samples is far back along the path.
        let mut cmd: Vec<P3> = (0..=50).map(|k| [k as f64, 0.0, 0.0]).collect();
        cmd.extend((0..=50).rev().map(|k| [k as f64, 1.0, 0.0]));
        let act: Vec<P3> = (0..=50).map(|k| [k as f64, 0.4, 0.0]).collect();
        let (e, _) = trajectory_error_mm(&cmd, &act);
        assert!((e - 0.4).abs() < 1e-12);
    }

    fn point() -> impl Strategy<Value = P3> {
        prop::array::uniform3(-5.0f64..5.0)
    }

    proptest! {
        #[test]
        fn matches_brute_force(
            commanded in prop::collection::vec(point(), 1..60),
            actual in prop::collection::vec(point(), 1..60),
        ) {
            let (e, i) = trajectory_error_mm(&commanded, &actual);
            let (e_ref, _) = brute_force(&commanded, &actual);
            prop_assert!((e - e_ref).abs() <= 1e-12 * (1.0 + e_ref), "{} vs {}", e, e_ref);
            // The reported sample really is that far from the whole path.
            let (e_at_i, _) = brute_force(&commanded, &actual[i..=i]);
            prop_assert!((e_at_i - e).abs() <= 1e-12 * (1.0 + e));
        }

        #[test]
        fn matches_brute_force_on_a_followed_path(
            steps in prop::collection::vec(point(), 2..200),
            noise in prop::collection::vec(point(), 200),
        ) {
            // A random walk as command, actual = command + small noise (the realistic case).
            let mut commanded = vec![[0.0; 3]];
            for s in &steps {
                let last = commanded[commanded.len() - 1];
                commanded.push([last[0] + s[0], last[1] + s[1], last[2] + s[2]]);
            }
            let actual: Vec<P3> = commanded.iter().zip(&noise)
                .map(|(c, n)| [c[0] + 0.01 * n[0], c[1] + 0.01 * n[1], c[2] + 0.01 * n[2]])
                .collect();
            let (e, _) = trajectory_error_mm(&commanded, &actual);
            let (e_ref, _) = brute_force(&commanded, &actual);
            prop_assert!((e - e_ref).abs() <= 1e-12 * (1.0 + e_ref));
        }
    }
}
