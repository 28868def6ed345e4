//! A bounding volume hierarchy over triangles (binned surface-area heuristic), for
//! closest-hit camera rays and any-hit shadow rays.

use glam::DVec3;

/// Leaves hold at most this many triangles unless they cannot be split.
const MAX_LEAF: usize = 4;
/// Centroid bins per axis tried by the surface-area heuristic.
const BINS: usize = 12;
/// Past this depth nodes split at the median, which bounds the tree depth (and the
/// traversal stack) whatever the triangle distribution.
const SAH_DEPTH: usize = 40;
/// Traversal stack size: SAH_DEPTH plus a median tree over 2³² triangles, with room to spare.
const STACK: usize = 96;
/// Barycentric slack, so that a ray through an edge shared by two triangles hits one of them
/// even when rounding differs between the two tests.
const EDGE_SLACK: f64 = 1e-9;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first triangle in `triangles`; interior: index of the left child (right = left + 1).
    first: u32,
    /// Triangles in a leaf; 0 for an interior node.
    count: u32,
}

/// A triangle as the intersection test wants it: one corner and the two edges from it.
#[derive(Clone, Copy, Debug)]
struct Triangle {
    v0: DVec3,
    e1: DVec3,
    e2: DVec3,
    /// Index into the mesh's triangle list.
    source: u32,
}

/// Where a ray meets a triangle: `origin + t·dir = (1 − u − v)·p0 + u·p1 + v·p2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TriangleHit {
    pub triangle: u32,
    pub t: f64,
    pub u: f64,
    pub v: f64,
}

#[derive(Clone, Debug)]
pub(crate) struct Bvh {
    nodes: Vec<Node>,
    triangles: Vec<Triangle>,
}

struct Item {
    lo: DVec3,
    hi: DVec3,
    centroid: DVec3,
    triangle: Triangle,
}

impl Bvh {
    /// Builds over the triangles with non-zero area; the others can never be hit.
    pub fn build(positions: &[DVec3], triangles: &[[u32; 3]]) -> Self {
        let mut items: Vec<Item> = triangles
            .iter()
            .enumerate()
            .filter_map(|(i, &[a, b, c])| {
                let (p0, p1, p2) = (
                    positions[a as usize],
                    positions[b as usize],
                    positions[c as usize],
                );
                let (e1, e2) = (p1 - p0, p2 - p0);
                let area2 = e1.cross(e2).length_squared();
                (area2 > 0.0 && area2.is_finite()).then(|| {
                    let lo = p0.min(p1).min(p2);
                    let hi = p0.max(p1).max(p2);
                    Item {
                        lo,
                        hi,
                        centroid: (lo + hi) * 0.5,
                        triangle: Triangle {
                            v0: p0,
                            e1,
                            e2,
                            source: i as u32,
                        },
                    }
                })
            })
            .collect();
        let mut nodes = Vec::with_capacity(2 * items.len() / MAX_LEAF + 1);
        nodes.push(Node {
            lo: DVec3::ZERO,
            hi: DVec3::ZERO,
            first: 0,
            count: 0,
        });
        build_node(&mut nodes, 0, &mut items, 0, 0);
        let triangles = items.into_iter().map(|item| item.triangle).collect();
        Self { nodes, triangles }
    }

