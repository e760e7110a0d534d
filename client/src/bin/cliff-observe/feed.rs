//! Recorded tracks as the stream of observe requests a live tracker would send: rows in
//! time order, cut into requests of whole time windows with each track's rows together,
//! and every track's last row marked as its end ([`Feed`]).

use cliff::tracks::{Row, Track};
use cliff_client::protocol::{FLAG_TRACK_END, Observation};

/// Every row of the tracks, in time order, with the track id it is sent under.
pub(crate) struct Feed {
    rows: Vec<Observation>,
}

impl Feed {
    /// The rows of `files` (the tracks of each file): track ids are numbered 0, 1, ... over
    /// all files, so two files' person 3 are two people.
    pub(crate) fn new(files: &[Vec<Track>]) -> Result<Feed, String> {
        let mut rows = Vec::new();
        let mut id: u32 = 0;
        for tracks in files {
            for t in tracks {
                let n = t.rows.len();
                rows.extend(t.rows.iter().enumerate().map(|(i, r)| {
                    let mut o = observation(id, r);
                    if i + 1 == n {
                        o.flags |= FLAG_TRACK_END;
                    }
                    o
                }));
                id = id
                    .checked_add(1)
                    .ok_or("more than 4294967295 tracks in the files")?;
            }
        }
        // time order as a tracker would see it (ties: by track)
        rows.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.agent.cmp(&b.agent)));
        Ok(Feed { rows })
    }

    /// Rows in all.
    pub(crate) fn len(&self) -> usize {
        self.rows.len()
    }

    /// The first and last time.
    pub(crate) fn span(&self) -> Option<(f64, f64)> {
        Some((self.rows.first()?.t, self.rows.last()?.t))
    }

    /// The window of `every` seconds of recording time (windows start at the first row's
    /// time) holding the row at `start`: the end (exclusive) of its rows from `start`, at
    /// least `start + 1`, and the time the window closes.
    pub(crate) fn window(&self, start: usize, every: f64) -> (usize, f64) {
        let t0 = self.rows[0].t;
        let k = ((self.rows[start].t - t0) / every).floor();
        let close = t0 + (k + 1.0) * every;
        let end = start + self.rows[start..].partition_point(|o| o.t < close);
        (end.max(start + 1), close)
    }

    /// The rows from `start` of one request of at most `max` rows: the rows of a time
    /// window, grouped by track (each track's rows stay in time order).
    pub(crate) fn request(&self, start: usize, max: usize, out: &mut Vec<Observation>) {
        let end = (start + max).min(self.rows.len());
        out.clear();
        out.extend_from_slice(&self.rows[start..end]);
        out.sort_by_key(|o| o.agent); // stable: times stay increasing within a track
    }
}

fn observation(id: u32, r: &Row) -> Observation {
    Observation {
        agent: id,
        ..Observation::with_velocity(r.t, r.position.x, r.position.y, r.speed, r.angle)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cliff::tracks::{Format, parse_tracks};

    #[test]
    fn requests_hold_time_windows_grouped_by_track_with_ends_marked() {
        let text = "0,1,0,0,1,0\n1,1,1,0,1,0\n2,1,2,0,1,0\n0.5,2,5,5,1,0\n1.5,2,5,6,1,0\n";
        let a = parse_tracks(text, "a", Format::Atc).unwrap();
        let b = parse_tracks("0.2,1,9,9,1,0\n", "b", Format::Atc).unwrap();
        let feed = Feed::new(&[a, b]).unwrap();
        assert_eq!(feed.len(), 6);
        assert_eq!(feed.span(), Some((0.0, 2.0)));
        let mut out = Vec::new();
        feed.request(0, 4, &mut out);
        // rows at 0, 0.2, 0.5, 1 grouped: track 0 (0, 1), track 1 (0.5), track 2 (0.2)
        let got: Vec<(u32, f64)> = out.iter().map(|o| (o.agent, o.t)).collect();
        assert_eq!(got, vec![(0, 0.0), (0, 1.0), (1, 0.5), (2, 0.2)]);
        // the other file's person 1 is another track, and a one-row track ends at once
        assert_ne!(out[3].flags & FLAG_TRACK_END, 0);
        assert_eq!(out[0].flags & FLAG_TRACK_END, 0);
        feed.request(4, 4, &mut out);
        let ends: Vec<bool> = out.iter().map(|o| o.flags & FLAG_TRACK_END != 0).collect();
        assert_eq!(ends, vec![true, true]);
    }

    #[test]
    fn windows_hold_the_rows_of_their_seconds_of_recording_time() {
        // rows at 10, 10.2, 10.5, 11, 11.5 and 12.1
        let text = "10,1,0,0,1,0\n11,1,1,0,1,0\n12.1,1,2,0,1,0\n10.5,2,5,5,1,0\n11.5,2,5,6,1,0\n";
        let a = parse_tracks(text, "a", Format::Atc).unwrap();
        let b = parse_tracks("10.2,1,9,9,1,0\n", "b", Format::Atc).unwrap();
        let feed = Feed::new(&[a, b]).unwrap();
        // windows of 0.4 s: [10, 10.4) holds 10 and 10.2; [10.4, 10.8) holds 10.5; then
        // 11, 11.5 and 12.1 each in a window of their own
        let mut starts = vec![0];
        let mut closes = Vec::new();
        while *starts.last().unwrap() < feed.len() {
            let (end, close) = feed.window(*starts.last().unwrap(), 0.4);
            starts.push(end);
            closes.push(close);
        }
        assert_eq!(starts, vec![0, 2, 3, 4, 5, 6]);
        let want = [10.4, 10.8, 11.2, 11.6, 12.4];
        assert_eq!(closes.len(), want.len());
        for (c, w) in closes.iter().zip(want) {
            assert!((c - w).abs() < 1e-9, "{closes:?}");
        }
        // a window as long as the recording holds all of it
        assert_eq!(feed.window(0, 10.0).0, feed.len());
    }
}
