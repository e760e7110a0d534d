//! The prediction [`Request`] a client builds: map, parameters, options and the agents'
//! observed histories.

use cliff::predict::{Method, Options, Params};

use crate::error::Error;
use crate::protocol::{self, MapTime, Observation, RequestHeader};

/// A prediction request: map, parameters and the agents' observed histories. Reuse it
/// between calls ([`clear_agents`](Self::clear_agents) keeps the allocation).
///
/// Beyond [`Params`], a request may ask for another method, the options beyond the
/// paper, a score per sample and a map of the time of day:
///
/// ```
/// use cliff::predict::Params;
/// use cliff_client::{MapTime, Request};
///
/// let r = Request::new("atc", &Params::default())?
///     .speed_beta(2.0) // the speed follows the map's
///     .coast(6.0) // 6 s at constant velocity where the map has no data
///     .scores(true) // a score per sample: Prediction::scores, best_sample
///     .time(1_351_700_000.0); // the map of that time of day (default: the daemon's clock)
/// let o = r.options();
/// assert_eq!((o.speed_beta, o.coast, o.scores), (2.0, 6.0, true));
/// assert_eq!(r.map_time(), MapTime::At(1_351_700_000.0));
/// # Ok::<(), cliff_client::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    header: RequestHeader,
    rows: Vec<Observation>,
}

impl Request {
    /// A request against the map `map` with `params` and no agents yet. On a learning
    /// daemon (`cliffd --learn`) `map` may name a version: `NAME@VERSION`, `NAME@0` the
    /// map as loaded (as [`base_map`](Self::base_map)); every response says which version
    /// answered ([`Prediction::map_version`](crate::Prediction::map_version)).
    pub fn new(map: &str, params: &Params) -> Result<Self, Error> {
        let mut header = RequestHeader::from_params(params);
        header.set_map_name(map).map_err(Error::InvalidRequest)?;
        Ok(Request {
            header,
            rows: Vec::new(),
        })
    }

    /// Replace the parameters (keeps map, agents, options and map time).
    pub fn set_params(&mut self, params: &Params) {
        let keep = self.header;
        self.header = RequestHeader {
            map: keep.map,
            agents: keep.agents,
            speed_beta: keep.speed_beta,
            coast: keep.coast,
            flags: keep.flags,
            time_mode: keep.time_mode,
            time: keep.time,
            ..RequestHeader::from_params(params)
        };
    }

    /// With the method `method` (the parameters' method otherwise).
    pub fn method(mut self, method: Method) -> Self {
        self.header.method = protocol::method_code(method);
        self
    }

    /// With the speed kernel parameter ([`Options::speed_beta`]; 0, the default, keeps
    /// the observed speed).
    pub fn speed_beta(mut self, speed_beta: f64) -> Self {
        self.header.speed_beta = speed_beta;
        self
    }

    /// With `seconds` of coasting where the map has no data ([`Options::coast`], at most
    /// the horizon; 0, the default, stops a sample there).
    pub fn coast(mut self, seconds: f64) -> Self {
        self.header.coast = seconds;
        self
    }

    /// With (or without, the default) a score per sample in the response
    /// ([`Prediction::scores`](crate::Prediction::scores),
    /// [`Prediction::best_sample`](crate::Prediction::best_sample)). The improved method scores its
    /// samples either way.
    pub fn scores(mut self, on: bool) -> Self {
        let mut o = self.options();
        o.scores = on;
        self.header.set_options(&o);
        self
    }

    /// With the map of the time of day for `time` (s on the map's clock: unix time, as
    /// the tracks had it) instead of the daemon's wall clock.
    pub fn time(mut self, time: f64) -> Self {
        self.header.set_map_time(MapTime::At(time));
        self
    }

    /// On the map as the daemon loaded it (or not, the default): a learning daemon
    /// (`cliffd --learn`) otherwise answers with its newest learned version.
    pub fn base_map(mut self, on: bool) -> Self {
        self.set_base_map(on);
        self
    }

    /// Set whether to predict on the map as the daemon loaded it ([`base_map`](Self::base_map)).
    pub fn set_base_map(&mut self, on: bool) {
        if on {
            self.header.flags |= protocol::FLAG_BASE_MAP;
        } else {
            self.header.flags &= !protocol::FLAG_BASE_MAP;
        }
    }

    /// With the all-day map, whatever the time.
    pub fn all_day(mut self) -> Self {
        self.header.set_map_time(MapTime::AllDay);
        self
    }

    /// Set the method.
    pub fn set_method(&mut self, method: Method) {
        self.header.method = protocol::method_code(method);
    }

    /// Set the options beyond the paper (speed kernel, coasting, scores).
    pub fn set_options(&mut self, options: &Options) {
        self.header.set_options(options);
    }

    /// The options beyond the paper, as they will be sent.
    pub fn options(&self) -> Options {
        self.header.options()
    }

    /// Set which map of the time of day to use ([`MapTime::Now`], the default: the
    /// daemon's wall clock when the request arrives).
    pub fn set_map_time(&mut self, when: MapTime) {
        self.header.set_map_time(when);
    }

    /// Which map of the time of day the request asks for.
    pub fn map_time(&self) -> MapTime {
        match self.header.time_mode {
            protocol::TIME_AT => MapTime::At(self.header.time),
            protocol::TIME_ALL_DAY => MapTime::AllDay,
            _ => MapTime::Now,
        }
    }

    /// Set the seed of the request's random generator.
    pub fn set_seed(&mut self, seed: u64) {
        self.header.seed = seed;
    }

    /// Change the map (or its version: `NAME@VERSION`, as in [`new`](Self::new)).
    pub fn set_map(&mut self, map: &str) -> Result<(), Error> {
        self.header.set_map_name(map).map_err(Error::InvalidRequest)
    }

    /// Remove all agents.
    pub fn clear_agents(&mut self) {
        self.rows.clear();
        self.header.agents = 0;
    }

    /// Add an agent with its observed history, oldest row first; returns its index in
    /// the response. Rows made with [`Observation::with_velocity`] give the observed
    /// velocity from the tracker's speed and heading, rows made with
    /// [`Observation::position`] from the positions (at least two rows then).
    pub fn add_agent(&mut self, history: impl IntoIterator<Item = Observation>) -> usize {
        let a = self.header.agents;
        self.rows
            .extend(history.into_iter().map(|o| Observation { agent: a, ..o }));
        self.header.agents += 1;
        a as usize
    }

    /// Number of agents.
    pub fn agents(&self) -> usize {
        self.header.agents as usize
    }

    /// The wire header (request id and listener are filled in when sent).
    pub fn header(&self) -> &RequestHeader {
        &self.header
    }

    /// The wire header, for the C ABI (which passes codes through as given).
    pub(crate) fn header_mut(&mut self) -> &mut RequestHeader {
        &mut self.header
    }

    /// The wire rows.
    pub fn rows(&self) -> &[Observation] {
        &self.rows
    }
}