    /// The nearest hit with `t` in (`t_min`, `t_max`).
    pub fn closest(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<TriangleHit> {
        let mut best: Option<TriangleHit> = None;
        let mut t_best = t_max;
        self.traverse(origin, dir, t_max, |tri| {
            if let Some((t, u, v)) = intersect(tri, origin, dir, t_min, t_best) {
                t_best = t;
                best = Some(TriangleHit {
                    triangle: tri.source,
                    t,
                    u,
                    v,
                });
            }
            (t_best, false)
        });
        best
    }

    /// Whether any triangle lies along the ray with `t` in (`t_min`, `t_max`).
    pub fn any_hit(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> bool {
        let mut found = false;
        self.traverse(origin, dir, t_max, |tri| {
            found = intersect(tri, origin, dir, t_min, t_max).is_some();
            (t_max, found)
        });
        found
    }

    /// Visits the triangles of every leaf the ray may reach, nearer children first.
    /// `visit` returns the current far limit and whether to stop.
    fn traverse(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_max: f64,
        mut visit: impl FnMut(&Triangle) -> (f64, bool),
    ) {
        if self.triangles.is_empty() {
            return;
        }
        // A zero component would give 0 · ∞ = NaN in the slab test for a ray lying in a box's
        // face plane; a tiny one keeps the products finite and the test exact enough.
        let nonzero = |d: f64| if d == 0.0 { 1e-300f64.copysign(d) } else { d };
        let inv = DVec3::new(nonzero(dir.x), nonzero(dir.y), nonzero(dir.z)).recip();
        let mut t_far = t_max;
        let mut stack = [0u32; STACK];
        let mut depth = 0;
        let mut node = &self.nodes[0];
        if slab(node, origin, inv, t_far).is_none() {
            return;
        }
        loop {
            if node.count > 0 {
                let first = node.first as usize;
                for tri in &self.triangles[first..first + node.count as usize] {
                    let (limit, stop) = visit(tri);
                    if stop {
                        return;
                    }
                    t_far = limit;
                }
            } else {
                let left = &self.nodes[node.first as usize];
                let right = &self.nodes[node.first as usize + 1];
                match (
                    slab(left, origin, inv, t_far),
                    slab(right, origin, inv, t_far),
                ) {
                    (Some(tl), Some(tr)) => {
                        let (near, far) = if tl <= tr {
                            (left, node.first + 1)
                        } else {
                            (right, node.first)
                        };
                        stack[depth] = far;
                        depth += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = left;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = right;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the next pending node that the ray still reaches within the current limit.
            loop {
                if depth == 0 {
                    return;
                }
                depth -= 1;
                let candidate = &self.nodes[stack[depth] as usize];
                if slab(candidate, origin, inv, t_far).is_some() {
                    node = candidate;
                    break;
                }
            }
        }
    }
}

/// Entry distance of the ray into the node's box, if it enters before `t_far`.
#[inline]
fn slab(node: &Node, origin: DVec3, inv: DVec3, t_far: f64) -> Option<f64> {
    let t1 = (node.lo - origin) * inv;
    let t2 = (node.hi - origin) * inv;
    let enter = t1.min(t2).max_element().max(0.0);
    let exit = t1.max(t2).min_element().min(t_far);
    (enter <= exit).then_some(enter)
}

/// Möller–Trumbore, both faces, returning (t, u, v).
#[inline]
fn intersect(
    tri: &Triangle,
    origin: DVec3,
    dir: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, f64, f64)> {
    let p = dir.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = origin - tri.v0;
    let u = s.dot(p) * inv_det;
    if !(-EDGE_SLACK..=1.0 + EDGE_SLACK).contains(&u) {
        return None;
    }
    let q = s.cross(tri.e1);
    let v = dir.dot(q) * inv_det;
    if v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
        return None;
    }
    let t = tri.e2.dot(q) * inv_det;
    (t > t_min && t < t_max).then_some((t, u, v))
}

fn bounds(items: &[Item]) -> (DVec3, DVec3) {
    items
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), item| {
            (lo.min(item.lo), hi.max(item.hi))
        })
}

fn half_area(lo: DVec3, hi: DVec3) -> f64 {
    let d = (hi - lo).max(DVec3::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

fn build_node(
    nodes: &mut Vec<Node>,
    index: usize,
    items: &mut [Item],
    offset: usize,
    depth: usize,
) {
    let (lo, hi) = bounds(items);
    let make_leaf = |nodes: &mut Vec<Node>| {
        nodes[index] = Node {
            lo,
            hi,
            first: offset as u32,
            count: items.len() as u32,
        };
    };
    if items.len() <= MAX_LEAF {
        make_leaf(nodes);
        return;
    }
    let (c_lo, c_hi) = items
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), item| {
            (l.min(item.centroid), h.max(item.centroid))
        });
    let extent = c_hi - c_lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    if extent[axis] <= 0.0 {
        // Every centroid coincides: no split separates them.
        make_leaf(nodes);
        return;
    }
    let split = if depth < SAH_DEPTH {
        sah_split(items, c_lo, extent, lo, hi)
    } else {
        None
    };
    let mid = match split {
        Some(SahSplit::Leaf) => {
            make_leaf(nodes);
            return;
        }
        Some(SahSplit::At { axis, bin }) => {
            let bin_of = |c: f64| bin_index(c, c_lo[axis], extent[axis]);
            partition(items, |item| bin_of(item.centroid[axis]) <= bin)
        }
        None => {
            let mid = items.len() / 2;
            items.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
            mid
        }
    };
    let left = nodes.len();
    nodes.push(Node {
        lo: DVec3::ZERO,
        hi: DVec3::ZERO,
        first: 0,
        count: 0,
    });
    nodes.push(Node {
        lo: DVec3::ZERO,
        hi: DVec3::ZERO,
        first: 0,
        count: 0,
    });
    nodes[index] = Node {
        lo,
        hi,
        first: left as u32,
        count: 0,
    };
    let (left_items, right_items) = items.split_at_mut(mid);
    build_node(nodes, left, left_items, offset, depth + 1);
    build_node(nodes, left + 1, right_items, offset + mid, depth + 1);
}

enum SahSplit {
    Leaf,
    /// Items whose centroid bin on `axis` is at most `bin` go left.
    At {
        axis: usize,
        bin: usize,
    },
}

fn bin_index(c: f64, lo: f64, extent: f64) -> usize {
    (((c - lo) / extent * BINS as f64) as usize).min(BINS - 1)
}

/// The cheapest binned split, `Leaf` when no split beats keeping the node whole, or `None`
/// when no bin boundary separates the items (fall back to the median).
fn sah_split(items: &[Item], c_lo: DVec3, extent: DVec3, lo: DVec3, hi: DVec3) -> Option<SahSplit> {
    let mut best: Option<(f64, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let mut counts = [0usize; BINS];
        let mut boxes = [(DVec3::INFINITY, DVec3::NEG_INFINITY); BINS];
        for item in items {
            let b = bin_index(item.centroid[axis], c_lo[axis], extent[axis]);
            counts[b] += 1;
            boxes[b] = (boxes[b].0.min(item.lo), boxes[b].1.max(item.hi));
        }
        // Sweep from the right to get the cost of every right-hand side, then from the left.
        let mut right_cost = [0.0f64; BINS];
        let (mut box_r, mut count_r) = ((DVec3::INFINITY, DVec3::NEG_INFINITY), 0usize);
        for b in (1..BINS).rev() {
            box_r = (box_r.0.min(boxes[b].0), box_r.1.max(boxes[b].1));
            count_r += counts[b];
            right_cost[b] = if count_r > 0 {
                half_area(box_r.0, box_r.1) * count_r as f64
            } else {
                0.0
            };
        }
        let (mut box_l, mut count_l) = ((DVec3::INFINITY, DVec3::NEG_INFINITY), 0usize);
        for b in 0..BINS - 1 {
            box_l = (box_l.0.min(boxes[b].0), box_l.1.max(boxes[b].1));
            count_l += counts[b];
            if count_l == 0 || count_l == items.len() {
                continue;
            }
            let cost = half_area(box_l.0, box_l.1) * count_l as f64 + right_cost[b + 1];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    let (cost, axis, bin) = best?;
    // A traversal step costs about one triangle test; stop when splitting does not pay.
    let leaf_cost = half_area(lo, hi) * items.len() as f64;
    if items.len() <= 2 * MAX_LEAF && cost + half_area(lo, hi) >= leaf_cost {
        return Some(SahSplit::Leaf);
    }
    Some(SahSplit::At { axis, bin })
}

/// Moves the items for which `left` holds to the front; returns how many there are.
fn partition(items: &mut [Item], left: impl Fn(&Item) -> bool) -> usize {
    let mut mid = 0;
    for i in 0..items.len() {
        if left(&items[i]) {
            items.swap(i, mid);
            mid += 1;
        }
    }
    mid
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of small triangles in the z = 0 plane plus a second layer at z = -1.
    fn layered_grid(n: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for z in [0.0, -1.0] {
            for i in 0..n {
                for j in 0..n {
                    let base = positions.len() as u32;
                    let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                    let h = 1.0 / n as f64;
                    positions.push(DVec3::new(x, y, z));
                    positions.push(DVec3::new(x + h, y, z));
                    positions.push(DVec3::new(x, y + h, z));
                    triangles.push([base, base + 1, base + 2]);
                }
            }
        }
        (positions, triangles)
    }

    fn brute_force(
        positions: &[DVec3],
        triangles: &[[u32; 3]],
        o: DVec3,
        d: DVec3,
    ) -> Option<(u32, f64)> {
        let mut best: Option<(u32, f64)> = None;
        for (i, &[a, b, c]) in triangles.iter().enumerate() {
            let p0 = positions[a as usize];
            let tri = Triangle {
                v0: p0,
                e1: positions[b as usize] - p0,
                e2: positions[c as usize] - p0,
                source: i as u32,
            };
            if let Some((t, _, _)) = intersect(&tri, o, d, 0.0, f64::INFINITY)
                && best.is_none_or(|(_, bt)| t < bt)
            {
                best = Some((i as u32, t));
            }
        }
        best
    }

    #[test]
    fn closest_hit_matches_brute_force() {
        let (positions, triangles) = layered_grid(12);
        let bvh = Bvh::build(&positions, &triangles);
        let mut hits = 0;
        for k in 0..400 {
            let f = k as f64;
            let o = DVec3::new((f * 0.137).fract(), (f * 0.291).fract(), 2.0);
            let d = DVec3::new((f * 0.05).sin() * 0.1, (f * 0.07).cos() * 0.1, -1.0).normalize();
            let got = bvh
                .closest(o, d, 0.0, f64::INFINITY)
                .map(|h| (h.triangle, h.t));
            let want = brute_force(&positions, &triangles, o, d);
            assert_eq!(got.is_some(), want.is_some(), "ray {k}");
            if let (Some(g), Some(w)) = (got, want) {
                assert!((g.1 - w.1).abs() < 1e-12, "ray {k}: {g:?} vs {w:?}");
                hits += 1;
            }
            assert_eq!(bvh.any_hit(o, d, 0.0, f64::INFINITY), want.is_some());
        }
        assert!(hits > 50);
    }

    #[test]
    fn degenerate_triangles_are_skipped() {
        let positions = vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        let bvh = Bvh::build(&positions, &[[0, 1, 2]]);
        assert!(!bvh.any_hit(DVec3::new(1.0, 0.0, 1.0), -DVec3::Z, 0.0, f64::INFINITY));
    }
}
