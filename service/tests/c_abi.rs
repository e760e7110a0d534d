//! The C example, compiled with gcc against the generated header and libcliff_client,
//! talks to a live cliffd and gets the in-process numbers.

mod common;

use std::path::PathBuf;
use std::process::Command;

use cliff::map::CliffMap;
use cliff::predict::Params;
use cliff_client::{Observation, Request};
use common::*;

#[test]
fn c_example_predicts_through_a_live_daemon() {
    let ns = Namespace::new("cabi");
    // Cargo builds every crate type of a dependency into the deps folder beside this test
    let deps = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .to_path_buf();
    let lib = deps.join("libcliff_client.so");
    assert!(lib.exists(), "{} is missing", lib.display());
    let root = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let exe = std::env::temp_dir().join(format!("{}cliff_predict", ns.prefix));
    let out = Command::new("gcc")
        .arg(root.join("client/examples/c/cliff_predict.c"))
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-I"])
        .arg(root.join("client/include"))
        .arg(&lib)
        .arg(format!("-Wl,-rpath,{}", deps.display()))
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("run gcc");
    assert!(
        out.status.success(),
        "gcc failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let _daemon = Daemon::start(&ns, &[]);
    let run = Command::new(&exe)
        .arg(SERVICE)
        .env("CLIFF_IPC_PREFIX", &ns.prefix)
        .output()
        .expect("run the C example");
    let _ = std::fs::remove_file(&exe);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "C example failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        stdout.contains("2 agents x 5 samples x 30 steps"),
        "{stdout}"
    );
    assert!(
        stdout.contains("unknown map: result 4, status unknown-map"),
        "{stdout}"
    );
    assert!(stdout.contains("reload maps: result 0\n"), "{stdout}");
    assert!(
        stdout.contains("unknown time mode: result 4, status bad-value"),
        "{stdout}"
    );

    // the same request in-process gives the same first samples
    let params = Params {
        k: 5,
        seed: 42,
        ..Params::default()
    };
    let mut req = Request::new("demo", &params).unwrap();
    req.add_agent((0..4).map(|i| {
        Observation::with_velocity(0.4 * i as f64, -10.0 + 0.5 * i as f64, -1.0, 1.25, 0.0)
    }));
    req.add_agent(
        (0..3).map(|i| Observation::position(0.4 * i as f64, 0.5, -8.0 + 0.5 * i as f64)),
    );
    let mut lp = cliff_client::LocalPredictor::default();
    let b = lp
        .predict(&CliffMap::demo(), req.header(), req.rows())
        .unwrap();
    for a in 0..2 {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(&format!("agent {a} sample 0:")))
            .unwrap_or_else(|| panic!("no line for agent {a}:\n{stdout}"));
        let points: Vec<[f32; 2]> = line
            .split_once("points:")
            .unwrap()
            .1
            .split_whitespace()
            .map(|p| {
                let (x, y) = p.split_once(',').unwrap();
                [x.parse().unwrap(), y.parse().unwrap()]
            })
            .collect();
        let want = b.sample(a, 0);
        assert!(!want.is_empty());
        assert_eq!(points.len(), want.len(), "agent {a}");
        for (p, w) in points.iter().zip(want) {
            assert_eq!(p[0].to_bits(), w[0].to_bits(), "agent {a}");
            assert_eq!(p[1].to_bits(), w[1].to_bits(), "agent {a}");
        }
    }
    // the improved method with options, scores and the all-day map: the same best
    // sample, score and length as in-process
    let scored = req
        .clone()
        .method(cliff::predict::Method::Improved)
        .speed_beta(2.0)
        .coast(4.0)
        .scores(true)
        .all_day();
    let b = lp
        .predict(&CliffMap::demo(), scored.header(), scored.rows())
        .unwrap();
    assert_eq!(b.scores().len(), 10);
    for a in 0..2 {
        let best = b.best_sample(a).unwrap();
        let line = stdout
            .lines()
            .find(|l| l.starts_with(&format!("agent {a} best sample")))
            .unwrap_or_else(|| panic!("no scored line for agent {a}:\n{stdout}"));
        let want = format!("agent {a} best sample {best}: score ");
        assert!(line.starts_with(&want), "{line} (in-process: {want})");
        let (score, points) = line[want.len()..].split_once(", ").unwrap();
        let score: f32 = score.parse().unwrap();
        assert_eq!(
            score.to_bits(),
            b.score(a, best).unwrap().to_bits(),
            "{line}"
        );
        assert_eq!(points, format!("{} points", b.len(a, best)), "{line}");
    }
}
