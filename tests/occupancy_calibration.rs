//! Occupancy is calibrated on held-out people: on atc/dev (the six held-out hours, the
//! published ATC map, the seconds protocol at 1 s), the cells predicted at probability
//! p hold the person about p of the time, and better so for the map's methods than for
//! constant velocity, whose single path is a certainty it does not have.

use std::path::Path;

use cliff::eval::EvalConfig;
use cliff::eval::calibration::{CalibrationConfig, CalibrationRow, calibrate};
use cliff::eval::protocol::{Protocol, Settings};
use cliff::map::CliffMap;
use cliff::occupancy::Settings as OccupancySettings;
use cliff::predict::{Method, Params};
use cliff::tracks::{Format, read_many};

fn row(rows: &[CalibrationRow], method: Method, horizon: f64) -> &CalibrationRow {
    rows.iter()
        .find(|r| r.method == method && (r.horizon - horizon).abs() < 1e-9)
        .unwrap()
}

#[test]
fn occupancy_is_calibrated_on_held_out_atc_people() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/atc");
    let map = CliffMap::load(data.join("cliffmap-20121024.csv")).unwrap();
    let dev: Vec<_> = [9, 11, 13, 15, 17, 19]
        .iter()
        .map(|h| data.join(format!("dev/atc-1024-{h}_test.csv")))
        .collect();
    let tracks = read_many(&dev, Format::Atc).unwrap();
    let cfg = CalibrationConfig {
        eval: EvalConfig {
            motion_model: None,
            settings: Settings {
                protocol: Protocol::Seconds,
                obs: 3.2,
                dt: 1.0,
                horizon: 20.0,
                ..Settings::default()
            },
            params: Params {
                radius: 1.0,
                ..Params::default()
            },
            seeds: 1,
            methods: vec![Method::Cliff, Method::Improved, Method::Cvm],
            options: Default::default(),
        },
        occupancy: OccupancySettings::default(),
        resolution: 0.5,
        horizons: vec![5.0, 10.0, 20.0],
    };
    let rows = calibrate(&map, &tracks, &cfg, &|| {}).unwrap();
    for r in &rows {
        eprintln!(
            "{} {} s: {} people, ECE {:.4}, Brier {:.3}, log-likelihood {:.2}",
            r.method,
            r.horizon,
            r.people,
            r.ece(),
            r.brier,
            r.log_likelihood
        );
    }
    for h in [5.0, 10.0, 20.0] {
        let (cliff, improved, cvm) = (
            row(&rows, Method::Cliff, h),
            row(&rows, Method::Improved, h),
            row(&rows, Method::Cvm, h),
        );
        assert!(cliff.people > 250, "{h} s: {} people", cliff.people);
        // measured (2026-12-05): the paper's method 0.006 to 0.010, `improved` 0.017
        // to 0.026 (its samples a little tighter than where people go), constant
        // velocity 0.059 to 0.082; the bounds leave about half as much again
        assert!(cliff.ece() < 0.02, "cliff {h} s: ECE {:.4}", cliff.ece());
        assert!(
            improved.ece() < 0.04,
            "improved {h} s: ECE {:.4}",
            improved.ece()
        );
        // the map's samples spread where people go: better calibrated than one path
        // and a person-sized kernel, and more likely to have put density on the truth
        assert!(
            cvm.ece() > 3.0 * cliff.ece(),
            "{h} s: cvm {:.4} cliff {:.4}",
            cvm.ece(),
            cliff.ece()
        );
        assert!(cliff.log_likelihood > cvm.log_likelihood + 1.0, "{h} s");
        assert!(improved.log_likelihood > cvm.log_likelihood, "{h} s");
        // every person's cells sum to one person: the mass predicted in a bin and the
        // people found there agree over all the bins
        // (the grid holds every sample's kernel, so a person outside it is one the
        // prediction missed: measured 0.93 to 0.97 of the people inside for the paper's
        // method, 0.73 to 0.83 for `improved`)
        for (r, inside) in [(cliff, 0.9), (improved, 0.65)] {
            let predicted: f64 = r.bins.iter().map(|b| b.predicted).sum();
            let hits: u64 = r.bins.iter().map(|b| b.hits).sum();
            let n = r.people as f64;
            assert!(
                (predicted / n - 1.0).abs() < 0.02,
                "{h} s: {predicted} over {n}"
            );
            assert!((hits as f64 / n - r.in_grid).abs() < 1e-9);
            assert!(r.in_grid > inside, "{h} s: {}", r.in_grid);
        }
    }
}
