use super::super::filter::Filter;
use super::*;

const FILTERS: [Filter; 6] = [
    Filter::Box { radius: 0.5 },
    Filter::Box { radius: 1.5 },
    Filter::Tent { radius: 1.25 },
    Filter::Gaussian { stddev: 0.5 },
    Filter::Mitchell {
        b: 1.0 / 3.0,
        c: 1.0 / 3.0,
    },
    Filter::Lanczos { lobes: 3 },
];

/// A film of `w` x `h` with `m` x `m` camera samples per pixel on a regular grid,
/// of radiance `l(x, y)`, added through tile buffers as the renderer does.
fn camera_film(
    filter: &PixelFilter,
    (w, h): (u32, u32),
    m: u32,
    l: &dyn Fn(f32, f32) -> Rgb,
) -> Film {
    let mut film = Film::new(w, h);
    for t in crate::film::tiles(w, h, 4) {
        let mut buf = TileBuffer::for_filter(t, filter, w, h);
        for y in t.y0..t.y1 {
            for x in t.x0..t.x1 {
                for (i, j) in (0..m).flat_map(|i| (0..m).map(move |j| (i, j))) {
                    let p = Vec2::new(
                        x as f32 + (i as f32 + 0.5) / m as f32,
                        y as f32 + (j as f32 + 0.5) / m as f32,
                    );
                    buf.add_sample(filter, (x, y, p), l(p.x, p.y));
                }
            }
        }
        film.add_tile_buffer(&buf);
    }
    film
}

/// The same radiance as light-tracing splats: `m` x `m` per pixel of unit area,
/// each carrying 1 / m^2 of it (one "iteration").
fn splat_film(
    filter: &PixelFilter,
    (w, h): (u32, u32),
    m: u32,
    l: &dyn Fn(f32, f32) -> Rgb,
) -> Film {
    let mut film = Film::new(w, h);
    let n = (w * m, h * m);
    for (i, j) in (0..n.0).flat_map(|i| (0..n.1).map(move |j| (i, j))) {
        let p = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
        film.add_splat(filter, p, l(p.x, p.y) / (m * m) as f32, None);
    }
    film
}

/// Normalisation: a constant radiance gives the constant in every pixel, edges
/// included, with every filter, from camera samples (weights over their sum). From
/// splats (weights normalised per splat, as Mitsuba 3 does) it gives the constant
/// where no splat reaching the pixel is clipped by the film's edge (2 radii in),
/// and the image keeps the whole energy.
#[test]
fn constant_radiance_stays_constant_with_every_filter() {
    let (w, h) = (16, 14);
    let c = Rgb::new(0.25, 1.0, 3.0);
    for f in FILTERS {
        let filter = PixelFilter::new(f);
        let camera = camera_film(&filter, (w, h), 3, &|_, _| c).to_image(1.0 / 9.0);
        let splats = splat_film(&filter, (w, h), 16, &|_, _| c).to_image(1.0);
        let inside = 2.0 * f.radius();
        for y in 0..h {
            for x in 0..w {
                let d = (camera.get(x, y) - c).abs().max_element();
                assert!(d <= 3e-6, "{f:?} camera ({x}, {y}): {}", camera.get(x, y));
                let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
                let interior = [cx, w as f64 - cx, cy, h as f64 - cy]
                    .iter()
                    .all(|&d| d >= inside);
                let d = (splats.get(x, y) - c).abs().max_element();
                assert!(
                    !interior || d <= 6e-3,
                    "{f:?} splats ({x}, {y}): {}",
                    splats.get(x, y)
                );
            }
        }
        let energy = splats.mean() / c;
        assert!(
            (energy - Rgb::ONE).abs().max_element() < 1e-5,
            "{f:?}: {energy}"
        );
    }
}

