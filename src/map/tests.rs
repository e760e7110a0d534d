//! Unit tests of the map type: construction, validation, lookups and the draws.

use super::sampling_tables::four_uniforms_normal;
use super::*;
use crate::math::wrap_2pi;
use glam::DVec2;
use rand::RngExt;
use rand::distr::Distribution;
use std::f64::consts::TAU;

fn comp(theta: f64, w: f64) -> Component {
    Component {
        theta,
        rho: 1.0,
        cov: [0.1, 0.0, 0.0, 0.1],
        weight: w,
    }
}

fn loc(x: f64, y: f64, ratio: f64, comps: Vec<Component>) -> Location {
    Location {
        position: DVec2::new(x, y),
        components: comps,
        motion_ratio: 1.0,
        observation_ratio: ratio,
    }
}

#[test]
fn clamp_psd_fixes_negative_eigenvalue_and_keeps_good_ones() {
    let good = [0.2, 0.05, 0.05, 0.1];
    assert_eq!(clamp_psd(good), (good, false));
    let (c, fixed) = clamp_psd([0.1, 0.2, 0.2, 0.1]); // eigenvalues 0.3, -0.1
    assert!(fixed);
    let det = c[0] * c[3] - c[1] * c[2];
    assert!(det > -1e-12 && c[0] >= 0.0 && c[3] >= 0.0, "{c:?}");
    assert!((c[0] - 0.15).abs() < 1e-12 && (c[1] - 0.15).abs() < 1e-12);
    let (c, fixed) = clamp_psd([-0.5, 0.0, 0.0, 0.2]);
    assert!(fixed);
    assert!(
        c[0] == 0.0 && c[1] == 0.0 && (c[3] - 0.2).abs() < 1e-12,
        "{c:?}"
    );
}

#[test]
fn renormalises_weights_and_reports() {
    let m = CliffMap::new(vec![loc(
        0.0,
        0.0,
        1.0,
        vec![comp(0.0, 0.2), comp(1.0, 0.2)],
    )])
    .unwrap();
    assert_eq!(m.report().renormalised_locations, 1);
    assert_eq!(m.report().clamped_covariances, 0);
    // raw values are kept
    assert_eq!(m.locations()[0].components[0].weight, 0.2);
}

#[test]
fn best_near_takes_largest_ratio_first_on_ties() {
    let m = CliffMap::new(vec![
        loc(0.0, 0.0, 0.5, vec![comp(0.0, 1.0)]),
        loc(1.0, 0.0, 0.9, vec![comp(0.0, 1.0)]),
        loc(0.0, 1.0, 0.9, vec![comp(0.0, 1.0)]),
        loc(5.0, 5.0, 1.0, vec![comp(0.0, 1.0)]),
    ])
    .unwrap();
    assert_eq!(m.best_near(DVec2::new(0.4, 0.4), 1.0), Some(1));
    assert_eq!(m.best_near(DVec2::new(0.1, 0.1), 0.5), Some(0));
    assert_eq!(m.best_near(DVec2::new(2.5, 2.5), 1.0), None);
    assert_eq!(m.nearest(DVec2::new(0.1, 0.6), 1.0), Some(2));
    // strictly within: a location at exactly the radius is not near
    assert_eq!(m.best_near(DVec2::new(0.0, -1.0), 1.0), None);
}

#[test]
fn neighbour_table_agrees_with_grid_scan_on_real_maps() {
    use rand::SeedableRng;
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data");
    for f in ["thor1/cliffmap.csv", "atc/cliffmap-20121024.csv"] {
        let m = CliffMap::load(std::path::Path::new(dir).join(f)).unwrap();
        let (lo, hi) = m.info().extent;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
        for radius in [0.3, 0.5, 0.7071, 1.0, 2.5] {
            let lookup = m.lookup(radius);
            assert!(matches!(lookup, Lookup::Table(_)));
            for _ in 0..20000 {
                let p = DVec2::new(
                    rng.random_range(lo.x - 3.0..hi.x + 3.0),
                    rng.random_range(lo.y - 3.0..hi.y + 3.0),
                );
                assert_eq!(
                    lookup.best_near(p),
                    m.best_near(p, radius),
                    "{f} r {radius} at {p}"
                );
            }
            // points exactly on cell borders and on locations
            for l in m.locations().iter().take(200) {
                for d in [
                    DVec2::ZERO,
                    DVec2::splat(0.25),
                    DVec2::new(0.5, 0.0),
                    DVec2::new(radius, 0.0),
                ] {
                    let p = l.position + d;
                    assert_eq!(
                        lookup.best_near(p),
                        m.best_near(p, radius),
                        "{f} r {radius} at {p}"
                    );
                }
            }
        }
        assert!(matches!(m.lookup(f64::NAN), Lookup::Grid(..)));
    }
}

