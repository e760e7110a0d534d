//! Training the motion model's [`Network`]: the corrections to the linear part that
//! make its expected path closest to where people went.
//!
//! The loss is the walker's mean Euclidean error over the steps each window reaches
//! (the displacement error the benchmarks score, not its square, so people who stop or
//! turn abruptly do not dominate), each window weighed as in the linear fit. Adam
//! (learning rate 1e-3, betas 0.9 / 0.999) on shuffled batches of 256 windows, an L2
//! penalty of 1e-4 on the weights, He-normal starting weights for the hidden layers and
//! zeros for the output layer (so training starts from the linear model); the network
//! kept is the exponential moving average of the weights after each batch (factor
//! 0.999, less over the first thousand batches), which varies less with the seed than
//! the last batch's weights. Shuffling and
//! starting weights come from a seeded generator and every sum runs in one order: the
//! same windows and seed give the same network on the same machine.

use std::ops::Range;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

use super::model::FEATURES;
use super::network::{INPUTS, MAX_HIDDEN, Network, layer, relu};

/// How to train the network.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NetworkFit {
    /// Hidden units per layer (1 to [`MAX_HIDDEN`]).
    pub hidden: usize,
    /// Passes over the windows.
    pub epochs: usize,
    /// Seed of the shuffling and the starting weights.
    pub seed: u64,
}

impl Default for NetworkFit {
    /// 64 hidden units, 80 passes, seed 0.
    fn default() -> Self {
        Self {
            hidden: 64,
            epochs: 80,
            seed: 0,
        }
    }
}

const BATCH: usize = 256;
const LEARNING_RATE: f64 = 1e-3;
const BETA1: f64 = 0.9;
const BETA2: f64 = 0.999;
const EPSILON: f64 = 1e-8;
const DECAY: f64 = 1e-4;
/// Inputs that vary less than this (m) in the windows are taken as they are, not
/// standardised (walkers who all go straight): no scale beyond 10^4.
const SMALLEST_SPREAD: f64 = 1e-4;
/// Each batch's weights enter the kept average with `1 - AVERAGE`.
const AVERAGE: f64 = 0.999;
/// Errors shorter than this (m) take this length in the loss's gradient.
const SMALLEST_ERROR: f64 = 1e-3;

/// The windows the network learns from: inputs, the linear part's residuals to
/// correct (forward and left per step), the steps each window reaches, its weight.
#[derive(Debug, Default)]
pub(super) struct Examples {
    pub features: Vec<[f64; FEATURES]>,
    /// `outputs` values per window (zeros past its reach).
    pub targets: Vec<f64>,
    pub reach: Vec<usize>,
    pub weight: Vec<f64>,
}

impl Examples {
    fn len(&self) -> usize {
        self.features.len()
    }
}

/// Where each part of the network lies in one flat vector of values (the weights, and
/// for training their gradients and Adam moments): `w1 b1 w2 b2 w3 b3`.
struct Layout {
    parts: [Range<usize>; 6],
    len: usize,
}

impl Layout {
    fn new(hidden: usize, outputs: usize) -> Self {
        let (h, o) = (hidden, outputs);
        let sizes = [INPUTS * h, h, h * h, h, h * o, o];
        let mut start = 0;
        let parts = sizes.map(|size| {
            start += size;
            start - size..start
        });
        Layout { parts, len: start }
    }
}

