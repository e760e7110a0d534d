//! A time-of-day set: [`MapSet`], the all-day map and one map per slice, and the slice
//! a timestamp falls in.

use std::sync::Arc;

use super::clock::{DAY_SECONDS, check_clock_offset, slice_count};
use super::smoothing::Smoothing;
use crate::map::{CliffMap, MapError};

/// The parts of a [`MapSet`] (see [`MapSet::from_parts`]).
#[derive(Debug, Clone)]
pub struct SetParts {
    /// The map of the whole day.
    pub all_day: Arc<CliffMap>,
    /// One entry per slice (slice `i` covers local times `[i L, (i + 1) L)` of the day,
    /// `L` the slice length): its map, or `None` for the all-day map. Empty: no slices.
    pub slices: Vec<Option<Arc<CliffMap>>>,
    /// Slice length (s); ignored without slices.
    pub slice_length: f64,
    /// Seconds added to a timestamp to get the local time (e.g. `32400` for unix time
    /// in UTC+9).
    pub clock_offset: f64,
    /// How the slices were smoothed, when built by [`build_map_set`].
    pub smoothing: Option<Smoothing>,
    /// Observations of each slice's own data (empty when unknown).
    pub observations: Vec<u64>,
}

/// A time-of-day map set: the all-day map and a map per slice of the day (see the
/// module documentation).
#[derive(Debug, Clone)]
pub struct MapSet {
    all_day: Arc<CliffMap>,
    slices: Vec<Option<Arc<CliffMap>>>,
    slice_length: f64,
    clock_offset: f64,
    smoothing: Option<Smoothing>,
    observations: Vec<u64>,
}

impl From<CliffMap> for MapSet {
    fn from(map: CliffMap) -> Self {
        Self::single(map)
    }
}

impl MapSet {
    /// A set of one map: every time gets it.
    pub fn single(map: CliffMap) -> Self {
        Self::single_arc(Arc::new(map))
    }

    /// [`single`](Self::single) for a shared map.
    pub fn single_arc(map: Arc<CliffMap>) -> Self {
        Self {
            all_day: map,
            slices: Vec::new(),
            slice_length: DAY_SECONDS,
            clock_offset: 0.0,
            smoothing: None,
            observations: Vec::new(),
        }
    }

    /// Attach a speed prior to every map of the set (see
    /// [`CliffMap::set_speed_prior`]).
    pub fn set_speed_prior(
        &mut self,
        prior: Option<crate::motion::SpeedPrior>,
    ) -> Result<(), MapError> {
        Arc::make_mut(&mut self.all_day).set_speed_prior(prior)?;
        for s in self.slices.iter_mut().flatten() {
            Arc::make_mut(s).set_speed_prior(prior)?;
        }
        Ok(())
    }

    /// A set from its parts. Fails when the slice length does not divide the day (with
    /// slices), the number of slices does not match it, the observation counts are
    /// neither empty nor one per slice, the clock offset is beyond a day or not finite,
    /// or the smoothing values are out of range.
    pub fn from_parts(p: SetParts) -> Result<Self, MapError> {
        check_clock_offset(p.clock_offset)?;
        if let Some(s) = &p.smoothing {
            s.check()?;
        }
        if p.slices.is_empty() {
            if !p.observations.is_empty() {
                return Err(MapError::TimeOfDay(
                    "observation counts given for a set without slices".into(),
                ));
            }
            return Ok(Self {
                clock_offset: p.clock_offset,
                smoothing: p.smoothing,
                ..Self::single_arc(p.all_day)
            });
        }
        let n = slice_count(p.slice_length)?;
        if p.slices.len() != n {
            return Err(MapError::TimeOfDay(format!(
                "{} slices, a slice length of {} s makes {n}",
                p.slices.len(),
                p.slice_length
            )));
        }
        if !(p.observations.is_empty() || p.observations.len() == n) {
            return Err(MapError::TimeOfDay(format!(
                "{} observation counts for {n} slices",
                p.observations.len()
            )));
        }
        Ok(Self {
            all_day: p.all_day,
            slices: p.slices,
            slice_length: p.slice_length,
            clock_offset: p.clock_offset,
            smoothing: p.smoothing,
            observations: p.observations,
        })
    }

    /// The all-day map.
    pub fn all_day(&self) -> &Arc<CliffMap> {
        &self.all_day
    }

    /// True when the set has slices.
    pub fn is_sliced(&self) -> bool {
        !self.slices.is_empty()
    }

    /// The slices: slice `i` covers local times `[i L, (i + 1) L)`, `L` the
    /// [`slice_length`](Self::slice_length); `None` where the all-day map stands in.
    /// Empty for a set without slices.
    pub fn slices(&self) -> &[Option<Arc<CliffMap>>] {
        &self.slices
    }

