//! `--compare`: every way in at every client count, with the same requests and seeds,
//! back to back ([`run`]); the report is written by `report.rs`.

use std::process::ExitCode;
use std::sync::Arc;

use cliff::map::CliffMap;
use cliff_client::{LocalPredictor, Request};

use crate::args::Args;
use crate::floor::{FloorServer, Shape};
use crate::machine::{CoreBudget, Machine};
use crate::report::{Measured, Report, write_report};
use crate::runs::{Way, run_way};

/// The shape of cliffd's response to `r` (what the floor must send): predicted here once.
fn response_shape(map: &CliffMap, r: &Request) -> Result<Shape, String> {
    let mut local = LocalPredictor::default();
    let b = local
        .predict(map, r.header(), r.rows())
        .map_err(|e| format!("in-process prediction refused the request: {e}"))?;
    let (agents, k, steps) = b.shape();
    Ok(Shape {
        agents,
        k,
        steps,
        scores: !b.scores().is_empty(),
    })
}

/// Run the comparison and write its report.
pub(crate) fn run(
    a: Arc<Args>,
    map: Arc<CliffMap>,
    pool: Arc<Vec<Request>>,
) -> Result<ExitCode, String> {
    let mut machine = Machine::now();
    let counts = a.client_counts();
    let shape = response_shape(&map, &pool[0])?;
    let daemon = a.daemon_target();
    let zenoh = daemon.transport() == "zenoh";
    let floor = FloorServer::start(&a, shape, zenoh)?;
    // iceoryx2 always; zenoh when the daemon is reached over zenoh (then its iceoryx2
    // side is the same daemon under --service, on this host)
    #[cfg_attr(not(feature = "zenoh"), allow(unused_mut))]
    let mut ways = vec![
        Way::InProcess,
        Way::Floor(floor.ipc.clone()),
        Way::Daemon(crate::args::Target::Ipc {
            service: a.service.clone(),
        }),
    ];
    #[cfg(feature = "zenoh")]
    if let Some(z) = &floor.zenoh {
        ways.push(Way::Floor(z.clone()));
        ways.push(Way::Daemon(daemon.clone()));
    }
    let positions = a.agents * a.k * a.steps;
    let workers = a.daemon_workers.unwrap_or(machine.cores);
    let mut measured = Vec::new();
    for &clients in &counts {
        for way in &ways {
            let budget = CoreBudget::of(
                machine.cores,
                clients,
                a.wait,
                positions,
                workers,
                !matches!(way, Way::InProcess),
            );
            // zenoh clients block on their reply: they never spin
            let budget = if way.transport() == "zenoh" {
                CoreBudget {
                    spinning: 0,
                    ..budget
                }
            } else {
                budget
            };
            if let Some(w) = budget.warning(a.wait) {
                eprintln!("{} with {clients} client(s): {w}", way.name());
            }
            eprintln!(
                "cliff-bench --compare: {} with {clients} client(s)",
                way.name()
            );
            let run = run_way(&a, way, clients, &pool, &map);
            measured.push(Measured {
                way: way.clone(),
                clients,
                budget,
                run,
            });
        }
    }
    drop(floor);
    machine.finish();
    let report = Report {
        args: &a,
        machine: &machine,
        shape,
        measured: &measured,
        // the command as typed, without the directory of the executable
        command: std::iter::once("cliff-bench".to_string())
            .chain(std::env::args().skip(1))
            .collect::<Vec<_>>()
            .join(" "),
    };
    let table = write_report(&report, &a.out)?;
    println!("{table}");
    println!("report written to {}", a.out.display());
    let failed = measured
        .iter()
        .any(|m| !m.run.errors.is_empty() || m.run.mismatches.unwrap_or(0) > 0);
    for m in measured.iter().filter(|m| !m.run.errors.is_empty()) {
        eprintln!(
            "{} with {} client(s): {} request(s) failed; first: {}",
            m.way.name(),
            m.clients,
            m.run.failures.max(m.run.errors.len()),
            m.run.errors[0]
        );
    }
    Ok(if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
