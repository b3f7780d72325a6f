//! Learning-rate schedules, as functions of SB3's "progress remaining" (1 at the start
//! of training, 0 at the end).

/// A learning rate as a function of training progress.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum LrSchedule {
    /// The same rate throughout.
    Constant(f64),
    /// From `start` (progress remaining 1) to `end` (progress remaining 0), linearly.
    Linear {
        /// Rate at the start.
        start: f64,
        /// Rate at the end.
        end: f64,
    },
}

impl LrSchedule {
    /// The rate at `progress_remaining` in `[0, 1]`.
    pub fn at(&self, progress_remaining: f64) -> f64 {
        let p = progress_remaining.clamp(0.0, 1.0);
        match *self {
            LrSchedule::Constant(lr) => lr,
            LrSchedule::Linear { start, end } => end + (start - end) * p,
        }
    }

    /// Every rate the schedule can take is finite and positive.
    pub fn is_valid(&self) -> bool {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        match *self {
            LrSchedule::Constant(lr) => ok(lr),
            LrSchedule::Linear { start, end } => ok(start) && ok(end),
        }
    }
}

impl Default for LrSchedule {
    fn default() -> Self {
        LrSchedule::Constant(3e-4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_goes_from_start_to_end() {
        let s = LrSchedule::Linear {
            start: 1e-3,
            end: 1e-4,
        };
        assert_eq!(s.at(1.0), 1e-3);
        assert_eq!(s.at(0.0), 1e-4);
        assert!((s.at(0.5) - 5.5e-4).abs() < 1e-12);
        assert_eq!(LrSchedule::Constant(3e-4).at(0.3), 3e-4);
        assert!(!LrSchedule::Constant(0.0).is_valid());
    }
}
