//! [`MapAt`]: anything that gives the map for a moment, a single map or a set.

use std::sync::Arc;

use super::set::MapSet;
use crate::map::CliffMap;

/// Anything that gives the map for a moment: a single [`CliffMap`] (always itself) or
/// a [`MapSet`] (the map of the time's slice). Evaluation takes one, so that every
/// person is predicted with the map of their observation time.
pub trait MapAt {
    /// The map for the timestamp `time` (s, the clock of the data).
    fn map_at(&self, time: f64) -> &CliffMap;
}

impl MapAt for CliffMap {
    #[inline]
    fn map_at(&self, _time: f64) -> &CliffMap {
        self
    }
}

impl MapAt for MapSet {
    #[inline]
    fn map_at(&self, time: f64) -> &CliffMap {
        self.at(time)
    }
}

impl<T: MapAt + ?Sized> MapAt for Arc<T> {
    #[inline]
    fn map_at(&self, time: f64) -> &CliffMap {
        (**self).map_at(time)
    }
}

impl<T: MapAt + ?Sized> MapAt for &T {
    #[inline]
    fn map_at(&self, time: f64) -> &CliffMap {
        (**self).map_at(time)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_map_is_its_own_map_at_every_time_and_a_set_without_slices_its_all_day_map() {
        let m = CliffMap::demo();
        assert!(std::ptr::eq(m.map_at(123.0), &m));
        let set = MapSet::single(CliffMap::demo());
        assert!(std::ptr::eq(set.map_at(1.0), &**set.all_day()));
    }
}
