//! Curve skeleton of one connected tube-like mesh part (a trunk, a branch, a
//! welded tree): a set of chains (polylines with a local radius per node)
//! that follow the tubes, split at forks.
//!
//! Stages, all deterministic (vertex order breaks every tie):
//! 1. **Geodesic level sets.** Dijkstra over the mesh edges from the vertex
//!    farthest (along the surface) from the lowest vertex, i.e. from a tube
//!    end. Vertices fall into bands of width `h` (1.5 × the 90th-percentile
//!    edge length); each band's connected pieces are the rings of the tubes
//!    at that distance. Rings linked by an edge are neighbours: the graph is
//!    the tree's Reeb graph, a chain per tube that splits at forks.
//! 2. **Chains.** A spanning tree of that graph from the start ring; a chain
//!    goes on through rings with one child and stops at a fork, where the
//!    largest child goes on and each other child starts a new chain at the
//!    fork (so chains meet). Children whose subtree is shorter than two
//!    radii plus a band are bumps, not branches, and are pruned (their
//!    triangles go to the fork's chain).
//! 3. **Cross-sections.** Ring centroids are only a first guess (level sets
//!    are skewed near the start and in bends). Each chain is resampled about
//!    every 1.5 radii (5 cm – 50 cm) and every node is moved to the centre of
//!    the planar cross-section of the surface perpendicular to the chain
//!    there (the section loop nearest the node, length-weighted centroid of
//!    its segments); the radius is the loop's perimeter / 2π (the fitted
//!    circle). Sections that are not a tube's (at forks: too far off or too
//!    large) are rejected and the node keeps its guess, its radius
//!    interpolated from the neighbours. Two passes.
//! 4. **Ends.** Chain ends at tube tips are moved out to the tip's rim.
//!
//! Each triangle is owned by the chain and arc length of its first vertex's
//! ring, so the part's triangles can be split with the chain.

use std::collections::{BinaryHeap, HashMap};

use glam::Vec3;

/// One chain of the skeleton.
#[derive(Clone, Debug)]
pub(super) struct Chain {
    /// Axis nodes (mesh space).
    pub nodes: Vec<Vec3>,
    /// Radius per node, finite and > 0.
    pub radii: Vec<f32>,
}

/// The skeleton of a part.
#[derive(Clone, Debug)]
pub(super) struct Skeleton {
    /// Chains, the first one from the start ring.
    pub chains: Vec<Chain>,
    /// Per part triangle: (chain, arc length along it).
    pub owner: Vec<(u32, f32)>,
}

/// Passes of cross-section refinement.
const PASSES: usize = 2;
/// Smallest accepted ratio of a section's nearest to farthest point from
/// its centre (a 12-sided tube cut square gives 0.97; cut 50° off, 0.64).
const MIN_ROUNDNESS: f32 = 0.6;

