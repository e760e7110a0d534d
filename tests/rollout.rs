//! The rollout driven in chunks and by several callers: the same bytes and scores as
//! one call, on the THÖR1 people.

use cliff::map::CliffMap;
use cliff::motion::State;
use cliff::predict::*;

fn thor_agents() -> (CliffMap, Vec<State>) {
    use cliff::eval::protocol::{Settings, prepare};
    use cliff::tracks::{Format, read_tracks};
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/thor1/");
    let map = CliffMap::load(format!("{data}cliffmap.csv")).unwrap();
    let tracks = read_tracks(
        std::path::Path::new(&format!("{data}exp-1-run-2.csv")),
        Format::Thor,
    )
    .unwrap();
    let agents = tracks
        .iter()
        .filter_map(|t| prepare(t, &Settings::default()))
        .map(|c| c.start)
        .take(9)
        .collect();
    (map, agents)
}

#[test]
fn chunks_give_the_bytes_and_scores_of_one_call() {
    let (map, agents) = thor_agents();
    assert_eq!(agents.len(), 9);
    let n = agents.len();
    for (method, k) in [(Method::Cliff, 7), (Method::Cliff, 23), (Method::Cvm, 2)] {
        let params = Params {
            method,
            k,
            seed: 3,
            ..Params::default()
        };
        for options in [
            Options::default(),
            Options {
                scores: true,
                ..Options::default()
            },
            Options {
                speed_beta: 2.0,
                coast: 2.0,
                scores: true,
                ..Options::default()
            },
            Options {
                follow: 4.0,
                candidates: 3,
                scores: true,
                ..Options::default()
            },
        ] {
            let mut whole = TrajectoryBatch::new();
            predict_with(&map, &agents, &params, &options, &mut whole).unwrap();
            assert_eq!(whole.scores().len(), if options.scores { n * k } else { 0 });
            for cuts in [&[4usize][..], &[1, 2, 8], &[0, 5, 5]] {
                let mut pieces = TrajectoryBatch::new();
                pieces.reshape(n, k, params.steps());
                let mut scores = vec![-1.0f32; n * k];
                let mut rollout = Rollout::new(&params)
                    .unwrap()
                    .with_options(options)
                    .unwrap()
                    .with_tables(Tables::CachedOnly);
                let out = pieces.as_mut();
                let (mut positions, mut lens, mut sc) = (out.positions, out.lens, &mut scores[..]);
                let mut from = 0;
                for &to in cuts.iter().chain([&n]) {
                    let m = to - from;
                    let (p, rest_p) = positions.split_at_mut(m * k * params.steps());
                    let (l, rest_l) = lens.split_at_mut(m * k);
                    let (s, rest_s) = sc.split_at_mut(m * k);
                    rollout
                        .predict_agents(
                            &map,
                            &agents[from..to],
                            BatchMut {
                                positions: p,
                                lens: l,
                            },
                            Some(s),
                        )
                        .unwrap();
                    (positions, lens, sc) = (rest_p, rest_l, rest_s);
                    from = to;
                }
                let what = format!("{method:?} k {k} {options:?} cuts {cuts:?}");
                assert_eq!(whole.positions().len(), pieces.positions().len());
                assert!(
                    whole
                        .positions()
                        .iter()
                        .zip(pieces.positions())
                        .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)),
                    "{what}"
                );
                assert_eq!(whole.lens(), pieces.lens(), "{what}");
                if options.scores {
                    assert_eq!(whole.scores(), &scores[..], "{what}");
                    assert!(scores.iter().all(|s| s.is_finite()), "{what}");
                } else {
                    // a score buffer without scores asked for: NaN
                    assert!(scores.iter().all(|s| s.is_nan()), "{what}");
                }
            }
        }
    }
}

#[test]
fn a_restarted_rollout_predicts_as_a_new_one() {
    let (map, agents) = thor_agents();
    let n = agents.len();
    let first = Params {
        k: 6,
        seed: 1,
        ..Params::default()
    };
    let improved = Params {
        method: Method::Improved,
        k: 5,
        seed: 8,
        ..Params::default()
    };
    let asked = [
        (first, Options::default()),
        (
            improved,
            Options {
                coast: 3.0,
                ..Options::default()
            },
        ),
        (
            Params {
                method: Method::Cliff,
                ..improved
            },
            Options {
                speed_beta: 2.0,
                candidates: 4,
                scores: true,
                ..Options::default()
            },
        ),
    ];
    let mut rollout = Rollout::new(&first)
        .unwrap()
        .with_tables(Tables::CachedOnly);
    for (params, options) in asked {
        rollout.restart(&params, options).unwrap();
        let mut whole = TrajectoryBatch::new();
        predict_with(&map, &agents, &params, &options, &mut whole).unwrap();
        let mut again = TrajectoryBatch::new();
        again.reshape(n, params.k, params.steps());
        let mut scores = vec![0.0f32; n * params.k];
        rollout
            .predict_agents(&map, &agents, again.as_mut(), Some(&mut scores))
            .unwrap();
        assert_eq!(again.lens(), whole.lens(), "{params:?} {options:?}");
        assert!(
            whole
                .positions()
                .iter()
                .zip(again.positions())
                .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)),
            "{params:?} {options:?}"
        );
        if !whole.scores().is_empty() {
            assert_eq!(whole.scores(), &scores[..]);
        }
    }
    // a bad restart leaves the rollout as it was
    let before = rollout.clone();
    let bad = Options {
        coast: -1.0,
        ..Options::default()
    };
    assert!(rollout.restart(&first, bad).is_err());
    assert_eq!(
        (rollout.params(), rollout.options()),
        (before.params(), before.options())
    );
}