#[test]
fn huge_radii_fall_back_to_the_grid_scan() {
    // (radius / step) + 1 cells of margin used to overflow for radii near f64::MAX.
    let m = CliffMap::demo();
    for radius in [1e300, f64::MAX, 1e6] {
        let lookup = m.lookup(radius);
        assert!(matches!(lookup, Lookup::Grid(..)), "{radius}");
        let p = DVec2::new(1.0, 2.0);
        let best = lookup.best_near(p);
        assert!(best.is_some());
        assert_eq!(best, m.best_near(p, radius));
    }
}

#[test]
fn rejects_bad_locations() {
    assert!(matches!(CliffMap::new(vec![]), Err(MapError::Empty)));
    let mut l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 1.0)]);
    l.components[0].rho = -1.0;
    let e = CliffMap::new(vec![l]).unwrap_err().to_string();
    assert!(e.contains("negative speed"), "{e}");
    let mut l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 1.0)]);
    l.components[0].cov[1] = f64::NAN;
    assert!(
        CliffMap::new(vec![l])
            .unwrap_err()
            .to_string()
            .contains("non-finite")
    );
    let l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 0.0)]);
    assert!(
        CliffMap::new(vec![l])
            .unwrap_err()
            .to_string()
            .contains("sum to zero")
    );
    let l = loc(
        0.0,
        0.0,
        1.0,
        vec![comp(0.0, f64::MAX), comp(1.0, f64::MAX)],
    );
    let e = CliffMap::new(vec![l]).unwrap_err().to_string();
    assert!(e.contains("sum to infinity"), "{e}");
    let mut l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 1.0)]);
    l.components[0].cov[3] = -2e6;
    let e = CliffMap::new(vec![l]).unwrap_err().to_string();
    assert!(e.contains("beyond 1000000"), "{e}");
    let l = loc(0.0, 0.0, 1.0, vec![comp(0.0, 1.0); MAX_COMPONENTS + 1]);
    let e = CliffMap::new(vec![l]).unwrap_err().to_string();
    assert!(e.contains("65 components, at most 64"), "{e}");
    let l = loc(-1.5e6, 0.0, 1.0, vec![comp(0.0, 1.0)]);
    let e = CliffMap::new(vec![l]).unwrap_err().to_string();
    assert!(e.contains("beyond 1000000 m"), "{e}");
}

#[test]
fn direction_sampler_wraps_around_zero() {
    use rand::SeedableRng;
    let mut c = comp(0.05, 1.0);
    c.cov[0] = 0.01;
    let m = CliffMap::new(vec![loc(0.0, 0.0, 1.0, vec![c])]).unwrap();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1);
    let d = m.direction_at(0);
    let mut wrapped = 0;
    let (mut s, mut co) = (0.0, 0.0);
    for _ in 0..20000 {
        let t: f64 = d.sample(&mut rng);
        assert!((0.0..TAU).contains(&t));
        if t > 3.0 {
            wrapped += 1;
        }
        s += t.sin();
        co += t.cos();
    }
    // about 31% of draws from N(0.05, 0.1^2) fall below zero and wrap
    assert!((5000..7500).contains(&wrapped), "{wrapped}");
    let mean = wrap_2pi(s.atan2(co));
    assert!((mean - 0.05).abs() < 0.01, "{mean}");
}

#[test]
fn four_uniforms_make_a_standard_normal() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5);
    let n = 400_000;
    let z: Vec<f64> = (0..n)
        .map(|_| four_uniforms_normal(rng.next_u32()) as f64)
        .collect();
    let mean = z.iter().sum::<f64>() / n as f64;
    let var = z.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
    assert!(
        mean.abs() < 0.005 && (var - 1.0).abs() < 0.01,
        "{mean} {var}"
    );
    assert!(z.iter().all(|x| x.abs() <= 3.47));
    // the empirical distribution against the normal's, integrated numerically
    let phi = |x: f64| {
        let steps = 20_000;
        let (a, h) = (-9.0, (x + 9.0) / steps as f64);
        let f = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
        h * ((f(a) + f(x)) / 2.0 + (1..steps).map(|i| f(a + i as f64 * h)).sum::<f64>())
    };
    for x in [-3.0, -2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 2.5] {
        let below = z.iter().filter(|&&v| v <= x).count() as f64 / n as f64;
        assert!(
            (below - phi(x)).abs() < 0.01,
            "P(z <= {x}) = {below}, normal {}",
            phi(x)
        );
    }
}