/// Skeleton of a connected part; `None` when it is too small or too coarse
/// to have one (the caller falls back to a straight fit).
pub(super) fn skeletonise(pos: &[Vec3], tris: &[[u32; 3]]) -> Option<Skeleton> {
    let n = pos.len();
    if tris.len() < 6 || n < 6 {
        return None;
    }
    // Undirected edges, CSR adjacency.
    let mut edges: Vec<(u32, u32)> = tris
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let mut start = vec![0u32; n + 1];
    for &(a, b) in &edges {
        start[a as usize + 1] += 1;
        start[b as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; edges.len() * 2];
    for &(a, b) in &edges {
        adj[fill[a as usize] as usize] = b;
        fill[a as usize] += 1;
        adj[fill[b as usize] as usize] = a;
        fill[b as usize] += 1;
    }
    let neighbours = |v: u32| &adj[start[v as usize] as usize..start[v as usize + 1] as usize];

    let lowest = (0..n as u32)
        .min_by(|&a, &b| pos[a as usize].y.total_cmp(&pos[b as usize].y))
        .unwrap_or(0);
    // Upright parts (trees, trunks) start at their lowest point; others at
    // the vertex farthest along the surface from it (a tube's end).
    let (lo, hi) = pos
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let size = hi - lo;
    let (source, dist) = if size.y >= size.x.max(size.z) {
        (lowest, dijkstra(pos, &neighbours, lowest))
    } else {
        let d0 = dijkstra(pos, &neighbours, lowest);
        let source = (0..n as u32)
            .filter(|&v| d0[v as usize].is_finite())
            .max_by(|&a, &b| d0[a as usize].total_cmp(&d0[b as usize]).then(b.cmp(&a)))
            .unwrap_or(lowest);
        (source, dijkstra(pos, &neighbours, source))
    };

    let mut lengths: Vec<f32> = edges
        .iter()
        .map(|&(a, b)| pos[a as usize].distance(pos[b as usize]))
        .collect();
    lengths.sort_by(f32::total_cmp);
    let h = 1.5 * lengths[(lengths.len() * 9 / 10).min(lengths.len() - 1)];
    if !(h.is_finite() && h > 0.0) {
        return None;
    }
    let band = |v: u32| {
        let d = dist[v as usize];
        if d.is_finite() { (d / h) as i64 } else { -1 }
    };

    // Rings: connected pieces of each band.
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for &(a, b) in &edges {
        if band(a) == band(b) {
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            parent[ra.max(rb) as usize] = ra.min(rb);
        }
    }
    let mut ring_of_root: HashMap<u32, u32> = HashMap::new();
    let mut ring_of = vec![0u32; n];
    let mut rings: Vec<Ring> = Vec::new();
    for v in 0..n as u32 {
        let r = find(&mut parent, v);
        let k = *ring_of_root.entry(r).or_insert_with(|| {
            rings.push(Ring::default());
            (rings.len() - 1) as u32
        });
        ring_of[v as usize] = k;
        let ring = &mut rings[k as usize];
        ring.sum += pos[v as usize];
        ring.count += 1;
        ring.dist += dist[v as usize].min(1e30);
    }
    for ring in &mut rings {
        ring.centre = ring.sum / ring.count as f32;
        ring.dist /= ring.count as f32;
    }
    for v in 0..n {
        let ring = &mut rings[ring_of[v] as usize];
        ring.spread += pos[v].distance(ring.centre) / ring.count as f32;
    }
    // Ring graph.
    let mut links: Vec<(u32, u32)> = edges
        .iter()
        .map(|&(a, b)| (ring_of[a as usize], ring_of[b as usize]))
        .filter(|(a, b)| a != b)
        .flat_map(|(a, b)| [(a, b), (b, a)])
        .collect();
    links.sort_unstable();
    links.dedup();

    // Spanning tree (BFS) from the source's ring.
    let root = ring_of[source as usize];
    let m = rings.len();
    let mut tree_parent = vec![u32::MAX; m];
    let mut order = vec![root];
    tree_parent[root as usize] = root;
    let mut head = 0;
    while head < order.len() {
        let r = order[head];
        head += 1;
        let lo = links.partition_point(|l| l.0 < r);
        for &(_, o) in links[lo..].iter().take_while(|l| l.0 == r) {
            if tree_parent[o as usize] == u32::MAX {
                tree_parent[o as usize] = r;
                order.push(o);
            }
        }
    }
    let mut children: Vec<Vec<u32>> = vec![Vec::new(); m];
    for &r in &order[1..] {
        children[tree_parent[r as usize] as usize].push(r);
    }
    // Subtree reach (largest distance below) and size, leaves first.
    let mut reach: Vec<f32> = rings.iter().map(|r| r.dist).collect();
    let mut weight: Vec<u32> = rings.iter().map(|r| r.count).collect();
    for &r in order.iter().rev() {
        let p = tree_parent[r as usize];
        if p != r {
            reach[p as usize] = reach[p as usize].max(reach[r as usize]);
            weight[p as usize] += weight[r as usize];
        }
    }

    // Chains of rings.
    let mut chains_rings: Vec<Vec<u32>> = Vec::new();
    let mut owner_ring = vec![(u32::MAX, 0u32); m]; // (chain, index in chain)
    let mut stack: Vec<(u32, Option<u32>)> = vec![(root, None)];
    while let Some((first, fork)) = stack.pop() {
        let chain = chains_rings.len() as u32;
        let mut list: Vec<u32> = fork.into_iter().collect();
        let mut r = first;
        loop {
            owner_ring[r as usize] = (chain, list.len() as u32);
            list.push(r);
            let min_len = 2.0 * rings[r as usize].spread + h;
            let mut kids: Vec<u32> = children[r as usize]
                .iter()
                .copied()
                .filter(|&c| reach[c as usize] - rings[r as usize].dist >= min_len)
                .collect();
            // The chain goes on to the tip through its largest child even
            // when that is short; only side bumps are pruned.
            if kids.is_empty()
                && let Some(&c) = children[r as usize]
                    .iter()
                    .max_by(|&&a, &&b| weight[a as usize].cmp(&weight[b as usize]).then(b.cmp(&a)))
            {
                kids.push(c);
            }
            // Pruned children (bumps) belong to this ring.
            for &c in &children[r as usize] {
                if !kids.contains(&c) {
                    mark_subtree(
                        c,
                        &children,
                        &mut owner_ring,
                        (chain, list.len() as u32 - 1),
                    );
                }
            }
            if kids.is_empty() {
                break;
            }
            kids.sort_by(|&a, &b| weight[b as usize].cmp(&weight[a as usize]).then(a.cmp(&b)));
            for &k in kids[1..].iter().rev() {
                stack.push((k, Some(r)));
            }
            r = kids[0];
        }
        chains_rings.push(list);
    }

    // Nodes from ring centres; per chain the arc length of each ring.
    let grid = TriGrid::new(pos, tris, h);
    let mut chains: Vec<Chain> = Vec::new();
    let mut ring_u: Vec<Vec<f32>> = Vec::new();
    for list in &chains_rings {
        let nodes: Vec<Vec3> = list.iter().map(|&r| rings[r as usize].centre).collect();
        let radii: Vec<f32> = list.iter().map(|&r| rings[r as usize].spread).collect();
        let first_is_tip = chains.is_empty();
        let (nodes, radii, at) = refine_chain(&grid, pos, tris, nodes, radii, first_is_tip);
        ring_u.push(at);
        chains.push(Chain { nodes, radii });
    }
    let owner = tris
        .iter()
        .map(|t| {
            let (c, i) = owner_ring[ring_of[t[0] as usize] as usize];
            if c == u32::MAX {
                (0, 0.0)
            } else {
                (c, ring_u[c as usize][i as usize])
            }
        })
        .collect();
    let chains_ok = chains.iter().all(|c| {
        c.nodes.len() >= 2
            && c.nodes.iter().all(|p| p.is_finite())
            && c.radii.iter().all(|r| r.is_finite() && *r > 0.0)
    });
    if chains.is_empty() || !chains_ok || chains[0].nodes.len() < 2 {
        return None;
    }
    Some(Skeleton { chains, owner })
}

#[derive(Clone, Copy, Debug, Default)]
struct Ring {
    sum: Vec3,
    count: u32,
    dist: f32,
    centre: Vec3,
    /// Mean distance of its vertices from the centre: a first radius guess.
    spread: f32,
}

fn mark_subtree(r: u32, children: &[Vec<u32>], owner: &mut [(u32, u32)], to: (u32, u32)) {
    let mut stack = vec![r];
    while let Some(x) = stack.pop() {
        owner[x as usize] = to;
        stack.extend(children[x as usize].iter().copied());
    }
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let g = parent[parent[x as usize] as usize];
        parent[x as usize] = g;
        x = g;
    }
    x
}