#[test]
fn candidates_keep_the_furthest_reaching_then_best_scored_of_the_draws() {
    let (map, agents) = thor_agents();
    for (k, c) in [(5usize, 4u32), (20, 3), (7, 16)] {
        let params = Params {
            k,
            seed: 11,
            ..Params::default()
        };
        let opts = Options {
            follow: 2.0,
            scores: true,
            ..Options::default()
        };
        // the same draws: all c x k candidates, scored
        let mut all = TrajectoryBatch::new();
        let wide = Params {
            k: k * c as usize,
            ..params
        };
        predict_with(&map, &agents, &wide, &opts, &mut all).unwrap();
        let mut kept = TrajectoryBatch::new();
        let with = Options {
            candidates: c,
            ..opts
        };
        predict_with(&map, &agents, &params, &with, &mut kept).unwrap();
        for a in 0..agents.len() {
            let mut idx: Vec<usize> = (0..wide.k).collect();
            idx.sort_by(|&x, &y| {
                let (lx, ly) = (all.len(a, x), all.len(a, y));
                let (sx, sy) = (all.score(a, x).unwrap(), all.score(a, y).unwrap());
                ly.cmp(&lx).then(sy.total_cmp(&sx)).then(x.cmp(&y))
            });
            for (s, &i) in idx[..k].iter().enumerate() {
                let bits = |b: &TrajectoryBatch, s: usize| -> Vec<[u32; 2]> {
                    b.sample(a, s).iter().map(|p| p.map(f32::to_bits)).collect()
                };
                assert_eq!(bits(&kept, s), bits(&all, i), "k {k} c {c} agent {a}");
                assert_eq!(kept.len(a, s), all.len(a, i));
                assert_eq!(kept.score(a, s), all.score(a, i));
            }
            // kept samples reach at least as far as the others on average
            let mean = |b: &TrajectoryBatch, n: usize| {
                (0..n).map(|s| b.len(a, s) as f64).sum::<f64>() / n as f64
            };
            assert!(mean(&kept, k) >= mean(&all, wide.k));
        }
    }
}

#[test]
fn a_score_buffer_of_the_wrong_size_is_refused() {
    let (map, agents) = thor_agents();
    let params = Params {
        k: 2,
        ..Params::default()
    };
    let mut b = TrajectoryBatch::new();
    b.reshape(agents.len(), 2, params.steps());
    let mut scores = vec![0.0f32; 2 * agents.len() - 1];
    let mut rollout = Rollout::new(&params).unwrap();
    let e = rollout.predict_agents(&map, &agents, b.as_mut(), Some(&mut scores));
    assert!(matches!(e, Err(PredictError::Param { name: "scores", .. })));
    assert!(
        Rollout::new(&params)
            .unwrap()
            .with_options(Options {
                coast: -1.0,
                ..Options::default()
            })
            .is_err()
    );
}

/// The bits of a batch's positions.
#[test]
fn a_call_after_others_on_a_thread_predicts_as_on_a_fresh_thread() {
    // (a rollout leaves its buffers to the thread's next one)
    let (map, agents) = thor_agents();
    let map = std::sync::Arc::new(map);
    let improved = Params {
        method: Method::Improved,
        k: 7,
        seed: 4,
        ..Params::default()
    };
    let call = |map: &CliffMap, params: &Params, options: &Options| {
        let mut batch = TrajectoryBatch::new();
        predict_with(map, &agents, params, options, &mut batch).unwrap();
        (bits(&batch), batch.lens().to_vec(), batch.scores().to_vec())
    };
    let fresh = std::thread::scope(|s| {
        s.spawn(|| call(&map, &improved, &Options::default()))
            .join()
            .unwrap()
    });
    let after = std::thread::scope(|s| {
        s.spawn(|| {
            // larger calls first: more candidates, more samples, a longer horizon
            let wide = Options {
                candidates: 6,
                prune: true,
                follow: 4.0,
                scores: true,
                ..Options::default()
            };
            let long = Params {
                k: 20,
                horizon: 30.0,
                seed: 9,
                ..improved
            };
            call(
                &map,
                &Params {
                    method: Method::Cliff,
                    ..long
                },
                &wide,
            );
            call(&map, &long, &Options::default());
            call(&map, &improved, &Options::default())
        })
        .join()
        .unwrap()
    });
    assert_eq!(after.1, fresh.1);
    assert_eq!(after.0, fresh.0);
    assert_eq!(after.2, fresh.2);
    assert!(!fresh.2.is_empty());
}

