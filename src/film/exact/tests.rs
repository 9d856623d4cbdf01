use super::*;
use glam::Vec3 as Rgb;

/// A film of one "iteration": values spread over many binades, as radiance is.
fn iteration(seed: u64, layer: bool) -> Film {
    let mut film = Film::new(5, 4);
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    for i in 0..20 {
        let e = (next() * 40.0 - 20.0) as i32;
        let v = next() as f32 * 2f32.powi(e);
        film.add_index(i, Rgb::new(v, v * 0.3, next() as f32));
        if layer {
            let k = film.begin_layer("bpt");
            film.add_layer_index(k, i, Rgb::splat(v));
        }
    }
    film
}

#[test]
fn any_grouping_and_order_gives_the_same_bits() {
    let films: Vec<Film> = (0..12).map(|i| iteration(i, i % 3 != 0)).collect();
    let mut sequential = ExactSums::new(5, 4);
    for f in &films {
        sequential.add_film(f).unwrap();
    }
    // Ranges [0, 5), [5, 7), [7, 12), merged last to first.
    let mut merged = ExactSums::new(5, 4);
    for range in [7..12, 5..7, 0..5] {
        let mut part = ExactSums::new(5, 4);
        for f in &films[range] {
            part.add_film(f).unwrap();
        }
        merged.merge(&part).unwrap();
    }
    assert_eq!(merged, sequential);
    // The plain f64 way does depend on the grouping here (why this module exists).
    let mut a = films[0].clone();
    for f in &films[1..] {
        a.merge(f);
    }
    let mut b = films[11].clone();
    for f in films[..11].iter().rev() {
        b.merge(f);
    }
    assert_ne!(a.sums(), b.sums());
}

#[test]
fn the_film_it_gives_matches_the_f64_sums_to_rounding() {
    let films: Vec<Film> = (0..6).map(|i| iteration(i, true)).collect();
    let mut exact = ExactSums::new(5, 4);
    let mut plain = films[0].clone();
    exact.add_film(&films[0]).unwrap();
    for f in &films[1..] {
        exact.add_film(f).unwrap();
        plain.merge(f);
    }
    let film = exact.to_film();
    for (x, y) in film.sums().iter().zip(plain.sums()) {
        for c in 0..3 {
            let tol = 1e-15 * y[c].abs() + 6.0 * 2f64.powi(-65);
            assert!((x[c] - y[c]).abs() <= tol, "{} vs {}", x[c], y[c]);
        }
    }
    let (layers, plain_layers) = (film.layer_images(), plain.layer_images());
    assert_eq!(layers.len(), 1);
    assert_eq!(layers[0].0, plain_layers[0].0);
    let (m, p) = (layers[0].1.mean(), plain_layers[0].1.mean());
    assert!((m - p).abs().max_element() <= 1e-6 * p.abs().max_element());
    assert_eq!(film.dropped(), plain.dropped());
}

#[test]
fn fixed_point_from_the_bits_is_the_rounded_product() {
    let reference = |x: f64| (x * 2f64.powi(FRAC_BITS)).round() as i128;
    let mut values = vec![0.0, -0.0, 1.0, -1.5, 2f64.powi(-65), 2f64.powi(-66), 3e-20];
    values.extend([LIMIT * 0.999_999, -LIMIT * 0.5, 1e-300, f64::MIN_POSITIVE]);
    let mut s = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..100_000 {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        // Random bits over every binade from 2^-80 to 2^61, either sign.
        let e = (s % 142) as i32 - 80;
        let m = 1.0 + (s >> 12) as f64 / (1u64 << 52) as f64;
        values.push(if s & 1 == 1 { -m } else { m } * 2f64.powi(e));
    }
    // Exact halves of one unit round away from zero.
    values.extend([2.5 * 2f64.powi(-64), -2.5 * 2f64.powi(-64)]);
    for x in values {
        assert_eq!(to_fixed(x), Some(reference(x)), "{x:e}");
    }
    for x in [LIMIT, -LIMIT, f64::INFINITY, f64::NAN] {
        assert_eq!(to_fixed(x), None);
    }
}

#[test]
fn values_beyond_the_limit_are_dropped_and_counted() {
    let mut film = Film::new(2, 1);
    film.add_index(0, Rgb::new(1e19, 1.0, 0.0));
    film.add_index(1, Rgb::new(3.0e-20, 2.0e-20, 0.0));
    let mut exact = ExactSums::new(2, 1);
    exact.add_film(&film).unwrap();
    assert_eq!(exact.dropped(), 1);
    let back = exact.to_film();
    assert_eq!(back.sums()[0], [0.0, 1.0, 0.0]);
    // 3e-20 is just over one unit of 2^-64 (5.4e-20) / 2: rounds to one unit;
    // 2e-20 to zero.
    assert_eq!(back.sums()[1], [2f64.powi(-64), 0.0, 0.0]);
}

