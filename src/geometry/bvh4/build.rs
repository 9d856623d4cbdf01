//! From obvhs's binary tree to our four-wide one: a dynamic program over the binary
//! nodes picks, for each wide node, which descendants fill its four slots and which
//! subtrees become leaves, minimising the surface area heuristic with the costs of our
//! own kernels (Ylitie et al., "Efficient Incoherent Ray Traversal on GPUs Through
//! Compressed Wide BVHs", HPG 2017, section 3, with four lanes and triangle packs).
//!
//! A leaf is a run of primitives, stored in leaf order so that runs are contiguous;
//! a leaf of two to eight triangles or parallelograms, or of spheres only, is also
//! copied into a pack for the SIMD tests (`pack`).

use super::pack::{Sphere8, Tri8, WIDTH};
use super::{Bvh4, Node4, COUNT_SHIFT, EMPTY, INDEX_MASK, LEAF, MAX_RUN, PRIMS, SPHERES};
use crate::geometry::lanes::F4;
use crate::geometry::primitive::Prim;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;

/// Relative costs. The kernels' instruction counts (callgrind, Cornell box) are about
/// 60 for a four-box slab test with its stack work, 100 for a four-triangle test and
/// 85 for a triangle tested alone (the scalar test, out of line); spheres and disks
/// were not measured apart and are put a little above triangles. A node is charged
/// twice its count: it spans two cache lines behind a dependent load, and at 1.0 a
/// million scattered triangles built trees of half-empty nodes that traced 15-20%
/// slower (the Cornell box tree is the same either way).
const COST_NODE: f32 = 2.0;
const COST_PACK: f32 = 1.7;
const COST_TRI: f32 = 1.4;
const COST_OTHER: f32 = 1.5;
/// Most primitives a leaf holds: one pack.
const LEAF_SIZE: u32 = WIDTH as u32;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Choice {
    /// The subtree is one leaf.
    Leaf,
    /// The subtree is one wide node.
    Node,
    /// The node is opened: this many slots to its first child, the rest to the second.
    Split(u8),
}

/// For one binary node and k = 1..=4 slots: the least cost of covering its subtree
/// with at most k children of a wide node, and how.
#[derive(Clone, Copy)]
struct Plan {
    cost: [f32; 5],
    choice: [Choice; 5],
    tris: u32,
    others: u32,
    /// Of `others`, the spheres.
    spheres: u32,
}

/// How a leaf's primitives are tested.
#[derive(Clone, Copy, Debug, PartialEq)]
enum LeafKind {
    /// One at a time.
    Run,
    /// Triangles and parallelograms in packs.
    Tris,
    /// Spheres in packs.
    Spheres,
}

/// The tree, and the order to store the primitives in: `order[i]` is the index in
/// `prims` of the primitive the tree calls `i`. The binary tree must reference each
/// primitive once (obvhs does, without spatial splits).
pub(super) fn from_bvh2(bvh: &Bvh2, prims: &[Prim]) -> (Bvh4, Vec<u32>) {
    let mut out = Bvh4::empty();
    let mut order = Vec::with_capacity(prims.len());
    if bvh.nodes.is_empty() || prims.is_empty() {
        return (out, order);
    }
    let plans = plan(bvh, prims);
    let mut nodes = vec![EMPTY_NODE];
    // (binary node, our node, depth): our node covers that binary node's subtree.
    let mut work = vec![(0usize, 0usize, 1usize)];
    let mut depth = 1;
    let mut items = Vec::new();
    while let Some((src, dst, d)) = work.pop() {
        depth = depth.max(d);
        items.clear();
        if bvh.nodes[src].is_leaf() {
            // Only the root: a tree of one leaf still gets a node (which the flat
            // test below then leaves out of every walk).
            items.push(Item::new(bvh, &plans, src, Choice::Leaf));
        } else {
            let (l, r) = children(bvh, src);
            let j = best_split(&plans, l, r, 4).1 as usize;
            expand(bvh, &plans, l, j, &mut items);
            expand(bvh, &plans, r, 4 - j, &mut items);
        }
        merge_leaves(&mut items);
        // Shadow rays visit children in slot order and stop at the first hit: solid
        // objects first, where a blocked ray is most likely to stop early.
        items
            .sort_by_key(|it| !(it.how == Choice::Leaf && it.tris == 0 && it.spheres == it.others));
        if dst == 0 && flat_is_cheaper(&items, bvh.nodes[src].aabb()) {
            out.flat_len = items.len();
        }
        let mut node = EMPTY_NODE;
        for (slot, it) in items.iter().enumerate() {
            let r = if it.how == Choice::Leaf {
                out.push_leaf(bvh, &it.sources, prims, &mut order)
            } else {
                nodes.push(EMPTY_NODE);
                work.push((it.sources[0], nodes.len() - 1, d + 1));
                (nodes.len() - 1) as u32
            };
            set_slot(&mut node, slot, &it.aabb, r);
            if slot < out.flat_len {
                out.flat[slot] = r;
            }
        }
        nodes[dst] = node;
    }
    assert!(nodes.len() < LEAF as usize, "too many BVH nodes");
    assert_eq!(order.len(), prims.len(), "every primitive in one leaf");
    out.nodes = nodes
        .into_iter()
        .map(|(p, child)| Node4 {
            planes: std::array::from_fn(|a| [p[2 * a], p[2 * a + 1]].map(F4::from_array)),
            child,
        })
        .collect();
    out.root = 0;
    out.stack_len = 3 * depth + 1;
    (out, order)
}

