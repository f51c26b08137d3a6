//! How many CG iterations each recorded step contains.
//!
//! CG stops on the device, and iterations past convergence launch no
//! workgroup, but every recorded iteration still costs two empty
//! indirect dispatches (their recording and launch), so a budget of 200
//! for a solve that takes 30 would dominate the step. At each status
//! check the budget becomes the largest count any step needed since the
//! last check plus a quarter of it ([`CgBudget::after`]; at most the
//! configured maximum): the empty dispatches then stay within a quarter
//! of the iterations run. A window in which some step used the whole
//! budget doubles it (at most to the maximum) and counts a hit (such a
//! step stopped with its residual above the tolerance;
//! [`GpuSolver::step`](super::GpuSolver::step) runs it again with the
//! larger budget until no step is cut short).

/// The CG iteration budget of a solver and its rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct CgBudget {
    /// The configured maximum (`implicit.max_iterations`, or the
    /// semi-implicit filter's cap).
    max: u32,
    /// Iterations recorded per step at present.
    current: u32,
    /// Whether checks adapt the budget (else it stays at `max`).
    adaptive: bool,
    /// Check windows in which some step used the whole, reduced budget.
    hits: u64,
}

impl CgBudget {
    /// The budget after a window whose steps needed at most `used`
    /// iterations: `used` and a quarter more, rounded down, at least one
    /// more (a count that grows by more than that within a window is a
    /// hit).
    pub fn after(used: u32) -> u32 {
        used + (used / 4).max(1)
    }

    /// A budget of `max` iterations, adaptive.
    pub fn new(max: u32) -> CgBudget {
        CgBudget {
            max,
            current: max,
            adaptive: true,
            hits: 0,
        }
    }

    /// Iterations recorded per step at present.
    pub fn current(&self) -> u32 {
        self.current
    }

    /// The configured maximum.
    pub fn max(&self) -> u32 {
        self.max
    }

    /// Check windows in which a step used the whole, reduced budget.
    pub fn hits(&self) -> u64 {
        self.hits
    }

    /// Adapts at checks (`true`, the default) or stays at the maximum.
    pub fn set_adaptive(&mut self, on: bool) {
        self.adaptive = on;
        if !on {
            self.current = self.max;
        }
    }

    /// The rule, after a check found that the steps since the last one
    /// needed at most `used` iterations. Returns whether the window
    /// restarts (the device's count of the largest `used` is then zeroed).
    pub fn update(&mut self, used: u32) -> bool {
        if !self.adaptive || used == 0 {
            return false;
        }
        let exhausted = used >= self.current;
        if exhausted && self.current < self.max {
            self.hits += 1;
        }
        self.current = if exhausted {
            (2 * self.current).min(self.max)
        } else {
            Self::after(used).min(self.max)
        };
        true
    }
}

#[cfg(test)]
mod tests {
    use super::CgBudget;

    #[test]
    fn the_budget_follows_the_largest_count_and_recovers_from_a_hit() {
        let mut b = CgBudget::new(200);
        assert_eq!(b.current(), 200);
        assert!(b.update(30));
        assert_eq!(b.current(), 30 + 7);
        // A window that used the whole reduced budget: doubled, counted,
        // then doubled up to the maximum.
        assert!(b.update(b.current()));
        assert_eq!((b.current(), b.hits()), (74, 1));
        assert!(b.update(74));
        assert!(b.update(148));
        assert_eq!((b.current(), b.hits()), (200, 3));
        // Using the whole maximum is no hit (there was nothing more).
        assert!(b.update(200));
        assert_eq!((b.current(), b.hits()), (200, 3));
        // A window without CG changes nothing.
        assert!(!b.update(0));
        assert_eq!(b.current(), 200);
        assert!(b.update(170));
        assert_eq!(b.current(), 200, "never above the maximum");
    }

    #[test]
    fn a_fixed_budget_stays_at_the_maximum() {
        let mut b = CgBudget::new(50);
        b.update(3);
        assert_eq!(b.current(), 3 + 1);
        b.set_adaptive(false);
        assert_eq!(b.current(), 50);
        assert!(!b.update(3));
        assert_eq!((b.current(), b.hits()), (50, 0));
    }
}