#[test]
fn direction_following_draws_the_von_mises_posterior() {
    use rand::SeedableRng;
    // narrow components 0.5 rad apart, unequal weights; 6 of them (two blocks of
    // four, padded), 11 (wider than the padding: three blocks), a map where one
    // location has 11 and the other 1 (uneven block counts), and one where a location of
    // 3 has a second block of padding only (the other holds 6)
    let mixture = |n: usize| -> Vec<Component> {
        (0..n)
            .map(|j| {
                let mut c = comp(0.5 * j as f64, 1.0 + j as f64);
                c.cov[0] = 1e-6;
                c
            })
            .collect()
    };
    for (n, other, kappa, heading) in [
        (6, None, 3.0, 1.2),
        (11, None, 2.0, 4.0),
        (11, Some(1), 5.0, 0.3),
        (3, Some(6), 3.0, 1.0),
        // far from every component with the largest follow: the terms underflow
        // unless scaled, yet the choice still favours the nearest direction
        (3, None, 100.0, 4.5),
    ] {
        let mut locs = vec![loc(0.0, 0.0, 1.0, mixture(n))];
        if let Some(m) = other {
            locs.push(loc(5.0, 0.0, 1.0, mixture(m)));
        }
        let map = CliffMap::new(locs).unwrap();
        // the rule in double precision, independently of the map's tables
        let post: Vec<f64> = (0..n)
            .map(|j| {
                let w = (1.0 + j as f64) / (n * (n + 1) / 2) as f64;
                w * (-kappa * (1.0 - (heading - 0.5 * j as f64).cos())).exp()
            })
            .collect();
        let total: f64 = post.iter().sum();
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        let draws = 60_000;
        let mut counts = vec![0usize; n];
        for _ in 0..draws {
            let t = map.direction_following(0, heading.cos(), heading.sin(), kappa, &mut rng);
            // the component whose mean is nearest on the circle
            let j = (0..n)
                .min_by(|&a, &b| {
                    let d = |j: usize| (t - 0.5 * j as f64).sin_cos();
                    let ((sa, ca), (sb, cb)) = (d(a), d(b));
                    sa.atan2(ca).abs().total_cmp(&sb.atan2(cb).abs())
                })
                .unwrap();
            counts[j] += 1;
        }
        // split in two (as the predictor does where the weights fit), the same draws
        if map.follow_weights_fit() {
            let (mut r1, mut r2) = (
                rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3),
                rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3),
            );
            let (hx, hy) = (heading.cos(), heading.sin());
            for _ in 0..1000 {
                let w = map.follow_weights(0, hx as f32, hy as f32, kappa as f32);
                assert_eq!(
                    map.direction_following(0, hx, hy, kappa, &mut r1),
                    map.draw_following(0, &w, &mut r2)
                );
            }
        }
        assert_eq!(map.follow_weights_fit(), n <= 8);
        for (j, (&c, p)) in counts.iter().zip(&post).enumerate() {
            let p = p / total;
            let sd = (p * (1.0 - p) / draws as f64).sqrt();
            let share = c as f64 / draws as f64;
            assert!(
                (share - p).abs() <= 5.0 * sd + 1e-4,
                "{n} components, kappa {kappa}: component {j} drawn {share}, expected {p}"
            );
        }
    }
}

#[test]
fn direction_sampler_follows_weights() {
    use rand::SeedableRng;
    let mut a = comp(1.0, 3.0);
    a.cov[0] = 1e-6;
    let mut b = comp(4.0, 1.0);
    b.cov[0] = 1e-6;
    let m = CliffMap::new(vec![loc(0.0, 0.0, 1.0, vec![a, b])]).unwrap();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
    let n = 40000;
    let near_a = (0..n)
        .filter(|_| (m.direction_at(0).sample(&mut rng) - 1.0).abs() < 0.1)
        .count();
    let share = near_a as f64 / n as f64;
    assert!((share - 0.75).abs() < 0.01, "{share}");
}