/// A vertical step, radiance 1 left of x = 6.3 and 0 right of it: from camera
/// samples each pixel is the filter's share left of the step among its share
/// inside the film (tent in closed form, Gaussian by a fine sum of its closed
/// form). Splats give the same away from the edges with filters whose shifted
/// copies sum to one (the tent of radius 1, Mitchell's family), where Mitsuba's
/// per-splat normalisation divides by one.
#[test]
fn a_step_is_the_filters_convolution() {
    // Row h / 2 is two radii from the top and bottom edges.
    let (w, h, edge) = (12u32, 9u32, 6.3f64);
    let step = |x: f32, _: f32| Rgb::splat(if (x as f64) < edge { 1.0 } else { 0.0 });
    // The tent's integral from -r to t, in closed form.
    let tent_cdf = |r: f64, t: f64| {
        let t = t.clamp(-r, r);
        if t <= 0.0 {
            (t + r) * (t + r) / (2.0 * r)
        } else {
            r - (r - t) * (r - t) / (2.0 * r)
        }
    };
    let tent = |a: f64, b: f64| tent_cdf(1.25, b) - tent_cdf(1.25, a);
    let tent1 = |a: f64, b: f64| tent_cdf(1.0, b) - tent_cdf(1.0, a);
    let fine = |f: &dyn Fn(f64) -> f64, a: f64, b: f64| {
        let n = 200_000;
        let h = (b - a) / n as f64;
        (0..n).map(|i| f(a + (i as f64 + 0.5) * h) * h).sum::<f64>()
    };
    let gauss = |a: f64, b: f64| fine(&|x| ((-2.0 * x * x).exp() - (-8.0f64).exp()).max(0.0), a, b);
    // Mitchell with B = C = 1/3, [MN88] eq. 8 written out again.
    let mitchell = |a: f64, b: f64| {
        let k = |x: f64| {
            let x = x.abs();
            match x {
                x if x < 1.0 => (7.0 * x * x * x - 12.0 * x * x + 16.0 / 3.0) / 6.0,
                x if x < 2.0 => {
                    (-7.0 / 3.0 * x * x * x + 12.0 * x * x - 20.0 * x + 32.0 / 3.0) / 6.0
                }
                _ => 0.0,
            }
        };
        fine(&k, a, b)
    };
    let third = 1.0 / 3.0;
    // (filter, its integral over [a, b], whether splats are checked too)
    type Case<'a> = (Filter, &'a dyn Fn(f64, f64) -> f64, bool);
    let cases: [Case; 4] = [
        (Filter::Tent { radius: 1.25 }, &tent, false),
        (Filter::Gaussian { stddev: 0.5 }, &gauss, false),
        (Filter::Tent { radius: 1.0 }, &tent1, true),
        (Filter::Mitchell { b: third, c: third }, &mitchell, true),
    ];
    for (f, integral, splats_too) in cases {
        let filter = PixelFilter::new(f);
        let m = 40;
        let camera = camera_film(&filter, (w, h), m, &step).to_image(1.0);
        let splats = splat_film(&filter, (w, h), m, &step).to_image(1.0);
        for x in 0..w {
            let c = x as f64 + 0.5;
            let want = integral(-c, edge - c) / integral(-c, w as f64 - c);
            let got = camera.get(x, h / 2).x as f64;
            assert!(
                (got - want).abs() < 2e-3,
                "{f:?} camera pixel {x}: {got} vs {want}"
            );
            let inside = c >= 2.0 * f.radius() && w as f64 - c >= 2.0 * f.radius();
            if splats_too && inside {
                let got = splats.get(x, h / 2).x as f64;
                assert!(
                    (got - want).abs() < 2e-3,
                    "{f:?} splats pixel {x}: {got} vs {want}"
                );
            }
        }
    }
}

/// With the pixel box nothing but the sums exists: splats land in them, the
/// image is sums times the scale, bit for bit as before filters.
#[test]
fn the_pixel_box_keeps_one_sum_per_pixel() {
    let filter = PixelFilter::new(Filter::default());
    let mut film = Film::new(3, 2);
    film.add_splat(&filter, Vec2::new(2.9, 1.2), Rgb::splat(0.3), None);
    film.add_splat(&filter, Vec2::new(3.0, 2.0), Rgb::splat(0.1), None);
    let mut buf = TileBuffer::for_filter(crate::film::tiles(3, 2, 4)[0], &filter, 3, 2);
    buf.add_sample(&filter, (2, 1, Vec2::new(2.5, 1.5)), Rgb::splat(0.7));
    film.add_tile_buffer(&buf);
    assert_eq!((film.weights(), film.splats()), (None, None));
    // Splats to the pixel they lie in (the film's edge belongs to the last pixel).
    let want = 0.3f32 as f64 + 0.1f32 as f64 + 0.7f32 as f64;
    assert_eq!(film.sums()[5], [want; 3]);
    assert_eq!(
        film.to_image(0.5).get(2, 1),
        Rgb::splat((want * 0.5) as f32)
    );
}