fn children(bvh: &Bvh2, n: usize) -> (usize, usize) {
    let f = bvh.nodes[n].first_index as usize;
    (f, f + 1)
}

/// Best use of k slots by the two children of a node: (cost, slots of the first).
fn best_split(plans: &[Plan], l: usize, r: usize, k: usize) -> (f32, u8) {
    (1..k)
        .map(|j| (plans[l].cost[j] + plans[r].cost[k - j], j as u8))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((f32::INFINITY, 1))
}

/// A child of a wide node being built: a binary subtree that becomes a node, or the
/// binary subtrees whose primitives make one leaf.
struct Item {
    sources: Vec<usize>,
    how: Choice,
    aabb: Aabb,
    tris: u32,
    others: u32,
    spheres: u32,
}

impl Item {
    fn new(bvh: &Bvh2, plans: &[Plan], n: usize, how: Choice) -> Item {
        let p = &plans[n];
        Item {
            sources: vec![n],
            how,
            aabb: *bvh.nodes[n].aabb(),
            tris: p.tris,
            others: p.others,
            spheres: p.spheres,
        }
    }

    /// The leaf's cost as the surface area heuristic counts it.
    fn leaf_cost(&self) -> f32 {
        self.aabb.half_area() * leaf_cost(self.tris, self.others, self.spheres).0
    }
}

/// The children that binary node `n` contributes to a wide node through `k` slots.
fn expand(bvh: &Bvh2, plans: &[Plan], n: usize, k: usize, out: &mut Vec<Item>) {
    match plans[n].choice[k] {
        Choice::Split(j) => {
            let (l, r) = children(bvh, n);
            let j = j as usize;
            expand(bvh, plans, l, j, out);
            expand(bvh, plans, r, k - j, out);
        }
        how => out.push(Item::new(bvh, plans, n, how)),
    }
}

/// Whether a root whose children are `items` is better left out: when they are all
/// leaves, a ray can test every one instead of first slab-testing their boxes. By the
/// surface area heuristic (costs relative to the root's area), the slab test costs
/// `COST_NODE` and leaf i is tested with probability A_i / A; testing all costs the
/// sum of the leaves' costs. In the SmallVCM boxes the walls' pack spans the root's
/// box, so the slab test saves only the spheres' pack for rays that miss its box.
fn flat_is_cheaper(items: &[Item], root: &Aabb) -> bool {
    if items.iter().any(|it| it.how != Choice::Leaf) {
        return false;
    }
    let area = root.half_area();
    let each: f32 = items
        .iter()
        .map(|it| leaf_cost(it.tris, it.others, it.spheres).0)
        .sum();
    let picked: f32 = items.iter().map(Item::leaf_cost).sum();
    area * each < area * COST_NODE + picked
}

/// Joins leaves of one wide node while the surface area heuristic gains, best pair
/// first. Leaves are whole binary subtrees, so the binary builder's splits decide what
/// can share a pack; siblings across those splits often belong together. In the
/// SmallVCM boxes the floor (a flat box) was split from the other walls and tested
/// alone, out of line, by every ray that went down; in the walls' pack it costs
/// nothing, since the pack tests up to eight at once.
fn merge_leaves(items: &mut Vec<Item>) {
    loop {
        let mut best: Option<(f32, usize, usize)> = None;
        for i in 0..items.len() {
            for j in i + 1..items.len() {
                let (a, b) = (&items[i], &items[j]);
                if a.how != Choice::Leaf || b.how != Choice::Leaf {
                    continue;
                }
                let (tris, others) = (a.tris + b.tris, a.others + b.others);
                let Some(cost) = leaf_cost_within(tris, others, a.spheres + b.spheres) else {
                    continue;
                };
                let joined = a.aabb.union(&b.aabb).half_area() * cost;
                let gain = a.leaf_cost() + b.leaf_cost() - joined;
                if gain > 0.0 && best.is_none_or(|(g, ..)| gain > g) {
                    best = Some((gain, i, j));
                }
            }
        }
        let Some((_, i, j)) = best else {
            return;
        };
        let b = items.remove(j);
        let a = &mut items[i];
        a.sources.extend(b.sources);
        a.aabb = a.aabb.union(&b.aabb);
        a.tris += b.tris;
        a.others += b.others;
        a.spheres += b.spheres;
    }
}

