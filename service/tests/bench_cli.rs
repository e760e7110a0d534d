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

#[test]
fn bench_defaults_to_the_client_librarys_wait_and_verifies_every_response() {
    let ns = Namespace::new("benchdef");
    let _daemon = Daemon::start(&ns, &[]);
    let run = |extra: &[&str]| {
        let mut args = vec![
            "--requests",
            "60",
            "--warmup",
            "5",
            "--k",
            "5",
            "--steps",
            "10",
        ];
        args.extend_from_slice(extra);
        let out = bench(&ns, &args);
        let stdout = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(
            out.status.success(),
            "{stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        (
            serde_json::from_str::<serde_json::Value>(stdout.trim()).expect("one JSON object"),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let (v, _) = run(&["--json"]);
    // what a program gets from Client::connect
    let library = cliff_client::ClientOptions::default().wait;
    assert_eq!(library, cliff_client::WaitMode::default());
    assert_eq!(v["wait"], library.to_string());
    // checked by default, and every response identical to the in-process prediction
    assert_eq!(v["mismatches"], 0, "{v}");
    assert_eq!(v["warmup_excluded"], true);
    let m = &v["machine"];
    assert!(m["cores"].as_u64().unwrap() >= 1, "{m}");
    assert_eq!(
        m["load_average_start"].as_array().map(|a| a.len()),
        Some(3),
        "{m}"
    );
    // --no-verify turns the check off (the last of the two flags wins)
    let (v, _) = run(&["--json", "--verify", "--no-verify"]);
    assert!(v["mismatches"].is_null(), "{v}");
    let (v, _) = run(&["--json", "--no-verify", "--verify"]);
    assert_eq!(v["mismatches"], 0, "{v}");
}

#[test]
fn bench_warns_when_spinning_clients_outnumber_the_free_cores() {
    let ns = Namespace::new("benchcores");
    let _daemon = Daemon::start(&ns, &[]);
    let cores = std::thread::available_parallelism().unwrap().get();
    // the daemon's serving thread takes a core: as many spinning clients as cores are
    // one too many, as many blocking ones are not
    let clients = cores.to_string();
    for (wait, over) in [("spin", true), ("block", false)] {
        let out = bench(
            &ns,
            &[
                "--clients",
                &clients,
                "--requests",
                "40",
                "--warmup",
                "2",
                "--k",
                "5",
                "--steps",
                "10",
                "--wait",
                wait,
                "--json",
            ],
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{wait}: {stdout}\n{stderr}");
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON object");
        let c = &v["cores"];
        assert_eq!(c["oversubscribed"], over, "{wait}: {c}");
        assert_eq!(c["cores"].as_u64(), Some(cores as u64), "{c}");
        assert_eq!(c["free"].as_u64(), Some(cores as u64 - 1), "{c}");
        assert_eq!(
            stderr.contains("cores are free"),
            over,
            "{wait}: stderr:\n{stderr}"
        );
    }
}

#[test]
fn bench_compare_writes_a_report_with_the_floor_under_the_round_trip() {
    let ns = Namespace::new("benchcmp");
    let _daemon = Daemon::start(&ns, &[]);
    let dir = std::env::temp_dir().join(format!("cliff-bench-compare-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = bench(
        &ns,
        &[
            "--compare",
            "--clients",
            "1,2",
            "--requests",
            "400",
            "--warmup",
            "50",
            "--agents",
            "2",
            "--k",
            "20",
            "--steps",
            "30",
            // every round trip pays one wake-up, floor and full alike: a hybrid client's
            // spin-or-sleep choice depends on the last round trip, and on a loaded machine
            // it may settle in either mode for a whole run
            "--wait",
            "block",
            "--out",
            dir.to_str().unwrap(),
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "report.md",
        "report.json",
        "latency-cdf.png",
        "throughput.png",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing in {}", dir.display());
    }
    for f in ["latency-cdf.png", "throughput.png"] {
        let bytes = std::fs::read(dir.join(f)).unwrap();
        assert!(bytes.starts_with(b"\x89PNG"), "{f} is not a PNG");
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    // the machine's facts, from /proc as the test reads them too
    let m = &v["machine"];
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap();
    let model = cpuinfo
        .lines()
        .find_map(|l| l.split_once(':').filter(|(k, _)| k.trim() == "model name"))
        .map(|(_, v)| v.trim().to_string())
        .unwrap_or_default();
    assert_eq!(m["cpu_model"], model, "{m}");
    assert_eq!(
        m["cores"].as_u64(),
        Some(std::thread::available_parallelism().unwrap().get() as u64)
    );
    for key in ["load_average_start", "load_average_end"] {
        let l = m[key].as_array().unwrap_or_else(|| panic!("{key} in {m}"));
        assert_eq!(l.len(), 3);
        assert!(l.iter().all(|x| x.as_f64().unwrap() >= 0.0));
    }
    assert_eq!(v["warmup_excluded"], true);
    assert_eq!(v["settings"]["verify"], true);
    // every way in at both client counts, every percentile row ordered
    let runs = v["runs"].as_array().unwrap();
    let p = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    for kind in ["prediction", "floor", "full"] {
        for clients in [1, 2] {
            let r = runs
                .iter()
                .find(|r| r["kind"] == kind && r["transport"] != "zenoh" && r["clients"] == clients)
                .unwrap_or_else(|| panic!("no {kind} run with {clients} clients in {v}"));
            assert_eq!(r["completed"].as_u64(), Some(400 * clients), "{r}");
            assert_eq!(r["errors"], 0, "{r}");
            let ps = ["p50_us", "p90_us", "p99_us", "p999_us", "max_us"].map(|k| p(r, k));
            assert!(ps[0] > 0.0, "{r}");
            assert!(ps.windows(2).all(|w| w[0] <= w[1]), "{kind}: {ps:?}");
            if kind == "full" {
                assert_eq!(r["mismatches"], 0, "{r}");
            }
        }
    }
    // the bare transport is no slower than the same round trip with cliffd's work in it
    let median = |kind: &str| {
        runs.iter()
            .find(|r| r["kind"] == kind && r["transport"] == "iceoryx2" && r["clients"] == 1)
            .map(|r| p(r, "p50_us"))
            .unwrap()
    };
    assert!(
        median("floor") <= median("full"),
        "floor {} us, full {} us",
        median("floor"),
        median("full")
    );
    let b = &v["breakdown"][0];
    assert_eq!(b["transport"], "iceoryx2");
    assert_eq!(b["floor_p50_us"].as_f64(), Some(median("floor")));
    // the Markdown table has a row per run and says how it was measured
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    for s in [
        "iceoryx2 floor (echo)",
        "iceoryx2 via cliffd",
        "in-process",
        "not counted",
        "nearest rank",
        "cliffd adds",
        "latency-cdf.png",
    ] {
        assert!(md.contains(s), "'{s}' missing from:\n{md}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// With `--zenoh`, `--compare` measures zenoh beside iceoryx2: the bare queryable (the
/// zenoh floor) and the round trip through cliffd, every response of it verified.
#[cfg(feature = "zenoh")]
#[test]
fn bench_compare_over_zenoh_adds_the_zenoh_floor_and_cliffd_over_zenoh() {
    let ns = Namespace::new("benchcmpz");
    let endpoint = "tcp/127.0.0.1:27495";
    let _daemon = Daemon::start(&ns, &["--zenoh", endpoint]);
    let dir = std::env::temp_dir().join(format!("cliff-bench-compare-z-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = bench(
        &ns,
        &[
            "--compare",
            "--zenoh",
            endpoint,
            "--clients",
            "1",
            "--requests",
            "200",
            "--warmup",
            "20",
            "--wait",
            "block",
            "--out",
            dir.to_str().unwrap(),
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    let runs = v["runs"].as_array().unwrap();
    for (kind, transport) in [
        ("prediction", None),
        ("floor", Some("iceoryx2")),
        ("full", Some("iceoryx2")),
        ("floor", Some("zenoh")),
        ("full", Some("zenoh")),
    ] {
        let r = runs
            .iter()
            .find(|r| r["kind"] == kind && transport.is_none_or(|t| r["transport"] == t))
            .unwrap_or_else(|| panic!("no {kind} run over {transport:?} in {v}"));
        assert_eq!(r["completed"].as_u64(), Some(200), "{r}");
        assert_eq!(r["errors"], 0, "{r}");
        let ps = ["p50_us", "p90_us", "p99_us", "p999_us", "max_us"]
            .map(|k| r[k].as_f64().unwrap_or(f64::NAN));
        assert!(ps[0] > 0.0 && ps.windows(2).all(|w| w[0] <= w[1]), "{r}");
        if kind == "full" {
            assert_eq!(r["mismatches"], 0, "{r}");
        }
    }
    let breakdown = v["breakdown"].as_array().unwrap();
    assert!(breakdown.iter().any(|b| b["transport"] == "zenoh"), "{v}");
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    for s in ["zenoh floor (echo)", "zenoh via cliffd"] {
        assert!(md.contains(s), "{s} in\n{md}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
