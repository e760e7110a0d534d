//! Several client processes against one cliffd; one of them killed with SIGKILL.

mod common;

use std::time::Duration;

use cliff::map::CliffMap;
use cliff::predict::Method;
use cliff_client::WaitMode;
use common::*;

#[test]
#[ignore = "helper: the client process the other tests spawn (does nothing on its own)"]
fn child_client() {
    run_child_client();
}

#[test]
fn concurrent_client_processes_each_get_their_own_answers() {
    let ns = Namespace::new("conc");
    // two workers: requests arriving together are predicted in parallel
    let _daemon = Daemon::start(&ns, &["--workers", "2"]);
    let waits = ["spin", "hybrid", "block", "hybrid"];
    let mut children: Vec<ChildClient> = waits
        .iter()
        .enumerate()
        .map(|(i, w)| {
            ChildClient::spawn(
                "child_client",
                &format!("{},150,{},{w},c{i}", ns.prefix, 1 + i % 3),
            )
        })
        .collect();
    for (i, c) in children.iter_mut().enumerate() {
        c.wait_line(&format!("CHILD c{i} done 150"), Duration::from_secs(90));
        assert!(c.wait_exit(Duration::from_secs(10)).success(), "child c{i}");
    }
}

#[test]
fn a_client_killed_mid_traffic_does_not_disturb_the_others() {
    let ns = Namespace::new("kill");
    // room for exactly three clients: the victim's slot must be freed for the last step
    let mut daemon = Daemon::start(&ns, &["--max-clients", "3", "--cleanup-interval-ms", "200"]);
    let mut victim = ChildClient::spawn(
        "child_client",
        &format!("{},1000000,2,spin,victim", ns.prefix),
    );
    victim.wait_line("CHILD victim started", Duration::from_secs(30));
    let mut others: Vec<ChildClient> = (0..2)
        .map(|i| ChildClient::spawn("child_client", &format!("{},300,2,hybrid,o{i}", ns.prefix)))
        .collect();
    others[0].wait_line("CHILD o0 started", Duration::from_secs(30));
    std::thread::sleep(Duration::from_millis(100));
    victim.kill9();
    for (i, c) in others.iter_mut().enumerate() {
        c.wait_line(&format!("CHILD o{i} done 300"), Duration::from_secs(90));
        assert!(c.wait_exit(Duration::from_secs(10)).success(), "child o{i}");
    }
    assert!(daemon.child.try_wait().unwrap().is_none(), "cliffd died");
    // the killed client's resources are cleaned up: three clients fit again at once
    std::thread::sleep(Duration::from_millis(600));
    let map = CliffMap::demo();
    let mut clients: Vec<_> = (0..3).map(|_| ns.connect(WaitMode::Block)).collect();
    for (i, c) in clients.iter_mut().enumerate() {
        let req = demo_request(5 + i as u64, 2, 20, Method::Cliff);
        let p = c.predict(&req).expect("served after a client was killed");
        assert_eq!(bits(p.positions(), p.lens()), local_bits(&map, &req).1);
    }
    let _ = &mut daemon;
}
