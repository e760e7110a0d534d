//! Request validation: [`decode_request`] checks a predict request field by field and
//! turns it into prediction parameters and the agents' start states, for the daemon and
//! the in-process reference alike.

use cliff::glam::DVec2;
use cliff::motion::{
    DEFAULT_SIGMA, History, State, velocity_from_positions, velocity_from_speed_angle,
};
use cliff::predict::preset::cost_factor;
use cliff::predict::{HeadingRule, Options, Params};

use super::codes::{
    FLAG_VELOCITY, HEADING_CIRCULAR_MEAN, HEADING_PAPER, KIND_PREDICT, KNOWN_FLAGS, MAX_HISTORY,
    PROTOCOL_VERSION, method_from_code,
};
use super::limits::Limits;
use super::map_time::MapTime;
use super::request::{Observation, RequestHeader};
use super::response::{payload_words, scores_in_response};
use super::status::{Field, Rejection, Status};

/// Reusable buffers for [`decode_request`]: sized once, then no allocation per request.
#[derive(Debug, Clone)]
pub struct DecodeScratch {
    times: Vec<f64>,
    positions: Vec<DVec2>,
    speeds: Vec<f64>,
    headings: Vec<f64>,
    states: Vec<State>,
    histories: Vec<History>,
}

impl DecodeScratch {
    /// Buffers for requests within `limits`.
    pub fn new(limits: &Limits) -> Self {
        let h = limits.max_history.min(MAX_HISTORY) as usize;
        DecodeScratch {
            times: Vec::with_capacity(h),
            positions: Vec::with_capacity(h),
            speeds: Vec::with_capacity(h),
            headings: Vec::with_capacity(h),
            states: Vec::with_capacity(limits.max_agents as usize),
            histories: Vec::with_capacity(limits.max_agents as usize),
        }
    }

    /// The agents' start states decoded by the last successful [`decode_request`].
    pub fn states(&self) -> &[State] {
        &self.states
    }

    /// The agents' observed paths on the motion model's grid, one per state (what the
    /// methods `motion` and `cvm-last` read).
    pub fn histories(&self) -> &[History] {
        &self.histories
    }
}

fn finite(v: f64) -> bool {
    v.is_finite()
}

/// A validated predict request: what [`decode_request`] returns (the agents' start
/// states are in the [`DecodeScratch`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decoded {
    /// The prediction parameters, as asked (a preset method such as `Improved` is
    /// resolved by the predictor).
    pub params: Params,
    /// The options beyond the paper, as asked (all off for a request that asks for none), except
    /// `scores`: whether the response carries scores, i.e. the request set
    /// [`FLAG_SCORES`](super::FLAG_SCORES) or its method's preset scores its samples (`Improved`).
    pub options: Options,
    /// Which map of the time of day the request asks for.
    pub map_time: MapTime,
}

impl Decoded {
    /// The payload words of the response to this request for `agents` agents.
    pub fn payload_words(&self, agents: usize) -> usize {
        payload_words(
            agents,
            self.params.k,
            self.params.steps(),
            self.options.scores,
        )
    }
}