    /// Slice length (s); a day for a set without slices.
    pub fn slice_length(&self) -> f64 {
        self.slice_length
    }

    /// Seconds added to a timestamp to get the local time.
    pub fn clock_offset(&self) -> f64 {
        self.clock_offset
    }

    /// Change the clock offset (s); fails when it is not finite or beyond a day.
    pub fn set_clock_offset(&mut self, offset: f64) -> Result<(), MapError> {
        check_clock_offset(offset)?;
        self.clock_offset = offset;
        Ok(())
    }

    /// How the slices were smoothed, when the set was built by [`build_map_set`].
    pub fn smoothing(&self) -> Option<Smoothing> {
        self.smoothing
    }

    /// Observations of each slice's own data when the set was built (empty when
    /// unknown).
    pub fn observations(&self) -> &[u64] {
        &self.observations
    }

    /// The local time of day (s, in `[0, 86400)`) of a timestamp: `time + clock offset`
    /// around the clock; `None` for a time that is not finite.
    pub fn time_of_day(&self, time: f64) -> Option<f64> {
        let t = time + self.clock_offset;
        if !t.is_finite() {
            return None;
        }
        let tod = t.rem_euclid(DAY_SECONDS);
        // rem_euclid can round up to the modulus itself
        Some(if tod >= DAY_SECONDS { 0.0 } else { tod })
    }

    /// The slice a local time of day (s) falls in; `None` without slices or for a time
    /// outside `[0, 86400)`.
    pub fn slice_of_time_of_day(&self, seconds: f64) -> Option<usize> {
        if self.slices.is_empty() || !(0.0..DAY_SECONDS).contains(&seconds) {
            return None;
        }
        Some(((seconds / self.slice_length) as usize).min(self.slices.len() - 1))
    }

    /// The slice a timestamp falls in (after the clock offset); `None` without slices
    /// or for a time that is not finite.
    pub fn slice_index(&self, time: f64) -> Option<usize> {
        self.slice_of_time_of_day(self.time_of_day(time)?)
    }

    /// The map for a timestamp: the map of its slice, or the all-day map when the slice
    /// has none, the set has no slices or the time is not finite.
    #[inline]
    pub fn at(&self, time: f64) -> &Arc<CliffMap> {
        self.slice_index(time)
            .and_then(|i| self.slices[i].as_ref())
            .unwrap_or(&self.all_day)
    }

    /// The map of slice `index` (the all-day map where the slice has none); `None` for
    /// an index beyond the slices.
    pub fn slice_map(&self, index: usize) -> Option<&Arc<CliffMap>> {
        self.slices
            .get(index)
            .map(|s| s.as_ref().unwrap_or(&self.all_day))
    }