#[test]
fn padded_sampling_tables_draw_only_real_components() {
    use rand::SeedableRng;
    // three components at one location, one at the other: the second is padded
    let sharp = |theta: f64, w: f64| {
        let mut c = comp(theta, w);
        c.cov[0] = 1e-8;
        c
    };
    let m = CliffMap::new(vec![
        loc(
            0.0,
            0.0,
            1.0,
            vec![sharp(1.0, 0.2), sharp(2.0, 0.3), sharp(3.0, 0.5)],
        ),
        loc(1.0, 0.0, 1.0, vec![sharp(5.0, 1.0)]),
    ])
    .unwrap();
    assert_eq!(m.info().components, 4);
    assert_eq!(m.info().components_per_location, (1, 3));
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
    let mut counts = [0usize; 3];
    for _ in 0..30000 {
        let t: f64 = m.direction_at(0).sample(&mut rng);
        counts[(t.round() as usize).clamp(1, 3) - 1] += 1;
        let u: f64 = m.direction_at(1).sample(&mut rng);
        assert!((u - 5.0).abs() < 1e-3, "{u}");
    }
    for (c, w) in counts.iter().zip([0.2, 0.3, 0.5]) {
        assert!((*c as f64 / 30000.0 - w).abs() < 0.015, "{counts:?}");
    }
}

/// The cache of neighbour tables, driven through the map.
mod table_cache {
    use glam::DVec2;

    use super::*;
    use crate::map::tables::*;

    #[test]
    fn tables_stay_within_the_budget_evicting_the_least_recently_used() {
        let map = CliffMap::demo();
        let one = map.build_table(0.5, false).unwrap().memory_bytes();
        // room for about two tables of this size
        map.set_table_budget(2 * one + one / 2);
        for r in [0.5, 0.6, 0.7] {
            map.build_table(r, false).unwrap();
            let s = map.table_stats();
            assert!(s.bytes <= s.budget, "{s:?}");
        }
        // 0.5 was used least recently: evicted for 0.7
        assert_eq!(map.table_stats().radii, vec![0.6, 0.7]);
        // using 0.6 makes 0.7 the next victim
        assert!(map.cached_lookup(0.6).max_tests() > 0);
        assert!(matches!(
            map.cached_lookup(0.6),
            crate::map::Lookup::Table(_)
        ));
        map.build_table(0.8, false).unwrap();
        assert_eq!(map.table_stats().radii, vec![0.6, 0.8]);
        // a radius without a table is answered by the grid scan, without building
        assert!(matches!(
            map.cached_lookup(0.5),
            crate::map::Lookup::Grid(..)
        ));
        assert_eq!(map.table_stats().radii, vec![0.6, 0.8]);
    }

    #[test]
    fn pinned_tables_are_kept_and_failed_builds_remembered() {
        let map = CliffMap::demo();
        let one = map.build_table(0.5, true).unwrap().memory_bytes();
        map.set_table_budget(one + one / 2);
        // the pinned table survives; another one cannot fit beside it
        let e = map.build_table(0.6, false).unwrap_err();
        assert!(matches!(e, TableError::TooLarge { .. }), "{e}");
        assert_eq!(map.table_stats().radii, vec![0.5]);
        assert_eq!(map.table_stats().failed, vec![0.6]);
        assert!(map.table_settled(0.6) && map.table_settled(0.5) && !map.table_settled(0.7));
        // a huge radius gives up without building (and is remembered too)
        let e = map.build_table(150.0, false).unwrap_err();
        assert!(matches!(e, TableError::TooLarge { .. }), "{e}");
        assert!(map.table_settled(150.0));
        // the library's lookup falls back to the grid scan with the same answers
        let p = DVec2::new(-3.2, 0.4);
        assert_eq!(map.lookup(0.6).best_near(p), map.best_near(p, 0.6));
        assert!(matches!(
            map.build_table(f64::NAN, false),
            Err(TableError::BadRadius { .. })
        ));
        // a larger budget forgets the failures
        map.set_table_budget(DEFAULT_TABLE_BUDGET);
        assert!(map.build_table(0.6, false).is_ok());
    }

