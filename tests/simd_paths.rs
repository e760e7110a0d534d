//! The lane loop's two instruction paths (baseline and AVX2 + FMA, `cliff::math::Simd`)
//! on the THÖR1 people: each deterministic for a seed, and the two alike up to the last
//! bits of the positions (fused multiply-adds round once where the baseline rounds
//! twice), with every option.

use cliff::map::CliffMap;
use cliff::math::Simd;
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
        .take(30)
        .collect();
    (map, agents)
}

/// One agent's prediction on `simd`: positions, lengths, scores.
fn one(
    map: &CliffMap,
    agent: &State,
    params: &Params,
    options: Options,
    simd: Simd,
) -> (Vec<[f32; 2]>, Vec<u32>, Vec<f32>) {
    let steps = params.steps();
    let mut positions = vec![[0.0f32; 2]; params.k * steps];
    let mut lens = vec![0u32; params.k];
    let mut scores = vec![0.0f32; params.k];
    let mut rollout = Rollout::new(params)
        .unwrap()
        .with_options(options)
        .unwrap()
        .with_simd(simd);
    assert_eq!(rollout.simd(), simd);
    rollout
        .predict_agents(
            map,
            std::slice::from_ref(agent),
            BatchMut {
                positions: &mut positions,
                lens: &mut lens,
            },
            Some(&mut scores),
        )
        .unwrap();
    (positions, lens, scores)
}

#[test]
fn each_path_is_deterministic_and_the_paths_agree_but_for_the_last_bits() {
    if !Simd::Avx2Fma.available() {
        eprintln!("this processor has no AVX2 + FMA: only the baseline path runs");
        return;
    }
    let (map, agents) = thor_agents();
    assert_eq!(agents.len(), 30);
    let bits = |p: &[[f32; 2]]| p.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
    for options in [
        Options::default(),
        Options {
            scores: true,
            speed_beta: 1.0,
            coast: 2.0,
            ..Options::default()
        },
        Options {
            follow: 4.0,
            candidates: 3,
            scores: true,
            ..Options::default()
        },
    ] {
        let (mut alike, mut same_bits, mut worst) = (0, 0, 0.0f32);
        for (i, agent) in agents.iter().enumerate() {
            let params = Params {
                k: 20,
                seed: i as u64,
                ..Params::default()
            };
            let base = one(&map, agent, &params, options, Simd::Baseline);
            let avx = one(&map, agent, &params, options, Simd::Avx2Fma);
            // deterministic on each path
            let again = one(&map, agent, &params, options, Simd::Avx2Fma);
            assert_eq!(bits(&avx.0), bits(&again.0));
            assert_eq!(avx.1, again.1);
            let again = one(&map, agent, &params, options, Simd::Baseline);
            assert_eq!(bits(&base.0), bits(&again.0));
            same_bits += (bits(&base.0) == bits(&avx.0)) as usize;
            // the same samples, a last-bit difference apart (a draw near a boundary
            // of the map's lookup may end a sample one step apart on the two paths,
            // and then the generator's stream shifts: such agents are counted, not
            // compared)
            if base.1 == avx.1 {
                alike += 1;
                for (a, b) in base.0.iter().zip(&avx.0) {
                    if a[0].is_nan() {
                        assert!(b[0].is_nan());
                        continue;
                    }
                    worst = worst.max((a[0] - b[0]).abs()).max((a[1] - b[1]).abs());
                }
                if options.scores {
                    for (a, b) in base.2.iter().zip(&avx.2) {
                        assert!((a - b).abs() <= 1e-3 * a.abs().max(1.0), "{a} {b}");
                    }
                }
            }
        }
        assert!(alike >= 27, "{options:?}: {alike} of 30 people alike");
        assert!(worst < 1e-3, "{options:?}: worst difference {worst} m");
        // fused multiply-adds do change the last bits
        assert!(
            same_bits < 30,
            "{options:?}: the two paths gave the same bits"
        );
    }
}

#[test]
fn the_baseline_setting_is_honoured_and_an_unavailable_path_falls_back() {
    assert_eq!(Simd::choose(Some("baseline")), Simd::Baseline);
    let r = Rollout::new(&Params::default()).unwrap();
    assert_eq!(r.simd(), Simd::active());
    assert!(r.simd().available());
    let r = r.with_simd(Simd::Baseline);
    assert_eq!(r.simd(), Simd::Baseline);
    if !Simd::Avx2Fma.available() {
        assert_eq!(r.with_simd(Simd::Avx2Fma).simd(), Simd::Baseline);
    }
    // in this process, CLIFF_SIMD decides the default path
    match std::env::var("CLIFF_SIMD").as_deref() {
        Ok("baseline") => assert_eq!(Simd::active(), Simd::Baseline),
        _ => assert_eq!(Simd::active(), Simd::detect()),
    }
}