#[test]
fn bytes_round_trip_and_reject_damage() {
    let mut exact = ExactSums::new(5, 4);
    exact.add_film(&iteration(3, true)).unwrap();
    exact.add_film(&iteration(4, false)).unwrap();
    let bytes = exact.encode();
    assert_eq!(ExactSums::decode(&bytes).unwrap(), exact);
    for cut in [0, 7, 30, bytes.len() - 1] {
        assert!(ExactSums::decode(&bytes[..cut]).is_err(), "cut at {cut}");
    }
    let mut long = bytes.clone();
    long.push(0);
    assert!(ExactSums::decode(&long).is_err());
    let mut huge = bytes.clone();
    huge[8..16].copy_from_slice(&[0xff; 8]);
    assert!(ExactSums::decode(&huge).is_err());
}

/// A filtered film of one "iteration": camera samples spread by a Gaussian (with
/// summed weights), splats, and a layer with both.
fn filtered_iteration(seed: u64) -> Film {
    use crate::film::{Filter, PixelFilter, TileBuffer};
    use glam::Vec2;
    let filter = PixelFilter::new(Filter::Gaussian { stddev: 0.5 });
    let mut film = iteration(seed, false);
    film.clear();
    let k = film.begin_layer("s2_t1");
    let mut s = seed | 1;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    for t in crate::film::tiles(5, 4, 2) {
        let mut buf = TileBuffer::for_filter(t, &filter, 5, 4);
        for y in t.y0..t.y1 {
            for x in t.x0..t.x1 {
                let p = Vec2::new(x as f32 + next(), y as f32 + next());
                let v = Rgb::new(next(), next() * 1e-3, next() * 1e3);
                buf.add_sample(&filter, (x, y, p), v);
                film.add_layer_sample(&filter, k, (x, y, p), v * 0.5);
            }
        }
        film.add_tile_buffer(&buf);
    }
    for _ in 0..30 {
        let p = Vec2::new(next() * 5.0, next() * 4.0);
        film.add_splat(&filter, p, Rgb::splat(next()), Some(k));
    }
    film
}

#[test]
fn filter_weights_and_splats_sum_exactly_and_round_trip() {
    let films: Vec<Film> = (1..=9).map(filtered_iteration).collect();
    let mut sequential = ExactSums::new(5, 4);
    for f in &films {
        sequential.add_film(f).unwrap();
    }
    let mut merged = ExactSums::new(5, 4);
    for range in [6..9, 0..2, 2..6] {
        let mut part = ExactSums::new(5, 4);
        for f in &films[range] {
            part.add_film(f).unwrap();
        }
        merged.merge(&part).unwrap();
    }
    assert_eq!(merged, sequential);
    assert!(!sequential.weights.is_empty() && !sequential.splats.is_empty());
    assert!(!sequential.layers[0].splats.is_empty());
    // Its film develops as the f64 sums of the same films do, to rounding.
    let mut plain = films[0].clone();
    for f in &films[1..] {
        plain.merge(f);
    }
    let (a, b) = (
        sequential.to_film().to_image(1.0 / 9.0),
        plain.to_image(1.0 / 9.0),
    );
    assert!((a.mean() - b.mean()).abs().max_element() < 1e-6 * b.mean().max_element());
    let bytes = sequential.encode();
    assert_eq!(&bytes[..8], MAGIC);
    assert_eq!(ExactSums::decode(&bytes).unwrap(), sequential);
    for cut in [20, 40 + 48 * 20, bytes.len() - 1] {
        assert!(ExactSums::decode(&bytes[..cut]).is_err(), "cut at {cut}");
    }
    // Magic, width, height, dropped and the layer count take 28 bytes.
    let mut flag = bytes.clone();
    assert_eq!(flag[28 + 48 * 20], 1, "the weights' flag");
    flag[28 + 48 * 20] = 2;
    assert!(ExactSums::decode(&flag).is_err(), "a weights flag of 2");
}

#[test]
fn pixel_box_sums_are_written_as_version_1() {
    let mut exact = ExactSums::new(5, 4);
    exact.add_film(&iteration(3, true)).unwrap();
    assert_eq!(&exact.encode()[..8], MAGIC_V1);
}

#[test]
fn films_of_another_size_are_refused() {
    let mut exact = ExactSums::new(5, 4);
    assert_eq!(
        exact.add_film(&Film::new(4, 5)),
        Err(ExactError::Size(5, 4, 4, 5))
    );
    assert!(exact.merge(&ExactSums::new(1, 1)).is_err());
}