    /// Every distinct map of the set, the all-day map first, then the slice maps in slice
    /// order (for work on each map: neighbour tables, table budgets).
    pub fn maps(&self) -> impl Iterator<Item = &Arc<CliffMap>> {
        std::iter::once(&self.all_day).chain(self.slices.iter().flatten())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::timeofday::clock::{clock_label, slice_label};

    fn hourly(offset: f64, with: &[usize]) -> (MapSet, Vec<Arc<CliffMap>>) {
        let maps: Vec<Arc<CliffMap>> = (0..24).map(|_| Arc::new(CliffMap::demo())).collect();
        let slices = (0..24)
            .map(|i| with.contains(&i).then(|| maps[i].clone()))
            .collect();
        let set = MapSet::from_parts(SetParts {
            all_day: Arc::new(CliffMap::demo()),
            slices,
            slice_length: 3600.0,
            clock_offset: offset,
            smoothing: None,
            observations: Vec::new(),
        })
        .unwrap();
        (set, maps)
    }

    #[test]
    fn slice_lengths_must_divide_the_day() {
        assert_eq!(slice_count(3600.0).unwrap(), 24);
        assert_eq!(slice_count(1800.0).unwrap(), 48);
        assert_eq!(slice_count(DAY_SECONDS).unwrap(), 1);
        assert_eq!(slice_count(60.0).unwrap(), 1440);
        for bad in [
            0.0,
            -3600.0,
            59.0,
            7.0 * 60.0,
            86401.0,
            f64::NAN,
            f64::INFINITY,
        ] {
            let e = slice_count(bad).unwrap_err().to_string();
            assert!(e.contains("does not divide the day"), "{bad}: {e}");
        }
    }

    #[test]
    fn timestamps_pick_the_slice_of_their_local_time() {
        let (set, maps) = hourly(32400.0, &[9, 13, 23]);
        // 2012-10-24 00:00 UTC is 09:00 in Japan
        let midnight_utc = 1_351_036_800.0;
        assert_eq!(set.slice_index(midnight_utc), Some(9));
        assert!(Arc::ptr_eq(set.at(midnight_utc), &maps[9]));
        assert_eq!(set.slice_index(midnight_utc + 3599.9), Some(9));
        assert_eq!(set.slice_index(midnight_utc + 3600.0), Some(10));
        // 10:00 has no map: the all-day map
        assert!(Arc::ptr_eq(set.at(midnight_utc + 3600.0), set.all_day()));
        assert!(Arc::ptr_eq(set.at(midnight_utc + 4.5 * 3600.0), &maps[13]));
        // around the clock: 14:59 UTC is 23:59 local, 15:00 UTC is 00:00 local
        assert_eq!(set.slice_index(midnight_utc + 14.99 * 3600.0), Some(23));
        assert_eq!(set.slice_index(midnight_utc + 15.0 * 3600.0), Some(0));
        // negative times and times before the epoch
        assert_eq!(set.slice_index(-32400.0 - 60.0), Some(23));
        assert_eq!(set.time_of_day(-32400.0), Some(0.0));
        // no time, no slice: the all-day map
        for t in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(set.slice_index(t), None);
            assert!(Arc::ptr_eq(set.at(t), set.all_day()));
        }
        assert_eq!(set.slice_of_time_of_day(DAY_SECONDS), None);
        assert_eq!(set.slice_of_time_of_day(-1.0), None);
        // a different clock: the same timestamps fall in other slices
        let mut utc = set.clone();
        utc.set_clock_offset(0.0).unwrap();
        assert_eq!(utc.slice_index(midnight_utc), Some(0));
        assert!(utc.set_clock_offset(2.0 * DAY_SECONDS).is_err());
        assert!(utc.set_clock_offset(f64::NAN).is_err());
        assert_eq!(utc.clock_offset(), 0.0);
        // maps() lists each map once, the all-day map first
        assert_eq!(set.maps().count(), 4);
        assert!(Arc::ptr_eq(set.maps().next().unwrap(), set.all_day()));
        assert!(Arc::ptr_eq(set.slice_map(10).unwrap(), set.all_day()));
        assert!(set.slice_map(24).is_none());
    }

    #[test]
    fn a_single_map_is_a_set_without_slices() {
        let set = MapSet::single(CliffMap::demo());
        assert!(!set.is_sliced());
        for t in [0.0, 1e9, -5.0, f64::NAN] {
            assert_eq!(set.slice_index(t), None);
            assert!(Arc::ptr_eq(set.at(t), set.all_day()));
        }
        assert_eq!(set.maps().count(), 1);
    }

    #[test]
    fn inconsistent_parts_are_refused() {
        let parts = |slices: usize, length: f64, offset: f64, observations: Vec<u64>| SetParts {
            all_day: Arc::new(CliffMap::demo()),
            slices: vec![None; slices],
            slice_length: length,
            clock_offset: offset,
            smoothing: None,
            observations,
        };
        let e = |p| MapSet::from_parts(p).unwrap_err().to_string();
        assert!(
            e(parts(23, 3600.0, 0.0, vec![]))
                .contains("23 slices, a slice length of 3600 s makes 24")
        );
        assert!(e(parts(24, 3500.0, 0.0, vec![])).contains("does not divide the day"));
        assert!(
            e(parts(24, 3600.0, 1e6, vec![]))
                .contains("clock offset 1000000 s is not within a day")
        );
        assert!(
            e(parts(24, 3600.0, 0.0, vec![1; 3])).contains("3 observation counts for 24 slices")
        );
        assert!(e(parts(0, 3600.0, 0.0, vec![1])).contains("without slices"));
        assert!(MapSet::from_parts(parts(24, 3600.0, -32400.0, vec![0; 24])).is_ok());
        let mut p = parts(24, 3600.0, 0.0, vec![]);
        p.smoothing = Some(Smoothing {
            max_components: 0,
            ..Smoothing::default()
        });
        assert!(e(p).contains("components per location"));
        let mut p = parts(24, 3600.0, 0.0, vec![]);
        p.smoothing = Some(Smoothing {
            prior_weight: f64::NAN,
            ..Smoothing::default()
        });
        assert!(e(p).contains("prior weight"));
    }

    #[test]
    fn labels_read_as_clock_times() {
        assert_eq!(slice_label(9, 3600.0), "09:00-10:00");
        assert_eq!(slice_label(47, 1800.0), "23:30-24:00");
        assert_eq!(clock_label(90.0), "00:01:30");
    }
}
