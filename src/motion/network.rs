//! The motion model's network: a small multilayer perceptron that corrects the ridge
//! regression's expected path where walking is not linear in the history (people who
//! slow down to stop, who start, who turn).
//!
//! It reads the same seven displacements in the walker's frame as the linear part,
//! each standardised by the fit's mean and spread, through two hidden layers of
//! rectified linear units, and gives for every grid step of the model a correction of
//! the forward and the left displacement, added to the linear part's. Evaluating it is
//! `14 h + h^2 + 2 s h` multiply-adds (`h` hidden units, `s` steps) in single precision
//! (the corrections are centimetres to metres: single precision keeps them to well
//! under a millimetre) on the stack: no allocation. The loops run in one fixed order, so the same input gives the same bits
//! on every machine and instruction path.

use super::history::HISTORY_POINTS;
use crate::math::Simd;
use glam::DVec2;

/// Inputs of the network: the seven observed displacements (forward, left of each;
/// the linear part's constant is the layers' biases).
pub const INPUTS: usize = 2 * (HISTORY_POINTS - 1);
/// Most outputs a network may give (two per grid step).
pub const MAX_OUTPUTS: usize = 300;
/// Most hidden units per layer a network may hold.
pub const MAX_HIDDEN: usize = 128;

/// A network's weights (see the [module documentation](self)).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Network {
    /// Hidden units per layer.
    pub hidden: usize,
    /// Outputs: two per grid step (forward, left), step by step.
    pub outputs: usize,
    /// Per input: the mean subtracted before the first layer.
    pub mean: [f32; INPUTS],
    /// Per input: the factor applied after subtracting the mean.
    pub scale: [f32; INPUTS],
    /// First layer, `INPUTS x hidden`, row by row (one row per input).
    pub w1: Vec<f32>,
    /// First layer's biases (`hidden`).
    pub b1: Vec<f32>,
    /// Second layer, `hidden x hidden`, one row per unit of the first layer.
    pub w2: Vec<f32>,
    /// Second layer's biases (`hidden`).
    pub b2: Vec<f32>,
    /// Output layer, `hidden x outputs`, one row per unit of the second layer.
    pub w3: Vec<f32>,
    /// Output biases (`outputs`).
    pub b3: Vec<f32>,
}

/// Largest absolute weight a network may hold (a file with larger ones is refused).
const MAX_WEIGHT: f32 = 1.0e4;

impl Network {
    /// Check the shapes and values; `steps` is the model's number of grid steps.
    pub fn check(&self, steps: usize) -> Result<(), String> {
        let h = self.hidden;
        if !(1..=MAX_HIDDEN).contains(&h) {
            return Err(format!(
                "the network has {h} hidden units, a model holds 1 to {MAX_HIDDEN}"
            ));
        }
        if self.outputs != 2 * steps || self.outputs > MAX_OUTPUTS {
            return Err(format!(
                "the network gives {} outputs for {steps} steps (two per step)",
                self.outputs
            ));
        }
        let shapes = [
            ("first layer", self.w1.len(), INPUTS * h),
            ("first layer's biases", self.b1.len(), h),
            ("second layer", self.w2.len(), h * h),
            ("second layer's biases", self.b2.len(), h),
            ("output layer", self.w3.len(), h * self.outputs),
            ("output biases", self.b3.len(), self.outputs),
        ];
        for (what, got, want) in shapes {
            if got != want {
                return Err(format!(
                    "the network's {what} holds {got} values, not {want}"
                ));
            }
        }
        let values = self.mean.iter().chain(&self.scale).chain(&self.w1);
        let values = values.chain(&self.b1).chain(&self.w2).chain(&self.b2);
        if let Some(v) = values
            .chain(&self.w3)
            .chain(&self.b3)
            .find(|v| !v.is_finite() || v.abs() > MAX_WEIGHT)
        {
            return Err(format!(
                "the network holds {v}, not a number within {MAX_WEIGHT}"
            ));
        }
        Ok(())
    }