fn bits(b: &TrajectoryBatch) -> Vec<u32> {
    b.positions()
        .iter()
        .flatten()
        .map(|v| v.to_bits())
        .collect()
}

#[test]
fn all_cores_give_the_bytes_and_scores_of_one_thread() {
    let (map, agents) = thor_agents();
    // 9 people repeated to 450: enough work to be shared among the threads
    let many: Vec<State> = agents.iter().cycle().take(450).copied().collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    for (params, options) in [
        (
            Params {
                k: 20,
                seed: 9,
                ..Params::default()
            },
            Options::default(),
        ),
        (
            Params {
                method: Method::Improved,
                k: 7,
                seed: 2,
                ..Params::default()
            },
            Options::default(),
        ),
        (
            Params {
                k: 3,
                seed: 4,
                ..Params::default()
            },
            Options {
                speed_beta: 1.0,
                coast: 2.0,
                scores: true,
                ..Options::default()
            },
        ),
    ] {
        let mut one = TrajectoryBatch::new();
        predict_with(&map, &many, &params, &options, &mut one).unwrap();
        let mut all = TrajectoryBatch::new();
        pool.install(|| predict_batch(&map, &many, &params, &options, &mut all))
            .unwrap();
        assert_eq!(bits(&one), bits(&all), "{params:?} {options:?}");
        assert_eq!(one.lens(), all.lens());
        assert_eq!(one.scores(), all.scores());
        // a repeated person draws anew at every place in the call
        assert_ne!(one.sample(0, 0), one.sample(9, 0));
        // and the slices flavour, started after other agents of the same rollout
        let mut split = TrajectoryBatch::new();
        split.reshape(many.len(), params.k, params.steps());
        let mut scores = vec![0.0f32; many.len() * params.k];
        let cut = 100;
        let per = params.k * params.steps();
        let out = split.as_mut();
        let (p1, p2) = out.positions.split_at_mut(cut * per);
        let (l1, l2) = out.lens.split_at_mut(cut * params.k);
        let (s1, s2) = scores.split_at_mut(cut * params.k);
        let mut rollout = Rollout::new(&params)
            .unwrap()
            .with_options(options)
            .unwrap();
        // the later share first, from a copy ahead of the first share
        pool.install(|| {
            rollout
                .ahead(cut as u64)
                .predict_agents_parallel(
                    &map,
                    &many[cut..],
                    BatchMut {
                        positions: p2,
                        lens: l2,
                    },
                    Some(s2),
                )
                .unwrap()
        });
        rollout
            .predict_agents(
                &map,
                &many[..cut],
                BatchMut {
                    positions: p1,
                    lens: l1,
                },
                Some(s1),
            )
            .unwrap();
        assert_eq!(rollout.next_agent(), cut as u64);
        assert_eq!(bits(&one), bits(&split), "{params:?} {options:?} in shares");
        if !one.scores().is_empty() {
            assert_eq!(one.scores(), &scores[..]);
        }
    }
    // a horizon shorter than a step: no positions, on all cores too
    let mut none = TrajectoryBatch::new();
    let params = Params {
        horizon: 0.1,
        ..Params::default()
    };
    pool.install(|| predict_batch(&map, &many, &params, &Options::default(), &mut none))
        .unwrap();
    assert_eq!(none.shape(), (450, 20, 0));
    assert!(none.lens().iter().all(|&l| l == 0));
}

#[test]
fn a_one_person_call_is_the_first_person_of_a_call() {
    let (map, agents) = thor_agents();
    let params = Params {
        seed: 77,
        ..Params::default()
    };
    let mut alone = TrajectoryBatch::new();
    predict(&map, &agents[..1], &params, &mut alone).unwrap();
    let mut many = TrajectoryBatch::new();
    predict(&map, &agents, &params, &mut many).unwrap();
    let sample_bits = |b: &TrajectoryBatch, a: usize, s: usize| {
        b.full_sample(a, s)
            .iter()
            .flatten()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>()
    };
    for s in 0..params.k {
        assert_eq!(sample_bits(&alone, 0, s), sample_bits(&many, 0, s));
    }
    // the second person of the call is not the first one of a call of its own
    let mut second = TrajectoryBatch::new();
    predict(&map, &agents[1..2], &params, &mut second).unwrap();
    assert_ne!(sample_bits(&second, 0, 0), sample_bits(&many, 1, 0));
}