/// Validate a predict request and decode its parameters; the agents' start states are
/// left in `scratch` ([`DecodeScratch::states`]). Checks, in order: version, kind,
/// method and heading rule, flags and time mode, parameters and options (finite, then
/// in range), `k`, steps, agents (and the cost of a method dearer than CLiFF-LHMP),
/// then every row. The map name is checked by the caller (who holds the maps).
///
/// Each agent starts at its last row's position and time; its speed and heading come
/// from the speed/heading columns when its rows carry them, else from the positions
/// ([`cliff::motion`], sigma [`DEFAULT_SIGMA`]).
pub fn decode_request(
    h: &RequestHeader,
    rows: &[Observation],
    limits: &Limits,
    scratch: &mut DecodeScratch,
) -> Result<Decoded, Rejection> {
    use Status::*;
    scratch.states.clear();
    scratch.histories.clear();
    if h.version != PROTOCOL_VERSION {
        return Err(Rejection::over(
            BadVersion,
            Field::Version,
            PROTOCOL_VERSION,
        ));
    }
    if h.kind != KIND_PREDICT {
        return Err(Rejection::new(UnknownKind, Field::None));
    }
    let Some(method) = method_from_code(h.method) else {
        return Err(Rejection::new(UnknownMethod, Field::Method));
    };
    let heading = match h.heading_rule {
        HEADING_CIRCULAR_MEAN => HeadingRule::CircularMean,
        HEADING_PAPER => HeadingRule::Paper,
        _ => return Err(Rejection::new(UnknownMethod, Field::HeadingRule)),
    };
    if h.flags & !KNOWN_FLAGS != 0 {
        return Err(Rejection::new(BadValue, Field::Flags));
    }
    let map_time = MapTime::from_wire(h.time_mode, h.time)?;
    for (v, f) in [
        (h.dt, Field::Dt),
        (h.horizon, Field::Horizon),
        (h.beta, Field::Beta),
        (h.radius, Field::Radius),
        (h.speed_beta, Field::SpeedBeta),
        (h.coast, Field::Coast),
    ] {
        if !finite(v) {
            return Err(Rejection::new(NonFinite, f));
        }
    }
    if h.dt <= 0.0 {
        return Err(Rejection::new(BadValue, Field::Dt));
    }
    if h.horizon < 0.0 {
        return Err(Rejection::new(BadValue, Field::Horizon));
    }
    if h.beta < 0.0 {
        return Err(Rejection::new(BadValue, Field::Beta));
    }
    if h.radius <= 0.0 {
        return Err(Rejection::new(BadValue, Field::Radius));
    }
    if h.speed_beta < 0.0 {
        return Err(Rejection::new(BadValue, Field::SpeedBeta));
    }
    if h.coast < 0.0 || h.coast > h.horizon {
        return Err(Rejection::new(BadValue, Field::Coast));
    }
    if h.k == 0 || h.k > limits.max_k {
        return Err(Rejection::over(BadK, Field::K, limits.max_k));
    }
    let ratio = h.horizon / h.dt;
    let steps = if ratio.is_finite() && ratio < (limits.max_steps as f64 + 2.0) {
        cliff::predict::steps_for(h.horizon, h.dt)
    } else {
        usize::MAX
    };
    if steps == 0 || steps > limits.max_steps as usize {
        return Err(Rejection::over(BadSteps, Field::Steps, limits.max_steps));
    }
    if h.agents == 0 || h.agents > limits.max_agents {
        return Err(Rejection::over(BadAgents, Field::Agents, limits.max_agents));
    }
    let params = Params {
        method,
        k: h.k as usize,
        dt: h.dt,
        horizon: h.horizon,
        beta: h.beta,
        radius: h.radius,
        seed: h.seed,
        heading,
    };
    let mut options = h.options();
    let factor = cost_factor(&params, &options) as u64;
    if factor > 1 {
        // the most agents of this k and steps within the cost of the largest request
        let per_agent = h.k as u64 * steps as u64 * factor;
        let most = (limits.max_cost() / per_agent).min(limits.max_agents as u64) as u32;
        if h.agents > most {
            return Err(Rejection::over(BadAgents, Field::Agents, most));
        }
    }
    let max_history = limits.max_history.min(MAX_HISTORY) as usize;

    let mut start = 0usize;
    for a in 0..h.agents {
        // the run of rows of agent `a`
        if rows.get(start).map(|o| o.agent) != Some(a) {
            return Err(Rejection {
                agent: Some(a),
                ..Rejection::new(BadLayout, Field::Agents)
            });
        }
        let mut end = start;
        while end < rows.len() && rows[end].agent == a {
            end += 1;
        }
        let run = &rows[start..end];
        if run.len() > max_history {
            return Err(Rejection {
                agent: Some(a),
                ..Rejection::over(HistoryTooLong, Field::None, max_history as u32)
            });
        }
        let (state, history) = agent_state(a, run, scratch_bufs(scratch))?;
        scratch.states.push(state);
        scratch.histories.push(history);
        start = end;
    }
    if let Some(extra) = rows.get(start) {
        // rows after the last agent, or an agent index out of order
        return Err(Rejection {
            agent: Some(extra.agent),
            ..Rejection::new(BadLayout, Field::Agents)
        });
    }
    options.scores = scores_in_response(&params, &options);
    Result::Ok(Decoded {
        params,
        options,
        map_time,
    })
}

