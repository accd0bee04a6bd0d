//! What a design run may spend on a specification: wall-clock time, merit evaluations, or both.
//!
//! A time budget stops work where the clock says, so how far a run gets depends on the machine and
//! its load. An evaluation budget stops it at points fixed by the work itself (between global
//! generations, and between finished candidates taken in merit order), so the same settings give the
//! same library on any machine and with any number of threads, and a killed run resumes to the same
//! bytes (the count is saved with the search state).
//!
//! The unit is one merit value (`Merit::value`) of one design; an exact Jacobian counts as the merit
//! values it costs ([`crate::local::linearisation_cost`]).

use std::time::Instant;

#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Budget {
    /// Stop once this instant has passed.
    pub deadline: Option<Instant>,
    /// Stop once this many merit evaluations have been spent.
    pub evaluations: Option<u64>,
}

impl Budget {
    /// No limit at all.
    pub const UNLIMITED: Budget = Budget {
        deadline: None,
        evaluations: None,
    };

    /// Whether the budget is spent after `used` evaluations.
    pub fn spent(&self, used: u64) -> bool {
        self.out_of_time() || self.evaluations_spent(used)
    }

    /// Whether `used` evaluations reach the evaluation limit (the clock aside).
    pub fn evaluations_spent(&self, used: u64) -> bool {
        self.evaluations.is_some_and(|limit| used >= limit)
    }

    pub fn out_of_time(&self) -> bool {
        self.deadline.is_some_and(|d| Instant::now() >= d)
    }

    /// Whether any limit is set (a budgeted search never calls a poor design converged).
    pub fn is_limited(&self) -> bool {
        self.deadline.is_some() || self.evaluations.is_some()
    }

    /// `share` of what is left after `used` evaluations (and of the time left), for a stage that
    /// counts its own evaluations from zero.
    pub fn share_of_rest(&self, used: u64, share: f64) -> Budget {
        Budget {
            deadline: self.deadline.map(|d| {
                let left = d.saturating_duration_since(Instant::now());
                Instant::now() + left.mul_f64(share)
            }),
            evaluations: self
                .evaluations
                .map(|limit| (limit.saturating_sub(used) as f64 * share).floor() as u64),
        }
    }
}
