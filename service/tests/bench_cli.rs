//! The latency tool's command-line contract, against a live daemon.

mod common;

use std::path::PathBuf;
use std::process::Command;

use common::*;

/// `cliff-bench` is a binary of the cliff-client package: `cargo test --workspace`
/// builds it beside `cliffd`.
fn bench_exe() -> PathBuf {
    let exe = PathBuf::from(env!("CARGO_BIN_EXE_cliffd")).with_file_name("cliff-bench");
    assert!(
        exe.exists(),
        "{} is missing: run the tests with --workspace, or `cargo build -p cliff-client --bins` first",
        exe.display()
    );
    exe
}

fn bench(ns: &Namespace, args: &[&str]) -> std::process::Output {
    Command::new(bench_exe())
        .args(["--service", SERVICE, "--prefix", &ns.prefix])
        .args(args)
        .output()
        .expect("run cliff-bench")
}

#[test]
fn bench_prints_the_json_contract_and_verifies_every_response() {
    let ns = Namespace::new("bench");
    let _daemon = Daemon::start(&ns, &[]);
    for wait in ["spin", "hybrid", "block"] {
        let out = bench(
            &ns,
            &[
                "--clients",
                "2",
                "--requests",
                "150",
                "--warmup",
                "10",
                "--agents",
                "2",
                "--k",
                "5",
                "--steps",
                "12",
                "--wait",
                wait,
                "--verify",
                "--json",
            ],
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{wait}: {stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON object");
        for key in [
            "p50_us",
            "p90_us",
            "p99_us",
            "p999_us",
            "max_us",
            "requests_per_s",
            "agent_predictions_per_s",
            "inprocess_p50_us",
            "inprocess_p99_us",
        ] {
            let x = v[key]
                .as_f64()
                .unwrap_or_else(|| panic!("{wait}: {key} missing in {v}"));
            assert!(x > 0.0 && x.is_finite(), "{wait}: {key} = {x}");
        }
        let p = |k: &str| v[k].as_f64().unwrap();
        assert!(
            p("p50_us") <= p("p99_us")
                && p("p99_us") <= p("p999_us")
                && p("p999_us") <= p("max_us")
        );
        assert_eq!(v["completed"], 300);
        assert_eq!(v["mismatches"], 0);
        assert_eq!(v["wait"], wait);
        // 2 agents per request
        assert!((p("agent_predictions_per_s") / p("requests_per_s") - 2.0).abs() < 1e-9);
    }
    // the table names its columns and units
    let out = bench(
        &ns,
        &[
            "--requests",
            "50",
            "--warmup",
            "5",
            "--k",
            "5",
            "--steps",
            "10",
            "--wait",
            "block",
        ],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    for s in [
        "p50",
        "p99.9",
        "microseconds",
        "round trip through cliffd",
        "in-process prediction",
        "agent-predictions/s",
    ] {
        assert!(text.contains(s), "'{s}' missing from:\n{text}");
    }
}

#[test]
fn bench_runs_the_improved_method_and_scores_and_verifies_them() {
    let ns = Namespace::new("benchv2");
    let _daemon = Daemon::start(&ns, &[]);
    for (method, scores) in [("improved", false), ("cliff", true), ("cvm", true)] {
        let mut args = vec![
            "--requests",
            "100",
            "--warmup",
            "5",
            "--agents",
            "3",
            "--k",
            "8",
            "--steps",
            "15",
            "--method",
            method,
            "--wait",
            "hybrid",
            "--verify",
            "--json",
        ];
        if scores {
            args.push("--scores");
        }
        let out = bench(&ns, &args);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{method}: {stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON object");
        assert_eq!(v["method"], method);
        assert_eq!(v["scores"], scores);
        assert_eq!(v["completed"], 100);
        assert_eq!(v["mismatches"], 0, "{method}: {v}");
    }
    let out = bench(&ns, &["--requests", "5", "--method", "nonsense"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("improved"), "{err}");
}

#[test]
fn bench_paces_requests_with_rate() {
    let ns = Namespace::new("benchrate");
    let _daemon = Daemon::start(&ns, &[]);
    let out = bench(
        &ns,
        &[
            "--requests",
            "20",
            "--warmup",
            "2",
            "--rate",
            "100",
            "--k",
            "5",
            "--steps",
            "10",
            "--wait",
            "block",
            "--json",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON object");
    assert_eq!(v["rate_hz"], 100.0);
    assert_eq!(v["completed"], 20);
    // 20 requests on a 10 ms schedule take at least 190 ms: at most ~105 per second
    let rps = v["requests_per_s"].as_f64().unwrap();
    assert!(rps > 0.0 && rps < 110.0, "{rps} requests/s at --rate 100");
    // the table says so
    let out = bench(&ns, &["--requests", "5", "--warmup", "1", "--rate", "200"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("paced at 200 requests/s"), "{text}");
    // and a rate that is no rate is refused
    for bad in ["0", "-5", "nan"] {
        let out = bench(&ns, &["--requests", "5", &format!("--rate={bad}")]);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("--rate"), "{bad}: {err}");
    }
}

#[test]
fn bench_without_a_daemon_fails_with_a_clear_message() {
    let ns = Namespace::new("benchnone");
    let out = bench(&ns, &["--requests", "10", "--json"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no cliffd daemon serves"), "{err}");
}