type Bufs<'a> = (
    &'a mut Vec<f64>,
    &'a mut Vec<DVec2>,
    &'a mut Vec<f64>,
    &'a mut Vec<f64>,
);

fn scratch_bufs(s: &mut DecodeScratch) -> Bufs<'_> {
    (
        &mut s.times,
        &mut s.positions,
        &mut s.speeds,
        &mut s.headings,
    )
}

/// The start state of agent `a` from its rows (already grouped, at most MAX_HISTORY),
/// and its observed path on the motion model's grid.
fn agent_state(a: u32, run: &[Observation], bufs: Bufs<'_>) -> Result<(State, History), Rejection> {
    use Status::*;
    let (times, positions, speeds, headings) = bufs;
    let with_velocity = run[0].flags & FLAG_VELOCITY != 0;
    let need = if with_velocity { 1 } else { 2 };
    if run.len() < need {
        return Err(Rejection {
            agent: Some(a),
            ..Rejection::over(HistoryTooShort, Field::None, need as u32)
        });
    }
    times.clear();
    positions.clear();
    speeds.clear();
    headings.clear();
    for (i, o) in run.iter().enumerate() {
        let row = i as u32;
        if (o.flags & FLAG_VELOCITY != 0) != with_velocity {
            return Err(Rejection::at(BadLayout, Field::Speed, a, row));
        }
        if !finite(o.t) {
            return Err(Rejection::at(NonFinite, Field::Time, a, row));
        }
        if !(finite(o.x) && finite(o.y)) {
            return Err(Rejection::at(NonFinite, Field::Position, a, row));
        }
        if with_velocity {
            if !finite(o.speed) {
                return Err(Rejection::at(NonFinite, Field::Speed, a, row));
            }
            if !finite(o.heading) {
                return Err(Rejection::at(NonFinite, Field::Heading, a, row));
            }
            if o.speed < 0.0 {
                return Err(Rejection::at(BadValue, Field::Speed, a, row));
            }
            speeds.push(o.speed);
            headings.push(o.heading);
        }
        if i > 0 && o.t <= run[i - 1].t {
            return Err(Rejection::at(HistoryNotIncreasing, Field::Time, a, row));
        }
        times.push(o.t);
        positions.push(DVec2::new(o.x, o.y));
    }
    let v = if with_velocity {
        velocity_from_speed_angle(speeds, headings, DEFAULT_SIGMA)
    } else {
        velocity_from_positions(times, positions, DEFAULT_SIGMA)
    };
    // Everything the velocity functions check was checked above; a failure here would
    // be a disagreement between the two, reported rather than unwrapped.
    let v = v.map_err(|_| Rejection::at(BadLayout, Field::None, a, u32::MAX))?;
    if !(v.speed.is_finite() && v.heading.is_finite()) {
        // e.g. positions so far apart in so little time that the speed overflows
        return Err(Rejection::at(NonFinite, Field::Speed, a, u32::MAX));
    }
    let last = run[run.len() - 1];
    let state = State {
        position: DVec2::new(last.x, last.y),
        speed: v.speed,
        heading: v.heading,
        time: last.t,
    };
    // (the rows were checked above as the history needs them)
    let history = History::from_points(times, positions)
        .map_err(|_| Rejection::at(BadLayout, Field::None, a, u32::MAX))?;
    Result::Ok((state, history))
}

#[cfg(test)]
mod tests {
    use cliff::map::CliffMap;
    use cliff::predict::Method;

    use super::*;
    use crate::protocol::codes::{FLAG_SCORES, TIME_AT, method_code};
    use crate::protocol::request::fixtures::{header, walk};

    fn reject(h: &RequestHeader, rows: &[Observation]) -> Rejection {
        let mut s = DecodeScratch::new(&Limits::default());
        decode_request(h, rows, &Limits::default(), &mut s).unwrap_err()
    }