#[test]
fn drops_and_counts_invalid_samples() {
    let mut film = Film::new(2, 1);
    film.add(0, 0, Rgb::new(1.0, 2.0, 3.0));
    film.add(0, 0, Rgb::new(f32::NAN, 0.0, 0.0));
    film.add(0, 0, Rgb::new(0.0, f32::INFINITY, 0.0));
    film.add(1, 0, Rgb::new(0.0, 0.0, f32::NEG_INFINITY));
    film.add(1, 0, Rgb::new(0.5, -1e-6, 0.5));
    film.add_index(1, Rgb::new(0.0, 0.0, 0.25));
    assert_eq!(film.dropped(), 4);
    assert_eq!(film.sums(), &[[1.0, 2.0, 3.0], [0.0, 0.0, 0.25]]);
}

#[test]
fn negative_zero_is_accepted() {
    let mut film = Film::new(1, 1);
    film.add(0, 0, Rgb::new(-0.0, 0.0, 0.0));
    assert_eq!(film.dropped(), 0);
}

#[test]
fn merge_adds_sums_and_dropped() {
    let mut a = Film::new(2, 1);
    let mut b = Film::new(2, 1);
    a.add(0, 0, Rgb::ONE);
    b.add(0, 0, Rgb::splat(2.0));
    b.add(1, 0, Rgb::new(0.0, 1.0, 0.0));
    b.add(1, 0, Rgb::NAN);
    a.add(1, 0, Rgb::NAN);
    a.merge(&b);
    assert_eq!(a.sums(), &[[3.0, 3.0, 3.0], [0.0, 1.0, 0.0]]);
    assert_eq!(a.dropped(), 2);
}

#[test]
#[should_panic(expected = "films of different sizes")]
fn merge_of_different_sizes_panics() {
    Film::new(2, 1).merge(&Film::new(1, 2));
}

#[test]
fn clear_and_to_image_scale() {
    let mut film = Film::new(1, 2);
    film.add(0, 1, Rgb::new(2.0, 4.0, 6.0));
    film.add(0, 1, Rgb::new(2.0, 0.0, 0.0));
    let img = film.to_image(0.5);
    assert_eq!(img.get(0, 1), Rgb::new(2.0, 2.0, 3.0));
    assert_eq!(img.get(0, 0), Rgb::ZERO);
    film.add(0, 0, Rgb::NAN);
    film.clear();
    assert_eq!(film.dropped(), 0);
    assert!(film.sums().iter().all(|s| *s == [0.0; 3]));
}

#[test]
fn add_tile_places_values() {
    let mut film = Film::new(4, 3);
    let tile = Tile {
        x0: 1,
        y0: 1,
        x1: 3,
        y1: 3,
    };
    let values = [
        [1.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [3.0, 0.0, 0.0],
        [4.0, 0.0, 0.0],
    ];
    film.add_tile(&tile, &values, 7);
    let img = film.to_image(1.0);
    assert_eq!(img.get(1, 1).x, 1.0);
    assert_eq!(img.get(2, 1).x, 2.0);
    assert_eq!(img.get(1, 2).x, 3.0);
    assert_eq!(img.get(2, 2).x, 4.0);
    assert_eq!(img.mean().x, 10.0 / 12.0);
    assert_eq!(film.dropped(), 7);
}

#[test]
#[should_panic(expected = "buffer length does not match")]
fn add_tile_checks_buffer_length() {
    let tile = Tile {
        x0: 0,
        y0: 0,
        x1: 2,
        y1: 2,
    };
    Film::new(2, 2).add_tile(&tile, &[[0.0; 3]; 3], 0);
}