    /// The corrections for `features` (the linear part's inputs: at least [`INPUTS`]
    /// values; fewer panic) added to `out` (one displacement per step: forward, left). On the AVX2 path
    /// ([`Simd::active`]) the loops run four values to a register, with the same
    /// operations in the same order as the baseline path: both give the same bits.
    #[inline]
    pub fn add_to(&self, features: &[f64], out: &mut [DVec2]) {
        #[cfg(target_arch = "x86_64")]
        if Simd::active() == Simd::Avx2Fma {
            // SAFETY: `Simd::active` gives the AVX2 path only where the processor has it.
            unsafe { self.eval_avx2(features, out) };
            return;
        }
        self.eval_generic(features, out);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn eval_avx2(&self, features: &[f64], out: &mut [DVec2]) {
        self.eval_generic(features, out);
    }

    #[inline(always)]
    fn eval_generic(&self, features: &[f64], out: &mut [DVec2]) {
        let h = self.hidden;
        let mut x = [0.0f32; INPUTS];
        for (i, v) in x.iter_mut().enumerate() {
            *v = (features[i] as f32 - self.mean[i]) * self.scale[i];
        }
        let mut h1 = [0.0f32; MAX_HIDDEN];
        let h1 = &mut h1[..h];
        layer(&x, &self.w1, &self.b1, h1);
        relu(h1);
        let mut h2 = [0.0f32; MAX_HIDDEN];
        let h2 = &mut h2[..h];
        layer(h1, &self.w2, &self.b2, h2);
        relu(h2);
        let mut o = [0.0f32; MAX_OUTPUTS];
        let o = &mut o[..self.outputs];
        layer(h2, &self.w3, &self.b3, o);
        for (out, o) in out.iter_mut().zip(o.chunks_exact(2)) {
            *out += DVec2::new(f64::from(o[0]), f64::from(o[1]));
        }
    }
}

/// `out = b + sum_i x_i w_i` (`w` row by row, one row per input).
#[inline(always)]
pub(super) fn layer<
    T: Copy + PartialEq + Default + std::ops::Mul<Output = T> + std::ops::AddAssign,
>(
    x: &[T],
    w: &[T],
    b: &[T],
    out: &mut [T],
) {
    out.copy_from_slice(b);
    let n = out.len();
    for (xi, row) in x.iter().zip(w.chunks_exact(n)) {
        // a unit the rectifier silenced adds nothing (about half of them)
        if *xi == T::default() {
            continue;
        }
        for (o, wij) in out.iter_mut().zip(row) {
            *o += *xi * *wij;
        }
    }
}

#[inline(always)]
pub(super) fn relu<T: Copy + PartialOrd + Default>(v: &mut [T]) {
    for x in v {
        if (*x).partial_cmp(&T::default()) != Some(std::cmp::Ordering::Greater) {
            *x = T::default();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    pub(crate) fn random_network(hidden: usize, steps: usize, seed: u64) -> Network {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut values =
            |n: usize| -> Vec<f32> { (0..n).map(|_| rng.random_range(-0.3..0.3)).collect() };
        Network {
            hidden,
            outputs: 2 * steps,
            mean: [0.1; INPUTS],
            scale: [2.0; INPUTS],
            w1: values(INPUTS * hidden),
            b1: values(hidden),
            w2: values(hidden * hidden),
            b2: values(hidden),
            w3: values(hidden * 2 * steps),
            b3: values(2 * steps),
        }
    }

    #[test]
    fn both_instruction_paths_give_the_same_bits() {
        let net = random_network(64, 30, 5);
        net.check(30).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
        for _ in 0..200 {
            let mut f = [1.0; INPUTS + 1];
            for v in f.iter_mut().take(INPUTS) {
                *v = rng.random_range(-0.8..0.8);
            }
            let mut generic = [DVec2::ZERO; 30];
            net.eval_generic(&f, &mut generic);
            assert!(generic.iter().any(|v| *v != DVec2::ZERO));
            #[cfg(target_arch = "x86_64")]
            if Simd::Avx2Fma.available() {
                let mut avx2 = [DVec2::ZERO; 30];
                // SAFETY: the processor has AVX2 (checked above)
                unsafe { net.eval_avx2(&f, &mut avx2) };
                for (a, b) in generic.iter().zip(&avx2) {
                    assert_eq!(
                        (a.x.to_bits(), a.y.to_bits()),
                        (b.x.to_bits(), b.y.to_bits())
                    );
                }
            }
        }
    }

    #[test]
    fn networks_of_the_wrong_shape_or_values_are_refused() {
        let net = random_network(8, 4, 1);
        assert!(net.check(4).is_ok());
        assert!(net.check(5).unwrap_err().contains("8 outputs for 5 steps"));
        let mut short = net.clone();
        short.w2.pop();
        assert!(
            short
                .check(4)
                .unwrap_err()
                .contains("second layer holds 63 values")
        );
        let mut nan = net.clone();
        nan.b3[2] = f32::NAN;
        assert!(nan.check(4).unwrap_err().contains("NaN"));
        let wide = random_network(MAX_HIDDEN + 1, 4, 1);
        assert!(wide.check(4).unwrap_err().contains("hidden units"));
    }
}