/// Train a network of `fit.hidden` units on `examples` with `outputs` values each.
pub(super) fn train_network(examples: &Examples, outputs: usize, fit: &NetworkFit) -> Network {
    let h = fit.hidden.clamp(1, MAX_HIDDEN);
    let n = examples.len();
    // standardise the inputs
    let mut mean = [0.0; INPUTS];
    let mut scale = [1.0; INPUTS];
    for i in 0..INPUTS {
        let m = examples.features.iter().map(|f| f[i]).sum::<f64>() / n.max(1) as f64;
        let var = examples
            .features
            .iter()
            .map(|f| (f[i] - m) * (f[i] - m))
            .sum::<f64>()
            / n.max(1) as f64;
        mean[i] = m;
        // an input that does not vary (walkers who all go straight) is not magnified
        let sd = var.sqrt();
        scale[i] = if sd < SMALLEST_SPREAD {
            1.0
        } else {
            1.0 / (sd + 1e-6)
        };
    }
    let inputs: Vec<[f64; INPUTS]> = examples
        .features
        .iter()
        .map(|f| std::array::from_fn(|i| (f[i] - mean[i]) * scale[i]))
        .collect();

    let layout = Layout::new(h, outputs);
    let mut values = vec![0.0; layout.len];
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(fit.seed);
    {
        let [w1, _, w2, _, _, _] = layout.parts.clone();
        let (s1, s2) = ((2.0 / INPUTS as f64).sqrt(), (2.0 / h as f64).sqrt());
        for v in &mut values[w1] {
            let z: f64 = StandardNormal.sample(&mut rng);
            *v = s1 * z;
        }
        for v in &mut values[w2] {
            let z: f64 = StandardNormal.sample(&mut rng);
            *v = s2 * z;
        }
    }
    let is_weight: Vec<bool> = {
        let mut w = vec![false; layout.len];
        for part in [0, 2, 4] {
            w[layout.parts[part].clone()].fill(true);
        }
        w
    };
    let mut grad = vec![0.0; layout.len];
    let mut m1 = vec![0.0; layout.len];
    let mut m2 = vec![0.0; layout.len];
    let mut order: Vec<usize> = (0..n).collect();
    let mut step = 0i32;
    let mut scratch = Scratch::new(h, outputs);
    // the weights kept: an exponential moving average of the iterates
    let mut average = values.clone();
    for _ in 0..fit.epochs {
        order.shuffle(&mut rng);
        for batch in order.chunks(BATCH) {
            grad.iter_mut().for_each(|g| *g = 0.0);
            for &e in batch {
                let y = &examples.targets[e * outputs..(e + 1) * outputs];
                let share = examples.weight[e] / batch.len() as f64;
                scratch.backward(
                    &values,
                    &layout,
                    &inputs[e],
                    y,
                    examples.reach[e],
                    share,
                    &mut grad,
                );
            }
            step += 1;
            let (c1, c2) = (1.0 - BETA1.powi(step), 1.0 - BETA2.powi(step));
            for i in 0..layout.len {
                let g = grad[i] + if is_weight[i] { DECAY * values[i] } else { 0.0 };
                m1[i] = BETA1 * m1[i] + (1.0 - BETA1) * g;
                m2[i] = BETA2 * m2[i] + (1.0 - BETA2) * g * g;
                values[i] -= LEARNING_RATE * (m1[i] / c1) / ((m2[i] / c2).sqrt() + EPSILON);
            }
            // short runs: the average follows the early weights less
            let keep = AVERAGE.min((1.0 + step as f64) / (10.0 + step as f64));
            for (a, v) in average.iter_mut().zip(&values) {
                *a = keep * *a + (1.0 - keep) * v;
            }
        }
    }
    let [w1, b1, w2, b2, w3, b3] = layout.parts;
    let single = |r: Range<usize>| average[r].iter().map(|v| *v as f32).collect();
    Network {
        hidden: h,
        outputs,
        mean: mean.map(|v| v as f32),
        scale: scale.map(|v| v as f32),
        w1: single(w1),
        b1: single(b1),
        w2: single(w2),
        b2: single(b2),
        w3: single(w3),
        b3: single(b3),
    }
}

/// The activations and their gradients of one window.
struct Scratch {
    h1: Vec<f64>,
    h2: Vec<f64>,
    out: Vec<f64>,
    d_out: Vec<f64>,
    d2: Vec<f64>,
    d1: Vec<f64>,
}

impl Scratch {
    fn new(h: usize, outputs: usize) -> Self {
        Self {
            h1: vec![0.0; h],
            h2: vec![0.0; h],
            out: vec![0.0; outputs],
            d_out: vec![0.0; outputs],
            d2: vec![0.0; h],
            d1: vec![0.0; h],
        }
    }

