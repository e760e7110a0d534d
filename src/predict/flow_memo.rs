//! The states of the flow walks that project a pruned candidate's reach
//! (`Lanes::project_reach`, in `flow_walk.rs`): which
//! location and heading an earlier walk of the same checkpoint passed, and how many
//! steps it stayed on the map from there.

/// Heading bins of the flow walks' shared states (`flow_walk.rs`).
pub(super) const FLOW_BINS: usize = 32;

/// The state key of a flow walk at location `loc` heading `(hx, hy)`.
#[inline]
pub(super) fn flow_key(loc: usize, hx: f32, hy: f32) -> u32 {
    flow_key_of(loc, flow_bin(hx, hy))
}

/// The state key of a flow walk at location `loc` in heading bin `bin` ([`flow_bin`]).
#[inline(always)]
pub(super) fn flow_key_of(loc: usize, bin: u32) -> u32 {
    (loc * FLOW_BINS) as u32 + bin
}

/// The heading bin of `(hx, hy)` in a flow walk's state key (branch-free: several
/// headings' bins in one loop are computed side by side, with the same bits).
#[inline(always)]
pub(super) fn flow_bin(hx: f32, hy: f32) -> u32 {
    let a = crate::math::fastmath::atan2_f32(hy, hx); // [-pi, pi]
    let bin = ((a + std::f32::consts::PI) * (FLOW_BINS as f32 / std::f32::consts::TAU)) as u32;
    bin.min(FLOW_BINS as u32 - 1)
}

/// The flow walks' states of one checkpoint and the steps each is worth: an
/// open-addressed table whose entries carry the checkpoint's number (so a new
/// checkpoint starts empty without clearing it).
#[derive(Debug, Clone, Default)]
pub(super) struct FlowMemo {
    /// (key + 1, steps, checkpoint); key 0 is empty.
    slots: Vec<[u32; 3]>,
    checkpoint: u32,
    /// The keys of the states of the walk under way.
    pub(super) path: Vec<u32>,
}

/// Slots of a [`FlowMemo`] (a power of two).
pub(super) const FLOW_SLOTS: usize = 1024;
/// Probes before a [`FlowMemo`] gives up on a key.
const FLOW_PROBES: usize = 8;

impl FlowMemo {
    /// Start a checkpoint: no state known.
    pub(super) fn start(&mut self) {
        if self.slots.len() != FLOW_SLOTS {
            self.slots = vec![[0; 3]; FLOW_SLOTS];
        }
        self.checkpoint = self.checkpoint.wrapping_add(1);
        if self.checkpoint == 0 {
            self.slots.fill([0; 3]);
            self.checkpoint = 1;
        }
    }

    #[inline(always)]
    fn slot(key: u32, probe: usize) -> usize {
        ((key.wrapping_add(1).wrapping_mul(0x9e37_79b1) >> 22) as usize + probe) & (FLOW_SLOTS - 1)
    }

    /// The steps state `key` is worth, if a walk of this checkpoint passed it.
    #[inline(always)]
    pub(super) fn get(&self, key: u32) -> Option<u32> {
        for probe in 0..FLOW_PROBES {
            let [k, v, c] = self.slots[Self::slot(key, probe)];
            if c != self.checkpoint || k == 0 {
                return None;
            }
            if k == key.wrapping_add(1) {
                return Some(v);
            }
        }
        None
    }

    /// Remember that state `key` is worth `steps` (unless its slots are taken).
    #[inline(always)]
    pub(super) fn insert(&mut self, key: u32, steps: u32) {
        for probe in 0..FLOW_PROBES {
            let i = Self::slot(key, probe);
            let [k, _, c] = self.slots[i];
            if c != self.checkpoint || k == 0 || k == key.wrapping_add(1) {
                self.slots[i] = [key.wrapping_add(1), steps, self.checkpoint];
                return;
            }
        }
    }
}