    #[test]
    fn lookup_work_is_bounded_by_the_radius_in_grid_steps() {
        for f in ["thor1/cliffmap.csv", "atc/cliffmap-20121024.csv"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../shared/data")
                .join(f);
            let map = CliffMap::load(&path).unwrap();
            let step = map.grid().step();
            for cells in [1.0, 2.5, 4.0] {
                let r = cells * step;
                // (floor(2r) + 1)^2 cells, at most one location each
                let bound = ((2.0 * cells).floor() as usize + 1).pow(2);
                let grid = map.cached_lookup(r);
                assert!(matches!(grid, crate::map::Lookup::Grid(..)));
                assert!(grid.max_tests() <= bound, "{f} r {r}: {}", grid.max_tests());
                // a table's candidate lists also cover half a cell more around each cell
                let table = map.lookup(r);
                let table_bound = ((2.0 * cells).ceil() as usize + 3).pow(2);
                assert!(
                    table.max_tests() <= table_bound,
                    "{f} r {r}: {} > {table_bound}",
                    table.max_tests()
                );
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[test]
fn eight_lanes_give_each_lanes_step_density_bits() {
    use crate::math::Simd;
    use std::arch::x86_64::*;
    if !Simd::Avx2Fma.available() {
        return;
    }
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/");
    let atc = CliffMap::load(format!("{data}atc/cliffmap-20121024.csv")).unwrap();
    // (ATC's map has locations of five components: their second blocks; the wide map
    // one of up to twelve, with one, two and three further blocks)
    let wide = CliffMap::new(
        (1..=12)
            .map(|n| {
                let comps = (0..n)
                    .map(|j| Component {
                        theta: 0.7 * j as f64 - 2.0,
                        rho: 0.5 + 0.1 * j as f64,
                        cov: [0.1 + 0.02 * j as f64, 0.01, 0.01, 0.2],
                        weight: 1.0 / (j + 1) as f64,
                    })
                    .collect();
                loc(2.0 * n as f64, 0.0, 1.0, comps)
            })
            .collect(),
    )
    .unwrap();
    for (map, has_more) in [(CliffMap::demo(), false), (atc, true), (wide, true)] {
        let n = map.locations().len();
        let more: Vec<u32> = (0..n)
            .filter(|&i| map.locations()[i].components.len() > 4)
            .map(|i| i as u32)
            .collect();
        assert!(
            !has_more || !more.is_empty(),
            "no location of more than four components"
        );
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for round in 0..2000 {
            // locations (in turn those with further blocks), headings a few turns
            // either way, speeds from standing to running
            let loc: [u32; 8] = std::array::from_fn(|l| match (round + l) % 3 {
                0 if !more.is_empty() => more[next() as usize % more.len()],
                _ => (next() % n as u64) as u32,
            });
            let theta: [f32; 8] = std::array::from_fn(|_| (next() % 40_000) as f32 * 0.001 - 20.0);
            let rho: [f32; 8] = std::array::from_fn(|_| (next() % 3000) as f32 * 0.001);
            let mut got = [0.0f32; 8];
            // SAFETY: AVX2 and FMA (checked above); the locations are the map's.
            unsafe {
                let v = map.step_log_density8(
                    _mm256_loadu_si256(loc.as_ptr() as *const __m256i),
                    _mm256_loadu_ps(theta.as_ptr()),
                    _mm256_loadu_ps(rho.as_ptr()),
                );
                _mm256_storeu_ps(got.as_mut_ptr(), v);
            }
            for l in 0..8 {
                let want = map.step_log_density_at(loc[l] as usize, theta[l], rho[l]);
                let what = (loc[l], theta[l], rho[l]);
                assert_eq!(got[l].to_bits(), want.to_bits(), "{what:?}");
            }
        }
    }
}

#[test]
fn the_heading_density_given_the_speed_integrates_to_one_over_the_headings() {
    // two components of unequal weight, one with heading and speed correlated, and a
    // component whose speed is far from the others'
    let m = CliffMap::new(vec![loc(
        0.0,
        0.0,
        1.0,
        vec![
            Component {
                theta: 0.3,
                rho: 1.2,
                cov: [0.2, 0.05, 0.05, 0.04],
                weight: 0.6,
            },
            Component {
                theta: 4.0,
                rho: 0.8,
                cov: [0.5, 0.0, 0.0, 0.09],
                weight: 0.3,
            },
            Component {
                theta: 2.0,
                rho: 2.5,
                cov: [0.1, 0.0, 0.0, 0.01],
                weight: 0.1,
            },
        ],
    )])
    .unwrap();
    let n = 20_000;
    for rho in [0.3, 0.8, 1.2, 1.9, 2.5] {
        // the midpoint rule over [0, 2 pi)
        let total: f64 = (0..n)
            .map(|i| {
                let theta = (i as f64 + 0.5) * TAU / n as f64;
                m.heading_log_density(0, theta, rho).exp() * TAU / n as f64
            })
            .sum();
        assert!((total - 1.0).abs() < 1e-3, "speed {rho}: {total}");
    }
    // one component, heading and speed uncorrelated: the heading's density is the same
    // at any speed, however unlikely the speed
    let one = CliffMap::new(vec![loc(0.0, 0.0, 1.0, vec![comp(1.0, 1.0)])]).unwrap();
    for theta in [0.0, 1.0, 2.5, 5.0] {
        let at = |rho| one.heading_log_density(0, theta, rho);
        assert!((at(1.0) - at(2.0)).abs() < 1e-9, "{theta}");
        assert!(one.log_density(0, theta, 1.0) > one.log_density(0, theta, 2.0) + 1.0);
    }
}