/// Surface distances (along edges) from `src`; ties by vertex index.
fn dijkstra<'a>(pos: &[Vec3], neighbours: &impl Fn(u32) -> &'a [u32], src: u32) -> Vec<f32> {
    #[derive(PartialEq)]
    struct Item(f32, u32);
    impl Eq for Item {}
    impl PartialOrd for Item {
        fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for Item {
        fn cmp(&self, o: &Self) -> std::cmp::Ordering {
            o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
        }
    }
    let mut d = vec![f32::INFINITY; pos.len()];
    d[src as usize] = 0.0;
    let mut heap = BinaryHeap::from([Item(0.0, src)]);
    while let Some(Item(dv, v)) = heap.pop() {
        if dv > d[v as usize] {
            continue;
        }
        for &o in neighbours(v) {
            let nd = dv + pos[v as usize].distance(pos[o as usize]);
            if nd < d[o as usize] {
                d[o as usize] = nd;
                heap.push(Item(nd, o));
            }
        }
    }
    d
}

/// Triangles bucketed in a uniform grid by their bounding boxes.
struct TriGrid {
    cell: f32,
    map: HashMap<[i32; 3], Vec<u32>>,
}

impl TriGrid {
    fn new(pos: &[Vec3], tris: &[[u32; 3]], cell: f32) -> Self {
        let mut map: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
        let key = |p: Vec3| {
            (p / cell)
                .floor()
                .to_array()
                .map(|c| c.clamp(-1e9, 1e9) as i32)
        };
        for (i, t) in tris.iter().enumerate() {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            let (lo, hi) = (key(a.min(b).min(c)), key(a.max(b).max(c)));
            // Huge triangles (much larger than a cell) are rare in tubes;
            // cap the cells visited so a bad mesh cannot blow up.
            if (0..3).map(|k| (hi[k] - lo[k] + 1) as i64).product::<i64>() > 4096 {
                map.entry(lo).or_default().push(i as u32);
                continue;
            }
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        map.entry([x, y, z]).or_default().push(i as u32);
                    }
                }
            }
        }
        TriGrid { cell, map }
    }

    /// Triangles whose cells touch the box `c ± r`, sorted, unique.
    fn near(&self, c: Vec3, r: f32, out: &mut Vec<u32>) {
        out.clear();
        let key = |p: Vec3| {
            (p / self.cell)
                .floor()
                .to_array()
                .map(|c| c.clamp(-1e9, 1e9) as i32)
        };
        let (lo, hi) = (key(c - Vec3::splat(r)), key(c + Vec3::splat(r)));
        let cells = (0..3).map(|k| (hi[k] - lo[k] + 1) as i64).product::<i64>();
        if cells > 1_000_000 {
            return;
        }
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    if let Some(v) = self.map.get(&[x, y, z]) {
                        out.extend_from_slice(v);
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

/// The cross-section loop of the surface with the plane through `c` normal
/// to `t`, nearest `c` and within `r_max` of it: (centre, radius).
fn section(
    grid: &TriGrid,
    pos: &[Vec3],
    tris: &[[u32; 3]],
    c: Vec3,
    t: Vec3,
    r_max: f32,
    scratch: &mut Vec<u32>,
) -> Option<(Vec3, f32)> {
    grid.near(c, r_max, scratch);
    // Crossing points keyed by edge; segments between them.
    let mut key_index: HashMap<(u32, u32), u32> = HashMap::new();
    let mut points: Vec<Vec3> = Vec::new();
    let mut segs: Vec<(u32, u32)> = Vec::new();
    let side = |v: u32| {
        let s = (pos[v as usize] - c).dot(t);
        if s == 0.0 { 1e-12 } else { s }
    };
    for &ti in scratch.iter() {
        let tri = tris[ti as usize];
        let s = tri.map(side);
        let mut ends = [0u32; 2];
        let mut k = 0;
        for e in 0..3 {
            let (a, b) = (e, (e + 1) % 3);
            if (s[a] > 0.0) != (s[b] > 0.0) && k < 2 {
                let (va, vb) = (tri[a], tri[b]);
                let key = (va.min(vb), va.max(vb));
                let idx = *key_index.entry(key).or_insert_with(|| {
                    let (sa, sb) = (s[a], s[b]);
                    let f = sa / (sa - sb);
                    points.push(pos[va as usize].lerp(pos[vb as usize], f));
                    (points.len() - 1) as u32
                });
                ends[k] = idx;
                k += 1;
            }
        }
        if k == 2 {
            segs.push((ends[0], ends[1]));
        }
    }
    if segs.is_empty() {
        return None;
    }
    let mut parent: Vec<u32> = (0..points.len() as u32).collect();
    for &(a, b) in &segs {
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
    // Per loop: length, weighted centroid, clipped flag.
    let mut loops: HashMap<u32, (f32, Vec3, bool)> = HashMap::new();
    for &(a, b) in &segs {
        let (pa, pb) = (points[a as usize], points[b as usize]);
        let len = pa.distance(pb);
        let root = find(&mut parent, a);
        let e = loops.entry(root).or_insert((0.0, Vec3::ZERO, false));
        e.0 += len;
        e.1 += (pa + pb) * 0.5 * len;
        e.2 |= pa.distance(c) > r_max || pb.distance(c) > r_max;
    }
    // Open loops (a point on one segment: a rim, a hole) are not sections
    // of a tube.
    let mut degree = vec![0u8; points.len()];
    for &(a, b) in &segs {
        degree[a as usize] = degree[a as usize].saturating_add(1);
        degree[b as usize] = degree[b as usize].saturating_add(1);
    }
    let mut open: HashMap<u32, bool> = HashMap::new();
    for (i, d) in degree.iter().enumerate() {
        let root = find(&mut parent, i as u32);
        *open.entry(root).or_insert(false) |= *d != 2;
    }
    let mut best: Option<(f32, Vec3, f32)> = None;
    let mut roots: Vec<_> = loops.into_iter().collect();
    roots.sort_by_key(|e| e.0);
    for (root, (len, sum, clipped)) in roots {
        if clipped || len <= 0.0 || open.get(&root).copied().unwrap_or(true) {
            continue;
        }
        let centre = sum / len;
        // Round: a plane far from perpendicular to the tube (or grazing it)
        // cuts a long ellipse; its centre is not trusted.
        let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
        for (i, p) in points.iter().enumerate() {
            if find(&mut parent, i as u32) == root {
                let d = p.distance(centre);
                lo = lo.min(d);
                hi = hi.max(d);
            }
        }
        if lo.is_nan() || lo < MIN_ROUNDNESS * hi {
            continue;
        }
        let d = centre.distance(c);
        if best.is_none_or(|b| d < b.0) {
            best = Some((d, centre, len / std::f32::consts::TAU));
        }
    }
    best.map(|(_, centre, r)| (centre, r))
}

/// Resamples and refines one chain by cross-sections. Returns the nodes,
/// radii and the arc length of each of the chain's rings. A side chain's
/// first node is its fork, so only the first chain's start is a tip.
fn refine_chain(
    grid: &TriGrid,
    pos: &[Vec3],
    tris: &[[u32; 3]],
    mut nodes: Vec<Vec3>,
    mut radii: Vec<f32>,
    first_is_tip: bool,
) -> (Vec<Vec3>, Vec<f32>, Vec<f32>) {
    let mut scratch = Vec::new();
    // A chain of one ring (a stub) gets a second node along its spread.
    if nodes.len() == 1 {
        return (nodes.clone(), radii, vec![0.0]);
    }
    let mut ring_index: Vec<usize> = (0..nodes.len()).collect();
    let mut refined: Vec<bool> = Vec::new();
    for pass in 0..=PASSES {
        if pass == 1 {
            // Resample: about 1.5 radii between nodes (5–50 cm).
            let mut out_n = vec![nodes[0]];
            let mut out_r = vec![radii[0]];
            let mut idx = vec![0usize];
            for i in 0..nodes.len() - 1 {
                let len = nodes[i].distance(nodes[i + 1]);
                let step = (1.5 * radii[i].min(radii[i + 1])).clamp(0.05, 0.5);
                let k = ((len / step).ceil() as usize).clamp(1, 64);
                for j in 1..=k {
                    let f = j as f32 / k as f32;
                    out_n.push(nodes[i].lerp(nodes[i + 1], f));
                    out_r.push(radii[i] + (radii[i + 1] - radii[i]) * f);
                }
                idx.push(out_n.len() - 1);
            }
            nodes = out_n;
            radii = out_r;
            ring_index = idx;
        }
        let count = nodes.len();
        let mut found: Vec<Option<f32>> = vec![None; count];
        let old = nodes.clone();
        for i in 0..count {
            let (a, b) = (old[i.saturating_sub(1)], old[(i + 1).min(count - 1)]);
            let t = (b - a).normalize_or_zero();
            if t == Vec3::ZERO {
                continue;
            }
            let r0 = radii[i];
            let r_max = 2.5 * r0 + 0.5 * a.distance(b);
            if let Some((centre, r)) = section(grid, pos, tris, old[i], t, r_max, &mut scratch)
                && centre.distance(old[i]) < 0.75 * r0.max(r)
                && r < 1.6 * r0
                && r > 0.3 * r0
            {
                nodes[i] = centre;
                found[i] = Some(r);
            }
        }
        let known: Vec<(usize, f32)> = found
            .iter()
            .enumerate()
            .filter_map(|(i, r)| r.map(|r| (i, r)))
            .collect();
        if !known.is_empty() {
            radii = fill(&found, &known);
        }
        refined = found.iter().map(Option::is_some).collect();
    }
    // Tip nodes without a tube section (the first ring of a lying part is a
    // patch of surface around the start vertex; an open rim is cut
    // obliquely) are dropped; the ends are then extended to the rim.
    if let (Some(first_ok), Some(last_ok)) = (
        refined.iter().position(|&f| f),
        refined.iter().rposition(|&f| f),
    ) {
        let lo = if first_is_tip { first_ok } else { 0 };
        let hi = last_ok;
        if hi > lo && (lo > 0 || hi + 1 < nodes.len()) {
            nodes = nodes[lo..=hi].to_vec();
            radii = radii[lo..=hi].to_vec();
            for i in &mut ring_index {
                *i = (*i).clamp(lo, hi) - lo;
            }
        }
    }
    extend_ends(
        pos,
        tris,
        grid,
        &mut nodes,
        &radii,
        first_is_tip,
        &mut scratch,
    );
    // Drop nodes closer than 1 mm to the previous (keep the last).
    let mut keep_n = vec![nodes[0]];
    let mut keep_r = vec![radii[0]];
    let mut new_index = vec![0usize; nodes.len()];
    for i in 1..nodes.len() {
        if nodes[i].distance(*keep_n.last().unwrap_or(&nodes[i])) >= 1e-3 || i + 1 == nodes.len() {
            if nodes[i].distance(*keep_n.last().unwrap_or(&nodes[i])) < 1e-3 {
                keep_n.pop();
                keep_r.pop();
            }
            keep_n.push(nodes[i]);
            keep_r.push(radii[i]);
        }
        new_index[i] = keep_n.len() - 1;
    }
    let mut cum = vec![0.0f32];
    for w in keep_n.windows(2) {
        cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
    }
    let at = ring_index
        .iter()
        .map(|&i| cum[new_index[i.min(new_index.len() - 1)].min(cum.len() - 1)])
        .collect();
    (keep_n, keep_r, at)
}

/// Missing values interpolated between known neighbours (constant past the ends).
fn fill(values: &[Option<f32>], known: &[(usize, f32)]) -> Vec<f32> {
    (0..values.len())
        .map(|i| {
            if let Some(v) = values[i] {
                return v;
            }
            let k = known.partition_point(|k| k.0 < i);
            match (k.checked_sub(1).map(|j| known[j]), known.get(k)) {
                (Some((i0, v0)), Some(&(i1, v1))) => {
                    v0 + (v1 - v0) * (i - i0) as f32 / (i1 - i0) as f32
                }
                (Some((_, v)), None) | (None, Some(&(_, v))) => v,
                (None, None) => 0.0,
            }
        })
        .collect()
}

/// Moves chain ends that sit at a tube tip out to the tip's rim: the
/// farthest projection, along the end's direction, of the surface near the
/// end that lies at least half a radius off the axis (not a cap's apex).
fn extend_ends(
    pos: &[Vec3],
    tris: &[[u32; 3]],
    grid: &TriGrid,
    nodes: &mut [Vec3],
    radii: &[f32],
    first_is_tip: bool,
    scratch: &mut Vec<u32>,
) {
    let n = nodes.len();
    if n < 2 {
        return;
    }
    let ends: &[usize] = if first_is_tip { &[0, n - 1] } else { &[n - 1] };
    for &end in ends {
        let inner = if end == 0 { 1 } else { n - 2 };
        let (p, q) = (nodes[end], nodes[inner]);
        let dir = (p - q).normalize_or_zero();
        let r = radii[end];
        if dir == Vec3::ZERO {
            continue;
        }
        grid.near(p, 3.0 * r, scratch);
        let mut far = 0.0f32;
        let mut any_ahead = false;
        for &ti in scratch.iter() {
            for v in tris[ti as usize] {
                let rel = pos[v as usize] - p;
                let along = rel.dot(dir);
                let off = (rel - dir * along).length();
                if along > -0.5 * r && off < 1.5 * r {
                    any_ahead |= along > 0.0;
                    if off > 0.5 * r {
                        far = far.max(along);
                    }
                }
            }
        }
        if any_ahead && far > 0.0 && far < 3.0 * r {
            nodes[end] = p + dir * far;
        }
    }
}