    #[test]
    fn a_good_request_decodes_to_the_last_position_and_observed_velocity() {
        let mut rows = walk(0, 4);
        rows.extend(walk(1, 3));
        rows.push(Observation {
            agent: 2,
            ..Observation::with_velocity(1.0, 2.0, 3.0, 1.5, std::f64::consts::FRAC_PI_2)
        });
        let mut s = DecodeScratch::new(&Limits::default());
        let d = decode_request(&header(3), &rows, &Limits::default(), &mut s).unwrap();
        let p = d.params;
        assert_eq!((p.k, p.steps()), (20, 30));
        assert_eq!((d.options, d.map_time), (Options::default(), MapTime::Now));
        let st = s.states();
        assert_eq!(st.len(), 3);
        // 0.5 m per 0.4 s eastwards
        assert!((st[0].speed - 1.25).abs() < 1e-12 && st[0].heading.abs() < 1e-12);
        assert_eq!(st[0].position, DVec2::new(-8.5, 0.5));
        assert!((st[0].time - 1.2).abs() < 1e-12);
        assert_eq!(st[1].position, DVec2::new(-9.0, 0.5));
        assert!((st[2].speed - 1.5).abs() < 1e-12);
        assert!((st[2].heading - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // every method's code decodes to the method
        for method in Method::ALL {
            let mut h = RequestHeader::from_params(&Params {
                method,
                ..Params::default()
            });
            h.agents = 3;
            let p = decode_request(&h, &rows, &Limits::default(), &mut s).unwrap();
            assert_eq!(p.params.method, method);
            assert_eq!(method_from_code(method_code(method)), Some(method));
        }
        assert_eq!(method_from_code(5), None);
        // each agent's observed path ends at its state's position
        assert_eq!(s.histories().len(), 3);
        for (st, h) in s.states().iter().zip(s.histories()) {
            assert_eq!(h.last(), st.position);
        }
    }

    #[test]
    fn every_kind_of_bad_request_gets_its_status() {
        let rows = walk(0, 3);
        let bad = |f: &dyn Fn(&mut RequestHeader)| {
            let mut h = header(1);
            f(&mut h);
            reject(&h, &rows)
        };
        let r = bad(&|h| h.version = 1);
        assert_eq!(
            (r.status, r.field, r.limit),
            (Status::BadVersion, Field::Version, PROTOCOL_VERSION)
        );
        assert_eq!(
            r.to_string(),
            "bad-version (version): the daemon speaks protocol version 2"
        );
        assert_eq!(bad(&|h| h.version = 99).status, Status::BadVersion);
        assert_eq!(bad(&|h| h.kind = 7).status, Status::UnknownKind);
        assert_eq!(bad(&|h| h.method = 5).status, Status::UnknownMethod);
        let r = bad(&|h| h.dt = f64::NAN);
        assert_eq!((r.status, r.field), (Status::NonFinite, Field::Dt));
        let r = bad(&|h| h.radius = f64::INFINITY);
        assert_eq!((r.status, r.field), (Status::NonFinite, Field::Radius));
        assert_eq!(bad(&|h| h.dt = -0.1).status, Status::BadValue);
        assert_eq!(bad(&|h| h.k = 0).status, Status::BadK);
        let r = bad(&|h| h.k = 51);
        assert_eq!((r.status, r.limit), (Status::BadK, 50));
        assert_eq!(bad(&|h| h.horizon = 0.1).status, Status::BadSteps);
        assert_eq!(bad(&|h| h.horizon = 1e300).status, Status::BadSteps);
        assert_eq!(bad(&|h| h.dt = 1e-300).status, Status::BadSteps);
        assert_eq!(bad(&|h| h.agents = 0).status, Status::BadAgents);
        assert_eq!(bad(&|h| h.agents = 33).status, Status::BadAgents);
        // the fields of version 2, each named
        let named = |f: &dyn Fn(&mut RequestHeader)| {
            let r = bad(f);
            (r.status, r.field)
        };
        use Status::{BadValue, NonFinite};
        assert_eq!(
            named(&|h| h.speed_beta = f64::NAN),
            (NonFinite, Field::SpeedBeta)
        );
        assert_eq!(
            named(&|h| h.speed_beta = -0.5),
            (BadValue, Field::SpeedBeta)
        );
        assert_eq!(
            named(&|h| h.coast = f64::INFINITY),
            (NonFinite, Field::Coast)
        );
        assert_eq!(named(&|h| h.coast = -1.0), (BadValue, Field::Coast));
        // coast at most the horizon (12 s)
        assert_eq!(named(&|h| h.coast = 12.5), (BadValue, Field::Coast));
        assert_eq!(named(&|h| h.flags = 4), (BadValue, Field::Flags));
        assert_eq!(named(&|h| h.flags = 1 << 31), (BadValue, Field::Flags));
        assert_eq!(named(&|h| h.time_mode = 3), (BadValue, Field::TimeMode));
        assert_eq!(named(&|h| h.time = f64::NAN), (NonFinite, Field::MapTime));
        let r = bad(&|h| {
            h.time_mode = TIME_AT;
            h.time = f64::NEG_INFINITY
        });
        assert_eq!((r.status, r.field), (NonFinite, Field::MapTime));
        assert_eq!(r.to_string(), "non-finite (map time)");
        // and the good values of every new field decode
        let mut h = header(1);
        h.speed_beta = 2.0;
        h.coast = 12.0;
        h.flags = FLAG_SCORES;
        h.set_map_time(MapTime::At(1.35e9));
        let mut s = DecodeScratch::new(&Limits::default());
        let d = decode_request(&h, &rows, &Limits::default(), &mut s).unwrap();
        let want = Options {
            speed_beta: 2.0,
            coast: 12.0,
            scores: true,
            ..Options::default()
        };
        assert_eq!((d.options, d.map_time), (want, MapTime::At(1.35e9)));
        h.set_map_time(MapTime::AllDay);
        let d = decode_request(&h, &rows, &Limits::default(), &mut s).unwrap();
        assert_eq!(d.map_time, MapTime::AllDay);
        assert_eq!(d.payload_words(1), payload_words(1, 20, 30, true));
        // rows
        let h = header(1);
        let r = reject(&h, &walk(0, 1));
        assert_eq!((r.status, r.agent), (Status::HistoryTooShort, Some(0)));
        let mut rows = walk(0, 3);
        rows[2].t = rows[1].t;
        let r = reject(&h, &rows);
        assert_eq!(
            (r.status, r.agent, r.row),
            (Status::HistoryNotIncreasing, Some(0), Some(2))
        );
        let mut rows = walk(0, 3);
        rows[1].y = f64::NAN;
        let r = reject(&h, &rows);
        assert_eq!(
            (r.status, r.field, r.row),
            (Status::NonFinite, Field::Position, Some(1))
        );
        let r = reject(&h, &walk(0, 65));
        assert_eq!((r.status, r.limit), (Status::HistoryTooLong, 64));
        // layout: two agents announced, one given; agent 1 before agent 0; extra rows
        assert_eq!(reject(&header(2), &walk(0, 3)).status, Status::BadLayout);
        assert_eq!(reject(&h, &walk(1, 3)).status, Status::BadLayout);
        let mut rows = walk(0, 3);
        rows.extend(walk(1, 2));
        assert_eq!(reject(&h, &rows).status, Status::BadLayout);
        // mixed velocity flags within one agent
        let mut rows = walk(0, 3);
        rows[1].flags = FLAG_VELOCITY;
        assert_eq!(reject(&h, &rows).status, Status::BadLayout);
        // negative tracker speed
        let rows = [Observation::with_velocity(0.0, 0.0, 0.0, -1.0, 0.0)];
        let r = reject(&h, &rows);
        assert_eq!((r.status, r.field), (Status::BadValue, Field::Speed));
    }

    #[test]
    fn a_method_that_costs_more_may_hold_fewer_agents() {
        // k 50, 100 steps: the largest request of the default limits
        let improved = Params {
            method: Method::Improved,
            k: 50,
            horizon: 40.0,
            ..Params::default()
        };
        let factor = cost_factor(&improved, &Options::default());
        assert!(factor > 1, "the improved preset draws candidates");
        let most = (32 * 50 * 100 / (50 * 100 * factor)) as u32;
        let rows = |n: u32| (0..n).flat_map(|a| walk(a, 2)).collect::<Vec<_>>();
        let mut s = DecodeScratch::new(&Limits::default());
        let mut h = RequestHeader::from_params(&improved);
        h.set_map_name("demo").unwrap();
        h.agents = most + 1;
        let r = decode_request(&h, &rows(most + 1), &Limits::default(), &mut s).unwrap_err();
        assert_eq!(
            (r.status, r.field, r.limit),
            (Status::BadAgents, Field::Agents, most)
        );
        h.agents = most;
        assert!(decode_request(&h, &rows(most), &Limits::default(), &mut s).is_ok());
        // the paper's method: up to the limit on agents
        let mut h = RequestHeader::from_params(&Params {
            method: Method::Cliff,
            ..improved
        });
        h.agents = 32;
        assert!(decode_request(&h, &rows(32), &Limits::default(), &mut s).is_ok());
    }

    /// Random bit patterns and random near-valid requests: decoding never panics, and
    /// whatever it accepts predicts without error into a buffer of the announced shape.
    #[test]
    fn random_requests_never_panic_and_accepted_ones_predict() {
        use rand::{RngExt, SeedableRng};
        let map = CliffMap::demo();
        let limits = Limits {
            max_agents: 4,
            max_k: 5,
            max_steps: 12,
            max_history: 8,
        };
        let mut s = DecodeScratch::new(&limits);
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(17);
        let mut accepted = 0;
        let mut with_options = 0;
        let specials = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.4,
            1e-300,
            1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            f64::MAX,
        ];
        for _ in 0..20_000 {
            // mostly plausible values, sometimes special or random bit patterns
            let num = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus, near: f64| -> f64 {
                match rng.random_range(0..40) {
                    0 => specials[rng.random_range(0..specials.len())],
                    1 => f64::from_bits(rng.random()),
                    _ => near * rng.random_range(0.5..1.5),
                }
            };
            let agents = rng.random_range(0..6u32);
            let mut h = header(if rng.random_ratio(1, 20) {
                rng.random_range(0..8)
            } else {
                agents
            });
            h.version = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                PROTOCOL_VERSION
            };
            h.kind = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                KIND_PREDICT
            };
            h.method = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                rng.random_range(0..3)
            };
            h.heading_rule = if rng.random_ratio(1, 40) {
                7
            } else {
                rng.random_range(0..2)
            };
            h.k = rng.random_range(0..7);
            h.dt = num(&mut rng, 0.4);
            h.horizon = num(&mut rng, 3.0);
            h.beta = num(&mut rng, 1.0);
            h.radius = num(&mut rng, 0.7);
            h.seed = rng.random();
            if rng.random_ratio(1, 2) {
                h.speed_beta = num(&mut rng, 2.0);
            }
            if rng.random_ratio(1, 2) {
                h.coast = num(&mut rng, 1.5);
            }
            h.flags = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                rng.random_range(0..2)
            };
            h.time_mode = if rng.random_ratio(1, 40) {
                rng.random()
            } else {
                rng.random_range(0..3)
            };
            h.time = num(&mut rng, 1.3e9);
            let mut rows = Vec::new();
            for a in 0..agents {
                let flags = rng.random_range(0..2);
                let mut t = num(&mut rng, 10.0);
                for _ in 0..rng.random_range(1..10) {
                    t += num(&mut rng, 0.4);
                    rows.push(Observation {
                        agent: if rng.random_ratio(1, 100) {
                            rng.random()
                        } else {
                            a
                        },
                        flags: if rng.random_ratio(1, 100) {
                            1 - flags
                        } else {
                            flags
                        },
                        t,
                        x: num(&mut rng, -5.0),
                        y: num(&mut rng, 1.0),
                        speed: num(&mut rng, 1.2),
                        heading: num(&mut rng, 3.0),
                    });
                }
            }
            if let Result::Ok(d) = decode_request(&h, &rows, &limits, &mut s) {
                accepted += 1;
                let (p, o) = (d.params, d.options);
                if !o.is_paper() {
                    with_options += 1;
                }
                let st = s.states();
                assert!(st.len() <= 4 && p.k <= 5 && p.steps() <= 12 && p.steps() > 0);
                assert!(o.coast <= p.horizon);
                let mut pos = vec![[0f32; 2]; st.len() * p.k * p.steps()];
                let mut lens = vec![0u32; st.len() * p.k];
                let mut scores = vec![0f32; if o.scores { st.len() * p.k } else { 0 }];
                let out = cliff::predict::BatchMut {
                    positions: &mut pos,
                    lens: &mut lens,
                };
                cliff::predict::predict_into_with(&map, st, &p, &o, out, &mut scores)
                    .expect("accepted requests predict");
            }
        }
        assert!(accepted > 100, "only {accepted} random requests were valid");
        assert!(with_options > 50, "only {with_options} with options");
    }
}