    /// Add the gradient of `share` times the window's loss to `grad`.
    #[allow(clippy::too_many_arguments)]
    fn backward(
        &mut self,
        values: &[f64],
        layout: &Layout,
        x: &[f64; INPUTS],
        y: &[f64],
        reach: usize,
        share: f64,
        grad: &mut [f64],
    ) {
        let [w1, b1, w2, b2, w3, b3] = layout.parts.clone();
        let o = self.out.len();
        let h = self.h1.len();
        layer(x, &values[w1.clone()], &values[b1.clone()], &mut self.h1);
        relu(&mut self.h1);
        layer(
            &self.h1,
            &values[w2.clone()],
            &values[b2.clone()],
            &mut self.h2,
        );
        relu(&mut self.h2);
        layer(
            &self.h2,
            &values[w3.clone()],
            &values[b3.clone()],
            &mut self.out,
        );
        self.d_out.iter_mut().for_each(|v| *v = 0.0);
        for k in 0..reach.min(o / 2) {
            let (ex, ey) = (
                self.out[2 * k] - y[2 * k],
                self.out[2 * k + 1] - y[2 * k + 1],
            );
            let len = (ex * ex + ey * ey).sqrt().max(SMALLEST_ERROR);
            self.d_out[2 * k] = share * ex / len;
            self.d_out[2 * k + 1] = share * ey / len;
        }
        // output layer
        outer(&self.h2, &self.d_out, &mut grad[w3.clone()]);
        add(&self.d_out, &mut grad[b3]);
        for i in 0..h {
            self.d2[i] = if self.h2[i] > 0.0 {
                dot(
                    &values[w3.start + i * o..w3.start + (i + 1) * o],
                    &self.d_out,
                )
            } else {
                0.0
            };
        }
        // second layer
        outer(&self.h1, &self.d2, &mut grad[w2.clone()]);
        add(&self.d2, &mut grad[b2]);
        for i in 0..h {
            self.d1[i] = if self.h1[i] > 0.0 {
                dot(&values[w2.start + i * h..w2.start + (i + 1) * h], &self.d2)
            } else {
                0.0
            };
        }
        // first layer
        outer(x, &self.d1, &mut grad[w1]);
        add(&self.d1, &mut grad[b1]);
    }
}

/// `g += a b^T` (row by row, one row per element of `a`); rows of a zero `a_i` skipped.
fn outer(a: &[f64], b: &[f64], g: &mut [f64]) {
    for (ai, row) in a.iter().zip(g.chunks_exact_mut(b.len())) {
        if *ai != 0.0 {
            for (gj, bj) in row.iter_mut().zip(b) {
                *gj += ai * bj;
            }
        }
    }
}

fn add(a: &[f64], g: &mut [f64]) {
    for (gi, ai) in g.iter_mut().zip(a) {
        *gi += ai;
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A target the linear part cannot give: the walker's forward step squared.
    #[test]
    fn the_network_learns_what_is_not_linear_in_its_inputs() {
        let mut ex = Examples::default();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        for _ in 0..4000 {
            let mut f = [0.0; FEATURES];
            for v in f.iter_mut().take(INPUTS) {
                *v = rand::RngExt::random_range(&mut rng, -1.0..1.0);
            }
            f[FEATURES - 1] = 1.0;
            let v = f[INPUTS - 2];
            ex.features.push(f);
            ex.targets.extend([v * v, 0.0]);
            ex.reach.push(1);
            ex.weight.push(1.0);
        }
        let net = train_network(
            &ex,
            2,
            &NetworkFit {
                hidden: 16,
                epochs: 30,
                seed: 1,
            },
        );
        net.check(1).unwrap();
        let mut err = 0.0;
        for (f, y) in ex.features.iter().zip(ex.targets.chunks_exact(2)) {
            let mut out = [glam::DVec2::ZERO];
            net.add_to(f, &mut out);
            err += (out[0].x - y[0]).abs();
        }
        // the best constant (the median of v^2) is off by about 0.25 on average
        let mean_err = err / ex.len() as f64;
        assert!(mean_err < 0.05, "{mean_err}");
        // the same windows and seed give the same network
        let again = train_network(
            &ex,
            2,
            &NetworkFit {
                hidden: 16,
                epochs: 30,
                seed: 1,
            },
        );
        assert_eq!(net, again);
    }
}