/// The dynamic program, children before parents.
fn plan(bvh: &Bvh2, prims: &[Prim]) -> Vec<Plan> {
    // Looked up in leaf order, which is random in `prims`: a compact copy stays cached.
    let is_tri: Vec<bool> = prims.iter().map(packable).collect();
    let is_sphere: Vec<bool> = prims.iter().map(is_sphere).collect();
    let unset = Plan {
        cost: [f32::INFINITY; 5],
        choice: [Choice::Leaf; 5],
        tris: 0,
        others: 0,
        spheres: 0,
    };
    let mut plans = vec![unset; bvh.nodes.len()];
    // Post-order without recursion: binary trees from PLOC can be deep.
    let mut stack = vec![(0usize, false)];
    while let Some((n, done)) = stack.pop() {
        let node = &bvh.nodes[n];
        let area = node.aabb().half_area();
        if node.is_leaf() {
            let (a, b) = (node.first_index as usize, node.prim_count as usize);
            let ids = &bvh.primitive_indices[a..a + b];
            let tris = ids.iter().filter(|&&i| is_tri[i as usize]).count() as u32;
            let spheres = ids.iter().filter(|&&i| is_sphere[i as usize]).count() as u32;
            let others = ids.len() as u32 - tris;
            plans[n] = Plan {
                cost: [area * leaf_cost(tris, others, spheres).0; 5],
                tris,
                others,
                spheres,
                ..unset
            };
            continue;
        }
        let (l, r) = children(bvh, n);
        if !done {
            stack.extend([(n, true), (l, false), (r, false)]);
            continue;
        }
        let (tris, others, spheres) = (
            plans[l].tris + plans[r].tris,
            plans[l].others + plans[r].others,
            plans[l].spheres + plans[r].spheres,
        );
        let leaf = leaf_cost_within(tris, others, spheres).map_or(f32::INFINITY, |c| area * c);
        let inner = area * COST_NODE + best_split(&plans, l, r, 4).0;
        let (one, how) = if leaf <= inner {
            (leaf, Choice::Leaf)
        } else {
            (inner, Choice::Node)
        };
        let mut p = Plan {
            tris,
            others,
            spheres,
            ..unset
        };
        for k in 1..=4 {
            (p.cost[k], p.choice[k]) = (one, how);
            let (split, j) = best_split(&plans, l, r, k);
            if split < p.cost[k] {
                (p.cost[k], p.choice[k]) = (split, Choice::Split(j));
            }
        }
        plans[n] = p;
    }
    plans
}

/// Cost of a leaf, and how it is tested: as packs (triangles only, or spheres only)
/// or one primitive at a time.
fn leaf_cost(tris: u32, others: u32, spheres: u32) -> (f32, LeafKind) {
    let single = tris as f32 * COST_TRI + others as f32 * COST_OTHER;
    let packs = |n: u32| n.div_ceil(WIDTH as u32) as f32 * COST_PACK;
    if others == 0 && packs(tris) < single {
        (packs(tris), LeafKind::Tris)
    } else if tris == 0 && spheres == others && packs(spheres) < single {
        (packs(spheres), LeafKind::Spheres)
    } else {
        (single, LeafKind::Run)
    }
}

/// [`leaf_cost`] of a leaf one reference can hold: one pack, or a run of at most
/// [`MAX_RUN`] primitives.
fn leaf_cost_within(tris: u32, others: u32, spheres: u32) -> Option<f32> {
    if tris + others > LEAF_SIZE {
        return None;
    }
    let (cost, kind) = leaf_cost(tris, others, spheres);
    (kind != LeafKind::Run || tris + others <= MAX_RUN as u32).then_some(cost)
}

