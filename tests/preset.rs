//! The `improved` preset: what it resolves to, and that every entry point applies it.

use cliff::map::CliffMap;
use cliff::motion::State;
use cliff::predict::preset::*;
use cliff::predict::*;
use glam::DVec2;

#[test]
fn improved_predicts_as_cliff_with_the_preset() {
    let map = CliffMap::demo();
    let agents = [
        State {
            position: DVec2::new(-10.0, 0.5),
            speed: 1.2,
            heading: 0.0,
            time: 0.0,
        },
        State {
            position: DVec2::new(0.5, -6.0),
            speed: 1.0,
            heading: 1.5,
            time: 0.0,
        },
    ];
    let asked = Params {
        method: Method::Improved,
        k: 7,
        seed: 5,
        beta: 0.3,
        ..Params::default()
    };
    let (p, o) = resolve(&asked, &Options::default());
    assert_eq!(
        p,
        Params {
            method: Method::Cliff,
            beta: IMPROVED.beta,
            ..asked
        }
    );
    assert_eq!(o, IMPROVED.options);
    let mut direct = TrajectoryBatch::new();
    predict_with(&map, &agents, &p, &o, &mut direct).unwrap();
    // predict_with resolves: the same samples and scores
    let mut improved = TrajectoryBatch::new();
    predict_with(&map, &agents, &asked, &Options::default(), &mut improved).unwrap();
    assert_eq!(direct, improved);
    assert_eq!(improved.scores().len(), 14);
    // predict resolves too, but has nowhere to put scores
    let mut plain = TrajectoryBatch::new();
    predict(&map, &agents, &asked, &mut plain).unwrap();
    assert_eq!(plain.positions(), direct.positions());
    assert!(plain.scores().is_empty());
    // and the paper's method with the caller's beta is another prediction
    predict(
        &map,
        &agents,
        &Params {
            method: Method::Cliff,
            ..asked
        },
        &mut plain,
    )
    .unwrap();
    assert_ne!(plain.positions(), direct.positions());
    // a rollout resolves, whatever options it is given afterwards (but for coasting,
    // which stays the caller's)
    let r = Rollout::new(&asked)
        .unwrap()
        .with_options(Options {
            follow: 9.0,
            speed_beta: 3.0,
            ..Options::default()
        })
        .unwrap();
    assert_eq!((r.params(), r.options()), (&p, &o));
    let coasting = Rollout::new(&asked)
        .unwrap()
        .with_options(Options {
            coast: 3.0,
            ..Options::default()
        })
        .unwrap();
    assert_eq!(
        coasting.options(),
        &Options {
            coast: 3.0,
            ..IMPROVED.options
        }
    );
    let mut b = TrajectoryBatch::new();
    b.reshape(2, 7, p.steps());
    let mut scores = vec![0.0f32; 14];
    let mut r = r;
    r.predict_agents(&map, &agents, b.as_mut(), Some(&mut scores))
        .unwrap();
    assert_eq!(b.positions(), direct.positions());
    assert_eq!(&scores[..], direct.scores());
}

#[test]
fn other_methods_are_left_alone() {
    let o = Options {
        speed_beta: 1.0,
        coast: 2.0,
        follow: 1.0,
        ..Options::default()
    };
    for method in [Method::Cliff, Method::Cvm] {
        let p = Params {
            method,
            beta: 0.7,
            ..Params::default()
        };
        assert_eq!(resolve(&p, &o), (p, o));
    }
}
