//! Tidying a location's mixture: the Bhattacharyya distance of two components, merging
//! two by moment matching, merging near-duplicates and capping the count. Shared by the
//! online update and the time-of-day slices.

use super::location::Component;
use crate::math::wrap_2pi;
use crate::math::wrap_pi;

/// Bhattacharyya distance between two components.
pub(crate) fn bhattacharyya(a: &Component, b: &Component) -> f64 {
    let d = [wrap_pi(b.theta - a.theta), b.rho - a.rho];
    let m = [
        0.5 * (a.cov[0] + b.cov[0]),
        0.25 * (a.cov[1] + a.cov[2] + b.cov[1] + b.cov[2]),
        0.5 * (a.cov[3] + b.cov[3]),
    ];
    let det = m[0] * m[2] - m[1] * m[1];
    let det_a = a.cov[0] * a.cov[3] - a.cov[1] * a.cov[2];
    let det_b = b.cov[0] * b.cov[3] - b.cov[1] * b.cov[2];
    if !(det > 0.0 && det_a > 0.0 && det_b > 0.0) {
        return f64::INFINITY;
    }
    let q = (m[2] * d[0] * d[0] - 2.0 * m[1] * d[0] * d[1] + m[0] * d[1] * d[1]) / det;
    0.125 * q + 0.5 * (det / (det_a * det_b).sqrt()).ln()
}

/// Moment-matched merge of two components (weights add).
pub(crate) fn merge(a: &Component, b: &Component) -> Component {
    let w = a.weight + b.weight;
    let (fa, fb) = if w > 0.0 {
        (a.weight / w, b.weight / w)
    } else {
        (0.5, 0.5)
    };
    let d = [wrap_pi(b.theta - a.theta), b.rho - a.rho];
    // Mean in coordinates relative to a.
    let mu = [fb * d[0], fb * d[1]];
    let da = [-mu[0], -mu[1]];
    let db = [d[0] - mu[0], d[1] - mu[1]];
    let cov = [
        fa * (a.cov[0] + da[0] * da[0]) + fb * (b.cov[0] + db[0] * db[0]),
        fa * (a.cov[1] + da[0] * da[1]) + fb * (b.cov[1] + db[0] * db[1]),
        fa * (a.cov[2] + da[1] * da[0]) + fb * (b.cov[2] + db[1] * db[0]),
        fa * (a.cov[3] + da[1] * da[1]) + fb * (b.cov[3] + db[1] * db[1]),
    ];
    Component {
        theta: wrap_2pi(a.theta + mu[0]),
        rho: (a.rho + mu[1]).max(0.0),
        cov,
        weight: w,
    }
}

/// Merge the closest pair of `comps` (Bhattacharyya distance) while it is closer than
/// `merge_distance`; the number of merges.
pub(crate) fn merge_near_duplicates(comps: &mut Vec<Component>, merge_distance: f64) -> usize {
    let mut merged = 0;
    loop {
        let mut best: Option<(f64, usize, usize)> = None;
        for i in 0..comps.len() {
            for j in i + 1..comps.len() {
                let d = bhattacharyya(&comps[i], &comps[j]);
                if best.is_none_or(|(bd, _, _)| d < bd) {
                    best = Some((d, i, j));
                }
            }
        }
        match best {
            Some((d, i, j)) if d < merge_distance => {
                comps[i] = merge(&comps[i], &comps[j]);
                comps.remove(j);
                merged += 1;
            }
            _ => return merged,
        }
    }
}

/// Merge the lightest component of `comps` into its closest neighbour until at most
/// `max_components` remain (so strong flows keep their shape); the number of merges.
pub(crate) fn cap_components(comps: &mut Vec<Component>, max_components: usize) -> usize {
    let mut merged = 0;
    while comps.len() > max_components.max(1) {
        let light = (0..comps.len())
            .min_by(|&a, &b| comps[a].weight.total_cmp(&comps[b].weight))
            .expect("not empty");
        let into = (0..comps.len())
            .filter(|&k| k != light)
            .min_by(|&a, &b| {
                bhattacharyya(&comps[light], &comps[a])
                    .total_cmp(&bhattacharyya(&comps[light], &comps[b]))
            })
            .expect("two or more");
        comps[into] = merge(&comps[into], &comps[light]);
        comps.remove(light);
        merged += 1;
    }
    merged
}
