//! cliffd as a real process: answers match the in-process predictor.

mod common;

use cliff::map::CliffMap;
use cliff::predict::Method;
use cliff_client::WaitMode;
use common::*;

#[test]
fn daemon_answers_like_the_in_process_predictor() {
    let ns = Namespace::new("basic");
    let daemon = Daemon::start(&ns, &[]);
    assert!(daemon.ready_line.contains("demo"), "{}", daemon.ready_line);
    let map = CliffMap::demo();
    for wait in [WaitMode::Spin, WaitMode::Hybrid, WaitMode::Block] {
        let mut client = ns.connect(wait);
        for i in 0..20 {
            let method = if i % 5 == 4 { Method::Cvm } else { Method::Cliff };
            let req = demo_request(i, 1 + (i as usize % 3), 20, method);
            let (shape, want) = local_bits(&map, &req);
            let p = client.predict(&req).unwrap_or_else(|e| panic!("{wait} request {i}: {e}"));
            assert_eq!(p.shape(), shape);
            assert_eq!(bits(p.positions(), p.lens()), want, "{wait} request {i}");
            // the iterators see the same data
            let n: usize = p.agents().map(|a| a.samples().map(|s| s.len()).sum::<usize>()).sum();
            assert_eq!(n, p.lens().iter().map(|&l| l as usize).sum::<usize>());
        }
    }
}
