//! Prints BVH build times for degenerate inputs beside normal ones, and which builder
//! made each tree.
//!
//! `cargo run --release --example bvh_build -- [N...]`; `CASES=grid,cloud` picks cases
//! by name, `OBVHS=1` also times obvhs's build alone (what `Accel::build` did before it
//! checked its input: minutes on the degenerate cases beyond 16k).

use caustic::geometry::{Accel, Prim, PrimMeta};
use caustic::math::Vec3A;
use obvhs::aabb::Aabb;
use std::time::{Duration, Instant};

fn tri(p0: Vec3A, p1: Vec3A, p2: Vec3A) -> Prim {
    Prim::Tri {
        p0,
        e1: p1 - p0,
        e2: p2 - p0,
    }
}

fn cases(n: usize) -> Vec<(&'static str, Vec<Prim>)> {
    let t = tri(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    let f = |i: usize| i as f32 / n as f32;
    vec![
        ("identical triangles", vec![t; n]),
        (
            "identical spheres",
            vec![
                Prim::Sphere {
                    c: Vec3A::ONE,
                    r: 0.5
                };
                n
            ],
        ),
        (
            "zero-area at one point",
            vec![tri(Vec3A::ONE, Vec3A::ONE, Vec3A::ONE); n],
        ),
        (
            "zero-area segments",
            (0..n)
                .map(|i| tri(Vec3A::ZERO, Vec3A::X * (1.0 + f(i)), Vec3A::X))
                .collect(),
        ),
        (
            "one centroid, rotated",
            (0..n)
                .map(|i| {
                    let a = f(i) * std::f32::consts::TAU;
                    let (s, c) = a.sin_cos();
                    let u = Vec3A::new(c, s, 0.0);
                    let v = Vec3A::new(-s, c, 0.0);
                    tri(u, -0.5 * u + 0.866 * v, -0.5 * u - 0.866 * v)
                })
                .collect(),
        ),
        (
            "concentric spheres",
            (0..n)
                .map(|i| Prim::Sphere {
                    c: Vec3A::ZERO,
                    r: 1.0 + f(i),
                })
                .collect(),
        ),
        (
            "shifted growing spheres",
            (0..n)
                .map(|i| Prim::Sphere {
                    c: Vec3A::X * f(i),
                    r: 1.0 + f(i),
                })
                .collect(),
        ),
        (
            "ulp-shifted triangles",
            (0..n)
                .map(|i| {
                    let o = Vec3A::splat(1.0 + i as f32 * f32::EPSILON);
                    tri(o, o + Vec3A::X, o + Vec3A::Y)
                })
                .collect(),
        ),
        (
            "random 1e-6 jitter tris",
            (0..n)
                .map(|i| {
                    let h = (i as u32).wrapping_mul(2654435761) as f32 / u32::MAX as f32;
                    let o = Vec3A::splat(1.0 + h * 1e-6);
                    tri(o, o + Vec3A::X, o + Vec3A::Y)
                })
                .collect(),
        ),
        ("grid mesh", grid(n)),
        ("random cloud", cloud(n, 0.05)),
        ("random big cloud", cloud(n, 2.0)),
    ]
}

/// Random triangles in a cube, of edges up to `size`.
fn cloud(n: usize, size: f32) -> Vec<Prim> {
    let mut s = 12345u64;
    let mut r = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let c = Vec3A::new(r(), r(), r()) * 20.0;
            let mut e = || Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5) * size;
            tri(c, c + e(), c + e())
        })
        .collect()
}

/// A height field of about n triangles.
fn grid(n: usize) -> Vec<Prim> {
    let k = ((n / 2) as f32).sqrt() as usize;
    let p = |i: usize, j: usize| {
        let (x, y) = (i as f32 / k as f32, j as f32 / k as f32);
        Vec3A::new(x, y, 0.1 * (7.0 * x).sin() * (5.0 * y).cos())
    };
    let mut out = Vec::new();
    for i in 0..k {
        for j in 0..k {
            out.push(tri(p(i, j), p(i + 1, j), p(i + 1, j + 1)));
            out.push(tri(p(i, j), p(i + 1, j + 1), p(i, j + 1)));
        }
    }
    out
}

fn main() {
    let filter = std::env::var("CASES").unwrap_or_default();
    let obvhs_too = std::env::var("OBVHS").is_ok();
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let sizes = if sizes.is_empty() {
        vec![4096, 16384, 65536]
    } else {
        sizes
    };
    for n in sizes {
        for (name, prims) in cases(n) {
            if !filter.is_empty() && !filter.split(',').any(|f| name.contains(f)) {
                continue;
            }
            let meta = vec![PrimMeta::default(); prims.len()];
            let start = Instant::now();
            let accel = Accel::build(prims.clone(), meta);
            let total = start.elapsed().as_secs_f64();
            print!(
                "{name:24} n={:7}  Accel::build {total:8.3} s  {:?}",
                prims.len(),
                accel.builder
            );
            if obvhs_too {
                print!("  obvhs alone {:8.3} s", obvhs_alone(&prims));
            }
            println!();
        }
    }
}

/// obvhs's build as Accel::build called it before, in seconds.
fn obvhs_alone(prims: &[Prim]) -> f64 {
    let aabbs: Vec<Aabb> = prims.iter().map(Prim::aabb).collect();
    let mut p = if prims.len() < 200_000 {
        obvhs::BvhBuildParams::very_slow_build()
    } else {
        obvhs::BvhBuildParams::medium_build()
    };
    p.max_prims_per_leaf = 1;
    let start = Instant::now();
    obvhs::bvh2::builder::build_bvh2(&aabbs, p, &mut Duration::default());
    start.elapsed().as_secs_f64()
}
