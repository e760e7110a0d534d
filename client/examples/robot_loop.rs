//! A robot's perception loop: track a few people and ask cliffd for their future
//! trajectories at 10 Hz.
//!
//! Start the daemon with the built-in scene, then the loop:
//!
//! ```text
//! cargo run --release -p cliff-service --bin cliffd &
//! cargo run --release -p cliff-client --example robot_loop -- --seconds 5
//! ```
//!
//! Each cycle the (simulated) tracker adds one observation per person; the loop sends
//! the last 8 observations of every person in one request and reads, per person, where
//! the k samples put them 4 s ahead. The request is reused (no allocation per cycle). A
//! failed cycle (daemon restarting, deadline passed) is reported and the loop goes on:
//! the same client works again once the daemon is back.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use clap::Parser;
use cliff::predict::Params;
use cliff_client::{Client, ClientOptions, Error, Observation, Request, WaitMode};

/// Track three people in the demo hall and predict them at 10 Hz through cliffd.
#[derive(Parser, Debug)]
struct Args {
    /// iceoryx2 service name of the daemon.
    #[arg(long, default_value = cliff_client::DEFAULT_SERVICE)]
    service: String,
    /// How long to run (s).
    #[arg(long, default_value_t = 5.0)]
    seconds: f64,
    /// Loop rate (Hz).
    #[arg(long, default_value_t = 10.0)]
    rate: f64,
}

/// A simulated person: walks at constant velocity, turns at the hall's crossing.
struct Person {
    id: u32,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    history: VecDeque<Observation>,
}

const HISTORY: usize = 8;

impl Person {
    fn step(&mut self, t: f64, dt: f64) {
        self.x += self.vx * dt;
        self.y += self.vy * dt;
        // turn north once at the crossing, wrap around at the hall's ends
        if self.id == 2 && self.x > 0.0 && self.vy == 0.0 {
            (self.vx, self.vy) = (0.0, 1.1);
        }
        if self.x > 14.0 {
            self.x = -14.0;
            self.history.clear();
        }
        if self.y > 9.0 {
            (self.x, self.y, self.vx, self.vy) = (-14.0, 0.5, 1.1, 0.0);
            self.history.clear();
        }
        let speed = self.vx.hypot(self.vy);
        let heading = self.vy.atan2(self.vx);
        if self.history.len() == HISTORY {
            self.history.pop_front();
        }
        self.history.push_back(Observation::with_velocity(
            t, self.x, self.y, speed, heading,
        ));
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let options = ClientOptions {
        wait: WaitMode::Hybrid,
        deadline: Duration::from_millis(50), // half a cycle
        ..ClientOptions::default()
    };
    let mut client = match Client::connect_with(&args.service, options) {
        Ok(c) => c,
        Err(e @ Error::NoDaemon { .. }) => {
            eprintln!("{e}\nstart it first: cargo run --release -p cliff-service --bin cliffd");
            std::process::exit(2);
        }
        Err(e) => return Err(e.into()),
    };
    let mut people = vec![
        Person {
            id: 0,
            x: -12.0,
            y: -1.0,
            vx: 1.3,
            vy: 0.0,
            history: VecDeque::new(),
        },
        Person {
            id: 1,
            x: 10.0,
            y: 1.5,
            vx: -1.2,
            vy: 0.0,
            history: VecDeque::new(),
        },
        Person {
            id: 2,
            x: -6.0,
            y: 0.5,
            vx: 1.1,
            vy: 0.0,
            history: VecDeque::new(),
        },
    ];
    let params = Params {
        k: 20,
        dt: 0.4,
        horizon: 8.0,
        ..Params::default()
    };
    let mut request = Request::new("demo", &params)?;
    let period = Duration::from_secs_f64(1.0 / args.rate);
    let start = Instant::now();
    let mut next = start;
    let mut cycle = 0u64;
    while start.elapsed().as_secs_f64() < args.seconds {
        let t = cycle as f64 * period.as_secs_f64();
        for p in &mut people {
            p.step(t, period.as_secs_f64());
        }
        // one request for everyone tracked long enough
        request.clear_agents();
        request.set_seed(cycle);
        let tracked: Vec<u32> = people
            .iter()
            .filter(|p| p.history.len() >= 2)
            .map(|p| {
                request.add_agent(p.history.iter().copied());
                p.id
            })
            .collect();
        if !tracked.is_empty() {
            let t0 = Instant::now();
            match client.predict(&request) {
                Ok(prediction) => {
                    let rtt = t0.elapsed();
                    let mut line = format!("t={t:5.1}s rtt {:6.1} us |", rtt.as_secs_f64() * 1e6);
                    let ahead = 10; // step 10 = 4 s ahead at dt 0.4
                    for (agent, id) in prediction.agents().zip(&tracked) {
                        let (mut sx, mut sy, mut n) = (0.0f32, 0.0f32, 0);
                        for sample in agent.samples() {
                            if let Some(p) = sample.get(ahead - 1) {
                                sx += p[0];
                                sy += p[1];
                                n += 1;
                            }
                        }
                        if n > 0 {
                            line += &format!(
                                " person {id}: in 4 s at ({:5.1}, {:5.1}) [{n}/{} samples]",
                                sx / n as f32,
                                sy / n as f32,
                                agent.len()
                            );
                        } else {
                            line += &format!(" person {id}: leaves the map within 4 s");
                        }
                    }
                    println!("{line}");
                }
                Err(e) => println!("t={t:5.1}s no prediction this cycle: {e}"),
            }
        }
        cycle += 1;
        next += period;
        if let Some(wait) = next.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
    }
    Ok(())
}