impl Bvh4 {
    /// Stores the leaf made of binary subtrees: their primitives go next in `order`,
    /// and triangles-only leaves worth it are also packed. Returns its reference.
    fn push_leaf(
        &mut self,
        bvh: &Bvh2,
        sources: &[usize],
        prims: &[Prim],
        order: &mut Vec<u32>,
    ) -> u32 {
        let first = order.len();
        let mut stack: Vec<usize> = sources.iter().rev().copied().collect();
        while let Some(n) = stack.pop() {
            let node = &bvh.nodes[n];
            if node.is_leaf() {
                let (a, b) = (node.first_index as usize, node.prim_count as usize);
                order.extend_from_slice(&bvh.primitive_indices[a..a + b]);
            } else {
                let (l, r) = children(bvh, n);
                stack.extend([r, l]);
            }
        }
        let ids = &order[first..];
        let count = |f: fn(&Prim) -> bool| ids.iter().filter(|&&i| f(&prims[i as usize])).count();
        let (tris, spheres) = (count(packable), count(is_sphere));
        let others = ids.len() - tris;
        match leaf_cost(tris as u32, others as u32, spheres as u32).1 {
            LeafKind::Run => leaf_ref(PRIMS, first, ids.len()),
            LeafKind::Tris => {
                let packs = self.tris.len();
                for (k, chunk) in ids.chunks(WIDTH).enumerate() {
                    self.tris
                        .push(pack(chunk, (first + WIDTH * k) as u32, prims));
                }
                leaf_ref(0, packs, self.tris.len() - packs)
            }
            LeafKind::Spheres => {
                let packs = self.spheres.len();
                for (k, chunk) in ids.chunks(WIDTH).enumerate() {
                    self.spheres
                        .push(pack_spheres(chunk, (first + WIDTH * k) as u32, prims));
                }
                leaf_ref(SPHERES, packs, self.spheres.len() - packs)
            }
        }
    }
}

/// A node while building: planes lo x, hi x, lo y, hi y, lo z, hi z, and children.
type NodeBuild = ([[f32; 4]; 6], [u32; 4]);

const EMPTY_NODE: NodeBuild = (
    [
        [f32::INFINITY; 4],
        [f32::NEG_INFINITY; 4],
        [f32::INFINITY; 4],
        [f32::NEG_INFINITY; 4],
        [f32::INFINITY; 4],
        [f32::NEG_INFINITY; 4],
    ],
    [EMPTY; 4],
);

fn set_slot(node: &mut NodeBuild, slot: usize, b: &Aabb, r: u32) {
    for axis in 0..3 {
        node.0[2 * axis][slot] = b.min[axis];
        node.0[2 * axis + 1][slot] = b.max[axis];
    }
    node.1[slot] = r;
}

fn leaf_ref(kind: u32, first: usize, count: usize) -> u32 {
    assert!(first <= INDEX_MASK as usize, "too many BVH leaves");
    assert!((1..=MAX_RUN).contains(&count), "BVH leaf too large");
    LEAF | kind | (count as u32) << COUNT_SHIFT | first as u32
}

/// Triangles and parallelograms go in packs; other primitives are tested alone.
fn packable(p: &Prim) -> bool {
    matches!(p, Prim::Tri { .. } | Prim::Quad { .. })
}

fn is_sphere(p: &Prim) -> bool {
    matches!(p, Prim::Sphere { .. })
}

/// Up to eight spheres, as [`pack`] packs triangles.
fn pack_spheres(ids: &[u32], first: u32, prims: &[Prim]) -> Sphere8 {
    let mut s = Sphere8 {
        c: [[0.0; WIDTH]; 3],
        r: [0.0; WIDTH],
        prim: [u32::MAX; WIDTH],
        used: 0,
    };
    for (lane, &id) in ids.iter().enumerate() {
        let Prim::Sphere { c, r } = prims[id as usize] else {
            unreachable!("only spheres are packed together")
        };
        for axis in 0..3 {
            s.c[axis][lane] = c[axis];
        }
        s.r[lane] = r;
        s.prim[lane] = first + lane as u32;
        s.used |= 1 << lane;
    }
    s
}

/// Up to eight triangles or parallelograms, `ids` in the original order, `first` their
/// position in leaf order (what hits report).
fn pack(ids: &[u32], first: u32, prims: &[Prim]) -> Tri8 {
    let mut t = Tri8 {
        p0: [[0.0; WIDTH]; 3],
        e1: [[0.0; WIDTH]; 3],
        e2: [[0.0; WIDTH]; 3],
        k: [1.0; WIDTH],
        prim: [u32::MAX; WIDTH],
    };
    for (lane, &id) in ids.iter().enumerate() {
        let (p0, e1, e2) = match prims[id as usize] {
            Prim::Tri { p0, e1, e2 } => (p0, e1, e2),
            Prim::Quad { p0, e1, e2 } => {
                t.k[lane] = 0.0;
                (p0, e1, e2)
            }
            _ => unreachable!("only triangles and parallelograms are packed"),
        };
        for axis in 0..3 {
            t.p0[axis][lane] = p0[axis];
            t.e1[axis][lane] = e1[axis];
            t.e2[axis][lane] = e2[axis];
        }
        t.prim[lane] = first + lane as u32;
    }
    t
}
